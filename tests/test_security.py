"""The bus closed to strangers.

- By default every socket of every process (supervisor included) is TCP on loopback: the
  supervisor's router listens on the rig's loopback endpoint only, each process connects to it
  and listens on one loopback port for its peers (`[bus] peer_links`; no more open than the
  router's own unauthenticated loopback endpoint), and no process has a UDP socket at all, so
  nothing is announced by multicast scouting. The same check flags a default zenoh peer, which
  listens on every interface and scouts.
- With `[bus] credentials_path` and the shipped `deploy/zenoh-rig.json5` (TLS, access control;
  a throwaway CA and router certificate made with openssl here) each process authenticates as
  itself; a session without the CA, without credentials, or with a wrong password cannot join;
  a known identity that is not the gaze process cannot steer the head: its demands, its fake
  odometry and its forged liveliness token are dropped by the router, while the same demand from
  the gaze identity moves the head.
"""

from __future__ import annotations

import ipaddress
import os
import random
import shutil
import socket
import subprocess
import time
from pathlib import Path

import psutil
import pytest
import tomlkit
import zenoh
from conftest import REPO, RunningSupervisor, poll_until, write_rig

from gazed.bus import Bus, Subscription
from gazed.config import SERVICE_NAMES, BusSection, load_rig
from gazed.eval.private_rig import private_rig
from gazed.messages import Detection, GazeDemand, Health, Odometry
from gazed.session import TOOLS_IDENTITY, BusError, identity_of, open_session, session_config
from gazed.topics import (
    GAZE_DEMAND,
    SERVO_COMMAND,
    SERVO_ODOMETRY,
    SIM_TRUTH,
    VISION_DETECTION,
    alive_key,
    health,
)

DEPLOY_CONFIG = REPO / "deploy" / "zenoh-rig.json5"
IDENTITIES = ("supervisor", *SERVICE_NAMES, TOOLS_IDENTITY)
STRANGER_PAN_RAD = 0.35  # 20°: a demand the head would visibly follow


def exposed_sockets(pid: int) -> list[str]:
    """The process's (and its children's) internet sockets that are not TCP between loopback
    addresses: anything listening or bound beyond 127.0.0.1/::1, and every UDP socket (zenoh's
    multicast scouting needs one)."""
    process = psutil.Process(pid)
    found = []
    for each in (process, *process.children(recursive=True)):
        for conn in each.net_connections(kind="inet"):
            ends = [conn.laddr, *([conn.raddr] if conn.raddr else [])]
            loopback = all(_is_loopback(end.ip) for end in ends)
            if conn.type != socket.SOCK_STREAM or not loopback:
                kind = "udp" if conn.type == socket.SOCK_DGRAM else "tcp"
                found.append(f"pid {each.pid}: {kind} {conn.laddr} -> {conn.raddr} {conn.status}")
    return found


def _is_loopback(ip: str) -> bool:
    address = ipaddress.ip_address(ip.split("%", 1)[0])
    mapped = getattr(address, "ipv4_mapped", None)
    return (mapped or address).is_loopback


@pytest.mark.e2e
def test_every_socket_is_loopback_and_nothing_scouts(tmp_path: Path) -> None:
    rig_path = private_rig(REPO / "configs" / "sim.toml", tmp_path, "oval", None, None, 2, None)
    supervisor = RunningSupervisor(rig_path, tmp_path)
    try:
        supervisor.wait_ready(60.0)
        pids = supervisor.pids()
        assert set(pids) == set(SERVICE_NAMES)
        port = int(supervisor.rig.bus.listen[0].rsplit(":", 1)[1])
        listening, peers = {}, {}
        for name, pid in {"supervisor": supervisor.process.pid, **pids}.items():
            assert exposed_sockets(pid) == [], name
            connections = psutil.Process(pid).net_connections(kind="inet")
            listening[name] = sorted(
                c.laddr.port for c in connections if c.status == psutil.CONN_LISTEN
            )
            peers[name] = {c.raddr.port for c in connections if c.status == psutil.CONN_ESTABLISHED}
    finally:
        assert supervisor.stop() == 0
    # the router listens on the rig's port; each process on one loopback port for its peers
    # (exposed_sockets: nothing beyond loopback), none on the rig's
    assert listening.pop("supervisor") == [port]
    assert {name: len(ports) for name, ports in listening.items()} == dict.fromkeys(
        SERVICE_NAMES, 1
    )
    assert port not in {p for ports in listening.values() for p in ports}
    # and they use them: vision's detections go straight to the estimator, its predictions
    # straight to the gaze (a connection to the other's listening port, one way or the other)
    for a, b in (("vision", "estimator"), ("estimator", "gaze"), ("gaze", "servo")):
        assert set(listening[b]) & peers[a] or set(listening[a]) & peers[b], (a, b)


def test_the_check_flags_a_default_zenoh_peer() -> None:
    with zenoh.open(zenoh.Config()):  # zenoh's defaults: listen everywhere, scout by multicast
        exposed = exposed_sockets(os.getpid())
    assert any(" udp " in line for line in exposed)
    assert any("LISTEN" in line for line in exposed)


