"""The segments' masses fitted to the force plates over a result's trials (the recipe's
``inertia: fit``): the fit, the inertial parameters model.xml then holds, summary.json's
``inertia`` section and report.md's.

Each segment body (de Leva's, :func:`~mocap_mj.anatomy.inertia.segment_inertia`; the
carriers, clavicles, ulnae and toes, keep theirs) has its mass, first moment and inertia
scaled by the factor :func:`~mocap_mj.pipeline.inertial_fit.fit_masses` fits over the stance
frames of every trial with plates (:class:`StanceTrial`), de Leva's masses as the prior. The
centre of mass and the radii of gyration stay de Leva's, so every body stays physically
consistent (a positive mass, an inertia inside the triangle inequality). Without a stance
frame the regression's parameters are kept, with one notice (``mocap_mj.notices``).

summary.json's ``inertia``
    ``source`` ("fit", or "regression" with ``note``: why the fit did not run); with the fit,
    ``segments``: per body ``regression_mass_kg``, ``fitted_mass_kg``, ``sd_kg`` (the
    posterior sd of its mass), ``scale``, ``scale_sd``, ``determined``, ``at_bound``;
    ``singular_values`` (B,) [1] (of the whitened design, largest first);
    ``combinations_determined`` (the singular values of at least ``1 / DETERMINED_SD``: a
    posterior sd of at most 0.1 along them); ``stance_frames``; ``residuals``: per trial
    ``before`` and ``after`` (force RMS [N], % body weight, % of the peak ground reaction,
    moment RMS [N m] over its stance frames) and ``pooled`` (the same over all the fitted
    frames, % of the largest peak).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mocap_mj.anatomy.inertia import BodyInertia, Sex, segment_inertia
from mocap_mj.capture.contacts import FootLoads
from mocap_mj.errors import MocapError
from mocap_mj.outputs.dynamics_out import STANDARD_GRAVITY, model_with
from mocap_mj.outputs.kinetics_out import residual_figures
from mocap_mj.pipeline.dynamics import BodyLoad, inverse_dynamics
from mocap_mj.pipeline.inertial_fit import DETERMINED_SD, MassFit, Trial, fit_masses
from mocap_mj.pipeline.motion import load_motion
from mocap_mj.pipeline.quality import notice
from mocap_mj.skeleton.mjcf import load_model

__all__ = [
    "StanceTrial",
    "fit_inertia",
    "fitted_bodies",
    "inertia_text",
    "report_section",
    "scaled_inertia",
    "without_fit",
]


@dataclass(frozen=True)
class StanceTrial:
    """One trial of the fit: its ``name`` (the marker file), its ``motion`` file (motion.npz,
    the model's written layout), the feet's ``loads`` on the model's foot bodies, its
    ``stance`` frames (T,) bool (every load on the body measured) and the feet's ``feet``
    loads (their forces (T, 3) [N] give the peak ground reaction)."""

    name: str
    motion: Path
    loads: tuple[BodyLoad, ...]
    stance: np.ndarray
    feet: tuple[FootLoads, ...]


def fitted_bodies(inertia: BodyInertia) -> list[str]:
    """The bodies that carry a segment of their own (the carriers, of length 0, left out)."""
    return [b for b, n in zip(inertia.bodies, inertia.length, strict=True) if n > 0]


def scaled_inertia(inertia: BodyInertia, fit: MassFit) -> BodyInertia:
    """``inertia`` with each fitted body's mass and inertia (B,) scaled by ``fit.scale``; its
    centre of mass kept."""
    factor = np.ones(len(inertia.bodies))
    for body, s in zip(fit.bodies, fit.scale, strict=True):
        factor[inertia.bodies.index(body)] = s
    return dataclasses.replace(
        inertia, mass=inertia.mass * factor, inertia=inertia.inertia * factor[:, None, None]
    )


def fit_inertia(
    model_path: str | Path, trials: Sequence[StanceTrial], mass: float, *, sex: Sex = "male"
) -> tuple[BodyInertia, dict[str, Any]]:
    """The inertial parameters of the model file ``model_path`` (a result's model.xml) for a
    subject of ``mass`` [kg]: the masses fitted over the stance frames of ``trials`` (module
    docstring), or de Leva's with one notice when no trial has a stance frame; and
    summary.json's ``inertia`` section."""
    regression = segment_inertia(load_model(model_path), mass, sex=sex)
    usable = [t for t in trials if np.any(t.stance)]
    if not usable:
        return regression, without_fit("no stance frame on the force plates")
    model = model_with(model_path, mass, sex=sex)
    motions = [load_motion(t.motion) for t in usable]
    fit_trials = [
        Trial(m.qpos, m.times, t.loads, np.asarray(t.stance, dtype=bool))
        for m, t in zip(motions, usable, strict=True)
    ]
    try:
        fit = fit_masses(model, fit_trials, fitted_bodies(regression))
    except MocapError as exc:
        return regression, without_fit(str(exc))
    fitted = scaled_inertia(regression, fit)
    after_model = model_with(model_path, mass, sex=sex, inertia=fitted)
    residuals = []
    for t, m in zip(usable, motions, strict=True):
        dyns = [inverse_dynamics(mdl, m.qpos, m.times, t.loads) for mdl in (model, after_model)]
        figures = [residual_figures(d, t.feet, mass, t.stance) for d in dyns]
        residuals.append({"markers_file": t.name, "before": _figures(figures[0]),
                          "after": _figures(figures[1])})  # fmt: skip
    return fitted, _section(fit, mass, residuals)


def without_fit(why: str) -> dict[str, Any]:
    """summary.json's ``inertia`` of a fit that did not run (``why``), after its notice."""
    notice(f"warning: inertia fit: {why}: the segments keep de Leva's masses")
    return {"source": "regression", "note": why}


def _figures(fig: Any) -> dict[str, Any]:
    return {
        "stance_frames": fig.frames,
        "force_rms_n": fig.force_rms_n,
        "force_rms_pct_bw": fig.force_rms_pct_bw,
        "force_rms_pct_peak_grf": fig.force_rms_pct_peak_grf,
        "peak_grf_n": fig.peak_grf_n,
        "moment_rms_nm": fig.moment_rms_nm,
    }


def _section(fit: MassFit, mass: float, residuals: list[dict[str, Any]]) -> dict[str, Any]:
    """summary.json's ``inertia`` of ``fit`` (module docstring)."""
    weight = mass * STANDARD_GRAVITY
    peak = max(r["before"]["peak_grf_n"] for r in residuals)
    pooled = {
        label: {
            "force_rms_n": float(r[0]),
            "force_rms_pct_bw": 100.0 * float(r[0]) / weight,
            "force_rms_pct_peak_grf": 100.0 * float(r[0]) / peak if peak > 0 else float("nan"),
            "moment_rms_nm": float(r[1]),
        }
        for label, r in (("before", fit.residual_before), ("after", fit.residual_after))
    }
    segments = {
        b: {
            "regression_mass_kg": float(fit.mass_before[k]),
            "fitted_mass_kg": float(fit.mass_after[k]),
            "sd_kg": float(fit.sd[k] * fit.mass_before[k]),
            "scale": float(fit.scale[k]),
            "scale_sd": float(fit.sd[k]),
            "determined": bool(fit.determined[k]),
            "at_bound": bool(fit.at_bound[k]),
        }
        for k, b in enumerate(fit.bodies)
    }
    sv = [float(v) for v in fit.singular_values]
    return {
        "source": "fit",
        "segments": segments,
        "singular_values": sv,
        "combinations_determined": int(sum(v >= 1.0 / DETERMINED_SD for v in sv)),
        "stance_frames": int(sum(r["before"]["stance_frames"] for r in residuals)),
        "residuals": {"trials": residuals, "pooled": pooled},
    }


def _residual_line(label: str, r: dict[str, Any]) -> str:
    return (
        f"{label}: force RMS {r['force_rms_n']:.1f} N ({r['force_rms_pct_bw']:.1f} % body weight, "
        f"{r['force_rms_pct_peak_grf']:.1f} % of the peak ground reaction), moment RMS "
        f"{r['moment_rms_nm']:.1f} N m"
    )


def inertia_text(section: dict[str, Any]) -> list[str]:
    """The lines of the command's output and report.md on the fit: per segment its masses,
    sd and whether the data determine it, the singular values, the residuals before and
    after (masses in kg)."""
    if section["source"] != "fit":
        return [f"segment masses: de Leva's regression ({section['note']})"]
    segs = section["segments"]
    lines = [
        f"segment masses fitted to the force plates over {section['stance_frames']} stance "
        f"frames: {sum(s['determined'] for s in segs.values())} of {len(segs)} determined, "
        f"{section['combinations_determined']} combinations of {len(segs)}"
    ]
    for body, s in segs.items():
        state = "determined" if s["determined"] else "undetermined"
        state += " (at the bound)" if s["at_bound"] else ""
        lines.append(
            f"  {body}: regression {s['regression_mass_kg']:.2f} kg, fitted "
            f"{s['fitted_mass_kg']:.2f} +- {s['sd_kg']:.2f} kg, {state}"
        )
    lines.append("  singular values: " + ", ".join(f"{v:.3g}" for v in section["singular_values"]))
    pooled = section["residuals"]["pooled"]
    for label in ("before", "after"):
        line = _residual_line(label, pooled[label])
        lines.append(f"  root residual over the stance frames, {line}")
    return lines


def report_section(section: dict[str, Any]) -> str:
    """report.md's "Segment masses" section of summary.json's ``inertia``."""
    lines = inertia_text(section)
    if section["source"] != "fit":
        return f"\n## Segment masses\n\n- {lines[0]}\n"
    segs = section["segments"]
    rows = [
        f"| {b} | {s['regression_mass_kg']:.2f} | {s['fitted_mass_kg']:.2f} | {s['sd_kg']:.2f} "
        f"| {'yes' if s['determined'] else 'no'}{' (bound)' if s['at_bound'] else ''} |"
        for b, s in segs.items()
    ]
    trials = section["residuals"]["trials"]
    residuals = [
        f"- {Path(t['markers_file']).name}, {t['before']['stance_frames']} stance frames: "
        f"{_residual_line('before', t['before'])}; {_residual_line('after', t['after'])}"
        for t in trials
    ]
    return (
        "\n## Segment masses\n\n"
        f"{lines[0]}; the inertia of each segment scales with its mass, its centre of mass "
        "and radii of gyration stay de Leva's.\n\n"
        "| segment | regression [kg] | fitted [kg] | sd [kg] | determined |\n"
        "|---|---|---|---|---|\n" + "\n".join(rows) + "\n\n"
        "Singular values of the information: "
        + ", ".join(f"{v:.3g}" for v in section["singular_values"])
        + ".\n\n"
        + "\n".join(residuals)
        + "\n- all trials: "
        + f"{_residual_line('before', section['residuals']['pooled']['before'])}; "
        + f"{_residual_line('after', section['residuals']['pooled']['after'])}\n"
    )
