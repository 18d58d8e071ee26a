"""A rig spread over two hosts through a zenoh router.

Two network namespaces joined by a veth pair stand for two machines: host A runs the router
(`gazed run` of a rig with every process disabled, listening on A's veth address) and a
supervisor with `sim` and `servo`; host B runs a supervisor with `vision`, `estimator` and
`gaze`. Both supervisors are clients of the router (`[bus] router = false`, `connect`), so every
message between the hosts crosses the veth link. An observer on host B scores each simulated
frame (gaze error against the truth). The loop must track; then the router is stopped and
started again, and the loop must track again.

Needs root (network namespaces); skipped with the reason otherwise. Run as a script, this file is
the observer: `python tests/test_multihost.py RIG` prints one JSON line per frame.
"""

from __future__ import annotations

import json
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

pytestmark = pytest.mark.e2e

REPO = Path(__file__).resolve().parents[1]
PORT = 17947  # inside the namespaces: no other test can hold it
ADDRESS_A, ADDRESS_B = "10.231.7.1", "10.231.7.2"
IN_FOVEA_RUN = 25  # a second of frames in a row: tracking
TRACK_TIMEOUT_S = 90.0
RECOVER_TIMEOUT_S = 60.0


def observe(rig_path: Path) -> None:
    """The observer: one line per `sim/truth` frame, `{"t": capture ns, "error_deg": …}`."""
    import math

    from gazed.bus import Bus, BusError
    from gazed.config import load_rig
    from gazed.eval.loop_metrics import gaze_errors_rad
    from gazed.geometry.pose import CameraPose
    from gazed.topics import SIM_TRUTH
    from gazed.wakeup import Wakeup

    rig = load_rig(rig_path)
    pose = CameraPose.from_rig(rig)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    bus = Bus(rig, "observer")
    while not stop.is_set():
        try:
            bus.open()
            break
        except BusError:
            stop.wait(0.2)  # the router is not up yet
    wakeup = Wakeup()
    bus.on_arrival(wakeup.notify)
    truth = bus.subscribe(SIM_TRUTH, capacity=10_000)
    try:
        while not stop.is_set():
            wakeup.wait(0.5)
            for frame in truth.take():
                error = math.degrees(float(gaze_errors_rad([frame], pose)[0]))
                print(json.dumps({"t": frame.t_capture_ns, "error_deg": error}), flush=True)
    finally:
        bus.close()
        wakeup.close()


# --- the test ------------------------------------------------------------------------------


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(args, capture_output=True, text=True, timeout=30)


@pytest.fixture
def two_hosts() -> Iterator[tuple[str, str]]:
    """Namespaces A and B joined by a veth pair, A at ADDRESS_A, B at ADDRESS_B."""
    if shutil.which("ip") is None:
        pytest.skip("iproute2 (`ip`) is not installed: cannot build network namespaces")
    tag = uuid.uuid4().hex[:6]
    a, b = f"gzA{tag}", f"gzB{tag}"
    made = run("ip", "netns", "add", a)
    if made.returncode != 0:
        pytest.skip(f"cannot create a network namespace (needs root): {made.stderr.strip()}")
    try:
        steps = [
            ("ip", "netns", "add", b),
            ("ip", "link", "add", f"va{tag}", "type", "veth", "peer", "name", f"vb{tag}"),
            ("ip", "link", "set", f"va{tag}", "netns", a),
            ("ip", "link", "set", f"vb{tag}", "netns", b),
            ("ip", "-n", a, "addr", "add", f"{ADDRESS_A}/24", "dev", f"va{tag}"),
            ("ip", "-n", b, "addr", "add", f"{ADDRESS_B}/24", "dev", f"vb{tag}"),
            ("ip", "-n", a, "link", "set", f"va{tag}", "up"),
            ("ip", "-n", b, "link", "set", f"vb{tag}", "up"),
            ("ip", "-n", a, "link", "set", "lo", "up"),
            ("ip", "-n", b, "link", "set", "lo", "up"),
        ]
        for step in steps:
            done = run(*step)
            assert done.returncode == 0, f"{' '.join(step)}: {done.stderr}"
        ping = run("ip", "netns", "exec", b, "ping", "-c", "1", "-W", "5", ADDRESS_A)
        assert ping.returncode == 0 or shutil.which("ping") is None, ping.stdout + ping.stderr
        yield a, b
    finally:
        run("ip", "netns", "del", a)
        run("ip", "netns", "del", b)


