"""The core subcommands' flags and help, apart from their work, so that ``--help`` is instant.

Each ``register_<command>(subparsers)`` adds the command's parser, built from the shared flags
of :mod:`.options`; its ``func`` is a :class:`Lazy` that imports the command's module
(``mocap_mj.commands.<name>``, which loads NumPy, MuJoCo and the compiled kernels) only when
the command runs. A command's description is its module's docstring, read from the file
without importing it. This module imports nothing but argparse and the standard library.
"""

from __future__ import annotations

import argparse
import ast
import functools
import importlib
import importlib.util
from pathlib import Path
from typing import Any

from ._removed import add_removed_flags
from .common import add_force_flag, add_json_flag, add_trial_flag, number
from .options import (
    LOSSES,
    UP_AXES,
    add_input_options,
    add_kinetics_options,
    add_label_options,
    add_model_options,
    add_output_options,
    add_quality_options,
    add_recipe_options,
    add_report_options,
    add_subject_options,
)


class Lazy:
    """A command's ``func``: imports ``module`` (a core command's name, ``identify``, or a full
    module name, an add-on's) when called and runs its function ``name``."""

    def __init__(self, module: str, name: str = "run") -> None:
        self.module = module if "." in module else f"mocap_mj.commands.{module}"
        self.name = name

    def __call__(self, args: argparse.Namespace) -> int:
        run = getattr(importlib.import_module(self.module), self.name)
        return int(run(args) or 0)


@functools.cache
def description(module: str) -> str:
    """The docstring of ``module`` (as :class:`Lazy` names it), read from its source without
    importing it."""
    spec = importlib.util.find_spec(module if "." in module else f"mocap_mj.commands.{module}")
    if spec is None or spec.origin is None:
        raise ModuleNotFoundError(module)
    return ast.get_docstring(ast.parse(Path(spec.origin).read_text(encoding="utf-8"))) or ""


def register_info(sub: Any) -> None:
    p = sub.add_parser(
        "info",
        help="describe a model: bodies, DOF, markers, parameters",
        description="Describe an MJCF model as mocap-mj sees it: its bodies and joints, "
        "degrees of freedom, marker sites and the kinematic parameters identify estimates.",
    )
    p.add_argument("--model", metavar="MJCF", help="MJCF file (default: the bundled humanoid)")
    add_json_flag(p)
    p.set_defaults(func=Lazy("info"))


def register_ik(sub: Any) -> None:
    p = sub.add_parser(
        "ik",
        help="inverse kinematics of a marker file with a given model",
        description=description("ik"),
    )
    add_input_options(p, frames="to solve (the same as identify's, to compare with its fit)")
    add_model_options(p, model="MJCF model")
    add_output_options(p)
    p.add_argument(
        "--damping",
        choices=["adaptive", "sugihara"],
        default="adaptive",
        help="LM damping: adaptive (Nielsen's rule) or sugihara (error-dependent, Sugihara "
        "2011) (default: adaptive)",
    )
    p.add_argument(
        "--loss",
        choices=LOSSES,
        default="l2",
        help="per-frame loss of the marker distances, as identify's --loss; use the loss of "
        "the fit to reproduce it (default: l2)",
    )
    p.add_argument(
        "--no-sliding-landmarks",
        action="store_true",
        help="weigh every marker alike, the knee epicondyle markers too, even when the model "
        "records identify's sliding model of them (default: weigh them as identify did, to "
        "reproduce its fit)",
    )
    p.add_argument(
        "--max-iterations",
        type=number(int, least=1),
        default=100,
        metavar="N",
        help="LM iterations per frame at most (default: 100)",
    )
    p.add_argument(
        "--min-markers",
        type=number(int, least=1),
        default=None,
        metavar="N",
        help="present markers a frame needs to be solved (default: 16, or three quarters of "
        "the markers the trial records where it records fewer than 22, at least 4: a partial "
        "set's frame with one marker occluded is solved)",
    )
    add_quality_options(p)
    add_kinetics_options(p, several=False)
    add_force_flag(p)
    add_json_flag(p)
    add_removed_flags(p, "ik")
    p.set_defaults(func=Lazy("ik"))


def register_identify(sub: Any) -> None:
    p = sub.add_parser(
        "identify",
        help="identify the subject's model from marker trials",
        description=description("identify"),
    )
    add_input_options(p, several=True, frames="to fit")
    add_output_options(p)
    add_model_options(p, model="initial MJCF model")
    add_recipe_options(p, recipe=True)
    add_quality_options(p)
    add_subject_options(p)
    add_kinetics_options(p, several=True)
    add_removed_flags(p, "identify")
    add_force_flag(p)
    add_json_flag(p)
    p.set_defaults(func=Lazy("identify"))


