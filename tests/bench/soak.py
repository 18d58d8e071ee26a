"""Soak: the simulated rig's whole loop for N minutes under `gazed run`, on a private bus.

    python tests/bench/soak.py --minutes 30 [--rig configs/sim.toml] [--scenario oval] [--json]

Reports:
- resident memory (RSS) of the supervisor and of every process when all are up, after the first
  minute (imports, caches and buffers settled) and at the end; the growth from the first minute
  to the end, and the slope of a straight line fitted over the second half of the run;
- restarts: the supervisor's own count per process and any pid that changed;
- the message backlog: subscription queues that overflowed (`dropped`, frames `replaced` by newer
  ones) and malformed messages, from each process's health at the end; and per minute the end to
  end latency from capture to the command bytes written (a queue that grows shows as a latency
  that grows);
- tracking per minute, from `gazed.eval.loop_metrics`: fraction of frames with the target in the
  fovea, gaze error RMS, ground RMSE; CPU share per process over the whole run.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import psutil

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from gazed.bus import Bus  # noqa: E402
from gazed.config import SERVICE_NAMES, Rig  # noqa: E402
from gazed.eval.loop import open_observer, running  # noqa: E402
from gazed.eval.loop_metrics import LoopRecord, score  # noqa: E402
from gazed.eval.loop_record import cpu_seconds  # noqa: E402
from gazed.eval.private_rig import private_rig  # noqa: E402
from gazed.geometry.pose import CameraPose  # noqa: E402
from gazed.messages import Health, SupervisorStatus  # noqa: E402
from gazed.topics import (  # noqa: E402
    ESTIMATOR_STATE,
    GAZE_STATE,
    SERVO_COMMAND,
    SIM_TRUTH,
    SUPERVISOR_STATUS,
    health,
)
from gazed.wakeup import Wakeup  # noqa: E402

START_TIMEOUT_S = 90.0
SAMPLE_PERIOD_S = 10.0
WINDOW_S = 60.0
MIB = 1024.0 * 1024.0


class Soak:
    """One soak run: the supervisor as a subprocess, an observer session, samples and windows."""

    def __init__(self, rig: Rig, supervisor: subprocess.Popen[bytes], log_path: Path) -> None:
        self.rig = rig
        self.supervisor = supervisor
        self.log_path = log_path
        self.bus = Bus(rig, "soak")
        self.wakeup = Wakeup()
        self.bus.on_arrival(self.wakeup.notify)
        self.pose = CameraPose.from_rig(rig)
        self.pids: dict[str, int] = {}
        self.handles: dict[str, psutil.Process] = {}
        self.pid_changes: dict[str, int] = dict.fromkeys(SERVICE_NAMES, 0)
        self.rss: dict[str, list[tuple[float, float]]] = {}
        self.cpu_start_s: dict[str, float] = {}
        self.windows: list[dict[str, Any]] = []
        self.health: dict[str, Health] = {}
        self.status: SupervisorStatus | None = None

    def open(self) -> None:
        open_observer(self.bus, self.supervisor, self.log_path, START_TIMEOUT_S)

    def run(self, minutes: float) -> dict[str, Any]:
        truth = self.bus.subscribe(SIM_TRUTH, capacity=100000)
        states = self.bus.subscribe(GAZE_STATE, capacity=10000)
        commands = self.bus.subscribe(SERVO_COMMAND, capacity=100000)
        estimates = self.bus.subscribe(ESTIMATOR_STATE, capacity=100000)
        statuses = self.bus.subscribe(SUPERVISOR_STATUS)
        healths = {name: self.bus.subscribe(health(name), capacity=16) for name in SERVICE_NAMES}
        self._wait_running(statuses)
        for subscription in (truth, states, commands, estimates):
            subscription.take()
        self.handles["supervisor"] = psutil.Process(self.supervisor.pid)
        for name, pid in self.pids.items():
            self.handles[name] = psutil.Process(pid)
        self.cpu_start_s = {name: cpu_seconds(p) for name, p in self.handles.items()}
        started = time.monotonic()
        self._sample_rss(0.0)
        next_sample_s = started + SAMPLE_PERIOD_S
        window_start = started
        record = LoopRecord([], [], [], [])
        while (now := time.monotonic()) - started < minutes * 60.0:
            self.wakeup.wait(0.5)
            self._check_supervisor()
            record.truth.extend(truth.take())
            record.states.extend(states.take())
            record.commands.extend(commands.take())
            record.estimates.extend(estimates.take())
            self._follow_status(statuses)
            for name, subscription in healths.items():
                latest = subscription.latest()
                if latest is not None:
                    self.health[name] = latest
            if now >= next_sample_s:
                self._sample_rss(now - started)
                next_sample_s += SAMPLE_PERIOD_S
            if now - window_start >= WINDOW_S:
                self._score_window(record, window_start - started)
                record = LoopRecord([], [], [], [])
                window_start = now
        elapsed_s = time.monotonic() - started
        self._sample_rss(elapsed_s)
        if record.truth:
            self._score_window(record, window_start - started)
        cpu = {
            name: round(100.0 * (cpu_seconds(p) - self.cpu_start_s[name]) / elapsed_s, 1)
            for name, p in self.handles.items()
            if p.is_running()
        }
        return self._report(minutes, elapsed_s, cpu)

    def close(self) -> None:
        self.bus.close()
        self.wakeup.close()

    # --- pieces ---------------------------------------------------------------------------

    def _check_supervisor(self) -> None:
        if self.supervisor.poll() is not None:
            raise RuntimeError(
                f"gazed run exited with {self.supervisor.returncode}:\n"
                + self.log_path.read_text()[-2000:]
            )

    def _wait_running(self, statuses: Any) -> None:
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline:
            self.wakeup.wait(0.5)
            self._check_supervisor()
            latest = statuses.latest()
            if latest is None or latest.state != "running":
                continue
            running = {p.name: p.pid for p in latest.processes if p.state == "running" and p.pid}
            if set(running) == set(SERVICE_NAMES):
                self.status, self.pids = latest, running
                return
        raise RuntimeError("the rig's processes did not all come up")

    def _follow_status(self, statuses: Any) -> None:
        latest = statuses.latest()
        if latest is None:
            return
        self.status = latest
        for process in latest.processes:
            if process.pid and process.pid != self.pids.get(process.name):
                self.pid_changes[process.name] += 1
                self.pids[process.name] = process.pid
                try:
                    self.handles[process.name] = psutil.Process(process.pid)
                except psutil.NoSuchProcess:
                    self.handles.pop(process.name, None)

    def _sample_rss(self, t_s: float) -> None:
        for name, process in list(self.handles.items()):
            try:
                rss = process.memory_info().rss / MIB
            except psutil.NoSuchProcess:
                continue
            self.rss.setdefault(name, []).append((t_s, rss))

    def _score_window(self, record: LoopRecord, start_s: float) -> None:
        try:
            result = score(record, self.pose, self.rig.gaze.fovea_half_angle_deg)
        except ValueError as exc:  # no truth at all in this window
            self.windows.append({"start_s": round(start_s), "error": str(exc)})
            return
        self.windows.append(
            {
                "start_s": round(start_s),
                "frames": result["frames"],
                "fovea_fraction": result["fovea_fraction"],
                "gaze_error_rms_deg": (result["gaze_error_deg"] or {}).get("rms"),
                "ground_rmse_m": result["ground_rmse_m"],
                "end_to_end_p50_ms": result["latency_ms"]["end_to_end_p50"],
                "processing_p99_ms": result["latency_ms"]["processing_p99"],
            }
        )

    def _report(self, minutes: float, elapsed_s: float, cpu: dict[str, float]) -> dict[str, Any]:
        memory = {}
        for name, samples in self.rss.items():
            t = np.array([s[0] for s in samples])
            rss = np.array([s[1] for s in samples])
            warm = rss[np.searchsorted(t, WINDOW_S)] if t[-1] >= WINDOW_S else rss[0]
            half = t >= t[-1] / 2.0
            slope = np.polyfit(t[half], rss[half], 1)[0] * 3600.0 if half.sum() >= 3 else None
            memory[name] = {
                "up_mib": round(float(rss[0]), 1),
                "warm_mib": round(float(warm), 1),
                "end_mib": round(float(rss[-1]), 1),
                "growth_percent": round(100.0 * (rss[-1] - warm) / warm, 1),
                "second_half_slope_mib_h": None if slope is None else round(float(slope), 1),
            }
        restarts = {p.name: p.restarts for p in self.status.processes} if self.status else {}
        backlog = {
            name: {
                key: h.counters.get(key, 0)
                for key in ("dropped", "replaced", "malformed", "step_errors")
            }
            for name, h in sorted(self.health.items())
        }
        scored = [w for w in self.windows if "fovea_fraction" in w]
        return {
            "minutes": minutes,
            "elapsed_s": round(elapsed_s, 1),
            "rss": memory,
            "restarts": restarts,
            "pid_changes": self.pid_changes,
            "backlog": backlog,
            "cpu_percent": cpu,
            "windows": self.windows,
            "fovea_fraction_min": min((w["fovea_fraction"] for w in scored), default=None),
            "fovea_fraction_mean": (
                round(float(np.mean([w["fovea_fraction"] for w in scored])), 4) if scored else None
            ),
            "load_average": [round(x, 2) for x in psutil.getloadavg()],
        }


def soak(rig_path: Path, scenario: str, minutes: float, seed: int | None) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="gazed-soak-") as directory:
        private = private_rig(rig_path, Path(directory), scenario, None, None, seed, None)
        with running(private) as (rig, supervisor, log_path):
            run = Soak(rig, supervisor, log_path)
            try:
                run.open()
                return run.run(minutes)
            finally:
                run.close()


def table(report: dict[str, Any]) -> str:
    lines = [f"soak: {report['minutes']:g} min ({report['elapsed_s']:g} s measured)"]
    lines.append(
        f"  {'process':<11}{'RSS up':>9}{'1 min':>9}{'end':>9}{'growth':>9}"
        f"{'slope 2nd half':>16}{'restarts':>10}{'cpu %':>8}"
    )
    for name, m in report["rss"].items():
        slope = m["second_half_slope_mib_h"]
        lines.append(
            f"  {name:<11}{m['up_mib']:>8.1f}M{m['warm_mib']:>8.1f}M{m['end_mib']:>8.1f}M"
            f"{m['growth_percent']:>8.1f}%"
            f"{'-' if slope is None else f'{slope:+.1f} MiB/h':>16}"
            f"{report['restarts'].get(name, 0) + report['pid_changes'].get(name, 0):>10}"
            f"{report['cpu_percent'].get(name, float('nan')):>8.1f}"
        )
    lines.append("  backlog at the end (health counters):")
    for name, counters in report["backlog"].items():
        lines.append(f"    {name:<11}" + ", ".join(f"{k} {v}" for k, v in counters.items()))
    lines.append(
        f"  {'minute from s':>15}{'frames':>8}{'fovea':>8}{'err rms°':>10}{'ground m':>10}"
        f"{'e2e p50 ms':>12}{'proc p99 ms':>13}"
    )
    for w in report["windows"]:
        if "error" in w:
            lines.append(f"  {w['start_s']:>15}  {w['error']}")
            continue
        lines.append(
            f"  {w['start_s']:>15}{w['frames']:>8}{w['fovea_fraction']!s:>8}"
            f"{w['gaze_error_rms_deg']!s:>10}{w['ground_rmse_m']!s:>10}"
            f"{w['end_to_end_p50_ms']!s:>12}{w['processing_p99_ms']!s:>13}"
        )
    lines.append(
        f"  fovea fraction: mean {report['fovea_fraction_mean']}, worst minute "
        f"{report['fovea_fraction_min']}; load average {report['load_average']}"
    )
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=30.0, help="length of the run")
    parser.add_argument("--rig", type=Path, default=REPO / "configs" / "sim.toml")
    parser.add_argument("--scenario", default="oval", help="the simulated target's trajectory")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args()
    report = soak(args.rig, args.scenario, args.minutes, args.seed)
    print(json.dumps(report, indent=2) if args.json else table(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
