"""``mocap-mj score``: an identification against its synthetic truth, beside the bound."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from mocap_mj.commands.common import add_json_flag, finish
from mocap_mj.io.strict_json import dumps
from mocap_mj.outputs.score import score, score_text

from ..io.atomic import atomic_write_text


def register(sub: Any) -> None:
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
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    s = score(args.truth, args.result)
    out = Path(args.result)

    atomic_write_text(out / "score.json", dumps(s, indent=2) + "\n")
    return finish(args, s, score_text(s))