# --- identities ------------------------------------------------------------------------------


def test_each_process_presents_its_own_identity() -> None:
    assert [identity_of(name) for name in ("supervisor", *SERVICE_NAMES)] == [
        "supervisor",
        *SERVICE_NAMES,
    ]
    assert identity_of("observer") == identity_of("calibrate") == TOOLS_IDENTITY


def write_credentials(directory: Path, seed: int) -> tuple[Path, dict[str, str]]:
    rng = random.Random(seed)
    passwords = {name: f"{rng.getrandbits(128):032x}" for name in IDENTITIES}
    path = directory / "credentials"
    path.write_text("".join(f"{name}:{password}\n" for name, password in passwords.items()))
    path.chmod(0o600)
    return path, passwords


def test_credentials_are_checked_before_anything_is_opened(tmp_path: Path) -> None:
    credentials, passwords = write_credentials(tmp_path, 1)
    rig_path = write_rig(tmp_path, "")
    text = rig_path.read_text().replace("[bus]\n", '[bus]\ncredentials_path = "credentials"\n')
    rig_path.write_text(text)
    bus = load_rig(rig_path).bus
    assert bus.credentials_path == credentials  # relative to the rig file
    config = session_config(bus, router=False, identity="gaze")
    assert config.get_json("transport/auth/usrpwd/user") == '"gaze"'
    assert config.get_json("transport/auth/usrpwd/password") == f'"{passwords["gaze"]}"'
    router = session_config(bus, router=True, identity="supervisor")
    assert router.get_json("transport/auth/usrpwd/dictionary_file") == f'"{credentials}"'
    with pytest.raises(BusError, match=r"no credentials for 'sim'"):
        credentials.write_text("gaze:x\n")
        session_config(bus, router=False, identity="sim")
    with pytest.raises(BusError, match=r"open to every user \(mode 604\)"):
        credentials.chmod(0o604)
        session_config(bus, router=False, identity="gaze")
    credentials.unlink()
    with pytest.raises(BusError, match=r"cannot read the bus credentials"):
        session_config(bus, router=False, identity="gaze")


def test_clients_leave_access_control_to_the_router() -> None:
    bus = BusSection(zenoh_config_path=DEPLOY_CONFIG)
    client = session_config(bus, router=False)
    router = session_config(bus, router=True)
    assert client.get_json("access_control/enabled") == "false"
    assert router.get_json("access_control/enabled") == "true"
    assert router.get_json("access_control/default_permission") == '"deny"'


# --- TLS, passwords and access control on a running rig ----------------------------------------


def make_certificates(directory: Path) -> Path:
    """A throwaway CA and a router certificate for 127.0.0.1/localhost; returns the directory."""
    openssl = shutil.which("openssl")
    if openssl is None:
        pytest.skip("openssl is not installed (needed to make a throwaway CA for the TLS test)")
    tls = directory / "tls"
    tls.mkdir()

    def run(*args: str) -> None:
        subprocess.run([openssl, *args], cwd=tls, check=True, capture_output=True, timeout=60)

    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem",
        "-days", "1", "-subj", "/CN=gazed test CA")  # fmt: skip
    run("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "router.key", "-out", "router.csr",
        "-subj", "/CN=router")  # fmt: skip
    (tls / "router.ext").write_text(
        "subjectAltName=IP:127.0.0.1,DNS:localhost\nbasicConstraints=CA:FALSE\n"
        "extendedKeyUsage=serverAuth,clientAuth\n"
    )
    run("x509", "-req", "-in", "router.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
        "-CAcreateserial", "-out", "router.pem", "-days", "1",
        "-extfile", "router.ext")  # fmt: skip
    return tls


def secured_rig(directory: Path, services: tuple[str, ...]) -> tuple[Path, dict[str, str]]:
    """The sim rig on a TLS endpoint, with per-process credentials and the shipped zenoh config
    (its certificate paths pointed at a throwaway CA), running only `services`."""
    tls = make_certificates(directory)
    zenoh_config = directory / "zenoh-rig.json5"
    zenoh_config.write_text(DEPLOY_CONFIG.read_text().replace("/etc/gazed/tls", str(tls)))
    credentials, passwords = write_credentials(directory, 2)
    rig_path = private_rig(REPO / "configs" / "sim.toml", directory, "oval", None, None, 4, None)
    document = tomlkit.parse(rig_path.read_text())
    bus = document["bus"]
    bus["listen"] = [str(bus["listen"][0]).replace("tcp/", "tls/")]
    bus["zenoh_config_path"] = str(zenoh_config)
    bus["credentials_path"] = str(credentials)
    for name in SERVICE_NAMES:
        document["services"].setdefault(name, tomlkit.table())["enabled"] = name in services
    rig_path.write_text(tomlkit.dumps(document))
    return rig_path, passwords


