"""The screen of :mod:`mocap_mj.pipeline.relabel`'s candidates in one round, all at once.

A candidate's screen (module docstring of :mod:`~mocap_mj.pipeline.relabel`, "Screen, then
confirm") compares its markers' residuals as labelled and with its labels exchanged, on the
original labeling's poses and on rigid (Kabsch) fits of its segments alone. Here the
exchanged contents of one segment, over every candidate that touches it, are stacked into
one rigid fit; the as-labelled fits are made once per round; the residuals of the
candidates with as many markers are gathered into one array, and the medians over every
candidate's spans are taken in one sort. Each number is computed as a per-candidate fit
computes it (the same operations on the same frames, in the same order). The rigid fits are
Horn's quaternion fits (:func:`~mocap_mj.skeleton.rigid.rigid_residuals_horn`): the Kabsch fits'
rotations to rounding, in arithmetic on whole arrays, where a stacked SVD of one 3 x 3
matrix per frame and content took most of a round's screen.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.skeleton.rigid import rigid_residuals_horn

if TYPE_CHECKING:
    from mocap_mj.pipeline.relabel import Candidate

__all__ = ["Pose", "Segments", "rms", "screens"]


@dataclass
class Pose:
    """The sampled frames' IK with one labeling: the model's marker positions (n, M, 3)
    [m], the squared residual per marker (n, M) [m^2] (NaN where missing or unsolved) and
    the whole body's RMS residual per frame (n,) [m]; the body origins (joint centres)
    (n, nbody, 3) [m] when asked for."""

    sites: np.ndarray
    sq: np.ndarray
    rms: np.ndarray
    origins: np.ndarray | None = None


def rms(sq: np.ndarray) -> np.ndarray:
    """(...) [m]: the RMS over the last axis of sq (..., k) [m^2] of the entries present
    (not NaN) (NaN: none)."""
    ok = ~np.isnan(sq)
    count = ok.sum(axis=-1)
    out = np.full(sq.shape[:-1], np.nan)
    np.sqrt(np.where(ok, sq, 0.0).sum(axis=-1) / np.maximum(count, 1), out=out, where=count > 0)
    return out


class Segments:
    """Rigid fits of one segment's markers and its joint centre (the body origin where the
    original labeling's IK puts it; not for the root) to the model's marker offsets, frame
    by frame: a segment judged free of the poses the exchanged labels forced on it."""

    def __init__(self, pset: ParameterSet, theta: np.ndarray, origins: np.ndarray) -> None:
        """theta (P,) [m]: the model's parameters; origins (n, nbody, 3) [m]: the body
        origins of the sampled frames."""
        self.offsets = pset.split(theta)[1].reshape(-1, 3)  # (M, 3) [m], body frames
        self.body = np.asarray(pset.model.site_bodyid, dtype=int)  # (M,)
        self.root = int(self.body[0]) if len(self.body) else -1
        while self.root > 0 and int(pset.model.body_parentid[self.root]) > 0:
            self.root = int(pset.model.body_parentid[self.root])
        self.origins = origins
        #: each marker-carrying body's markers (model order)
        self.members = {int(b): np.flatnonzero(self.body == b) for b in np.unique(self.body)}

    def fit_sq(self, meas: np.ndarray, b: int) -> np.ndarray | None:
        """(K, n, m) [m^2]: the squared residuals of segment b's markers in its rigid fits
        to K contents meas (K, n, m, 3) [m] of its m markers (its joint centre included but
        for the root), or None when it has fewer than three points."""
        ref = self.offsets[self.members[b]]  # (m, 3) [m]
        k, n, m = meas.shape[:3]
        if b != self.root:
            ref = np.vstack([ref, np.zeros(3)])
            centre = np.broadcast_to(self.origins[:, b][None, :, None], (k, n, 1, 3))
            meas = np.concatenate([meas, centre], axis=2)
        if len(ref) < 3:
            return None
        sq = rigid_residuals_horn(meas.reshape(k * n, len(ref), 3), ref)
        return sq[:, :m].reshape(k, n, m)

    def labelled(self, x: np.ndarray) -> np.ndarray:
        """(n, M + 1) [m^2]: each marker's squared residual in its segment's fit to x
        (n, M, 3) [m] as labelled (NaN where its segment has fewer than three points, and in
        the last column)."""
        out = np.full((len(x), x.shape[1] + 1), np.nan)
        for b, members in self.members.items():
            got = self.fit_sq(x[None, :, members], b)
            if got is not None:
                out[:, members] = got[0]
        return out

    def exchanged(
        self, x: np.ndarray, cands: Sequence[Candidate]
    ) -> tuple[np.ndarray, list[np.ndarray]]:
        """The squared residuals [m^2] of every candidate's markers in its segments' fits
        to x (n, M, 3) [m] with its labels exchanged: (n, columns + 1), the last column NaN,
        and per candidate the columns (len(slots),) of its slots (the last where the slot's
        segment has fewer than three points)."""
        contents: dict[int, list[np.ndarray]] = {}  # segment: (m,) sources of its markers
        where: list[list[tuple[int, int, int]]] = []  # per slot: segment, content, position
        for c in cands:
            take = dict(zip(c.slots, c.sources, strict=True))
            row = {}  # segment: this candidate's content's index among its contents
            for b in sorted({int(self.body[m]) for m in c.slots}):
                row[b] = len(contents.setdefault(b, []))
                contents[b].append(np.array([take.get(int(m), int(m)) for m in self.members[b]]))
            seg = [int(self.body[m]) for m in c.slots]
            where.append([(b, row[b], int(np.searchsorted(self.members[b], m)))
                          for b, m in zip(seg, c.slots, strict=True)])  # fmt: skip
        blocks, start, at = [], {}, 0
        for b, rows in contents.items():
            got = self.fit_sq(x[:, np.array(rows)].transpose(1, 0, 2, 3), b)
            if got is not None:
                start[b] = at
                at += got.shape[0] * got.shape[2]
                blocks.append(got.transpose(1, 0, 2).reshape(len(x), -1))
        blocks.append(np.full((len(x), 1), np.nan))
        columns = [
            np.array([start[b] + k * len(self.members[b]) + q if b in start else at
                      for b, k, q in w], dtype=int)
            for w in where
        ]  # fmt: skip
        return np.concatenate(blocks, axis=1), columns


def screens(
    cands: Sequence[Candidate],
    bounds: Sequence[np.ndarray],
    x: np.ndarray,
    base: Pose,
    segments: Segments,
    *,
    margin: float,
    least: int,
) -> np.ndarray:
    """(C,) [m^2]: each candidate's screen: over its spans (``bounds[i]`` (S, 2) [first,
    last) rows of x), the largest drop of the squared residual summed over its markers where
    the exchanged residuals pass, on the original poses ``base`` or in the rigid fits, half
    the margin: a median RMS of at most 0.8 of the labelled one's and ``margin`` [m] below
    it, over the span's frames where both are known (at least ``least`` of them, or all of a
    shorter span); else 0. x (n, M, 3) [m]: the sampled frames."""
    labelled = segments.labelled(x)  # (n, M + 1)
    exchanged, columns = segments.exchanged(x, cands)
    out = np.zeros(len(cands))
    sizes = np.array([len(c.slots) for c in cands])
    for k in np.unique(sizes):
        idx = np.flatnonzero(sizes == k).tolist()
        s = np.array([cands[i].slots for i in idx])  # (C_k, k)
        src = np.array([cands[i].sources for i in idx])
        tests = (
            (rms(base.sq[:, s]), rms(np.sum((base.sites[:, s] - x[:, src]) ** 2, axis=-1))),
            (rms(labelled[:, s]), rms(exchanged[:, np.array([columns[i] for i in idx])])),
        )  # each (n, C_k) [m]
        spans = [bounds[i] for i in idx]
        for old, new in tests:
            drops = _drops(old, new, spans, int(k), margin, least)
            out[idx] = np.maximum(out[idx], drops)
    return out


def _drops(
    old: np.ndarray, new: np.ndarray, spans: Sequence[np.ndarray], k: int, margin: float,
    least: int,
) -> np.ndarray:  # fmt: skip
    """(C,) [m^2]: per candidate (a column of old, new (n, C) [m]: its k markers' RMS
    residual as labelled and exchanged), the largest ``k * (before**2 - after**2)`` over
    its spans (rows ``spans[j]`` (S, 2)) whose medians pass (:func:`screens`), else 0."""
    group = np.full(old.shape[::-1], -1)  # (C, n): each frame's span, numbered over all
    length: list[int] = []  # each span's frames
    for j, rows in enumerate(spans):
        for a, b in rows:
            group[j, a:b] = len(length)
            length.append(int(b - a))
    good = np.isfinite(old.T) & np.isfinite(new.T) & (group >= 0)
    g = group[good]
    count = np.bincount(g, minlength=len(length))
    enough = (count >= np.minimum(least, length)) & (count > 0)
    first = np.cumsum(count) - count
    lo, hi = first + (count - 1) // 2, first + count // 2
    medians = []
    for values in (old.T[good], new.T[good]):
        v = values[np.lexsort((values, g))]  # by span, then by value
        m = np.full(len(length), np.nan)
        m[enough] = (v[lo[enough]] + v[hi[enough]]) / 2
        medians.append(m)
    before, after = medians
    passed = enough & (after < 0.8 * before) & (before - after > margin)
    owner = np.repeat(np.arange(len(spans)), [len(r) for r in spans])
    out = np.zeros(len(spans))
    for i in np.flatnonzero(passed):
        out[owner[i]] = max(out[owner[i]], k * (float(before[i]) ** 2 - float(after[i]) ** 2))
    return out
