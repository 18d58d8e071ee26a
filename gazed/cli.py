"""The `gazed` command: every subcommand is declared here, in COMMANDS.

A command NAME lives in the module that owns its subject, which exposes `NAME_arguments(parser)`
and `NAME_command(args) -> int`. A group (`gazed calibrate points`) is a name with commands
of its own. Only the one module a command needs is imported, when it runs: listing commands
imports none, and `gazed calibrate points` does not pay for the bus or `gazed tail` for OpenCV.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import sys
from dataclasses import dataclass


@dataclass(frozen=True)
class Command:
    """A command whose module has `<name>_arguments(parser)` and `<name>_command(args) -> int`."""

    module: str
    help: str


@dataclass(frozen=True)
class Group:
    """A command with subcommands: `gazed <group> <name> ...`."""

    help: str
    commands: dict[str, Command]


COMMANDS: dict[str, Command | Group] = {
    "run": Command(
        "gazed.supervisor.command", "start the rig's processes and watch them (systemd notify)"
    ),
    "check": Command("gazed.config.commands", "validate a rig file; exit 2 listing every problem"),
    "schema": Command("gazed.config.commands", "print the rig file's JSON Schema"),
    "tail": Command("gazed.bustools.tail", "print messages on the bus, one line each"),
    "status": Command(
        "gazed.bustools.status", "which processes are alive, restarts, rates, error counts"
    ),
    "latency": Command(
        "gazed.bustools.latency", "per-stage and end-to-end latency from message stamps"
    ),
    "select": Command(
        "gazed.bustools.select",
        "choose the person the running rig follows: a track id, a ground point or a pixel",
    ),
    "operate": Command(
        "gazed.bustools.operate", "park the running rig's head, search, hold it still, or resume"
    ),
    "record": Command(
        "gazed.record.record_cli", "write the bus's messages into an MCAP file (Foxglove opens it)"
    ),
    "replay": Command(
        "gazed.record.replay_cli", "publish an MCAP recording back on a rig's bus, in its timing"
    ),
    "view": Command(
        "gazed.view.view_cli", "the live view in the browser: frames, overlays, map, plots"
    ),
    "plot": Command("gazed.plots.plot_cli", "the paper's figures (PNG) from an MCAP recording"),
    "calibrate": Group(
        "calibrate with the rig: the ground homography, the camera's delay, the zoom table",
        {
            "points": Command(
                "gazed.geometry.calibrate_cli",
                "homography from 4+ gaze-angle <-> ground-point correspondences (seed 000 §3.1)",
            ),
            "lines": Command(
                "gazed.geometry.calibrate_cli",
                "homography from 4+ traced ground lines, no endpoint matching (seed 000 §3.2)",
            ),
            "tsai": Command(
                "gazed.geometry.tsai_cli",
                "a Tsai calibration (PETS XML) as the rig's [wide] camera and ground homography",
            ),
            "trace": Command(
                "gazed.gaze.trace_cli",
                "trace 4+ ground lines with the running rig, then the line calibration "
                "(seed 000 §3.2.1)",
            ),
            "speeds": Command(
                "gazed.servo.speed_calibration",
                "measure a speed-driven head's rate per speed step with its own position readings",
            ),
            "latency": Command(
                "gazed.calibrate.camera_latency",
                "step the running rig's head and time the image's motion: the camera's delay",
            ),
            "zoom": Command(
                "gazed.calibrate.zoom_calibration",
                "step the running rig's zoom on a still scene: the focal length at each position",
            ),
        },
    ),
    "eval": Group(
        "score the estimator offline or the whole loop in the simulator",
        {
            "estimator": Command(
                "gazed.eval.estimator", "score the estimation modes on scenarios or track files"
            ),
            "loop": Command(
                "gazed.eval.loop",
                "run the whole loop in the simulator on a private bus and score it",
            ),
        },
    ),
    "detect": Command("gazed.vision.detect_cli", "run a detector over a video file"),
    "servo": Group(
        "talk to the head directly",
        {
            "jog": Command(
                "gazed.servo.jog", "send one command to the head and show the reply decoded"
            )
        },
    ),
}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] in (["-V"], ["--version"]):
        from gazed import __version__

        print(f"gazed {__version__}")
        return 0
    return _dispatch("gazed", COMMANDS, argv)


def _dispatch(prog: str, commands: dict[str, Command | Group], argv: list[str]) -> int:
    """Find the command `argv` names in `commands`, then parse its arguments and run it."""
    if not argv or argv[0] in ("-h", "--help"):
        print(_usage(prog, commands))
        return 0 if argv else 2
    name = argv[0]
    if name not in commands:
        close = difflib.get_close_matches(name, commands, n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        print(
            f"{prog}: unknown command '{name}'{hint}\n\n{_usage(prog, commands)}", file=sys.stderr
        )
        return 2
    entry = commands[name]
    if isinstance(entry, Group):
        return _dispatch(f"{prog} {name}", entry.commands, argv[1:])
    module = importlib.import_module(entry.module)
    parser = argparse.ArgumentParser(prog=f"{prog} {name}", description=entry.help)
    getattr(module, f"{name}_arguments")(parser)
    args = parser.parse_args(argv[1:])
    try:
        return int(getattr(module, f"{name}_command")(args))
    except KeyboardInterrupt:
        return 130
    except SystemExit as exc:  # a command that exits (a bad rig: 2) ends with its code
        if isinstance(exc.code, str):
            print(exc.code, file=sys.stderr)
            return 1
        return 0 if exc.code is None else exc.code


def _usage(prog: str, commands: dict[str, Command | Group]) -> str:
    width = max(len(n) for n in commands)
    lines = [
        f"usage: {prog} COMMAND [options]   ({prog} COMMAND --help for its options)",
        "",
        "commands:",
    ]
    lines += [f"  {name:<{width}}  {entry.help}" for name, entry in commands.items()]
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
