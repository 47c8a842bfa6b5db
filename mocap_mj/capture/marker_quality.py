"""Marker data that cannot be trusted, found from the data alone before any solve.

A marker that does not move with its segment (mislabelled for the whole trial, swapped with
another label for a range of frames, fallen off and re-stuck elsewhere, a ghost) is fitted
by the identification like any other: the skeleton absorbs it and the RMSE stays small.
:func:`check_marker_quality` looks for four kinds of evidence, each from the markers'
positions (T, M, 3) [m] and the model's segment (body) of each marker:

``spread``
    The distance between two markers of one rigid segment varies over the trial by more
    than soft tissue allows: its p5-p95 range exceeds :data:`SPREAD_MAX` (50 mm). Skin
    sliding over a flexing knee moves THI-KNE by up to 31 mm on the shared Plug-in Gait
    trials; the synthetic soft-tissue model by less
    (docs/recordings.md#what-each-warning-means).
``step``
    That distance changes for good at one frame by more than :data:`STEP_MIN` (20 mm)
    between the medians of the frames before and after it: a marker re-stuck elsewhere.
``jump`` / ``swap``
    A marker's position leaves its constant-velocity prediction ``2 x(t-1) - x(t-2)`` by
    more than a body segment can accelerate in a frame, :data:`ACCEL_MAX` dt^2 and at least
    :data:`JUMP_MIN`; when another marker jumps at the same frame onto this one's
    prediction and back later, the two labels are swapped over that frame range.
``ghost``
    In some frames a marker's distance to every other marker of its segment departs from
    that distance's median over the trial by more than :data:`GHOST_MIN` (40 mm), counting
    only the distances rigid enough otherwise (p5-p95 within SPREAD_MAX): a ghost or a
    momentary mislabel, found whatever the frame rate (``jump`` cannot see a 50-100 mm
    ghost below about 60 Hz, where a body segment may move that far between frames). When
    the segment has two markers, the one further from the midpoint of its neighbouring
    frames is named.
``moved``
    Between trials fitted with one model (:func:`between_trials`): a same-segment distance's
    median differs between two trials by more than :data:`MOVED_MIN` (30 mm), a marker
    re-attached elsewhere (or fallen off) between the trials. One marker offset cannot fit
    both trials; each trial alone can.
``distance`` / ``asymmetry``
    The median distance between two Plug-in Gait landmarks of one bone (elbow-wrist,
    shoulder-elbow, knee-ankle, heel-toe) outside the range of any person 0.85-2.1 m tall
    (:data:`BONE_FRACTIONS`), or left and right differing by more than
    :data:`ASYMMETRY_MAX` (30 %).
``placement``
    A landmark further from its reference landmark than the subject's stature allows (T10
    against C7: :mod:`mocap_mj.anatomy.trunk`, which needs the stature and so runs in the
    identification, after this check); made by :func:`placement_finding`.

Each :class:`Finding` is one line naming the file, the marker (and partner), the frames,
the measured figure and what was expected. The check is a few vectorised passes over the
frames (no solve): it runs on hour-long recordings too.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from mocap_mj.errors import UnknownNameError

__all__ = [
    "ACCEL_MAX",
    "ASYMMETRY_MAX",
    "BONE_FRACTIONS",
    "GHOST_MIN",
    "JUMP_MIN",
    "MOVED_MIN",
    "NOT_RIGID_BETWEEN_TRIALS",
    "SPREAD_MAX",
    "STEP_MIN",
    "Finding",
    "between_trials",
    "check_marker_quality",
    "drop_ghosts",
    "exclude_markers",
    "marker_segments",
    "parse_marker_list",
    "placement_finding",
    "quality_lines",
    "suspects",
]

#: p5-p95 range [m] of a same-segment marker distance above which the pair is reported.
#: The largest range on the shared real trials is 31 mm (RTHI-RKNE, functional knee trial:
#: thigh skin sliding with flexion); 50 mm leaves margin for faster motion.
SPREAD_MAX = 0.050
#: Departure [m] of one frame's same-segment distance from its median over the trial above
#: which the frame is off its segment (``ghost``): above the 31 mm p5-p95 range of soft tissue
#: on the shared trials (SPREAD_MAX's comment), so sliding skin stays below it.
GHOST_MIN = 0.040
#: Persistent change [m] of a same-segment distance's median at one frame (a re-stuck marker).
STEP_MIN = 0.020
#: Difference [m] between two trials' medians of a same-segment distance above which a marker
#: moved between the trials (``moved``): above what posture alone changes (the spine flexed
#: in a jump against standing, a scapula marker with the arms raised: up to 20 mm on the
#: shared trials of one subject), below a re-attached marker's usual move of several cm.
MOVED_MIN = 0.030
#: Segments whose marker distances change with posture between trials, left out of
#: ``moved``: the model's thorax carries markers on the spine (C7, T10), the sternum and the
#: scapula (RBAK), and the spine flexes and the scapula turns with the arms (C7-T10 20 mm
#: longer in the shared jump than standing, STRN-RBAK 16 mm with the arms raised).
NOT_RIGID_BETWEEN_TRIALS = frozenset({"thorax"})
#: Largest acceleration [m/s^2] of a skin marker (about 30 g: above heel strike and hand
#: impacts measured on the skin, 5-20 g); a larger constant-velocity prediction error is a jump.
ACCEL_MAX = 300.0
#: Smallest jump [m] reported whatever the rate (noise and marker reconstruction flicker).
JUMP_MIN = 0.025
#: Largest left/right difference of a bone's landmark distance, as a fraction of the larger:
#: 10 % at most on the shared real trials; the synthetic truths of mocap_synth, whose left
#: and right lengths are perturbed independently (up to 20 % apart), reach 22 %.
ASYMMETRY_MAX = 0.30
#: Landmark pairs of one bone (Plug-in Gait names without the side letter) and their distance
#: as a fraction of body height (Winter, Biomechanics and Motor Control of Human Movement,
#: 4th ed., 2009, fig. 4.1: upper arm 0.186, forearm 0.146, shank 0.246, foot 0.152).
#: The allowed range is the fraction times :data:`_HEIGHTS`: statures of 0.85-2.10 m (a
#: clinical gait lab's youngest walkers, about 2 years old, to a tall adult), the lower end
#: times 0.85 because a small child's limbs are shorter for its stature than Winter's adult
#: fractions (sitting height about 0.58 of stature at 2 years against 0.52 in adults: the
#: legs 0.42 of stature against 0.48), and the whole
#: range widened by 0.8-1.25 for marker placement: from the fractions of a 0.58 m stature
#: (KNE-ANK 142 mm) to those of 2.6 m. A healthy child of 0.95 m stays inside (KNE-ANK about
#: 0.21 m); a marker swapped onto another segment mostly does not.
BONE_FRACTIONS: dict[tuple[str, str], float] = {
    ("SHO", "ELB"): 0.186,
    ("ELB", "WRA"): 0.146,
    ("ELB", "WRB"): 0.146,
    ("KNE", "ANK"): 0.246,
    ("HEE", "TOE"): 0.152,
}
_HEIGHTS = (0.85 * 0.85 * 0.8, 2.1 * 1.25)
#: Pairs of :data:`BONE_FRACTIONS` not compared left to right: where TOE sits (second
#: metatarsal head or further) varies between placements more than the foot does.
_NO_ASYMMETRY = {("HEE", "TOE")}
#: Same-segment distances are evaluated on at most this many frames (evenly spaced).
_MAX_SAMPLES = 20_000
#: A same-segment distance is searched for a step on at most this many block medians.
_STEP_BLOCKS = 400


@dataclass(frozen=True)
class Finding:
    """One piece of evidence that marker data cannot be trusted.

    file: the marker file; kind: ``spread``, ``step``, ``jump``, ``swap``, ``ghost``, ``distance``,
    ``asymmetry`` or ``placement``;
    markers: the marker(s) it names, suspect first; frames: [first, last) of the file's
    frames it concerns (None: the whole trial); value: the measured figure [m];
    expected: what a trustworthy marker would give; message: the one-line text; samples:
    the file's frames of the first marker's samples that are not the marker (``ghost``: the
    frames off the segment; ``jump``: the frame each jump lands on; else empty):
    :func:`drop_ghosts` removes them from the fit.
    """

    file: str
    kind: str
    markers: tuple[str, ...]
    frames: tuple[int, int] | None
    value: float
    expected: str
    message: str
    samples: tuple[int, ...] = ()


def check_marker_quality(
    path: str,
    names: Sequence[str],
    markers: np.ndarray,
    rate: float,
    segments: Sequence[str],
    *,
    first_frame: int = 0,
) -> list[Finding]:
    """Findings on the markers (T, M, 3) [m] of file ``path`` (NaN where missing).

    names (M,) and segments (M,): each marker's name and the model body carrying it; rate
    [Hz]; ``first_frame``: the file's frame number of row 0 (messages count the file's
    frames). The rules and thresholds are the module's (see its docstring).
    """
    x = np.asarray(markers, dtype=float)
    found: list[Finding] = []
    jumps = _jump_findings(path, names, x, rate, first_frame)
    found += _swap_edges_dropped(_segment_findings(path, names, x, segments, first_frame), jumps)
    found += jumps
    found += _ghost_findings(path, names, x, segments, first_frame)
    found += _bone_findings(path, names, x)
    return found


#: Frames [file frames] within which a ``step`` that begins at a swap's first or last frame is
#: that swap's edge (the distance returns, or leaves, with the labels), not a re-stuck marker.
SWAP_EDGE_FRAMES = 3


def _swap_edges_dropped(segment: list[Finding], jumps: list[Finding]) -> list[Finding]:
    """``segment``'s findings without the steps a ``swap`` in ``jumps`` explains: same marker,
    beginning within :data:`SWAP_EDGE_FRAMES` of the swap's start or end."""
    edges = [(set(f.markers), f.frames) for f in jumps if f.kind == "swap" and f.frames]

    def at_edge(f: Finding) -> bool:
        if f.kind != "step" or f.frames is None:
            return False
        start = f.frames[0]
        return any(set(f.markers) & markers and min(abs(start - e) for e in frames)
                   <= SWAP_EDGE_FRAMES for markers, frames in edges)  # fmt: skip

    return [f for f in segment if not at_edge(f)]


