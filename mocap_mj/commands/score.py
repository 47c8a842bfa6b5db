"""``mocap-mj score``: an identification against its synthetic truth, beside the bound."""

from __future__ import annotations

import argparse
from pathlib import Path

from mocap_mj.commands.common import finish
from mocap_mj.io.strict_json import dumps
from mocap_mj.outputs.score import score, score_text

from ..io.atomic import atomic_write_text


def run(args: argparse.Namespace) -> int:
    s = score(args.truth, args.result)
    out = Path(args.result)

    atomic_write_text(out / "score.json", dumps(s, indent=2) + "\n")
    return finish(args, s, score_text(s))
