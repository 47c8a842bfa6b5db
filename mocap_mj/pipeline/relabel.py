"""Mislabelled markers found and corrected: labels exchanged within a segment, across
neighbouring segments, left for right, over a whole trial or over a span of frames.

A label error keeps every marker where it is and moves only its name, so the data alone
cannot always see it (a reversed symmetric plate keeps every distance; a left/right exchange
of the pelvis mirrors it). A model can: each labeling is judged by how well the model's
skeleton fits it. :func:`find_label_errors` does so as follows.

Candidates (:func:`candidates`)
    The labelings a label error produces, as permutations of model markers: every exchange
    of two markers of one segment and every exchange of two disjoint pairs of them (a
    cluster or plate reversed front to back or mirrored: LFHD/RFHD with LBHD/RBHD), every
    exchange of a marker with one of a neighbouring segment (RKNE with RTIB: the nearest
    marker-carrying ancestor in the model's tree), every exchange of mirror-named markers
    (``L<x>`` with ``R<x>``: LASI with RASI, LKNE with RKNE) and of all the mirror-named
    markers of a left segment with its right twin (a side template applied to the wrong
    side), and every turn of three markers of one segment by one place (a triangular
    plate read rotated). Longer cycles, and exchanges across more than one joint, are not
    tried.
Spans
    A label can change only where its marker is lost, where it reappears after a gap, or
    where its track jumps further than a body segment accelerates (``jump`` of
    :mod:`mocap_mj.capture.marker_quality`): a candidate is judged on each span of frames between
    the breakpoints of its own markers, so a swap that starts after one occlusion and ends
    at the next is found for exactly that span, and one over the whole trial on every span.
    A frame with one of a candidate's markers missing is judged by the others (the RMS over
    those present). A span shorter than :data:`MIN_FRAMES` frames that fails on its own
    follows its neighbours when they are all taken (a marker lost for a frame inside a
    swap is not evidence that the swap stopped).
Evidence
    An IK with a model (:class:`~mocap_mj.solve.ik.IKSolver`, joint limits kept: an implausible
    pose cannot fit a wrong labeling) on a sample of frames: at most :data:`EVEN_FRAMES`
    evenly spaced ones, plus the first, middle and last of every span between the
    breakpoints of any marker (at most :data:`MAX_FRAMES` in all). ``identify`` gives the
    bundled model's nominal skeleton scaled by the subject's overall size
    (:func:`reference_theta`: built from no label alone, so it cannot have absorbed the
    error); ``ik`` the model it is given.
Screen, then confirm
    A screen says where to look: each candidate's markers' residuals with their labels
    exchanged, on the original labeling's poses and on rigid (Kabsch) fits of the
    candidate's segments alone, each segment's markers with its joint centre where the
    original IK puts it (a segment whose labels forced a wrong pose on it is re-posed; the
    joint centre keeps a head from fitting a front/back reversal upside down). The segments
    of a candidate that passes half the margin form a neighbourhood; every candidate within
    it is then fitted again by IK with its labels (the largest screens first, at most
    :data:`NEIGHBOURHOODS` neighbourhoods in a round once one gives a correction, at most
    :data:`CONFIRM` IKs), and of those that pass the margin the one that leaves the
    neighbourhood's markers the smallest residual wins (an exchange of one diagonal of a
    reversed head band passes too, but leaves two markers 65 mm off against 25 mm).
Margin
    A candidate is taken on a span when, over its sampled frames (at least
    :data:`MIN_FRAMES`, or all of a shorter span), the median RMS residual of its markers
    falls to :data:`FACTOR` (0.6) of the original labeling's or less and by at least
    :data:`MARGIN_MIN` (20 mm), and the whole body's summed squared residual falls too.
    When the candidate is not taken everywhere (a swap over a span), the span's original
    residual must also stand out by the same margin from the residual of the same markers,
    as labelled, where the candidate is not taken: a span of extreme poses that the model
    fits badly whatever the labels is not a swap (a clean synthetic range of motion with
    gaps had C7/RBHD at 73 mm as labelled and 43 mm exchanged over 21 frames, and those
    markers at 56 mm elsewhere; a real span swap stands at 190-213 mm against 32-44). On
    the five shared trials (unmodified) the nominal model misplaces a Plug-in Gait marker by
    up to 110 mm (thigh and tibia wands), yet the best alternative labeling of any of them
    reaches only 0.71 of the original residual and 7 mm less (LWRA/LWRB); an exchange
    leaves 140-250 mm and falls to 25-100 mm (0.1-0.5). Soft tissue and noise move a marker
    by a few mm to 30 mm. Markers closer together than about 50 mm cannot pass the margin
    (a plate's markers 60 mm apart still do): those, such as two wrist-bar markers swapped
    between two frames, are corrected by their tracks (:func:`track_swaps`).

The winners of a round's neighbourhoods are taken, the largest drop of the whole body's
squared residual first, one per segment, the data corrected and judged again (at most
:data:`MAX_ROUNDS` rounds): a correction that spoils the pose of a segment cannot make its
neighbour's look wrong for long. A round costs one IK of the sampled frames and one per
candidate confirmed, whatever the recording's length.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from mocap_mj.anatomy.initial import marker_stature, segment_scales
from mocap_mj.capture.marker_quality import ACCEL_MAX, JUMP_MIN, Finding
from mocap_mj.capture.subject import HUMAN_RANGES
from mocap_mj.pipeline.relabel_screen import Pose, Segments, rms, screens
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.ik import IKSolver

__all__ = [
    "CHUNK",
    "CONFIRM",
    "EVEN_FRAMES",
    "FACTOR",
    "MARGIN_MIN",
    "MAX_FRAMES",
    "MAX_ROUNDS",
    "MIN_FRAMES",
    "NEIGHBOURHOODS",
    "Candidate",
    "Relabel",
    "apply_relabels",
    "candidates",
    "find_label_errors",
    "reference_theta",
    "track_swaps",
]

#: The corrected labeling's median RMS residual of the exchanged markers, at most this
#: fraction of the original labeling's (module docstring, "Margin").
FACTOR = 0.6
#: ... and at least this much [m] below it.
MARGIN_MIN = 0.020
#: Evenly spaced frames the IK evidence is taken on (plus three per span between breakpoints).
EVEN_FRAMES = 200
#: Most frames the IK evidence is taken on.
MAX_FRAMES = 3000
#: Fewest sampled frames with a candidate's markers a span needs to be judged (all of a
#: shorter span).
MIN_FRAMES = 3
#: Most candidates fitted again by IK in a round.
CONFIRM = 60
#: Neighbourhoods (the segments of a candidate the screen passes) judged in a round when
#: one of them gives a correction; more are judged until one does (or CONFIRM is reached).
NEIGHBOURHOODS = 3
#: Most rounds of find, correct, judge again.
MAX_ROUNDS = 8
#: Frames read at once where every frame is read (the breakpoints).
CHUNK = 20_000


@dataclass(frozen=True)
class Candidate:
    """A labeling to try: ``slots[k]`` takes the data labelled ``sources[k]`` (marker
    indices; a permutation of one set); kind: ``within segment``, ``across segments`` or
    ``left/right`` (and ``tracks`` for a :class:`Relabel` made by :func:`track_swaps`)."""

    kind: str
    slots: tuple[int, ...]
    sources: tuple[int, ...]


@dataclass(frozen=True)
class Relabel:
    """One correction of one file's labels.

    file; kind (:class:`Candidate`); markers: the corrected labels, ``markers[k]`` takes the
    data the file labels ``sources[k]``; frames: [first, last) of the file's frames;
    before, after: median RMS IK residual [m] of those markers with the file's labels
    and with the corrected ones; applied: whether the fitted data carry the correction;
    message: the one-line text.
    """

    file: str
    kind: str
    markers: tuple[str, ...]
    sources: tuple[str, ...]
    frames: tuple[int, int]
    before: float
    after: float
    applied: bool
    message: str


# ------------------------------------------------------------------------------- candidates
def candidates(pset: ParameterSet) -> list[Candidate]:
    """Every labeling :func:`find_label_errors` tries for the model's markers (module
    docstring, "Candidates"), each permutation once."""
    names = list(pset.marker_names)
    body = [int(b) for b in pset.model.site_bodyid]
    groups: dict[int, list[int]] = {}
    for i, b in enumerate(body):
        groups.setdefault(b, []).append(i)
    out: dict[tuple[tuple[int, ...], tuple[int, ...]], Candidate] = {}

    def put(kind: str, slots: Sequence[int], sources: Sequence[int]) -> None:
        order = np.argsort(slots)
        key = (tuple(slots[i] for i in order), tuple(sources[i] for i in order))
        out.setdefault(key, Candidate(kind, *key))

    def add(kind: str, pairs: Sequence[tuple[int, int]]) -> None:
        put(kind, [k for a, b in pairs for k in (a, b)], [k for a, b in pairs for k in (b, a)])

    mirror = _mirror_pairs(names)
    for members in groups.values():
        pairs = list(itertools.combinations(members, 2))
        for p in pairs:
            add("left/right" if p in mirror else "within segment", [p])
        for p, q in itertools.combinations(pairs, 2):
            if not set(p) & set(q):
                add("within segment", [p, q])
        for i, j, k in itertools.combinations(members, 3):  # a plate turned by one place
            put("within segment", (i, j, k), (j, k, i))
            put("within segment", (i, j, k), (k, i, j))
    for b, members in groups.items():
        up = _marker_parent(pset, b, groups)
        if up is not None:
            for i, j in itertools.product(groups[up], members):
                add("across segments", [(i, j)])
    for p in mirror:
        add("left/right", [p])
    for b, members in groups.items():
        sided = [p for p in mirror if p[0] in members and body[p[1]] != b]
        if len(sided) > 1:
            add("left/right", sided)
    return list(out.values())


def _mirror_pairs(names: Sequence[str]) -> set[tuple[int, int]]:
    """(i, j), i < j, of markers named ``L<x>`` and ``R<x>``."""
    index = {n: i for i, n in enumerate(names)}
    out = set()
    for n, i in index.items():
        j = index.get("R" + n[1:]) if n.startswith("L") else None
        if j is not None:
            out.add((min(i, j), max(i, j)))
    return out


def _marker_parent(pset: ParameterSet, b: int, groups: Mapping[int, list[int]]) -> int | None:
    """The nearest ancestor of body b that carries markers (None: none)."""
    parent = pset.model.body_parentid
    a = int(parent[b])
    while a > 0 and a not in groups:
        a = int(parent[a])
    return a if a > 0 else None


# -------------------------------------------------------------------------------- the model
def reference_theta(pset: ParameterSet, markers: np.ndarray | Sequence[np.ndarray]) -> np.ndarray:
    """theta (P,) [m]: the model's nominal skeleton and marker offsets scaled by the
    subject's overall size (the median of the segment ratios of
    :func:`~mocap_mj.anatomy.initial.segment_scales`, robust to a few exchanged labels),
    built from no marker's label alone. markers: (T, M, 3) [m] or a sequence of trials;
    at most :data:`MAX_FRAMES` evenly spaced frames of each are read (a long recording's
    memory map is not copied whole)."""
    trials = [markers] if isinstance(markers, np.ndarray) and markers.ndim == 3 else markers
    few = [np.asarray(m[:: max(1, -(-len(m) // MAX_FRAMES))], dtype=float) for m in trials]
    overall = float(segment_scales(pset, few)["overall"].value)
    return np.asarray(pset.nominal, dtype=float) * (overall if np.isfinite(overall) else 1.0)


def _person_sized(pset: ParameterSet, markers: np.ndarray) -> bool:
    """Whether the markers (T, M, 3) [m] imply a person's stature (the human height range of
    :data:`mocap_mj.capture.subject.HUMAN_RANGES`): a recording whose length unit is wrong fits no
    reference model, and an exchange of labels would then be judged on residuals that no
    labeling explains (the fit's own checks name the unit)."""
    few = np.asarray(markers[:: max(1, -(-len(markers) // MAX_FRAMES))], dtype=float)
    stature = marker_stature(segment_scales(pset, [few]))
    low, high = HUMAN_RANGES["height"]
    return stature is None or low <= stature <= high


# --------------------------------------------------------------------------- the search
def find_label_errors(
    path: str,
    markers: np.ndarray,
    rate: float,
    kin: Kinematics,
    *,
    first_frame: int = 0,
) -> list[Relabel]:
    """The label errors of file ``path``'s markers (T, M, 3) [m] (model order, NaN where
    missing; not modified), judged with the model ``kin`` at its theta (module docstring);
    rate [Hz]; ``first_frame``: the file's frame of row 0. Each :class:`Relabel` is
    ``applied=True``; :func:`apply_relabels` makes the corrected copy."""
    x = np.asarray(markers, dtype=float)
    pset = kin.pset
    if len(x) < MIN_FRAMES or not _person_sized(pset, x):
        return []
    cands = candidates(pset)
    breaks = _breakpoints(x, rate)
    sample = _sample(len(x), breaks)
    solver = IKSolver(kin)
    xs = x[sample].copy()
    out: list[Relabel] = []
    for _ in range(MAX_ROUNDS):
        taken = _round(path, pset, solver, xs, _Sampled(sample, len(x), breaks), cands, first_frame)
        if not taken:
            break
        for r, spans in taken:
            out.append(r)
            for a, b in spans:
                rows = (sample >= a) & (sample < b)
                xs[rows] = _permuted(xs[rows], pset.marker_names, r)
    return out


def track_swaps(
    path: str,
    names: Sequence[str],
    markers: np.ndarray,
    findings: Sequence[Finding],
    *,
    first_frame: int = 0,
) -> list[Relabel]:
    """Corrections of the ``swap`` findings of
    :func:`~mocap_mj.capture.marker_quality.check_marker_quality`
    on file ``path`` (markers (T, M, 3) [m], model order): two labels that each jump onto
    the other's track at one frame and back at a later one (or at the end) are exchanged
    back over those frames. This is evidence of the tracks, not of a model: it corrects
    markers too close together for the model's margin (the two wrist-bar markers, about
    50 mm apart). The correction's before, after: the mean distance [m] of the two labels at
    the swap's first frame from their constant-velocity predictions, as labelled and
    exchanged."""
    x = np.asarray(markers)
    index = {n: i for i, n in enumerate(names)}
    out = []
    for f in findings:
        if f.file != path or f.kind != "swap" or f.frames is None:
            continue
        i, k = index[f.markers[0]], index[f.markers[1]]
        a = f.frames[0] - first_frame
        pred = 2 * np.asarray(x[a - 1], dtype=float) - x[a - 2]  # (M, 3)
        before = (np.linalg.norm(x[a, i] - pred[i]) + np.linalg.norm(x[a, k] - pred[k])) / 2
        after = (np.linalg.norm(x[a, k] - pred[i]) + np.linalg.norm(x[a, i] - pred[k])) / 2
        text = (
            f"{path}: labels exchanged (tracks): {names[i]} <-> {names[k]} in frames "
            f"{f.frames[0]}-{f.frames[1] - 1}; each label jumps {before * 1e3:.0f} mm off its "
            f"track onto the other's, {after * 1e3:.0f} mm exchanged back"
        )
        out.append(
            Relabel(
                path,
                "tracks",
                (names[i], names[k]),
                (names[k], names[i]),
                f.frames,
                float(before),
                float(after),
                True,
                text,
            )
        )
    return out


def apply_relabels(
    markers: np.ndarray,
    names: Sequence[str],
    relabels: Sequence[Relabel],
    path: str,
    *,
    first_frame: int = 0,
    in_place: bool = False,
) -> np.ndarray:
    """markers (T, M, 3) [m] of file ``path`` with the ``applied`` corrections of
    :func:`find_label_errors` made, in order (on a copy unless ``in_place``; the caller's
    array untouched by default)."""
    mine = [r for r in relabels if r.file == path and r.applied]
    if not mine:
        return markers
    out = markers if in_place else np.array(markers, dtype=float)
    index = {n: i for i, n in enumerate(names)}
    for r in mine:
        a, b = r.frames[0] - first_frame, r.frames[1] - first_frame
        # only the exchanged columns are read (a copy of those) and written
        out[a:b, [index[n] for n in r.markers]] = out[a:b, [index[n] for n in r.sources]]
    return out


def _permuted(x: np.ndarray, names: Sequence[str], r: Relabel) -> np.ndarray:
    """x (n, M, 3) with r's slots taking the data of its sources (a new array)."""
    index = {n: i for i, n in enumerate(names)}
    y = np.array(x, dtype=float)
    y[:, [index[n] for n in r.markers]] = x[:, [index[n] for n in r.sources]]
    return y


def _breakpoints(x: np.ndarray, rate: float) -> list[np.ndarray]:
    """Per marker, the sorted frames (rows) where its label may change: where it is lost,
    where it reappears after a gap and where its track jumps (module docstring, "Spans").
    Read in chunks of :data:`CHUNK` frames (a long recording's memory map is not copied)."""
    limit = max(JUMP_MIN, ACCEL_MAX / rate**2)
    found: list[list[np.ndarray]] = [[] for _ in range(x.shape[1])]
    for a in range(0, len(x), CHUNK):
        lo = max(a - 3, 0)  # three frames before: the prediction and the jump before it
        c = np.asarray(x[lo : a + CHUNK], dtype=float)
        present = np.all(np.isfinite(c), axis=2)  # (n, M)
        edge = np.zeros_like(present)
        edge[1:] = present[1:] != present[:-1]
        if len(c) >= 3:
            with np.errstate(invalid="ignore"):
                jump = np.linalg.norm(c[2:] - 2 * c[1:-1] + c[:-2], axis=2) > limit
            jump[1:] &= ~jump[:-1]  # a jump also spoils the next frame's prediction
            edge[2:] |= jump
        rows = edge[a - lo :]  # the chunk's own frames
        for m in range(x.shape[1]):
            found[m].append(a + np.flatnonzero(rows[:, m]))
    return [np.concatenate([np.zeros(0, dtype=int), *f]) for f in found]


def _sample(n: int, breaks: Sequence[np.ndarray]) -> np.ndarray:
    """The sorted frames the evidence is taken on (module docstring, "Evidence")."""
    edges = np.unique(np.concatenate([[0, n], *breaks]).astype(int))
    a, b = edges[:-1], edges[1:]
    spans = np.concatenate([a, (a + b) // 2, b - 1])
    even = np.linspace(0, n - 1, min(n, EVEN_FRAMES)).astype(int)
    out = np.unique(np.concatenate([even, spans]))
    if len(out) > MAX_FRAMES:
        out = out[np.linspace(0, len(out) - 1, MAX_FRAMES).astype(int)]
    return out


def _spans(c: Candidate, breaks: Sequence[np.ndarray], n: int) -> np.ndarray:
    """(S, 2) rows [first, last) of the spans between the breakpoints of c's markers."""
    edges = np.unique(np.concatenate([[0, n], *(breaks[m] for m in c.slots)]).astype(int))
    return np.stack([edges[:-1], edges[1:]], axis=1)


#: A span taken: first, last row of the recording, before, after [m] (median RMS of the
#: candidate's markers), sampled frames in it.
_Judged = tuple[int, int, float, float, int]


def _pose(solver: IKSolver, x: np.ndarray, *, origins: bool = False) -> Pose:
    """The IK of x (n, M, 3) [m]; with ``origins``, the body origins (n, nbody, 3) [m] too."""
    res = solver.solve_trial(x)
    ok = res.solved & np.all(np.isfinite(res.qpos), axis=1)
    sites = np.full_like(x, np.nan)
    xpos = np.full((len(x), solver.kin.model.nbody, 3), np.nan) if origins else None
    if ok.any():
        if xpos is not None:
            frames = solver.kin.forward(res.qpos[ok])
            sites[ok], xpos[ok] = frames.site_xpos, frames.xpos
        else:
            sites[ok] = solver.kin.marker_positions(res.qpos[ok])
    sq = np.sum((sites - x) ** 2, axis=2)
    return Pose(sites, sq, rms(sq), xpos)


def _medians(o: np.ndarray, n: np.ndarray) -> tuple[float, float] | None:
    """The medians [m] of o and n (m,) [m] over the frames where both are known, or None
    when those are fewer than MIN_FRAMES (or than the span's frames, when it is shorter)."""
    good = np.isfinite(o) & np.isfinite(n)
    if good.sum() < min(MIN_FRAMES, len(o)) or not good.any():
        return None
    return float(np.median(o[good])), float(np.median(n[good]))


def _confirm(
    c: Candidate,
    solver: IKSolver,
    x: np.ndarray,
    base: Pose,
    rows: list[np.ndarray],
    hood: Sequence[int],
) -> list[tuple[int, float, float, float, float]]:
    """The spans (indices into ``rows``) where c passes the margin after an IK with its
    labels: (span, before, after [m]: median RMS of c's markers present, the median drop
    of the whole body's summed squared residual [m^2], the median RMS after [m] of the
    markers ``hood``: those of the segments c is judged among)."""
    idx = np.concatenate(rows)
    y = x[idx].copy()
    y[:, list(c.slots)] = x[idx][:, list(c.sources)]
    new = _pose(solver, y)
    s = list(c.slots)
    old_c, new_c, new_h = rms(base.sq[idx][:, s]), rms(new.sq[:, s]), rms(new.sq[:, hood])
    drop = np.nansum(base.sq[idx], axis=1) - np.nansum(new.sq, axis=1)
    drop[~np.isfinite(base.rms[idx] + new.rms)] = np.nan
    out, at = [], 0
    ends = np.cumsum([len(r) for r in rows])
    for k, r in enumerate(rows):
        sl = slice(at, at + len(r))
        at += len(r)
        m = _medians(old_c[sl], new_c[sl])
        if m is None or not np.isfinite(drop[sl]).any():
            continue
        gain = float(np.nanmedian(drop[sl]))
        if _clearly(m[0], m[1]) and gain > 0:
            out.append((k, m[0], m[1], gain, float(np.nanmedian(new_h[sl]))))
    # the markers as labelled where c is not taken (spans long enough to judge)
    passed = {o[0] for o in out}
    elsewhere = [old_c[b - len(r) : b] for k, (r, b) in enumerate(zip(rows, ends, strict=True))
                 if k not in passed and len(r) >= MIN_FRAMES]  # fmt: skip
    values = np.concatenate([[np.nan], *elsewhere])
    if np.isfinite(values).sum() < MIN_FRAMES:
        return out
    usual = float(np.nanmedian(values))
    return [o for o in out if _clearly(o[1], usual)]


def _clearly(before: float, after: float) -> bool:
    """The margin (module docstring): ``after`` [m] at most FACTOR of ``before`` [m] and
    MARGIN_MIN below it."""
    return after <= FACTOR * before and before - after >= MARGIN_MIN


class _Sampled(NamedTuple):
    """The frames a search looks at: ``sample`` (n_s,) the rows sampled of the recording's
    ``n`` frames, ``breaks`` the breakpoints the spans are cut at (:func:`_breakpoints`)."""

    sample: np.ndarray
    n: int
    breaks: Sequence[np.ndarray]


def _round(
    path: str,
    pset: ParameterSet,
    solver: IKSolver,
    x: np.ndarray,
    sampled: _Sampled,
    cands: Sequence[Candidate],
    first: int,
) -> list[tuple[Relabel, list[tuple[int, int]]]]:
    """One round on the sampled frames x (n_s, M, 3) [m] (rows ``sampled.sample`` of the
    recording's ``sampled.n`` frames): the corrections taken, each with its spans [first,
    last) of rows of the recording (module docstring, "Evidence" and the rounds)."""
    sample, n, breaks = sampled
    base = _pose(solver, x, origins=True)
    assert base.origins is not None
    spans = [_spans(c, breaks, n) for c in cands]
    bounds = [np.searchsorted(sample, s) for s in spans]  # (S, 2) rows of x per candidate
    screened = screens(cands, bounds, x, base, Segments(pset, solver.kin.theta, base.origins),
                       margin=MARGIN_MIN / 2, least=MIN_FRAMES)  # fmt: skip
    plans = [
        _Plan(float(v), c, _bodies(pset, c), s, [np.arange(a, b) for a, b in r])
        for v, c, s, r in zip(screened, cands, spans, bounds, strict=True)
    ]
    won: list[tuple[float, _Plan, list[_Judged]]] = []
    hoods: list[frozenset[int]] = []
    tried = 0
    for top in sorted((p for p in plans if p.screen > 0), key=lambda p: -p.screen):
        if any(top.bodies <= h for h in hoods):
            continue
        if tried >= CONFIRM or (len(hoods) >= NEIGHBOURHOODS and won):
            break
        pool = [p for p in plans if p.bodies <= top.bodies and not _within(p.bodies, hoods)]
        hoods.append(top.bodies)
        tried += len(pool)
        best = _best_in(pool, solver, x, base, top.bodies, pset)
        if best is not None:
            won.append(best)
    won.sort(key=lambda t: -t[0])
    taken: list[tuple[Relabel, list[tuple[int, int]]]] = []
    used: set[int] = set()
    for _, p, judged in won:
        if not p.bodies & used:
            used |= p.bodies
            taken += _relabels(path, pset.marker_names, p.c, judged, first)
    return taken


@dataclass(frozen=True)
class _Plan:
    """A candidate in a round: its screen [m^2], its segments (body ids), its spans (S, 2)
    [first, last) and each span's rows of the sampled frames."""

    screen: float
    c: Candidate
    bodies: frozenset[int]
    spans: np.ndarray
    rows: list[np.ndarray]


def _bodies(pset: ParameterSet, c: Candidate) -> frozenset[int]:
    return frozenset(int(pset.model.site_bodyid[m]) for m in c.slots)


def _within(b: frozenset[int], hoods: Sequence[frozenset[int]]) -> bool:
    return any(b <= h for h in hoods)


def _best_in(
    pool: Sequence[_Plan],
    solver: IKSolver,
    x: np.ndarray,
    base: Pose,
    hood: frozenset[int],
    pset: ParameterSet,
) -> tuple[float, _Plan, list[_Judged]] | None:
    """The candidate of ``pool`` (those within the segments ``hood``) that passes the margin
    and leaves the hood's markers the smallest residual: (its whole-body drop [m^2], it,
    its spans taken), or None."""
    watch = [m for m, b in enumerate(pset.model.site_bodyid) if int(b) in hood]
    best: tuple[float, float, _Plan, list[_Judged]] | None = None
    for p in pool:
        ok = _confirm(p.c, solver, x, base, p.rows, watch)
        if not ok:
            continue
        w = np.array([len(p.rows[k]) for k, *_ in ok], dtype=float)
        left = float(np.average([h for *_, h in ok], weights=w))
        judged = [
            (int(p.spans[k][0]), int(p.spans[k][1]), mo, mn, len(p.rows[k]))
            for k, mo, mn, _, _ in ok
        ]
        judged += _short_spans(p.spans, ok)
        if best is None or left < best[0]:
            best = (left, max(g for _, _, _, g, _ in ok), p, judged)
    return None if best is None else best[1:]


def _short_spans(
    spans: np.ndarray, ok: Sequence[tuple[int, float, float, float, float]]
) -> list[_Judged]:
    """The spans shorter than MIN_FRAMES frames not taken on their own evidence (a frame or
    two around a flicker of one marker, too few to judge) whose neighbours are all taken:
    they follow them (with no sampled frames of their own)."""
    taken = {k: (mo, mn) for k, mo, mn, _, _ in ok}
    out = []
    for k, (a, b) in enumerate(spans):
        near = [j for j in (k - 1, k + 1) if 0 <= j < len(spans)]
        if k not in taken and b - a < MIN_FRAMES and near and all(j in taken for j in near):
            out.append((int(a), int(b), *taken[near[0]], 0))
    return out


def _said(names: Sequence[str], c: Candidate) -> str:
    """c in words: ``A <-> B`` for each exchanged pair, or ``A <- B`` (A takes the data
    labelled B) for each marker of a longer cycle."""
    take = dict(zip(c.slots, c.sources, strict=True))
    if all(take[b] == a for a, b in take.items()):
        pairs = sorted({(min(a, b), max(a, b)) for a, b in take.items()})
        return ", ".join(f"{names[a]} <-> {names[b]}" for a, b in pairs)
    return ", ".join(f"{names[a]} <- {names[b]}" for a, b in take.items())


def _relabels(
    path: str,
    names: Sequence[str],
    c: Candidate,
    judged: Sequence[_Judged],
    first: int,
) -> list[tuple[Relabel, list[tuple[int, int]]]]:
    """c's corrections, one per run of adjacent spans (first, last, before, after [m], rows)."""
    runs: list[list[_Judged]] = []
    for j in sorted(judged):  # spans do not overlap: sorted by first frame
        if runs and runs[-1][-1][1] == j[0]:
            runs[-1].append(j)
        else:
            runs.append([j])
    said = _said(names, c)
    out = []
    for run in runs:
        w = np.array([j[4] for j in run], dtype=float)
        before = float(np.average([j[2] for j in run], weights=w))
        after = float(np.average([j[3] for j in run], weights=w))
        frames = (first + run[0][0], first + run[-1][1])
        text = (
            f"{path}: labels exchanged ({c.kind}): {said} in frames {frames[0]}-{frames[1] - 1}; "
            f"the model fits these markers {before * 1e3:.0f} mm RMS as labelled, "
            f"{after * 1e3:.0f} mm exchanged back"
        )
        r = Relabel(
            path,
            c.kind,
            tuple(names[k] for k in c.slots),
            tuple(names[k] for k in c.sources),
            frames,
            before,
            after,
            True,
            text,
        )
        out.append((r, [(j[0], j[1]) for j in run]))
    return out