def between_trials(
    paths: Sequence[str],
    names: Sequence[str],
    markers: Sequence[np.ndarray],
    segments: Sequence[str],
) -> list[Finding]:
    """``moved`` findings across trials fitted with one model: ``paths`` (K,) and each
    trial's markers (T_k, M, 3) [m] (NaN where missing); names and segments (M,) as for
    :func:`check_marker_quality`. A pair needs at least 10 frames with both markers in
    every trial; the segments of :data:`NOT_RIGID_BETWEEN_TRIALS` are left out. With three
    or more trials, the trial whose median lies furthest from the median of all is named,
    when the others agree within MOVED_MIN."""
    if len(paths) < 2:
        return []
    medians = [_pair_medians(x, segments, skip=NOT_RIGID_BETWEEN_TRIALS) for x in markers]
    common = set.intersection(*(set(m) for m in medians))
    flagged: dict[tuple[int, int], float] = {}
    for key in sorted(common):
        apart = max(m[key] for m in medians) - min(m[key] for m in medians)
        if apart > MOVED_MIN:
            flagged[key] = apart
    out: list[Finding] = []
    for i, others, size in _attribute(flagged):
        j = others[0]
        values = np.array([m[(i, j) if (i, j) in flagged else (j, i)] for m in medians])
        off = np.abs(values - np.median(values))
        odd = int(np.argmax(off))
        rest = np.delete(values, odd)
        where = ", ".join(paths)
        if len(paths) > 2 and rest.max() - rest.min() <= MOVED_MIN:
            where = paths[odd]
        listed = ", ".join(
            f"{val * 1e3:.0f} mm in {Path(p).name}" for val, p in zip(values, paths, strict=True)
        )
        if len(others) > 1:
            listed = f"{names[i]}-{names[j]} {listed}"
        out.append(
            _line(
                where,
                "moved",
                (names[i], *[names[k] for k in others]),
                None,
                size,
                f"within {MOVED_MIN * 1e3:.0f} mm between trials (fixed on its segment)",
                f"{_who(names, i, others)} differs between the trials: {listed} (median "
                "of each; moved between trials? one marker offset cannot fit them all: "
                "identify them separately)",
            )
        )
    return out


