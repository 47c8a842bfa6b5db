"""Identified models of one subject's markers scaled to other sizes; prints figures.

    python benchmarks/subject_size.py REF_DIR SCALE=DIR [SCALE=DIR ...]

REF_DIR and every DIR are ``mocap-mj identify`` result folders: REF_DIR of the recording,
each DIR of the same recording with every marker coordinate multiplied by SCALE (a child of
0.55-0.75 the size, a tall adult at 1.15; no height in the files, so the runs use the stature
estimated from the markers). For each DIR: the stature estimate, the kinematic parameters at
a bound of their anatomical range, and every joint-centre distance
(:func:`mocap_mj.solve.consistency.joint_centre_lengths`) against REF_DIR's times SCALE:
the largest relative difference and the distances beyond ``--tolerance`` (default 3 %).
The markers themselves are scaled, so a size-independent pipeline would give REF_DIR's model
times SCALE exactly; the differences measure what does not scale (constants in millimetres:
the marker radius, widths of priors).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from mocap_mj.skeleton.parameters import ParameterSet
from mocap_mj.solve.consistency import joint_centre_lengths


def _model(folder: Path, pset: ParameterSet) -> tuple[dict, dict[str, float]]:
    summary = json.loads((folder / "summary.json").read_text())
    return summary, joint_centre_lengths(pset, pset.load_json(folder / "theta.json"))


def _stature(summary: dict) -> str:
    est = summary.get("stature_estimate")
    if est:
        return f"stature {est['value']:.3f} +- {est['sd']:.3f} m (estimated)"
    h = summary.get("measurements", {}).get("height")
    return f"height {h['value']:.3f} m (measured)" if h else "no stature"


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("reference", type=Path)
    ap.add_argument("scaled", nargs="+", metavar="SCALE=DIR")
    ap.add_argument("--tolerance", type=float, default=0.03)
    args = ap.parse_args()
    pset = ParameterSet()
    ref_summary, ref = _model(args.reference, pset)
    print(
        f"{args.reference.name}: {_stature(ref_summary)}; RMSE "
        f"{ref_summary['marker_rmse_mm']:.2f} mm; at bound: "
        f"{ref_summary.get('kappa_at_bound') or 'none'}"
    )
    for item in args.scaled:
        scale_text, folder_text = item.split("=", 1)
        scale, folder = float(scale_text), Path(folder_text)
        summary, lengths = _model(folder, pset)
        rel = {n: lengths[n] / (ref[n] * scale) - 1.0 for n in ref if ref[n] > 0.02}
        worst = max(rel, key=lambda n: abs(rel[n]))
        beyond = {n: v for n, v in rel.items() if abs(v) > args.tolerance}
        print(
            f"x{scale:.2f} {folder.name}: {_stature(summary)}; RMSE "
            f"{summary['marker_rmse_mm']:.2f} mm; at bound: "
            f"{summary.get('kappa_at_bound') or 'none'}; joint-centre distances vs reference "
            f"x {scale:.2f}: max {rel[worst] * 100:+.1f} % ({worst}); beyond "
            f"{args.tolerance * 100:.0f} %: "
            + (", ".join(f"{n} {v * 100:+.1f} %" for n, v in beyond.items()) or "none")
        )


if __name__ == "__main__":
    main()