def host_rig(directory: Path, name: str, rig_name: str, enabled: tuple[str, ...]) -> Path:
    """The sim rig for one host: its processes only, a client of the router on A."""
    import tomlkit

    from gazed.config import SERVICE_NAMES
    from gazed.eval.private_rig import private_rig

    path = private_rig(REPO / "configs" / "sim.toml", directory, "oval", None, None, 6, None)
    document = tomlkit.parse(path.read_text())
    document["rig"]["name"] = rig_name
    document["bus"]["router"] = False
    document["bus"]["listen"] = [f"tcp/{ADDRESS_A}:{PORT}"]
    document["bus"]["connect"] = [f"tcp/{ADDRESS_A}:{PORT}"]
    for process in SERVICE_NAMES:
        document["services"].setdefault(process, tomlkit.table())["enabled"] = process in enabled
    rig_path = directory / f"{name}.toml"
    rig_path.write_text(tomlkit.dumps(document))
    return rig_path


def router_rig(directory: Path) -> Path:
    """The router host: `gazed run` with no process, listening on A's address."""
    from gazed.config import SERVICE_NAMES

    services = "".join(f"[services.{p}]\nenabled = false\n" for p in SERVICE_NAMES)
    path = directory / "router.toml"
    path.write_text(
        f'[rig]\nname = "router{uuid.uuid4().hex[:6]}"\n\n'
        f'[bus]\nlisten = ["tcp/{ADDRESS_A}:{PORT}"]\n\n{services}'
    )
    return path


class Host:
    """Processes started in one namespace, their output kept, stopped in reverse order."""

    def __init__(self, namespace: str, log_dir: Path) -> None:
        self.namespace = namespace
        self.log_dir = log_dir
        self.processes: list[subprocess.Popen[str]] = []

    def start(
        self, name: str, *command: str, stdout: int | None = None, **env: str
    ) -> subprocess.Popen[str]:
        from conftest import child_env

        log = (self.log_dir / f"{name}.log").open("a")
        process = subprocess.Popen(
            ["ip", "netns", "exec", self.namespace, sys.executable, *command],
            env=child_env(**env),
            stdout=stdout if stdout is not None else log,
            stderr=log,
            text=True,
        )
        self.processes.append(process)
        return process

    def stop_all(self) -> None:
        for process in reversed(self.processes):
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
        for process in reversed(self.processes):
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


class Frames:
    """The observer's lines, read on a thread; `wait_tracking` waits for a run in the fovea."""

    def __init__(self, process: subprocess.Popen[str], fovea_deg: float) -> None:
        self.fovea_deg = fovea_deg
        self.lines: queue.Queue[dict[str, float]] = queue.Queue()
        self.errors: list[float] = []
        threading.Thread(target=self._read, args=(process,), daemon=True).start()

    def _read(self, process: subprocess.Popen[str]) -> None:
        assert process.stdout is not None
        for line in process.stdout:
            self.lines.put(json.loads(line))

    def drain(self) -> list[float]:
        got = []
        while not self.lines.empty():
            got.append(self.lines.get_nowait()["error_deg"])
        self.errors += got
        return got

    def wait_tracking(self, timeout_s: float, check: Callable[[], None]) -> float:
        """Seconds until IN_FOVEA_RUN frames in a row are in the fovea."""
        started = time.monotonic()
        run_length = 0
        while time.monotonic() - started < timeout_s:
            check()
            try:
                error = self.lines.get(timeout=0.5)["error_deg"]
            except queue.Empty:
                continue
            self.errors.append(error)
            run_length = run_length + 1 if error <= self.fovea_deg else 0
            if run_length >= IN_FOVEA_RUN:
                return time.monotonic() - started
        raise AssertionError(f"no tracking within {timeout_s} s")

    def fraction_in_fovea(self, seconds: float, check: Callable[[], None]) -> float:
        self.drain()
        deadline = time.monotonic() + seconds
        errors = []
        while time.monotonic() < deadline:
            check()
            try:
                errors.append(self.lines.get(timeout=0.5)["error_deg"])
            except queue.Empty:
                continue
        assert errors, "no frames"
        return sum(e <= self.fovea_deg for e in errors) / len(errors)