def _pair_medians(
    x: np.ndarray, segments: Sequence[str], skip: frozenset[str] = frozenset()
) -> dict[tuple[int, int], float]:
    """The median [m] over the frames of x (T, M, 3) [m] of every same-segment marker
    distance with at least 10 frames of data, keyed by the pair's marker indices; the
    segments named in ``skip`` are left out."""
    xs, _ = _sampled(x)
    out: dict[tuple[int, int], float] = {}
    for members in _by_segment(segments):
        if segments[members[0]] in skip:
            continue
        for i, j, d, ok in _pair_distances(xs, members):
            out[(i, j)] = float(np.median(d[ok]))
    return out


def drop_ghosts(
    markers: np.ndarray,
    names: Sequence[str],
    findings: Sequence[Finding],
    path: str,
    *,
    first_frame: int = 0,
    in_place: bool = False,
) -> tuple[np.ndarray, int]:
    """markers (T, M, 3) [m] of file ``path`` with the samples its ``ghost`` and ``jump``
    findings name missing (NaN; on a copy when there is any, unless ``in_place``: default
    False, the caller's array is left as it is), and how many were dropped.

    A sample off every rigid distance of its segment by more than GHOST_MIN, or one that
    lands off its track further than a body segment accelerates, is not the marker (or, for
    a jump to a new place for good, one sample of it: little lost), and a least-squares fit
    follows it: a knee marker 50-100 mm off in 1 % of the
    frames moved a joint-centre distance by 0.9-1.7 mm on the shared trials
    (docs/validation.md#real-recordings). ``first_frame``: the file's
    frame of row 0, as given to :func:`check_marker_quality`.
    """
    drop = {(f.markers[0], t) for f in findings if f.file == path for t in f.samples}
    if not drop:
        return markers, 0
    out = markers if in_place else np.array(markers, dtype=float)
    for name, t in drop:
        out[t - first_frame, list(names).index(name)] = np.nan
    return out, len(drop)


