"""``mocap-mj marker-sets``: the bundled marker sets, and how a recording's labels match one.

Without --check, lists the bundled sets (models/marker_sets/): name, markers, the bodies
they cover and the set's source. With --check FILE, reads the recording's labels (not its
positions) and says which label maps to which marker of the set and the landmark it sits
on, which of the set's markers are missing and which labels are ignored; the set is
--marker-set's, else the one detected from the labels as identify and ik detect it
(docs/recordings.md#marker-sets).
"""

from __future__ import annotations

import argparse
from typing import Any

from mocap_mj.capture.marker_set import MarkerSet
from mocap_mj.capture.marker_sets import DEFAULT, FIT_FRACTION, bundled, bundled_names, check
from mocap_mj.commands.common import finish

from ..io.labels import file_labels, non_marker_points
from ..io.names import load_marker_map


def listing() -> dict[str, Any]:
    """Every bundled set: name, markers, bodies, marker radius [m], source."""
    sets = []
    for name in bundled_names():
        s = bundled(name)
        sets.append({
            "name": name,
            "title": s.name,
            "markers": len(s.names),
            "bodies": list(s.bodies),
            "marker_radius_m": s.marker_radius,
            "source": s.source,
            "default": name == DEFAULT,
        })  # fmt: skip
    return {"marker_sets": sets, "fit_fraction": FIT_FRACTION}


def _listing_text(info: dict[str, Any]) -> str:
    width = max(len(s["name"]) for s in info["marker_sets"]) + 2
    lines = [f"{'name':<{width}}{'markers':>8}{'bodies':>8}  source"]
    for s in info["marker_sets"]:
        flag = " (default)" if s["default"] else ""
        lines.append(
            f"{s['name']:<{width}}{s['markers']:>8}{len(s['bodies']):>8}  {s['source']}{flag}"
        )
    lines.append(
        "--marker-set NAME picks one; without it identify and ik detect the set from the "
        "labels (docs/recordings.md#marker-sets)"
    )
    return "\n".join(lines)


def checked(args: argparse.Namespace) -> dict[str, Any]:
    """The --check report of ``args.check`` (JSON-ready)."""
    rename = load_marker_map(args.marker_map) if args.marker_map else {}
    labels = file_labels(args.check, subject=args.subject, marker_map=rename)
    c = check(labels, args.marker_set, renamed=set(rename.values()))
    return {
        "file": args.check,
        "marker_set": c.name,
        "how": c.how,
        "reason": c.reason,
        "markers_found": c.match.found,
        "markers": c.match.size,
        "mapped": [_mapped(c.marker_set, lab, n) for lab, n in c.match.mapped],
        "missing": list(c.match.missing),
        "ignored": list(c.match.ignored),
        "not_markers": non_marker_points(args.check, subject=args.subject, marker_map=rename),
    }


def _mapped(marker_set: MarkerSet, label: str, name: str) -> dict[str, Any]:
    m = marker_set.marker(name)
    return {"label": label, "marker": name, "body": m.body, "landmark": m.landmark}


def _check_text(r: dict[str, Any]) -> str:
    lines = [
        f"{r['file']}: marker set {r['marker_set']!r} ({r['markers_found']} of "
        f"{r['markers']} markers found; {r['reason']})",
        "label -> marker (body, landmark):",
    ]
    for m in r["mapped"]:
        lines.append(f"  {m['label']} -> {m['marker']} ({m['body']}, {m['landmark'] or '-'})")
    lines.append(f"missing ({len(r['missing'])}): {' '.join(r['missing']) or 'none'}")
    lines.append(
        f"labels not of the set, ignored ({len(r['ignored'])}): {' '.join(r['ignored']) or 'none'}"
    )
    if r["not_markers"]:
        outputs = r["not_markers"]
        lines.append(
            f"points that are no markers (a Nexus output's angles, bone points, kinetics), "
            f"ignored ({len(outputs)}): {' '.join(outputs[:12])}"
            + (f" ... ({len(outputs) - 12} more)" if len(outputs) > 12 else "")
        )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    if args.check is None:
        info = listing()
        return finish(args, info, _listing_text(info))
    report = checked(args)
    return finish(args, report, _check_text(report))