def register_score(sub: Any) -> None:
    p = sub.add_parser(
        "score",
        help="score an identification against synthetic truth",
        description="Compare a result folder of `mocap-mj identify` with the synthetic truth "
        "it was fitted to (a folder of `mocap-mj synth`): parameter, joint-centre and joint-"
        "angle errors beside their Cramer-Rao bounds, in the directions the markers observe. "
        "Writes RESULT/score.json. The result must have been fitted to that truth's markers "
        "(same subject and frames); anything else is refused.",
    )
    p.add_argument(
        "--truth", required=True, metavar="FOLDER", help="folder written by mocap-mj synth"
    )
    p.add_argument(
        "--result", required=True, metavar="FOLDER", help="folder written by mocap-mj identify"
    )
    add_json_flag(p)
    p.set_defaults(func=Lazy("score"))


#: The built-in formats of ``export --to``: name, the ``--out`` suffix that selects it (empty:
#: ``--to`` needed), its help (:data:`mocap_mj.commands.export.BUILTIN` runs them).
EXPORT_FORMATS: tuple[tuple[str, str, str], ...] = (
    ("osim", ".osim", "OpenSim model of the subject"),
    ("mot", ".mot", "OpenSim motion: coordinates in degrees"),
    (
        "grf",
        "",
        "OpenSim ground reactions (.mot) of grf.csv and their ExternalLoads (<stem>_loads.xml)",
    ),
    ("trc", ".trc", "TRC of the measured markers"),
    ("trc-model", "", "TRC of the model markers (fitted)"),
    ("c3d", ".c3d", "C3D: markers, model markers, joint centres, angles"),
    ("angles", "", "CSV of the model's angles in Plug-in Gait's conventions [deg]"),
    ("residuals", "", "CSV of per-marker, per-frame residuals [mm]"),
    ("scale", "", "CSV of segment lengths and scale factors"),
    ("all", "", "every built-in format and an OpenSim IK setup into the folder --out"),
)
#: ``export --out-up``: the vertical axis of the written .osim ground, TRC and GRF files.
OUT_UP = ("y", "z")


def register_export(sub: Any) -> None:
    from mocap_mj.export.registry import plugin_exporters

    plugins = [e for e in plugin_exporters() if e.name not in {f[0] for f in EXPORT_FORMATS}]
    helps = [(f[0], f[2]) for f in EXPORT_FORMATS] + [(e.name, e.help) for e in plugins]
    p = sub.add_parser(
        "export",
        help="write a result as OpenSim, TRC, C3D, CSV tables (or GLB with the viewer)",
        description="Write a result folder (identify, ik or synth) in the formats other tools "
        "read. Formats: "
        + "; ".join(f"{name}: {text}" for name, text in helps)
        + ". Angle conventions and frames: docs/opensim.md.",
    )
    p.add_argument(
        "result",
        nargs="?",
        metavar="RESULT_DIR",
        help="result folder (model.xml + motion.npz) or synthetic-truth folder",
    )
    p.add_argument(
        "--to",
        choices=sorted(n for n, _ in helps),
        help="format (default: from the suffix of --out)",
    )
    add_trial_flag(p)
    p.add_argument(
        "--out",
        metavar="PATH",
        help="output file, a folder for --to all (required; no default)",
    )
    p.add_argument(
        "--out-up",
        choices=OUT_UP,
        default="y",
        help="vertical axis of the written .osim ground, TRC and ground-reaction files "
        "(default y, OpenSim's convention; the model's own is +Z)",
    )
    p.add_argument(
        "--mass",
        type=float,
        metavar="KG",
        help="subject mass [kg] for the .osim bodies: de Leva's segment parameters, as the "
        "tool's inverse dynamics (default: the result's recorded mass, else the model's own "
        "masses)",
    )
    p.add_argument(
        "--nominal",
        metavar="MJCF",
        help="MJCF the scale factors are relative to (default: the bundled humanoid)",
    )
    p.add_argument(
        "--compare",
        metavar="PIG_DIR",
        help="with --to angles: a `mocap-mj plug-in-gait` output folder whose angles.csv is "
        "put beside ours (OUT_vs_plug_in_gait.md: RMS difference, offset and correlation per "
        "component; OUT_vs_plug_in_gait.png: both curves); frames matched by number, else "
        "counted from the recording's first (default: no comparison)",
    )
    add_force_flag(p)
    for exporter in plugins:
        if exporter.add_arguments is not None:
            exporter.add_arguments(p)
    add_json_flag(p)
    add_removed_flags(p, "export")
    p.set_defaults(func=Lazy("export"))