def marker_segments(model: mujoco.MjModel) -> list[str]:
    """The name of the body carrying each marker (site) of ``model`` (M,): the segments
    :func:`check_marker_quality` wants."""
    return [
        str(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(b))) for b in model.site_bodyid
    ]


def suspects(findings: Sequence[Finding]) -> dict[str, int]:
    """Markers the findings name, with how many name them, most named first; an
    ``asymmetry`` finding names no one (either side may be the wrong one)."""
    count: dict[str, int] = {}
    for f in findings:
        for n in () if f.kind == "asymmetry" else f.markers:
            count[n] = count.get(n, 0) + 1
    return dict(sorted(count.items(), key=lambda kv: (-kv[1], kv[0])))


def check_trials_quality(
    paths: Sequence[str],
    names: Sequence[str],
    markers: Sequence[np.ndarray],
    rates: Sequence[float],
    segments: Sequence[str],
    first_frames: Sequence[int],
    *,
    between: bool = True,
) -> list[Finding]:
    """Every trial's findings (:func:`check_marker_quality`: ``paths``, markers (T_i, M, 3)
    [m], rates [Hz] and first frames per trial) and, with ``between`` (one model for every
    trial), those across trials (:func:`between_trials`)."""
    found: list[Finding] = []
    for path, x, rate, first in zip(paths, markers, rates, first_frames, strict=True):
        found += check_marker_quality(path, names, x, rate, segments, first_frame=first)
    if between:
        found += between_trials(paths, names, markers, segments)
    return found