def test_rig_across_two_hosts_tracks_and_survives_a_router_restart(
    two_hosts: tuple[str, str], tmp_path: Path
) -> None:
    from conftest import NotifySocket, poll_until

    from gazed.config import load_rig

    namespace_a, namespace_b = two_hosts
    rig_name = f"multi{uuid.uuid4().hex[:6]}"
    rig_a = host_rig(tmp_path, "host-a", rig_name, ("sim", "servo"))
    rig_b = host_rig(tmp_path, "host-b", rig_name, ("vision", "estimator", "gaze"))
    router = router_rig(tmp_path)
    fovea_deg = load_rig(rig_a).gaze.fovea_half_angle_deg
    host_a, host_b = Host(namespace_a, tmp_path), Host(namespace_b, tmp_path)
    gazed = ("-m", "gazed.cli", "run")
    notify = NotifySocket(tmp_path / "router-notify.sock")

    def start_router() -> subprocess.Popen[str]:
        """The router, once it listens (its READY=1: no process to wait for)."""
        ready = notify.count("READY=1")
        process = host_a.start("router", *gazed, str(router), NOTIFY_SOCKET=str(notify.path))
        poll_until(lambda: notify.count("READY=1") > ready or process.poll() is not None, 30.0)
        assert process.poll() is None, (tmp_path / "router.log").read_text()[-3000:]
        return process

    try:
        routers = [start_router()]
        supervisors = [
            host_a.start("host-a", *gazed, str(rig_a)),
            host_b.start("host-b", *gazed, str(rig_b)),
        ]
        observer = host_b.start("observer", __file__, str(rig_b), stdout=subprocess.PIPE)
        frames = Frames(observer, fovea_deg)

        def check() -> None:
            for name, process in (
                ("host-a", supervisors[0]),
                ("host-b", supervisors[1]),
                ("router", routers[-1]),
                ("observer", observer),
            ):
                assert process.poll() is None, (tmp_path / f"{name}.log").read_text()[-3000:]

        first_s = frames.wait_tracking(TRACK_TIMEOUT_S, check)
        tracked = frames.fraction_in_fovea(5.0, check)

        routers[-1].send_signal(signal.SIGTERM)
        assert routers[-1].wait(timeout=30) == 0
        stopped = time.monotonic()
        routers.append(start_router())
        restarted_s = time.monotonic() - stopped
        frames.drain()
        recovered_s = frames.wait_tracking(RECOVER_TIMEOUT_S, check)
        after = frames.fraction_in_fovea(5.0, check)
    finally:
        host_b.stop_all()
        host_a.stop_all()
        notify.close()
    restarts = sum(
        (tmp_path / f"{host}.log").read_text().count("restarting in")
        for host in ("host-a", "host-b")
    )
    print(
        f"tracking after {first_s:.1f} s, fovea fraction {tracked:.2f}; router down "
        f"{restarted_s:.2f} s, tracking again {recovered_s:.1f} s after its restart, "
        f"fovea fraction then {after:.2f}; processes restarted by their supervisors: {restarts}"
    )
    assert tracked >= 0.7
    assert after >= 0.7
    assert [p.returncode for p in supervisors] == [0, 0]


if __name__ == "__main__":
    observe(Path(sys.argv[1]))
