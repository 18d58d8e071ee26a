"""`gazed run RIG`: the command that holds the bus and runs the supervisor's loop."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import time
from pathlib import Path

from gazed.bus import Bus, BusError
from gazed.config import exit_if_cannot_start, load_rig_or_exit
from gazed.console import REFRESH_S, LiveStatus
from gazed.sdnotify import Notifier
from gazed.supervisor.machine import GiveUp, Supervisor
from gazed.wakeup import Wakeup

log = logging.getLogger("gazed.supervisor")


def run_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("rig", type=Path, help="rig description (TOML), e.g. configs/sim.toml")
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")


def run_command(args: argparse.Namespace) -> int:
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    rig = load_rig_or_exit(args.rig)
    exit_if_cannot_start(rig)
    notifier = Notifier()
    try:
        with Bus(rig, "supervisor", router=rig.bus.router) as bus, Wakeup() as wakeup:
            bus.on_arrival(wakeup.notify)
            flags = _install_signals(wakeup)
            supervisor = Supervisor(args.rig.resolve(), rig, bus, notifier)
            status = LiveStatus(bus)
            try:
                return _loop(supervisor, wakeup, notifier, flags, status)
            finally:
                status.close()
    except BusError as exc:
        print(f"gazed run: {exc}", file=sys.stderr)
        return 1
    finally:
        notifier.close()


def _install_signals(wakeup: Wakeup) -> set[str]:
    """SIGTERM/SIGINT -> "stop", SIGHUP -> "hup"; every signal (SIGCHLD too) wakes the loop."""
    flags: set[str] = set()

    def on_signal(signum: int, _frame: object) -> None:
        if signum != signal.SIGCHLD:
            flags.add("hup" if signum == signal.SIGHUP else "stop")
        wakeup.notify()

    for signum in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGCHLD):
        signal.signal(signum, on_signal)
    return flags


def _loop(
    supervisor: Supervisor,
    wakeup: Wakeup,
    notifier: Notifier,
    flags: set[str],
    status: LiveStatus,
) -> int:
    code = 0
    try:
        supervisor.start(time.monotonic())
        while "stop" not in flags:
            if "hup" in flags:
                flags.discard("hup")
                supervisor.reload(time.monotonic())
            wait_s = supervisor.step(time.monotonic())
            status.refresh(time.monotonic(), *supervisor.up())
            wakeup.wait(min(wait_s, REFRESH_S))
    except GiveUp as exc:
        log.error("%s", exc)
        notifier.status(f"failed: {exc}")
        code = 1
    finally:
        notifier.stopping("stopping")
        supervisor.stop()
        supervisor.publish_status("failed" if code else "stopping")
        log.info("stopped")
    return code