def quality_lines(entry: Mapping[str, Any]) -> list[str]:
    """The report.md section on marker data quality from summary.json's ``marker_quality``
    entry (:func:`mocap_mj.pipeline.summary.quality_fields`: ``findings``, ``suspects``,
    ``excluded`` and ``relabelled``)."""
    lines = ["## Marker data quality", ""]
    for r in entry.get("relabelled") or []:
        done = "labels corrected" if r["applied"] else "labels not corrected (--no-relabel)"
        lines.append(f"- {done}: {r['message']}")
    if entry.get("excluded"):
        lines.append(
            f"- excluded by --exclude-markers: {', '.join(entry['excluded'])} (their data "
            "dropped: their offsets are not identified, they stay at their prior)"
        )
    if not entry.get("findings"):
        return [*lines, "- no finding (docs/recordings.md#marker-data-quality)", ""]
    lines += [f"- {f['message']}" for f in entry["findings"]]
    named = ", ".join(f"{n} ({c})" for n, c in entry["suspects"].items())
    return [*lines, f"- markers named: {named}; drop them with --exclude-markers NAME[,NAME]", ""]


def parse_marker_list(text: str | None, names: Sequence[str]) -> tuple[str, ...]:
    """``--exclude-markers`` text ("RELB,RWRA") -> names; an unknown one raises
    :class:`~mocap_mj.errors.UnknownNameError` listing the model's markers."""
    if not text:
        return ()
    out = tuple(n.strip() for n in text.split(",") if n.strip())
    for n in out:
        if n not in names:
            raise UnknownNameError("marker (--exclude-markers)", n, names)
    return out


def exclude_markers(markers: np.ndarray, names: Sequence[str], drop: Sequence[str]) -> np.ndarray:
    """markers (T, M, 3) [m] with the columns of ``drop`` set to NaN (missing), in place
    when the array is writable, else on a copy; returns the array."""
    if not drop:
        return markers
    out = markers if getattr(markers, "flags", None) and markers.flags.writeable else None
    if out is None:
        out = np.array(markers)
    out[:, [list(names).index(n) for n in drop], :] = np.nan
    return out


