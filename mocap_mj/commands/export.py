"""``mocap-mj export RESULT --to FORMAT --out PATH``: a result in the formats others read.

Formats: OpenSim model (``osim``), motion (``mot``), TRC of the measured markers (``trc``) or
of the model markers (``trc-model``), C3D with markers, joint centres and angles (``c3d``),
the model's angles in Plug-in Gait's conventions (``angles``, beside a ``plug-in-gait``
folder's with ``--compare``), per-marker residuals (``residuals``) and segment scale factors
(``scale``) as CSV, the ground reactions as OpenSim's external loads (``grf``: a ``.mot`` and
its ``ExternalLoads`` ``<stem>_loads.xml``), everything in one folder (``all``), and the
formats other packages register (:mod:`mocap_mj.export.registry`; the viewer adds ``glb``).
Without ``--to`` the format follows the suffix of ``--out``.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mocap_mj.commands.common import (
    finish,
    output_folder,
    write_summary,
)
from mocap_mj.export.read_result import ExportSource, load_result
from mocap_mj.pipeline.trials import open_trial
from mocap_mj.skeleton.mjcf import load_model

from ..anatomy.inertia import Sex, segment_inertia
from ..capture.events import read_events_csv
from ..clinical.compare import comparison_section, folder_angles, numbered_like
from ..errors import MocapError
from ..export.c3d import write_c3d
from ..export.clinical import clinical_angles
from ..export.grf import loads_path, read_grf_csv, write_grf
from ..export.ik_setup import write_ik_setup
from ..export.mot import write_mot
from ..export.opensim_id import id_setup_xml
from ..export.osim import write_osim
from ..export.registry import Exporter, plugin_exporters
from ..export.tables import (
    marker_residuals,
    scale_table_text,
    write_angles_csv,
    write_residuals_csv,
)
from ..export.trc import write_trc
from ..io.atomic import atomic_write_text
from ..pipeline.dynamics import CUTOFF_HZ
from ._inputs import refuse_overwriting, refuse_replacing_file
from .parsers import EXPORT_FORMATS

#: File names of ``--to all``, per format.
ALL_FILES: dict[str, str] = {
    "osim": "subject.osim",
    "mot": "coordinates.mot",
    "trc": "markers.trc",
    "trc-model": "model_markers.trc",
    "c3d": "result.c3d",
    "angles": "angles.csv",
    "residuals": "residuals.csv",
    "scale": "scale.csv",
}
#: OpenSim IK setup of ``--to all`` (subject.osim fitted to markers.trc, every weight 1).
IK_SETUP = "ik_setup.xml"
#: ``--to all`` of a result with ground reactions: them as OpenSim's external loads, and an
#: InverseDynamicsTool setup (subject.osim moving as coordinates.mot under them, OpenSim's
#: low-pass of the coordinates at the tool's own cutoff).
GRF_MOT, ID_SETUP = "grf.mot", "id_setup.xml"


def _subject_mass(args: argparse.Namespace, src: ExportSource) -> float | None:
    """--mass, else the subject's mass [kg] that the result's summary.json records (the
    measurement the identification used: the C3D's PROCESSING group or --subject-file), else
    None (the model's own masses)."""
    if args.mass is not None:
        return float(args.mass)
    measured = src.summary.get("measurements", {}).get("mass", {})
    value = measured.get("value") if isinstance(measured, dict) else None
    if isinstance(value, int | float) and measured.get("unit", "kg") == "kg":
        return float(value)
    kinetics = src.summary.get("kinetics", {})  # ik's: the mass its inverse dynamics used
    for trial in kinetics.get("trials", []) if isinstance(kinetics, dict) else []:
        if isinstance(trial, dict) and isinstance(trial.get("body_mass_kg"), int | float):
            return float(trial["body_mass_kg"])
    return None


def _sex(src: ExportSource) -> Sex:
    """The de Leva table the result's inverse dynamics used (its kinetics' ``sex``), else
    the men's (the tool's default)."""
    kinetics = src.summary.get("kinetics", {})
    for trial in kinetics.get("trials", []) if isinstance(kinetics, dict) else []:
        if isinstance(trial, dict) and trial.get("sex") == "female":
            return "female"
    return "male"


def _grf_path(src: ExportSource) -> Path:
    """The result's ground reactions for its motion: grf.csv beside motion.npz, grf_<i>.csv
    beside motion_<i>.npz (which may not exist)."""
    stem = src.motion_path.stem if src.motion_path is not None else "motion"
    suffix = stem[len("motion") :] if stem.startswith("motion") else ""
    return src.root / f"grf{suffix}.csv"


def _grf_csv(src: ExportSource) -> Path:
    """:func:`_grf_path`, refused in one line when the result has none."""
    path = _grf_path(src)
    if not path.is_file():
        raise MocapError(
            f"{path}: no ground reactions for the result's motion (ik and identify write "
            "grf.csv for a trial with force plates and a body mass)"
        )
    return path


def _write(fmt: str, path: Path, src: ExportSource, args: argparse.Namespace) -> None:
    model, motion = src.model, src.motion
    first = motion.first_frame
    if fmt == "osim":
        mass = _subject_mass(args, src)
        # with a mass, the parameters the tool's inverse dynamics uses (de Leva's)
        inertia = segment_inertia(model, mass, sex=_sex(src)) if mass is not None else None
        write_osim(path, model, up=args.out_up, mass=mass, inertia=inertia)
    elif fmt == "grf":
        write_grf(path, read_grf_csv(_grf_csv(src)), up=args.out_up)
    elif fmt == "mot":
        write_mot(path, model, motion.times, motion.qpos)
    elif fmt == "trc":
        write_trc(
            path,
            motion.marker_names,
            motion.times,
            motion.markers,
            up=args.out_up,
            first_frame=first,
        )
    elif fmt == "trc-model":
        fitted, _ = marker_residuals(model, motion.qpos, motion.markers)
        write_trc(
            path, motion.marker_names, motion.times, fitted, up=args.out_up, first_frame=first
        )
    elif fmt == "c3d":
        events = src.root / "events.csv"  # ik's and identify's gait events, when written
        write_c3d(path, src, events=read_events_csv(events) if events.is_file() else ())
    elif fmt == "angles":
        write_angles_csv(path, model, motion.times, motion.qpos, first)
    elif fmt == "residuals":
        _, distance = marker_residuals(model, motion.qpos, motion.markers)
        write_residuals_csv(path, motion.marker_names, motion.times, distance, first)
    elif fmt == "scale":
        nominal = load_model(args.nominal)  # the bundled humanoid without --nominal
        atomic_write_text(path, scale_table_text(model, nominal))
    else:  # pragma: no cover - the parser's choices
        raise MocapError(f"--to {fmt}: unknown format")


def _builtin(fmt: str) -> Callable[[argparse.Namespace], dict[str, Any]]:
    def run(args: argparse.Namespace) -> dict[str, Any]:
        src = _source(args)
        out = Path(args.out)
        extra = (loads_path(out),) if fmt == "grf" else ()
        for path in (out, *extra, *(_compare_files(out) if args.compare else ())):
            refuse_replacing_file(path, force=args.force)
        _write(fmt, out, src, args)
        compared = _compare(out, src, args.compare) if args.compare else {}
        return compared | {
            "result": str(src.root),
            "format": fmt,
            "out": str(out),
            "frames": len(src.motion.times),
        }

    return run


def _compare_files(out: Path) -> tuple[Path, Path]:
    """The report and figure ``--compare`` writes beside ``out``."""
    stem = out.parent / (out.with_suffix("").name + "_vs_plug_in_gait")
    return stem.with_suffix(".md"), stem.with_suffix(".png")


def _compare(out: Path, src: ExportSource, folder: str) -> dict[str, Any]:
    """``--compare``: the angles of ``out`` beside a plug-in-gait folder's, into
    ``<out>_vs_plug_in_gait.md`` and ``.png`` next to ``out``; the summary's entries."""
    frames = src.motion.frames
    ref = numbered_like(frames, folder_angles(folder))
    ours = clinical_angles(src.model, src.motion.qpos)
    report, figure = _compare_files(out)
    lines, rows = comparison_section(
        out.parent, frames, src.motion.times, ours, ref, figure=figure.name
    )
    atomic_write_text(report, "\n".join(lines))
    return {
        "compared_with": ref.source,
        "comparison": str(report),
        "angles_vs_plug_in_gait": {
            r.name: {"rms_deg": r.rms, "offset_deg": r.offset, "correlation": r.correlation}
            for r in rows
        },
    }


def _run_all(args: argparse.Namespace) -> dict[str, Any]:
    """Every format into the folder ``--out``, written whole (a hidden sibling renamed at the
    end, with summary.json), as every command's result folder."""
    src = _source(args)
    times = src.motion.times
    files = [*ALL_FILES.values(), IK_SETUP]
    summary = {
        "result": str(src.root),
        "format": "all",
        "out": str(args.out),
        "files": files,
        "frames": len(times),
    }
    with output_folder(args.out, force=args.force) as out:
        for fmt, name in ALL_FILES.items():
            _write(fmt, out / name, src, args)
        write_ik_setup(
            out / IK_SETUP,
            model_file=ALL_FILES["osim"],
            marker_file=ALL_FILES["trc"],
            marker_names=src.motion.marker_names,
            time_range=(float(times[0]), float(times[-1])),
        )
        if _grf_path(src).is_file():
            _, loads = write_grf(out / GRF_MOT, read_grf_csv(_grf_csv(src)), up=args.out_up)
            atomic_write_text(out / ID_SETUP, id_setup_xml(
                model_file=ALL_FILES["osim"], coordinates_file=ALL_FILES["mot"],
                time_range=(float(times[0]), float(times[-1])), output_file="id.sto",
                loads_file=loads.name, cutoff_hz=CUTOFF_HZ,
            ))  # fmt: skip
            files += [GRF_MOT, loads.name, ID_SETUP]
        write_summary(out, summary)
    return summary


def _source(args: argparse.Namespace) -> ExportSource:
    """The result to export: RESULT_DIR, with ``--motion`` for another trial's motion."""
    if not args.result:
        raise MocapError("RESULT_DIR: expected a result folder (model.xml + motion.npz)")
    for flag in ("model", "markers", "ghost"):
        if getattr(args, flag, None):
            raise MocapError(f"--{flag}: only for --to glb")
    if getattr(args, "compare", None) and args.to != "angles":
        raise MocapError("--compare: only for --to angles")
    return load_result(args.result, getattr(args, "motion", None), getattr(args, "trial", None))


#: The built-in formats (their names, suffixes and help: :data:`.parsers.EXPORT_FORMATS`).
BUILTIN: tuple[Exporter, ...] = tuple(
    Exporter(name, suffix, text, _run_all if name == "all" else _builtin(name))
    for name, suffix, text in EXPORT_FORMATS
)


def exporters() -> dict[str, Exporter]:
    """Built-in and registered exporters, by ``--to`` name (built-ins win a name clash)."""
    found = {e.name: e for e in plugin_exporters()}
    found.update({e.name: e for e in BUILTIN})
    return found


def _result_files(args: argparse.Namespace) -> list[Path]:
    """The files of RESULT_DIR (and ``--motion``) that an exported file must not replace."""
    try:
        rd = open_trial(args.result, getattr(args, "trial", None)) if args.result else None
    except MocapError:  # reported by the exporter, with the rest of its checks
        return []
    files = [Path(args.motion)] if getattr(args, "motion", None) else []
    if rd is not None:
        files += [rd.model, rd.motion, rd.root / "theta.json", rd.root / "summary.json"]
    return files


def run(args: argparse.Namespace) -> int:
    table = exporters()
    if not args.out:
        raise MocapError("--out: expected an output path")
    fmt = args.to
    if fmt is None:
        suffix = Path(args.out).suffix.lower()
        by_suffix = {e.suffix: e.name for e in table.values() if e.suffix}
        if suffix not in by_suffix:
            raise MocapError(
                f"--out {args.out}: cannot tell the format from {suffix or 'no suffix'!r}; "
                f"give --to ({', '.join(sorted(table))}) or a {', '.join(sorted(by_suffix))} file"
            )
        fmt = by_suffix[suffix]
    refuse_overwriting(args.out, _result_files(args))
    summary = table[fmt].run(args)
    text = f"wrote {summary.get('out', args.out)} ({fmt})"
    return finish(args, summary, text)
