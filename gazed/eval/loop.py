"""`gazed eval loop`: run a rig's whole loop in the simulator on a private bus and score it.

The rig file is copied with a private rig name, loopback port and head pty, and the scenario's
trajectory, filter, visual latency, seed and control mode; `gazed run` starts every process on
it (the real entry points); once the supervisor reports them all up, what the bus carries for
`--seconds` is recorded and scored (`loop_metrics`), with each process's CPU share over the
same window. `--compare` runs `imm`, `image-cv` and `none` (the IMM without prediction over the
latency) and the peers' control laws `pid` and `move-wait-move` on the same seed, one after the
other. With `--truth`, a digital head's rig runs over its footage instead and is scored against
the annotated people (`footage_loop`). A terminal shows the runs' progress (`progress`).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from gazed.bus import Bus, BusError
from gazed.config import Rig, RigError, load_rig
from gazed.eval.loop_metrics import LoopRecord, score
from gazed.eval.loop_record import Recording, Watch, record
from gazed.eval.private_rig import private_rig
from gazed.eval.progress import EvalProgress
from gazed.eval.zoom_score import zoom_scoring
from gazed.geometry.pose import CameraPose
from gazed.messages import ServoStatus
from gazed.sim.reach import FieldOfRegard
from gazed.topics import (
    ESTIMATOR_STATE,
    GAZE_STATE,
    SERVO_COMMAND,
    SERVO_STATUS,
    SIM_TRUTH,
    Topic,
)
from gazed.wakeup import Wakeup

FILTERS = ("imm", "innovation", "alphabeta", "image-cv", "none")
CONTROLS = ("pursuit", "look-and-move", "pid", "move-wait-move")
# (filter, control) of each --compare run: the estimation modes in pursuit, then the peers' laws
# (which use the detections alone; the estimator runs beside them unused)
COMPARED = (
    ("imm", None),
    ("image-cv", None),
    ("none", None),
    (None, "pid"),
    (None, "move-wait-move"),
)
START_TIMEOUT_S = 60.0
DEFAULT_SECONDS = 30.0
SIM_TOPICS = (SIM_TRUTH, GAZE_STATE, SERVO_COMMAND, ESTIMATOR_STATE, SERVO_STATUS)


def loop_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--rig", type=Path, required=True, help="the rig to run (its [sim] world, or footage)"
    )
    parser.add_argument(
        "--scenario",
        help="a trajectory: rounded-square, oval, stop-and-go, figure-eight, random, "
        "file:PATH#ped_id",
    )
    parser.add_argument(
        "--truth",
        type=Path,
        help="score a digital head's run on footage against this annotation CSV (no --scenario)",
    )
    parser.add_argument(
        "--start-frame",
        type=int,
        help="with --truth: the footage's first frame ([wide] start_frame)",
    )
    parser.add_argument(
        "--select-id", type=int, help="with --truth: choose this person at their first frame"
    )
    parser.add_argument(
        "--seconds",
        type=float,
        help="scored time after every process is up (default 30; with --select-id, until the "
        "person leaves the wide view)",
    )
    parser.add_argument(
        "--filter", choices=FILTERS, help="estimator mode (none: IMM without prediction)"
    )
    parser.add_argument(
        "--latency-ms",
        type=float,
        help="the simulated visual latency; "
        "with --truth, the frames' delay ([wide] frame_delay_ms)",
    )
    parser.add_argument("--seed", type=int, help="the simulated world's seed")
    parser.add_argument("--control", choices=CONTROLS, help="gaze control mode")
    parser.add_argument(
        "--compare",
        action="store_true",
        help="run imm, image-cv, none, pid and move-wait-move on the same seed (with --truth: "
        "imm, image-cv and none)",
    )
    parser.add_argument("--json", action="store_true", help="print JSON")
    parser.add_argument("--plot", type=Path, help="write the run's figures (PNG) into this folder")


def loop_command(args: argparse.Namespace) -> int:
    try:
        load_rig(args.rig)
    except RigError as exc:
        print(exc, file=sys.stderr)
        return 2
    if args.truth is not None:
        from gazed.eval.footage_loop import footage_command  # it builds on this module

        return footage_command(args)
    if args.scenario is None:
        print(
            "gazed eval loop: give --scenario (the simulator) or --truth (footage)", file=sys.stderr
        )
        return 2
    runs = COMPARED if args.compare else ((args.filter, args.control),)
    results = []
    progress = EvalProgress(len(runs), args.json)
    for mode, control in runs:
        try:
            results.append(
                run_loop(
                    args.rig,
                    args.scenario,
                    args.seconds if args.seconds is not None else DEFAULT_SECONDS,
                    mode,
                    args.latency_ms,
                    args.seed,
                    control,
                    args.plot / f"{mode}-{control}" if args.plot and args.compare else args.plot,
                    progress,
                )
            )
        except (RuntimeError, RigError) as exc:
            progress.close()
            print(f"gazed eval loop: {exc}", file=sys.stderr)
            return 1
    progress.close()
    print_results(results, args.json, _table)
    return 0


def print_results(
    results: list[dict[str, Any]], as_json: bool, table: Callable[[list[dict[str, Any]]], str]
) -> None:
    """One run's JSON (several runs' under "runs"), or the table of them."""
    if as_json:
        print(json.dumps(results[0] if len(results) == 1 else {"runs": results}, indent=2))
    else:
        print(table(results))


def run_loop(
    rig_path: Path,
    scenario: str,
    seconds: float,
    filter_mode: str | None = None,
    latency_ms: float | None = None,
    seed: int | None = None,
    control: str | None = None,
    plot_dir: Path | None = None,
    progress: EvalProgress | None = None,
) -> dict[str, Any]:
    """Run the rig's processes on a private bus for `seconds` after they are all up; score;
    with `plot_dir`, draw the run's figures there; with `progress`, show it there."""
    with tempfile.TemporaryDirectory(prefix="gazed-eval-") as directory:
        private = private_rig(
            rig_path, Path(directory), scenario, filter_mode, latency_ms, seed, control
        )
        with running(private) as (rig, supervisor, log_path):
            watch = progress and progress.recording(seconds, scenario, filter_mode, control)
            recording = record_run(rig, supervisor, log_path, SIM_TOPICS, seconds, watch)
        messages = recording.messages
        record = LoopRecord(
            messages[SIM_TRUTH.suffix],
            messages[GAZE_STATE.suffix],
            messages[SERVO_COMMAND.suffix],
            messages[ESTIMATOR_STATE.suffix],
        )
        result: dict[str, Any] = {
            "scenario": scenario,
            "filter": filter_mode or rig.estimator.filter,
            "control": rig.gaze.control,
            "seconds": seconds,
        }
        pose, reach = CameraPose.from_rig(rig), FieldOfRegard.for_scoring(rig)
        result.update(score(record, pose, rig.gaze.fovea_half_angle_deg, reach, zoom_scoring(rig)))
        if plot_dir is not None:
            from gazed.plots.plot_cli import plot_loop_run

            plot_loop_run(record, rig, f"{scenario} {result['filter']}", plot_dir)
        del result["frames"]
        result["cpu_percent"] = recording.cpu_percent
        result["servo"] = servo_summary(messages[SERVO_STATUS.suffix])
        return result