# ------------------------------------------------------------------ same-segment distances
def _sampled(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """At most ``_MAX_SAMPLES`` evenly spaced frames of x and their indices."""
    idx = np.arange(len(x))
    if len(x) > _MAX_SAMPLES:
        idx = np.linspace(0, len(x) - 1, _MAX_SAMPLES).astype(int)
    return np.asarray(x[idx], dtype=float), idx


def _segment_findings(
    path: str, names: Sequence[str], x: np.ndarray, segments: Sequence[str], first: int
) -> list[Finding]:
    xs, idx = _sampled(x)
    out: list[Finding] = []
    for members in _by_segment(segments):
        spread: dict[tuple[int, int], float] = {}
        steps: dict[tuple[int, int], tuple[float, int, float, float]] = {}
        for i, j, d, ok in _pair_distances(xs, members):
            p5, p95 = np.percentile(d[ok], [5, 95])
            if p95 - p5 > SPREAD_MAX:
                spread[(i, j)] = float(p95 - p5)
            step = _step(d[ok])
            if step is not None:
                size, at, before, after = step
                steps[(i, j)] = (size, int(idx[np.flatnonzero(ok)[at]]), before, after)
        for i, others, v in _attribute(spread):
            out.append(
                _line(
                    path,
                    "spread",
                    (names[i], *[names[k] for k in others]),
                    None,
                    v,
                    f"<= {SPREAD_MAX * 1e3:.0f} mm on one segment",
                    f"{_who(names, i, others)} varies by {v * 1e3:.0f} mm (p5-p95) over the trial",
                )
            )
        for i, others, v in _attribute({k: s[0] for k, s in steps.items()}):
            j = others[0]
            _, at, before, after = steps[(i, j) if (i, j) in steps else (j, i)]
            frames = (first + at, first + len(x))
            out.append(
                _line(
                    path,
                    "step",
                    (names[i], *[names[k] for k in others]),
                    frames,
                    v,
                    f"< {STEP_MIN * 1e3:.0f} mm (fixed on its segment)",
                    f"{_who(names, i, others)} changes for good at frame {frames[0]}, "
                    f"{before * 1e3:.0f} -> {after * 1e3:.0f} mm (re-stuck or slipped?)",
                )
            )
    return out


def _pair_distances(
    x: np.ndarray, members: Sequence[int]
) -> Iterator[tuple[int, int, np.ndarray, np.ndarray]]:
    """Every pair (i, j) of the markers ``members`` (indices into x (T, M, 3) [m]) with at
    least 10 frames of both: i, j, their distance (T,) [m] and where it is finite (T,)."""
    for a_pos, i in enumerate(members):
        for j in members[a_pos + 1 :]:
            d = np.linalg.norm(x[:, i] - x[:, j], axis=1)
            ok = np.isfinite(d)
            if ok.sum() >= 10:
                yield i, j, d, ok


def _by_segment(segments: Sequence[str]) -> list[list[int]]:
    """The marker indices of each segment, in the order the segments first appear."""
    groups: dict[str, list[int]] = {}
    for i, s in enumerate(segments):
        groups.setdefault(s, []).append(i)
    return list(groups.values())


def _ghost_findings(
    path: str, names: Sequence[str], x: np.ndarray, segments: Sequence[str], first: int
) -> list[Finding]:
    """``ghost`` findings: frames where a marker is off its segment (module docstring)."""
    off = np.zeros(x.shape[:2], dtype=bool)  # (T, M)
    size = np.zeros(x.shape[:2])
    for members in _by_segment(segments):
        rigid: dict[tuple[int, int], np.ndarray] = {}  # a pair's departure (T,) [m]
        for i, j, d, ok in _pair_distances(x, members):
            p5, p95 = np.percentile(d[ok], [5, 95])
            if p95 - p5 <= SPREAD_MAX:  # otherwise a ``spread``: not rigid enough
                rigid[(i, j)] = np.where(ok, np.abs(d - np.median(d[ok])), np.nan)
        for i in members:
            dev = [v for pair, v in rigid.items() if i in pair]
            if not dev:
                continue
            with np.errstate(invalid="ignore"):
                low = np.min(np.stack(dev), axis=0)  # the least departure over the mates
                off[:, i] = low > GHOST_MIN
            size[:, i] = np.nan_to_num(low)
        if len(members) == 2:  # both depart together: name the one off its own track
            a, b = members
            both = off[:, a] & off[:, b]
            if both.any():
                mid = np.full_like(x[:, members], np.nan)
                mid[1:-1] = 0.5 * (x[:-2, members] + x[2:, members])
                err = np.nan_to_num(np.linalg.norm(x[:, members] - mid, axis=2))  # (T, 2)
                off[both, a] = err[both, 0] >= err[both, 1]
                off[both, b] = ~off[both, a]
    out: list[Finding] = []
    for col in np.flatnonzero(off.any(axis=0)):
        ts = np.flatnonzero(off[:, col])
        if len(ts) > 0.05 * len(x):
            continue  # off for long: a ``spread`` or ``step``, not a ghost
        shown = ", ".join(str(first + t) for t in ts[:5]) + (", ..." if len(ts) > 5 else "")
        biggest = float(size[ts, col].max())
        line = _line(
            path,
            "ghost",
            (names[int(col)],),
            (first + int(ts[0]), first + int(ts[-1]) + 1),
            biggest,
            f"<= {GHOST_MIN * 1e3:.0f} mm from its segment's median distances",
            f"{names[int(col)]}: off its segment in {len(ts)} frame(s), at frame(s) {shown}, "
            f"by up to {biggest * 1e3:.0f} mm (a ghost or a momentary mislabel?): those "
            "samples are left out of the fit",
        )
        out.append(replace(line, samples=tuple(first + int(t) for t in ts)))
    return out


def _step(d: np.ndarray) -> tuple[float, int, float, float] | None:
    """The largest persistent change of d (n,) [m]: (size, first index after, level before,
    level after), or None when below STEP_MIN.

    d is summarised by the medians of ``_STEP_BLOCKS`` blocks at most (robust to single
    frames); a step must keep a tenth of the blocks each side, and both the means of the
    whole parts before and after it and those of the adjacent windows (a twentieth of the
    blocks) must differ by more than STEP_MIN, so that a cyclic motion is not a step.
    """
    b = -(-len(d) // _STEP_BLOCKS)
    m = len(d) // b
    lo = max(5, m // 10)
    if m < 2 * lo:
        return None
    blocks = np.median(d[: m * b].reshape(m, b), axis=1)
    c = np.concatenate([[0.0], np.cumsum(blocks)])
    s = np.arange(lo, m - lo + 1)
    before, after = c[s] / s, (c[m] - c[s]) / (m - s)
    w = max(3, lo // 2)
    sw = np.clip(s, w, m - w)
    local = np.abs((c[sw + w] - c[sw]) - (c[sw] - c[sw - w])) / w
    ok = (np.abs(after - before) > STEP_MIN) & (local > STEP_MIN)
    if not ok.any():
        return None
    k = int(np.argmax(np.where(ok, local, 0.0)))
    return float(abs(after[k] - before[k])), int(s[k]) * b, float(before[k]), float(after[k])


def _attribute(
    flagged: dict[tuple[int, int], float],
) -> list[tuple[int, list[int], float]]:
    """Flagged pairs -> (suspect, its flagged partners, largest value): a marker
    in two or more flagged pairs is the suspect of them all; the other pairs stay pairs."""
    count: dict[int, int] = {}
    for i, j in flagged:
        count[i] = count.get(i, 0) + 1
        count[j] = count.get(j, 0) + 1
    out = []
    done: set[tuple[int, int]] = set()
    for m in sorted(count, key=lambda k: -count[k]):
        if count[m] < 2:
            continue
        pairs = [p for p in flagged if m in p and p not in done]
        if len(pairs) < 2:
            continue
        done.update(pairs)
        others = [p[0] if p[1] == m else p[1] for p in pairs]
        out.append((m, others, max(flagged[p] for p in pairs)))
    for p, v in flagged.items():
        if p not in done:
            out.append((p[0], [p[1]], v))
    return out


# ------------------------------------------------------------------------- jumps and swaps
def _jump_findings(
    path: str, names: Sequence[str], x: np.ndarray, rate: float, first: int
) -> list[Finding]:
    if len(x) < 3:
        return []
    limit = max(JUMP_MIN, ACCEL_MAX / rate**2)
    err = _prediction_error(x)  # (T-2, M): of frames 2..T-1
    with np.errstate(invalid="ignore"):
        jump = err > limit
    onset = jump.copy()
    onset[1:] &= ~jump[:-1]  # a jump at t also spoils the prediction of t+1
    out: list[Finding] = []
    swaps: dict[tuple[int, int], list[int]] = {}
    lone: dict[int, list[tuple[int, float]]] = {}
    for r, i in zip(*np.nonzero(onset), strict=True):
        t = int(r) + 2
        xt = np.asarray(x[t], dtype=float)
        pred = 2 * np.asarray(x[t - 1], dtype=float) - x[t - 2]  # (M, 3)
        near = np.linalg.norm(xt - pred[i], axis=1)  # who landed on i's prediction
        near[i] = np.inf
        k = int(np.argmin(np.where(np.isfinite(near), near, np.inf)))
        back = float(np.linalg.norm(xt[i] - pred[k]))
        if near[k] < limit / 2 and back < limit / 2 and jump[r, k]:
            if i < k:
                swaps.setdefault((i, k), []).append(t)
        else:
            lone.setdefault(int(i), []).append((t, float(err[r, i])))
    for (i, k), ts in swaps.items():
        for a in range(0, len(ts), 2):
            start = ts[a]
            stop = ts[a + 1] if a + 1 < len(ts) else len(x)
            frames = (first + start, first + stop)
            out.append(
                _line(
                    path,
                    "swap",
                    (names[i], names[k]),
                    frames,
                    0.0,
                    "labels that stay on their markers",
                    f"{names[i]} and {names[k]}: labels swapped in frames "
                    f"{frames[0]}-{frames[1] - 1} (each jumps onto the other's track)",
                )
            )
    for i, events in lone.items():
        ts = [t for t, _ in events]
        biggest = max(e for _, e in events)
        shown = ", ".join(str(first + t) for t in ts[:5]) + (", ..." if len(ts) > 5 else "")
        line = _line(
            path,
            "jump",
            (names[i],),
            (first + ts[0], first + ts[-1] + 1),
            biggest,
            f"<= {limit * 1e3:.0f} mm per frame at {rate:g} Hz",
            f"{names[i]}: {len(ts)} jump(s) off its track, at frame(s) {shown}, up to "
            f"{biggest * 1e3:.0f} mm (a ghost, a label change or a re-stick?): the samples "
            "at the jumps are left out of the fit",
        )
        out.append(replace(line, samples=tuple(first + t for t in ts)))
    return out


def _prediction_error(x: np.ndarray) -> np.ndarray:
    """(T-2, M) [m]: |x(t) - (2 x(t-1) - x(t-2))| for t = 2..T-1, chunk by chunk (x may be
    a memory map of an hour-long recording)."""
    out = np.empty((len(x) - 2, x.shape[1]))
    for a in range(0, len(x) - 2, _MAX_SAMPLES):
        b = min(a + _MAX_SAMPLES, len(x) - 2)
        c = np.asarray(x[a : b + 2], dtype=float)
        out[a:b] = np.linalg.norm(c[2:] - 2 * c[1:-1] + c[:-2], axis=2)
    return out


# ------------------------------------------------------------------- bones of Plug-in Gait
def _bone_findings(path: str, names: Sequence[str], x: np.ndarray) -> list[Finding]:
    xs, _ = _sampled(x)
    col = {n: i for i, n in enumerate(names)}
    out: list[Finding] = []
    for (a, b), fraction in BONE_FRACTIONS.items():
        lo, hi = fraction * _HEIGHTS[0], fraction * _HEIGHTS[1]
        side: dict[str, float] = {}
        for s in "LR":
            i, j = col.get(s + a), col.get(s + b)
            if i is None or j is None:
                continue
            d = np.linalg.norm(xs[:, i] - xs[:, j], axis=1)
            d = d[np.isfinite(d)]
            if d.size == 0:
                continue
            med = side[s] = float(np.median(d))
            if not lo <= med <= hi:
                out.append(
                    _line(
                        path,
                        "distance",
                        (s + a, s + b),
                        None,
                        med,
                        f"{lo * 1e3:.0f}-{hi * 1e3:.0f} mm",
                        f"{s}{a}-{s}{b}: median distance {med * 1e3:.0f} mm, outside the "
                        f"{lo * 1e3:.0f}-{hi * 1e3:.0f} mm of any person 0.85-2.1 m tall",
                    )
                )
        if len(side) == 2 and (a, b) not in _NO_ASYMMETRY:
            rel = abs(side["L"] - side["R"]) / max(side.values())
            if rel > ASYMMETRY_MAX:
                out.append(
                    _line(
                        path,
                        "asymmetry",
                        (f"L{a}", f"L{b}", f"R{a}", f"R{b}"),
                        None,
                        abs(side["L"] - side["R"]),
                        f"left and right within {ASYMMETRY_MAX:.0%}",
                        f"L{a}-L{b} {side['L'] * 1e3:.0f} mm but R{a}-R{b} "
                        f"{side['R'] * 1e3:.0f} mm: left and right differ by {rel:.0%}",
                    )
                )
    return out


def placement_finding(
    path: str, markers: tuple[str, ...], value: float, expected: str, text: str
) -> Finding:
    """A ``placement`` finding over the whole trial (module docstring): ``markers`` the
    misplaced landmark first, ``value`` [m] how far it is from where it belongs."""
    return _line(path, "placement", markers, None, value, expected, text)


def _who(names: Sequence[str], i: int, others: Sequence[int]) -> str:
    """The subject of a same-segment finding: a suspect and its partners, or a pair."""
    if len(others) == 1:
        return f"{names[i]}-{names[others[0]]}: the distance of these two markers of one segment"
    return f"{names[i]}: its distance to {', '.join(names[k] for k in others)} (same segment)"


def _line(
    path: str,
    kind: str,
    markers: tuple[str, ...],
    frames: tuple[int, int] | None,
    value: float,
    expected: str,
    text: str,
) -> Finding:
    where = "all frames" if frames is None else f"frames {frames[0]}-{frames[1] - 1}"
    message = f"{path}: {text} [{kind}, {where}; expected {expected}]"
    return Finding(path, kind, markers, frames, float(value), expected, message)