def register_batch(sub: Any) -> None:
    from mocap_mj.batch.dataset import FLAGS, OPTION_KEYS

    p = sub.add_parser(
        "batch",
        help="identify and track every subject of a dataset (on Ray when installed)",
        description="Per subject: one identification from all its trials, then IK of each "
        "trial with the subject's model; summary.csv and report.md over the dataset. "
        "Re-running the same command skips subjects already done with the same inputs.",
    )
    p.add_argument(
        "dataset",
        metavar="DATASET",
        help="folder with one folder per subject, or a CSV/YAML manifest",
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="FOLDER",
        help="output folder: absent, empty, or a batch's own (its marker; re-used: finished "
        "subjects kept); never inside the dataset",
    )
    p.add_argument(
        "--address", metavar="HOST:PORT", help="join this Ray cluster (default: start a local Ray)"
    )
    p.add_argument(
        "--workers",
        type=number(int, least=1),
        metavar="N",
        help="CPUs of the local Ray (default: all)",
    )
    p.add_argument(
        "--timeout",
        type=number(above=0),
        default=3600.0,
        metavar="SECONDS",
        help="time one subject may take; a subject past it is recorded as timed out and the "
        "batch goes on (default: 3600, an hour: a subject's identification and IK take minutes)",
    )
    p.add_argument(
        "--serial",
        action="store_true",
        help="no Ray: one subject after the other (default: Ray when installed)",
    )
    _add_subject_defaults(p, FLAGS, OPTION_KEYS)
    add_json_flag(p)
    add_removed_flags(p, "batch")
    p.set_defaults(func=Lazy("batch"))


#: The placeholder of each of batch's per-subject options (choices instead, where there are).
_METAVARS = {"frames": "A:B", "marker_map": "FILE", "file_subject": "NAME", "model": "MJCF",
             "exclude_markers": "NAMES", "recipe": "FILE"}  # fmt: skip
_CHOICES = {"up": UP_AXES, "units": ("mm", "cm", "m"), "loss": LOSSES}


def _add_subject_defaults(p: Any, flags: dict[str, str], keys: dict[str, Any]) -> None:
    """batch's defaults of every subject: identify's flags of the same names."""
    g = p.add_argument_group("defaults of every subject (a manifest's options override them)")
    for key in keys:
        if keys[key] is bool:
            g.add_argument(
                flags[key],
                dest=key,
                action="store_true",
                default=None,
                help=f"as {flags[key]} of identify (default: the recipe's)",
            )
            continue
        g.add_argument(
            flags[key],
            dest=key,
            metavar=_METAVARS.get(key),
            choices=_CHOICES.get(key),
            help=f"as {flags[key]} of identify (default: identify's default)"
            + (": frames A up to but excluding B" if key == "frames" else ""),
        )


def register_plug_in_gait(sub: Any) -> None:
    p = sub.add_parser(
        "plug-in-gait",
        help="Plug-in Gait angles and joint centres, as Vicon Nexus computes them",
        description="Plug-in Gait (the Conventional Gait Model 1.0) from its published "
        "definitions: Davis hip centres, chord knee, ankle, shoulder, elbow and hand "
        "centres, the foot with the static offsets, Vicon's Cardan sequences and signs, "
        "pelvis, foot, thorax and head angles in the direction of progression. Subject "
        "values come from the C3D's PROCESSING group, then --static (offsets, inter-ASIS "
        "distance, leg lengths from the markers), then --subject-file. Writes OUT/angles.csv "
        "[deg], OUT/joint_centres.csv [mm, lab frame], OUT/result.c3d (Vicon's point "
        "names), OUT/summary.json and OUT/report.md; frames keep the recording's numbers. "
        "A C3D trial with force plates and a body mass also gives OUT/kinetics.csv: Plug-in "
        "Gait's joint moments, powers and forces and the ground reactions per kg (also in "
        "result.c3d under Vicon's names and units); a dynamic trial with a body mass, plates "
        "or not, its whole-body centre of mass (CentreOfMass, CentreOfMassFloor [mm]).",
    )
    add_input_options(p, frames="of the trial to compute (the static's are all used)")
    p.add_argument(
        "--static",
        metavar="FILE",
        help="static trial, read as the trial: its foot offsets replace the trial's; refused "
        "when its pelvis and leg markers move (--trial-type auto's rule), as a walk given for "
        "the static or the two files swapped (default: the trial's PROCESSING values; a "
        "trial that is itself static gives its own)",
    )
    p.add_argument(
        "--subject-file",
        metavar="FILE",
        help="subject values overriding the file's: a YAML file (measurements as in "
        "summary.json, and static_plantar_flex_l, static_rot_off_l, asis_trochanter_l, "
        "tibial_torsion_l, sole_delta_l, head_offset with a unit; Nexus' static options "
        "flat_foot_l, head_level: true or false), or Vicon's .vsk or .mp subject file "
        "(Plug-in Gait's names and the C3D PROCESSING group's units: mm, kg, rad) "
        "(default: none; a static's flat foot is told by its given offsets)",
    )
    p.add_argument(
        "--trial-type",
        choices=("auto", "static", "dynamic"),
        default="auto",
        help="static: the trial gives its own foot offsets and the static model's foot (as "
        "Nexus' static pipeline); dynamic: the offsets of the PROCESSING group, --static or "
        "--subject-file; auto (default): static when no --static is given and the pelvis "
        "and leg markers stay within 0.1 m of their median positions",
    )
    p.add_argument(
        "--plates",
        default="auto",
        metavar="LIST",
        help="the force plates whose contacts count for the kinetics: auto (default: the "
        "contacts the recording's own ground reactions count, as Nexus' "
        "LGroundReactionForce, its manual choices included; without them as all), all "
        "(each plate while one foot alone stands on it), none (no joint kinetics), or plate "
        "numbers from 1, e.g. 1,4 (a lab's choice of valid strikes)",
    )
    p.add_argument(
        "--report",
        action="store_true",
        help="also the gait report: OUT/cycles.csv, spatiotemporal.csv, scores.csv (with "
        "--normative) and report.html, as gait-report writes them (default: off)",
    )
    add_report_options(p)
    add_output_options(p)
    add_force_flag(p)
    add_json_flag(p)
    p.set_defaults(func=Lazy("plug_in_gait"))


