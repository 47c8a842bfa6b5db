"""A synthetic experiment: truth model, truth motion, measured markers; and writing it to disk.

Symbols: T frames, M markers (39), nq = 55, P = 151 model parameters.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.io import MarkerTrajectory, atomic_write_text, save_csv, save_trc
from mocap_mj.io.atomic import atomic_folder
from mocap_mj.pipeline.motion import Motion, save_motion
from mocap_mj.skeleton.exported import Layout
from mocap_mj.skeleton.kinematics import Kinematics
from mocap_mj.skeleton.parameters import ParameterSet

from . import noise, postures
from .config import SynthConfig
from .motion import generate
from .perturb import perturb_theta

__all__ = ["FILES", "Experiment", "summarize", "synthesize", "write_experiment"]

#: The files :func:`write_experiment` writes, in order.
FILES: tuple[str, ...] = (
    "markers.csv",
    "markers.trc",
    "truth.json",
    "truth_model.xml",
    "truth_motion.npz",
    "summary.json",
)

#: Independent random streams spawned from the seed, in this order; each part of the
#: experiment draws from its own, so turning one corruption on does not change the others.
STREAMS: tuple[str, ...] = ("model", "motion", "noise", "sta", "gaps", "outliers", "swaps")


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array, copy=True)
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class Experiment:
    """One synthetic experiment (arrays are read-only).

    Attributes
    ----------
    config : SynthConfig
    pset : ParameterSet
    theta_true : (P,) float [m]
        The truth model's parameters.
    theta_nominal : (P,) float [m]
        The parameters the truth was perturbed from (``pset.nominal``).
    times : (T,) float [s]
    qpos : (T, nq) float [m, unit quaternions, rad]
        The truth motion.
    markers_clean : (T, M, 3) float [m]
        Marker positions of the truth model in the truth motion (rigid forward kinematics).
    markers : (T, M, 3) float [m]
        The measurement: clean + soft-tissue artefact + noise, with label swaps, outliers and
        NaN in the occlusion gaps.
    sigma : float [m]
        Standard deviation of the white noise per axis.
    outlier_mask : (T, M) bool
        Samples displaced as outliers.
    gap_mask : (T, M) bool
        Samples missing (NaN) in ``markers``.
    swapped : list of (marker_a, marker_b, first_frame, last_frame)
        Label swaps: in frames first..last (inclusive) the two markers' labels are exchanged.
    sta : (T, M, 3) float [m]
        The soft-tissue displacement added to each marker (zeros when off).
    """

    config: SynthConfig
    pset: ParameterSet
    theta_true: np.ndarray
    theta_nominal: np.ndarray
    times: np.ndarray
    qpos: np.ndarray
    markers_clean: np.ndarray
    markers: np.ndarray
    sigma: float
    outlier_mask: np.ndarray
    gap_mask: np.ndarray
    swapped: list[tuple[str, str, int, int]] = field(default_factory=list)
    sta: np.ndarray | None = None

    @property
    def marker_names(self) -> tuple[str, ...]:
        """Marker names (M,), in model site order."""
        return self.pset.marker_names

    def trajectory(self) -> MarkerTrajectory:
        """The measured markers as a :class:`mocap_mj.io.MarkerTrajectory` (NaN = missing)."""
        cfg = self.config
        return MarkerTrajectory(
            times=self.times,
            positions=self.markers,
            names=self.marker_names,
            rate=cfg.rate,
            source={"format": "mocap-mj synth", "motion": cfg.motion, "seed": cfg.seed},
        )

    def truth_motion(self) -> Motion:
        """The truth motion with the clean marker positions, as a :class:`Motion`."""
        return Motion(
            qpos=np.array(self.qpos),
            times=np.array(self.times),
            markers=np.array(self.markers_clean),
            marker_names=self.marker_names,
        )


def synthesize(
    config: SynthConfig | None = None,
    pset: ParameterSet | None = None,
    landmarks: Mapping[str, str] | None = None,
) -> Experiment:
    """Build the experiment ``config`` describes (deterministic given ``config.seed``).

    Steps: perturb the nominal parameters and place the markers on the perturbed skeleton
    (:func:`mocap_synth.perturb.perturb_theta`, ``config.marker_placement``); generate
    the truth motion (:mod:`mocap_synth.motion`); forward kinematics of the truth model; add the
    soft-tissue artefact and the white noise; swap labels; cut the occlusion gaps; displace the
    outliers among the samples still visible. Each step draws from its own stream spawned from
    the seed (:data:`STREAMS`). The truth motion holds or starts in ``config.pose``, turned by
    ``config.heading_deg`` (:func:`mocap_synth.postures.apply`), from the same draws.

    Parameters
    ----------
    config : SynthConfig, optional
        Defaults to ``SynthConfig()``.
    pset : ParameterSet, optional
        The model parameterisation (the bundled humanoid by default).
    landmarks : mapping, optional
        Marker -> landmark of ``pset``'s marker set (its medial landmarks placed as the
        identification expects them; :func:`mocap_synth.perturb.place_landmarks`).

    Returns
    -------
    Experiment
    """
    cfg = config if config is not None else SynthConfig()
    pset = pset if pset is not None else ParameterSet()
    seeds = np.random.SeedSequence(cfg.seed).spawn(len(STREAMS))
    rng = {name: np.random.default_rng(s) for name, s in zip(STREAMS, seeds, strict=True)}

    theta = perturb_theta(pset, rng["model"], cfg.kappa_scale, cfg.offset_mm, cfg.symmetric,
                          cfg.marker_placement, landmarks)  # fmt: skip
    kin = Kinematics(pset)
    kin.set_theta(theta)
    qpos = generate(cfg.motion, kin.model, cfg.frames, cfg.rate, rng["motion"])
    qpos = postures.apply(kin.model, qpos, cfg.motion, cfg.pose, cfg.heading_deg, cfg.rate)
    frames = kin.forward(qpos)
    clean = np.array(frames.site_xpos)
    shape = clean.shape

    sigma = cfg.noise_mm / 1000.0
    white = noise.white_noise(shape, sigma, rng["noise"])
    sta = noise.soft_tissue(kin.model, qpos, frames.xmat, cfg.sta_mm / 1000.0, rng["sta"])
    names = pset.marker_names
    swaps = noise.pick_swaps(names, cfg.frames, cfg.swaps, rng["swaps"])
    measured = noise.apply_swaps(clean + sta + white, names, swaps)
    gaps = noise.occlusion_gaps(cfg.frames, len(names), cfg.gaps, cfg.rate, rng["gaps"])
    measured[gaps] = np.nan
    outliers = noise.outlier_mask(~gaps, cfg.outliers, rng["outliers"])
    measured[outliers] += noise.outlier_displacements(
        int(outliers.sum()), cfg.outlier_mm / 1000.0, rng["outliers"]
    )
    return Experiment(
        config=cfg,
        pset=pset,
        theta_true=_frozen(theta),
        theta_nominal=_frozen(pset.nominal),
        times=_frozen(np.arange(cfg.frames) / cfg.rate),
        qpos=_frozen(qpos),
        markers_clean=_frozen(clean),
        markers=_frozen(measured),
        sigma=sigma,
        outlier_mask=_frozen(outliers),
        gap_mask=_frozen(gaps),
        swapped=swaps,
        sta=_frozen(sta),
    )


def summarize(exp: Experiment) -> dict[str, Any]:
    """What the experiment holds, JSON-ready (no paths, no times: reproducible bytes)."""
    cfg = exp.config
    pset = exp.pset
    kappa, offsets = pset.split(exp.theta_true)
    kappa0, offsets0 = pset.split(exp.theta_nominal)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(kappa0 != 0, kappa / kappa0 - 1.0, 0.0)
    visible = ~exp.gap_mask & ~exp.outlier_mask
    if exp.swapped:
        for a, b, first, last in exp.swapped:
            for name in (a, b):
                visible[first : last + 1, pset.marker_index(name)] = False
    sta = exp.sta if exp.sta is not None else np.zeros_like(exp.markers_clean)
    resid = (exp.markers - exp.markers_clean - sta)[visible]
    sta_norm = np.linalg.norm(sta, axis=-1)
    n = exp.gap_mask.size
    return {
        "command": "synth",
        "motion": cfg.motion,
        "frames": cfg.frames,
        "rate_hz": cfg.rate,
        "duration_s": cfg.duration,
        "markers": len(pset.marker_names),
        "parameters": pset.size,
        "seed": cfg.seed,
        "sigma_m": exp.sigma,
        "noise_std_mm": float(np.std(resid) * 1000.0) if resid.size else 0.0,
        "sta_rms_mm": float(np.sqrt(np.mean(sta_norm**2)) * 1000.0),
        "sta_max_mm": float(sta_norm.max() * 1000.0) if sta_norm.size else 0.0,
        "gap_fraction": float(exp.gap_mask.sum() / n),
        "outlier_count": int(exp.outlier_mask.sum()),
        "outlier_fraction": float(exp.outlier_mask.sum() / n),
        "swapped": [list(s) for s in exp.swapped],
        "kappa_change_max_rel": float(np.max(np.abs(rel))),
        "offset_change_max_mm": float(np.max(np.abs(offsets - offsets0)) * 1000.0),
        "config": cfg.to_dict(),
        "files": list(FILES),
    }


def write_experiment(
    exp: Experiment,
    out_dir: str | Path,
    force: bool = False,
    extra: Callable[[Path], list[str]] | None = None,
) -> dict[str, Any]:
    """Write the experiment's files into ``out_dir`` (each atomically) and return the summary.

    Files (:data:`FILES`): ``markers.csv`` and ``markers.trc`` (the measured markers, mm),
    ``truth.json`` (theta_true by name, theta_nominal, sigma, seed, settings, swaps),
    ``truth_model.xml`` (MJCF of the truth model), ``truth_motion.npz`` (qpos, times, clean
    markers, marker names) and ``summary.json``. The bytes depend only on the experiment.

    Parameters
    ----------
    exp : Experiment
    out_dir : str or Path
        Created if needed, whole at the end (:func:`mocap_mj.io.atomic.atomic_folder`); an
        existing non-empty folder is refused unless ``force``, and then replaced.
    force : bool
    extra : callable, optional
        Writes further files into the folder (given its path) after the truth files; returns
        their names, added to the summary's ``files``.

    Returns
    -------
    dict
        The summary (:func:`summarize`), also written as ``summary.json``.
    """
    with atomic_folder(out_dir, force=force) as out:
        pset = exp.pset
        traj = exp.trajectory()
        save_csv(out / "markers.csv", traj)
        save_trc(out / "markers.trc", traj)
        summary = summarize(exp)
        pset.save_json(
            out / "truth.json",
            exp.theta_true,
            extra={
                "description": "mocap-mj synthetic truth: theta_true (kappa, offsets) and settings",
                "seed": exp.config.seed,
                "sigma_m": exp.sigma,
                "settings": exp.config.to_dict(),
                "swapped": [list(s) for s in exp.swapped],
                "parameter_names": list(pset.names),
                "theta": [float(v) for v in exp.theta_true],
                "theta_nominal": pset.to_dict(exp.theta_nominal),
            },
        )
        pset.export_mjcf(out / "truth_model.xml", exp.theta_true)
        truth = exp.truth_motion()
        written = Layout.of(pset.model).written(truth.qpos)
        save_motion(out / "truth_motion.npz", dataclasses.replace(truth, qpos=written))
        if extra is not None:
            summary["files"] = [*summary["files"], *extra(out)]
        atomic_write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    return summary
