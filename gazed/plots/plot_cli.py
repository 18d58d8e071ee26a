"""`gazed plot run.mcap --plot DIR [--rig RIG]`: the figures of a recording as PNG files, and
the `--plot DIR` of `gazed eval loop` and `gazed eval estimator`.

The figures (`gazed.plots.figures`): the ground trajectory with the truth, the estimates and
the predictions; the gaze error over time with saccades and state changes marked; the model
probabilities over time; a histogram of the latency per hop. A recording gives those it has
data for: the gaze error needs the simulator's truth and the rig (where its camera stands).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from gazed.config import load_rig_or_exit
from gazed.geometry.pose import CameraPose
from gazed.plots.bus_series import bus_series, recorded_messages
from gazed.plots.figures import write_figures

if TYPE_CHECKING:
    from gazed.config import Rig
    from gazed.eval.loop_metrics import LoopRecord

# how far ahead `gazed eval estimator --plot` draws the predictions (its first --horizons)
DEFAULT_HORIZON_S = 0.4


def plot_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", type=Path, help="an MCAP file written by `gazed record`")
    parser.add_argument("--plot", type=Path, required=True, help="directory for the PNG files")
    parser.add_argument(
        "--rig", type=Path, help="the recorded rig: where its camera stands, for the gaze error"
    )


def plot_command(args: argparse.Namespace) -> int:
    if not args.recording.is_file():
        print(f"gazed plot: {args.recording}: no such file", file=sys.stderr)
        return 2
    rig = load_rig_or_exit(args.rig) if args.rig is not None else None
    messages, damage = recorded_messages(args.recording)
    if damage is not None:
        print(f"gazed plot: {damage}; plotting what comes before", file=sys.stderr)
    pose = CameraPose.from_rig(rig) if rig is not None else None
    fovea = rig.gaze.fovea_half_angle_deg if rig is not None else None
    run = bus_series(args.recording.stem, messages, pose, fovea)
    written = write_figures(run, args.plot)
    if not written:
        print(f"gazed plot: {args.recording}: nothing to plot", file=sys.stderr)
        return 1
    print("\n".join(str(path) for path in written))
    return 0


def plot_loop_run(record: LoopRecord, rig: Rig, title: str, directory: Path) -> list[Path]:
    """The figures of one `gazed eval loop` run (its record and its rig) into `directory`."""
    messages: dict[str, list[Any]] = {
        "sim/truth": record.truth,
        "estimator/state": record.estimates,
        "gaze/state": record.states,
        "servo/command": record.commands,
    }
    pose = CameraPose.from_rig(rig)
    return write_figures(
        bus_series(title, messages, pose, rig.gaze.fovea_half_angle_deg), directory
    )


def plot_estimator_run(args: argparse.Namespace, section: Any, directory: Path) -> list[Path]:
    """The figures of a `gazed eval estimator` run (its arguments) into `directory`."""
    from gazed.plots.estimator_series import scenario_series, track_file_series

    horizons = [float(h) for h in args.horizons.split(",") if h.strip()]
    horizon_s = horizons[0] if horizons else DEFAULT_HORIZON_S
    if args.scenario is not None:
        run = scenario_series(
            section, args.scenario, args.seed, args.noise_m, args.velocity_noise_m_s, horizon_s
        )
    else:
        mode = "imm" if args.filter == "all" else args.filter
        run = track_file_series(section, args.data, mode, args.noise_m or 0.0, args.seed, horizon_s)
    return write_figures(run, directory)
