"""OpenSim's inverse dynamics on the exported model against the tool's own.

    python benchmarks/opensim_id.py [--trial PATH] [--result DIR] [--work DIR]

Runs ``mocap-mj ik`` on the trial (Movement_trial.c3d of ../shared: four force plates, 85 kg)
unless ``--result`` names a result folder with ``grf.csv``, exports the model (``export --to
osim``: de Leva's segment parameters, the ones the tool's inverse dynamics uses) and the ground
reactions (``export --to grf``: the ``.mot`` and its ``ExternalLoads``), and runs OpenSim's
InverseDynamicsTool twice: on the coordinates the tool's inverse dynamics differentiates (its
6 Hz Butterworth output, OpenSim's filter off) and on ``export --to mot``'s raw coordinates
with OpenSim's own 6 Hz low-pass. Prints per OpenSim coordinate the peak of the tool's
generalised force (dynamics.csv's, in OpenSim's coordinates by virtual work,
:func:`mocap_mj.export.opensim_id.in_coordinates`) and the largest and RMS difference of
OpenSim's over the frames both computed, in per cent of that peak, then the worst. Needs
the ``[opensim]`` extra; writes into ``--work`` (default a temporary folder) only.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mocap_mj.anatomy.inertia import inertial_model
from mocap_mj.export.coordinates import model_coordinates
from mocap_mj.export.grf import read_grf_csv
from mocap_mj.export.mot import read_mot, write_mot
from mocap_mj.export.opensim_id import id_setup_xml, in_coordinates
from mocap_mj.export.opensim_ik import import_opensim
from mocap_mj.outputs.dynamics_out import dynamics_of_result
from mocap_mj.outputs.kinetics_out import FOOT_BODIES
from mocap_mj.pipeline.dynamics import BodyLoad
from mocap_mj.pipeline.motion import ResultDir
from mocap_mj.skeleton.exported import Layout
from mocap_mj.skeleton.mjcf import load_model

SHARED = Path(__file__).resolve().parents[2] / "shared"
#: Skip the ends, where both programs' derivatives are one-sided [frames].
EDGE = 5


def cli(*args: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "mocap_mj", *args], capture_output=True,
                          text=True)  # fmt: skip
    if proc.returncode != 0:
        raise SystemExit(f"mocap-mj {' '.join(args)}: {proc.stderr.strip()}")


def opensim_id(work: Path, coordinates: Path, cutoff: float | None) -> tuple[list[str], np.ndarray]:
    """OpenSim's generalised forces (T, C) of the exported files in ``work``."""
    osim = import_opensim()
    _, times, _ = read_mot(coordinates)
    out = f"id_{coordinates.stem}.sto"
    setup = work / f"id_{coordinates.stem}.xml"
    setup.write_text(id_setup_xml(
        model_file=str(work / "subject.osim"), coordinates_file=str(coordinates),
        time_range=(float(times[0]), float(times[-1])), output_file=out,
        loads_file=str(work / "grf_loads.xml"), cutoff_hz=cutoff,
    ))  # fmt: skip
    tool = osim.InverseDynamicsTool(str(setup))
    tool.setResultsDir(str(work))
    t0 = time.perf_counter()
    if not tool.run():
        raise SystemExit(f"{setup}: OpenSim's InverseDynamicsTool failed")
    print(f"OpenSim ID on {coordinates.name}: {time.perf_counter() - t0:.2f} s")
    cols, _, values = read_mot(work / out)
    return [c.rsplit("_", 1)[0] for c in cols], values


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trial", type=Path, default=SHARED / "data/real/Movement_trial.c3d")
    ap.add_argument("--result", type=Path, help="an ik or identify result with grf.csv")
    ap.add_argument("--work", type=Path, help="folder for the exported files (default: temp)")
    args = ap.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="opensim_id_"))
    work.mkdir(parents=True, exist_ok=True)
    result = args.result
    if result is None:
        result = work / "ik"
        cli("ik", "--markers", str(args.trial), "--out", str(result), "--force")
    cli("export", str(result), "--to", "osim", "--out", str(work / "subject.osim"), "--force")
    cli("export", str(result), "--to", "grf", "--out", str(work / "grf.mot"), "--force")
    cli("export", str(result), "--to", "mot", "--out", str(work / "raw.mot"), "--force")

    rd = ResultDir.open(result)
    grf = read_grf_csv(result / "grf.csv")
    loads = [BodyLoad(FOOT_BODIES[s], grf.force[s], grf.cop[s], grf.moment[s]) for s in grf.force]
    entry = json.loads((result / "summary.json").read_text())["kinetics"]["trials"][0]
    dyn, _ = dynamics_of_result(result, loads, entry["body_mass_kg"], sex=entry["sex"])
    internal = load_model(rd.model)
    written = inertial_model(rd.model, entry["body_mass_kg"], sex=entry["sex"])
    ours = in_coordinates(internal, written, dyn.qpos, dyn.tau)
    smooth = work / "smoothed.mot"
    write_mot(smooth, internal, dyn.times, Layout.of(internal).internal(dyn.qpos))
    names = [c.name for c in model_coordinates(internal)]
    for label, coords, cutoff in (("the tool's smoothed coordinates, OpenSim's filter off",
                                   smooth, None),
                                  ("raw coordinates, OpenSim's 6 Hz low-pass", work / "raw.mot",
                                   6.0)):  # fmt: skip
        cols, theirs = opensim_id(work, coords, cutoff)
        print(f"\n## {label}\n{'coordinate':20s} {'peak':>9s} {'max %':>7s} {'RMS %':>7s}")
        worst = (0.0, "")
        for i, name in enumerate(names):
            a, b = ours[EDGE:-EDGE, i], theirs[EDGE:-EDGE, cols.index(name)]
            ok = np.isfinite(a) & np.isfinite(b)
            peak = float(np.max(np.abs(a[ok])))
            if peak < 1e-3:  # a coordinate with no load to speak of (the toes)
                continue
            d = np.abs(a[ok] - b[ok])
            pmax, prms = 100 * d.max() / peak, 100 * np.sqrt(np.mean(d**2)) / peak
            worst = max(worst, (pmax, name))
            print(f"{name:20s} {peak:9.2f} {pmax:7.3f} {prms:7.3f}")
        print(f"worst: {worst[1]} {worst[0]:.3f} % of its peak (target 2 %)")


if __name__ == "__main__":
    main()
