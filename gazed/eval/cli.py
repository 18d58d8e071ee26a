"""`gazed eval SUBCOMMAND`: offline and closed-loop evaluations.

Each subcommand lives in its own module with `NAME_arguments(parser)` and
`NAME_command(args) -> int`; adding one is one line in SUBCOMMANDS.
"""

from __future__ import annotations

import argparse
import importlib

# name -> (module, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "estimator": ("gazed.eval.estimator", "score the estimation modes on scenarios or track files"),
    "loop": (
        "gazed.eval.loop",
        "run the whole loop in the simulator on a private bus and score it",
    ),
}


def eval_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="subcommand", required=True, metavar="SUBCOMMAND")
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        module = importlib.import_module(module_name)
        child = sub.add_parser(name, help=help_text, description=help_text)
        getattr(module, f"{name}_arguments")(child)
        child.set_defaults(_run=getattr(module, f"{name}_command"))


def eval_command(args: argparse.Namespace) -> int:
    return int(args._run(args))
