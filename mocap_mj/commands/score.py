"""``mocap-mj score``: an identification against its synthetic truth, beside the bound."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from ..cli import add_json_flag, finish
from ..io.atomic import atomic_write_text
from ..score import score, score_text


def register(sub: Any) -> None:
    p = sub.add_parser("score", help="score an identification against synthetic truth")
    p.add_argument("--truth", required=True, help="folder written by mocap-mj synth")
    p.add_argument("--result", required=True, help="folder written by mocap-mj identify")
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    s = score(args.truth, args.result)
    out = Path(args.result)

    atomic_write_text(out / "score.json", json.dumps(s, indent=2) + "\n")
    return finish(args, s, score_text(s))