def servo_summary(statuses: list[ServoStatus]) -> dict[str, Any]:
    """What the servo said of its line during the run: how full it was (mean and worst
    second), polls unanswered, and the head's response lag at the end."""
    loads = [s.line_load for s in statuses if s.line_load is not None]
    last = statuses[-1] if statuses else None
    lag_s = last.response_lag_s if last is not None else None
    return {
        "line_load_mean": round(float(np.mean(loads)), 3) if loads else None,
        "line_load_max": round(max(loads), 3) if loads else None,
        "timeouts": (last.timeouts - statuses[0].timeouts) if last is not None else None,
        "response_lag_ms": round(lag_s * 1e3, 1) if lag_s is not None else None,
    }


@contextlib.contextmanager
def running(rig_path: Path) -> Iterator[tuple[Rig, subprocess.Popen[bytes], Path]]:
    """`gazed run RIG` in the background, its output in run.log beside the rig; stopped (SIGTERM,
    then SIGKILL after 30 s) on the way out — also when this process is sent SIGTERM (`timeout`,
    `kill`), which would otherwise end it at once and leave the supervisor running."""
    rig = load_rig(rig_path)
    log_path = rig_path.parent / "run.log"
    with log_path.open("w") as log:
        supervisor = subprocess.Popen(
            [sys.executable, "-m", "gazed.cli", "run", str(rig_path)],
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    previous = signal.signal(signal.SIGTERM, _exit_on_sigterm)
    try:
        yield rig, supervisor, log_path
    finally:
        signal.signal(signal.SIGTERM, previous)
        supervisor.send_signal(signal.SIGTERM)
        try:
            supervisor.wait(timeout=30)
        except subprocess.TimeoutExpired:
            supervisor.kill()
            supervisor.wait()


@contextlib.contextmanager
def observed(
    rig_path: Path, name: str, timeout_s: float = START_TIMEOUT_S
) -> Iterator[tuple[Rig, Bus, Wakeup]]:
    """`running(rig_path)` with a bus session called `name` on its bus, opened once the router
    listens (within timeout_s) and closed on the way out, and a `Wakeup` that every arrival
    on it wakes (the benches that watch a rig)."""
    with running(rig_path) as (rig, supervisor, log_path):
        bus = Bus(rig, name)
        open_observer(bus, supervisor, log_path, timeout_s)
        try:
            with Wakeup() as wakeup:
                bus.on_arrival(wakeup.notify)
                yield rig, bus, wakeup
        finally:
            bus.close()


def record_run(
    rig: Rig,
    supervisor: subprocess.Popen[bytes],
    log_path: Path,
    topics: tuple[Topic, ...],
    seconds: float,
    watch: Watch | None = None,
) -> Recording:
    """`record` on a bus session of the rig `running` runs."""
    bus = Bus(rig, "eval")
    open_observer(bus, supervisor, log_path)
    try:
        return record(bus, supervisor, log_path, topics, seconds, START_TIMEOUT_S, watch)
    finally:
        bus.close()


def _exit_on_sigterm(signum: int, _frame: object) -> None:
    raise SystemExit(128 + signum)


def open_observer(
    bus: Bus,
    supervisor: subprocess.Popen[bytes],
    log_path: Path,
    timeout_s: float = START_TIMEOUT_S,
) -> None:
    """Open `bus` on the rig of a `gazed run` from `running` once its router listens; the run's
    log in the error if it exits first."""
    deadline = time.monotonic() + timeout_s
    while True:
        if supervisor.poll() is not None:
            raise RuntimeError(
                f"gazed run exited with {supervisor.returncode}:\n{log_path.read_text()[-2000:]}"
            )
        try:
            bus.open()
            return
        except BusError:
            if time.monotonic() > deadline:
                raise RuntimeError("the private bus did not come up") from None
            time.sleep(0.1)  # the supervisor's router is not listening yet


def _table(results: list[dict[str, Any]]) -> str:
    rows = [
        ("filter", lambda r: r["filter"]),
        ("control", lambda r: r["control"]),
        ("acquired after (s)", lambda r: r["acquired_after_s"]),
        ("gaze error rms (deg)", lambda r: (r["gaze_error_deg"] or {}).get("rms")),
        ("gaze error p95 (deg)", lambda r: (r["gaze_error_deg"] or {}).get("p95")),
        ("fovea fraction", lambda r: r["fovea_fraction"]),
        ("saccades after acquisition", lambda r: r["saccades_after_acquisition"]),
        ("ground rmse (m)", lambda r: r["ground_rmse_m"]),
        ("processing p50 (ms)", lambda r: r["latency_ms"]["processing_p50"]),
        ("processing p99 (ms)", lambda r: r["latency_ms"]["processing_p99"]),
        ("end to end p50 (ms)", lambda r: r["latency_ms"]["end_to_end_p50"]),
        ("cpu total (%)", lambda r: round(sum(r["cpu_percent"].values()), 1)),
    ]
    lines = [f"scenario {results[0]['scenario']}, {results[0]['seconds']:g} s"]
    for label, get in rows:
        lines.append(f"  {label:<28}" + "".join(f"{get(r)!s:>16}" for r in results))
    return "\n".join(lines)