def register_gait_report(sub: Any) -> None:
    p = sub.add_parser(
        "gait-report",
        help="the gait report: cycles, spatiotemporal parameters, scores, report.html",
        description="Each trial's gait events (the C3D's EVENT group, else its force plates, "
        "else the kinematics, or --events), each side's cycles from one foot strike to the "
        "next (incomplete ones dropped and said), every Plug-in Gait angle and, with force "
        "plates and a body mass, every moment and power resampled to 101 points per cycle. "
        "Writes OUT/cycles.csv (trial, side, cycle, variable, percent, value: degrees, N m/kg, "
        "W/kg), OUT/spatiotemporal.csv (per cycle, each side's mean and sd), OUT/scores.csv "
        "(with --normative: Gait Variable Scores and Gait Profile Score, Baker et al. 2009), "
        "OUT/report.html (one self-contained page) and OUT/summary.json.",
    )
    p.add_argument(
        "--markers",
        required=True,
        nargs="+",
        metavar="TRIAL",
        help="walking trials of one subject (C3D, TRC...): with Plug-in Gait's markers its "
        "angles from them; with another set the angles, in Plug-in Gait's conventions, of the "
        "model mocap-mj identify identifies on the trials (kept as OUT/model.xml)",
    )
    p.add_argument(
        "--marker-set",
        metavar="SET",
        help="for a set other than Plug-in Gait's: the marker set of the identification, as "
        "identify --marker-set (default: detected from the labels)",
    )
    p.add_argument(
        "--static",
        metavar="STATIC",
        help="static trial for the subject values (foot offsets, leg lengths; as "
        "plug-in-gait --static) (default: each trial's PROCESSING values)",
    )
    p.add_argument(
        "--subject-file",
        metavar="FILE",
        help="subject values overriding the files' (as plug-in-gait --subject-file): YAML, "
        "Vicon's .vsk or .mp (default: none)",
    )
    p.add_argument(
        "--plates",
        default="auto",
        metavar="LIST",
        help="the force plates whose contacts count for the kinetics, as plug-in-gait "
        "--plates: auto (default: those the recording's own ground reactions count, else "
        "all), all, none, or plate numbers from 1, e.g. 1,4",
    )
    add_report_options(p)
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    add_force_flag(p)
    add_json_flag(p)
    p.set_defaults(func=Lazy("gait_report"), trial_type="dynamic")


def register_marker_sets(sub: Any) -> None:
    p = sub.add_parser(
        "marker-sets",
        help="list the bundled marker sets; --check how a recording's labels match one",
        description=description("marker_sets").split("\n\n", 1)[1],
    )
    p.add_argument(
        "--check",
        metavar="FILE",
        help="marker file whose labels to match: C3D, TRC, mocap-mj CSV, Vicon Nexus or "
        "OptiTrack Motive CSV (default: none, list the sets)",
    )
    p.add_argument(
        "--marker-set",
        metavar="SET",
        help="the set to match against: SET is a bundled set's name or a YAML file "
        "(default: the set detected from the labels, else Plug-in Gait)",
    )
    add_label_options(p)
    add_json_flag(p)
    p.set_defaults(func=Lazy("marker_sets"))
