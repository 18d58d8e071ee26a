"""The `gazed` command.

Each subcommand NAME lives in the module that owns its subject, which exposes
`NAME_arguments(parser)` and `NAME_command(args) -> int`; this file only dispatches, importing
the one module a command needs (so `gazed tail` does not pay for OpenCV).
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import json
import sys
from pathlib import Path

from gazed.config import SERVICE_NAMES, Rig, RigError, load_rig

# name -> (module with NAME_arguments / NAME_command, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("gazed.supervisor", "start the rig's processes and watch them (systemd notify)"),
    "check": ("gazed.cli", "validate a rig file; exit 2 listing every problem"),
    "schema": ("gazed.cli", "print the rig file's JSON Schema"),
    "tail": ("gazed.bustools", "print messages on the bus, one line each"),
    "status": ("gazed.bustools", "which processes are alive, restarts, rates, error counts"),
    "latency": ("gazed.bustools", "per-stage and end-to-end latency from message stamps"),
    "calibrate": ("gazed.geometry.calibrate_cli", "solve the frontal-plane -> ground homography"),
    "eval": ("gazed.eval.cli", "score the estimator offline or the whole loop in the simulator"),
    "detect": ("gazed.vision.detect_cli", "run a detector over a video file"),
    "servo": ("gazed.servo.jog", "send one command to the head and show the reply"),
}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] in ("-h", "--help"):
        print(_usage())
        return 0 if argv else 2
    if argv[0] in ("-V", "--version"):
        from gazed import __version__

        print(f"gazed {__version__}")
        return 0
    name = argv[0]
    if name not in COMMANDS:
        close = difflib.get_close_matches(name, COMMANDS, n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        print(f"gazed: unknown command '{name}'{hint}\n\n{_usage()}", file=sys.stderr)
        return 2
    module_name, help_text = COMMANDS[name]
    module = importlib.import_module(module_name)
    parser = argparse.ArgumentParser(prog=f"gazed {name}", description=help_text)
    getattr(module, f"{name}_arguments")(parser)
    args = parser.parse_args(argv[1:])
    try:
        return int(getattr(module, f"{name}_command")(args))
    except KeyboardInterrupt:
        return 130


def _usage() -> str:
    width = max(len(n) for n in COMMANDS)
    lines = [
        "usage: gazed COMMAND [options]   (gazed COMMAND --help for its options)",
        "",
        "commands:",
    ]
    lines += [f"  {name:<{width}}  {help_text}" for name, (_, help_text) in COMMANDS.items()]
    return "\n".join(lines)


def load_rig_or_exit(path: Path) -> Rig:
    """Load a rig for a command; on error print every problem and exit 2."""
    try:
        return load_rig(path)
    except RigError as exc:
        print(exc, file=sys.stderr)
        raise SystemExit(2) from exc


def check_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("rig", type=Path, help="rig description (TOML)")


def check_command(args: argparse.Namespace) -> int:
    try:
        rig = load_rig(args.rig)
    except RigError as exc:
        print(exc, file=sys.stderr)
        return 2
    enabled = [n for n in SERVICE_NAMES if rig.services.spec(n).enabled]
    print(
        f"{args.rig}: ok (rig '{rig.name}', servo {rig.servo.protocol} on {rig.servo.port}, "
        f"processes: {', '.join(enabled) or 'none'})"
    )
    return 0


def schema_arguments(parser: argparse.ArgumentParser) -> None:
    del parser


def schema_command(args: argparse.Namespace) -> int:
    del args
    schema = Rig.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "gazed rig description"
    print(json.dumps(schema, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