def stranger_bus(
    rig_path: Path, directory: Path, name: str, lines: str, ca: bool = True
) -> BusSection:
    """The rig's [bus] with other credentials (none if `lines` is empty), or without the CA."""
    document = tomlkit.parse(rig_path.read_text())
    bus = document["bus"]
    if lines:
        path = directory / f"{name}.credentials"
        path.write_text(lines)
        path.chmod(0o600)
        bus["credentials_path"] = str(path)
    else:
        del bus["credentials_path"]
    if not ca:
        config = Path(str(bus["zenoh_config_path"]))
        stripped = directory / f"{name}.json5"
        lines_kept = [line for line in config.read_text().splitlines() if "root_ca" not in line]
        stripped.write_text("\n".join(lines_kept))
        bus["zenoh_config_path"] = str(stripped)
    copy = directory / f"{name}.toml"
    copy.write_text(tomlkit.dumps(document))
    return load_rig(copy).bus


@pytest.mark.e2e
def test_a_stranger_cannot_steer_the_head(tmp_path: Path) -> None:
    rig_path, passwords = secured_rig(tmp_path, ("sim", "servo"))
    supervisor = RunningSupervisor(rig_path, tmp_path)
    rig = supervisor.rig
    observer = supervisor.bus
    try:
        supervisor.wait_ready(60.0)
        truth = observer.subscribe(SIM_TRUTH, capacity=100000)
        commands = observer.subscribe(SERVO_COMMAND, capacity=1000)
        odometry = observer.subscribe(SERVO_ODOMETRY, capacity=100000)
        markers = observer.subscribe(VISION_DETECTION, capacity=100)
        servo_health = observer.subscribe(health("servo"), capacity=100)
        alive: list[tuple[str, bool]] = []
        observer.watch_alive(lambda name, pid, up: alive.append((name, up)))
        first = poll_until(truth.latest, 20.0)

        # no CA, no credentials, a wrong password, an unknown user: none can join
        gaze_line = f"gaze:{passwords['gaze']}\n"
        strangers = [
            ("no-ca", gaze_line, False, "gaze"),
            ("no-credentials", "", True, "gaze"),
            ("wrong-password", "gaze:guess\n", True, "gaze"),
            ("unknown-user", "mallory:secret\n", True, "mallory"),
        ]
        for name, lines, ca, identity in strangers:
            bus = stranger_bus(rig_path, tmp_path, name, lines, ca)
            with pytest.raises(BusError, match="cannot reach the rig's bus"):
                open_session(bus, identity=identity).close()

        # a known identity that is not the gaze process: demands, odometry, a forged token
        with Bus(rig, "vision") as stranger:
            demands = stranger.publisher(GAZE_DEMAND)
            fake_odometry = stranger.publisher(SERVO_ODOMETRY)
            marker = stranger.publisher(VISION_DETECTION)
            poll_until(marker.matched, 10.0)
            token = stranger.session.liveliness().declare_token(
                alive_key(rig.name, "gaze", os.getpid())
            )
            for _ in range(20):
                demands.put(demand(STRANGER_PAN_RAD))
                fake_odometry.put(Odometry(t_capture_ns=1, pan_rad=1.234, tilt_rad=0.0))
            # what one session sends reaches the router in order: once this arrives, the
            # refused messages would have arrived too
            marker.put(Detection(t_capture_ns=7, seq=7, detector="marker", found=False,
                                 width_px=640, height_px=480))  # fmt: skip
            poll_until(markers.take, 10.0)
            sent_ns = time.time_ns()
            report = poll_until(lambda: newer_health(servo_health, sent_ns), 10.0)
            token.undeclare()
        assert report.counters["demands"] == 0
        assert commands.take() == []
        assert all(o.pan_rad != 1.234 for o in odometry.take())
        assert ("gaze", True) not in alive
        held = truth.take()
        # frames keep coming while we look (a loaded machine renders them slower)
        poll_until(lambda: held.extend(truth.take()) or len(held) > 10, 20.0)
        assert max(abs(t.head.pan_rad - first.head.pan_rad) for t in held) < 1e-3

        # the same demand from the gaze identity moves the head (the test can fail)
        with Bus(rig, "gaze") as gaze:
            demands = gaze.publisher(GAZE_DEMAND)
            poll_until(demands.matched, 10.0)

            def head_followed() -> bool:
                demands.put(demand(STRANGER_PAN_RAD))
                return any(t.head.pan_rad > 0.5 * STRANGER_PAN_RAD for t in truth.take())

            poll_until(head_followed, 15.0, 0.05)
        assert commands.take()
    finally:
        assert supervisor.stop() == 0


def demand(pan_rad: float) -> GazeDemand:
    return GazeDemand(t_capture_ns=time.time_ns(), kind="position", pan_rad=pan_rad, tilt_rad=0.0)


def newer_health(subscription: Subscription[Health], t_ns: int) -> Health | None:
    for report in subscription.take():
        if report.t_capture_ns > t_ns:
            return report
    return None
