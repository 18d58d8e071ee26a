"""The bus: typed pub/sub between real processes, frames, malformed payloads counted, liveliness,
and sessions that announce nothing and listen only where the rig says."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
import zenoh
from conftest import PYTHON, SUPPORT, child_env, poll_until, write_rig

from gazed.bus import Bus, BusError
from gazed.config import BusSection, load_rig
from gazed.messages import Detection, FrameHeader, Odometry
from gazed.session import session_config
from gazed.topics import SERVO_ODOMETRY, SIM_FRAME, VISION_DETECTION
from gazed.wakeup import Wakeup


@pytest.fixture
def rig(tmp_path: Path):
    return load_rig(write_rig(tmp_path))


def detection(seq: int) -> Detection:
    return Detection(
        t_capture_ns=seq + 1, seq=seq, detector="t", found=True, width_px=64, height_px=48
    )


@pytest.mark.e2e
def test_pub_sub_between_two_processes(tmp_path: Path) -> None:
    path = write_rig(tmp_path)
    rig = load_rig(path)
    count = 200
    with Bus(rig, "test", router=True) as bus:
        detections = bus.subscribe(VISION_DETECTION)
        child = subprocess.run(
            [
                PYTHON,
                str(SUPPORT / "publisher_process.py"),
                "--rig",
                str(path),
                "--count",
                str(count),
            ],
            env=child_env(),
            timeout=60,
            capture_output=True,
            text=True,
        )
        assert child.returncode == 0, child.stderr
        received: list[Detection] = []
        poll_until(lambda: received.extend(detections.take()) or len(received) >= count, 10.0)
    assert [d.seq for d in received] == list(range(count))
    assert all(d.stamps[0][0] == "vision" and d.stamps[0][1] >= d.t_capture_ns for d in received)
    assert received[7].u_px == 7.0 and received[7].v_px == 14.0


def test_malformed_payload_is_counted_not_raised(rig) -> None:
    with Bus(rig, "test", router=True) as bus, Bus(rig, "peer") as peer:
        detections = bus.subscribe(VISION_DETECTION)
        key = VISION_DETECTION.key(rig.name)
        publisher = peer.publisher(VISION_DETECTION)
        poll_until(publisher.matched, 5.0)
        peer.session.put(key, b"{not json", encoding=zenoh.Encoding("application/json"))
        peer.session.put(
            key, b'{"t_capture_ns": 1, "seq": -1}', encoding=zenoh.Encoding("application/json")
        )
        peer.session.put(
            key,
            Odometry(t_capture_ns=1, pan_rad=0, tilt_rad=0).to_json(),
            encoding=zenoh.Encoding("application/json").with_schema("gazed.Odometry/2"),
        )
        publisher.put(detection(5))
        got = poll_until(detections.take, 5.0)
        counters, received = bus.stats.snapshot()
    assert [d.seq for d in got] == [5]
    assert counters["malformed"] == 3
    assert counters["malformed:vision/detection"] == 3
    assert received == {"vision/detection": 1}


def test_publisher_refuses_the_wrong_model(rig) -> None:
    with Bus(rig, "test", router=True) as bus:
        publisher = bus.publisher(VISION_DETECTION)
        with pytest.raises(TypeError):
            publisher.put(Odometry(t_capture_ns=1, pan_rad=0, tilt_rad=0))


def test_frames_keep_only_the_newest(rig) -> None:
    with Bus(rig, "test", router=True) as bus, Bus(rig, "sim") as sim:
        frames = bus.subscribe(SIM_FRAME)
        publisher = sim.publisher(SIM_FRAME)
        poll_until(publisher.matched, 5.0)
        rng = np.random.default_rng(1)
        images = [rng.integers(0, 256, (48, 64, 3), dtype=np.uint8) for _ in range(5)]
        for seq, image in enumerate(images):  # one at a time: frames are dropped under congestion
            publisher.put_frame(
                FrameHeader(t_capture_ns=seq + 1, seq=seq, width=64, height=48), image
            )
            poll_until(lambda n=seq + 1: bus.stats.snapshot()[1].get("sim/frame", 0) == n, 5.0)
        frame = frames.latest()
        assert frames.latest() is None
        assert bus.stats.snapshot()[0]["replaced"] == 4
    assert frame.header.seq == 4
    np.testing.assert_array_equal(frame.pixels, images[4])


def test_frame_with_lying_header_is_dropped(rig) -> None:
    with Bus(rig, "test", router=True) as bus, Bus(rig, "sim") as sim:
        frames = bus.subscribe(SIM_FRAME)
        publisher = sim.publisher(SIM_FRAME)
        poll_until(publisher.matched, 5.0)
        header = FrameHeader(t_capture_ns=1, seq=0, width=64, height=48)
        sim.session.put(SIM_FRAME.key(rig.name), b"\0" * 100, attachment=header.to_json())
        sim.session.put(SIM_FRAME.key(rig.name), b"\0" * header.nbytes)  # no header at all
        publisher.put_frame(header.model_copy(update={"seq": 1}), np.zeros((48, 64, 3), np.uint8))
        frame = poll_until(frames.latest, 5.0)
        counters, _ = bus.stats.snapshot()
    assert frame.header.seq == 1
    assert counters["malformed:sim/frame"] == 2


def test_liveliness_appears_and_vanishes(rig) -> None:
    events: list[tuple[str, int, bool]] = []
    with Bus(rig, "supervisor", router=True) as bus:
        bus.watch_alive(lambda name, pid, alive: events.append((name, pid, alive)))
        with Bus(rig, "vision") as vision:
            vision.declare_alive()
            poll_until(lambda: ("vision", os.getpid(), True) in events, 5.0)
            assert bus.alive() == {"vision"}
        poll_until(lambda: ("vision", os.getpid(), False) in events, 5.0)
        assert bus.alive() == set()


@pytest.mark.parametrize("suffix", ["alive/vision", "alive/vision/first", "alive/vision/7/8"])
def test_a_token_without_a_pid_is_dropped_and_counted(rig, suffix: str, caplog) -> None:
    events: list[tuple[str, int, bool]] = []
    with Bus(rig, "supervisor", router=True) as bus:
        bus.watch_alive(lambda name, pid, alive: events.append((name, pid, alive)))
        with Bus(rig, "vision") as vision:
            token = vision.session.liveliness().declare_token(f"gazed/{rig.name}/{suffix}")
            vision.declare_alive()  # after the other: once it is seen, so was that
            poll_until(lambda: events, 5.0)
            counters, _ = bus.stats.snapshot()
            assert bus.alive() == {"vision"}  # the other is present, and not a process
            token.undeclare()
    assert set(events) <= {("vision", os.getpid(), True), ("vision", os.getpid(), False)}
    assert counters["malformed:alive"] == 1
    assert bus.stats.last_malformed == f"alive: not a liveliness key: gazed/{rig.name}/{suffix}"
    assert [r.message for r in caplog.records if r.name == "gazed.bus"] == [
        f"ignoring liveliness tokens such as gazed/{rig.name}/{suffix}: not alive/<process>/<pid>"
    ]


def test_an_arrival_wakes_the_owner(rig) -> None:
    with (
        Bus(rig, "test", router=True) as bus,
        Bus(rig, "servo") as servo,
        Wakeup() as wakeup,
    ):
        bus.on_arrival(wakeup.notify)
        odometry = bus.subscribe(SERVO_ODOMETRY)
        publisher = servo.publisher(SERVO_ODOMETRY)
        poll_until(publisher.matched, 5.0)
        assert wakeup.wait(0.0) is False or odometry.take() == []
        publisher.put(Odometry(t_capture_ns=1, pan_rad=0.25, tilt_rad=0))
        assert wakeup.wait(5.0) is True
        assert [o.pan_rad for o in odometry.take()] == [0.25]


def test_an_immediate_sample_first_offers_the_owner_a_step(rig) -> None:
    """`on_arrival(notify, step_now)`: a sample of an immediate subscription calls `step_now`
    and wakes the owner only when that could not step; any other sample, a liveliness change
    and `Bus.notify()` wake the owner."""
    calls: list[str] = []
    can_step = [True]

    def step_now() -> bool:
        calls.append("step")
        return can_step[0]

    with Bus(rig, "test", router=True) as bus, Bus(rig, "vision") as vision:
        bus.on_arrival(lambda: calls.append("notify"), step_now)
        detections = bus.subscribe(VISION_DETECTION, immediate=True)
        odometry = bus.subscribe(SERVO_ODOMETRY)
        publishers = vision.publisher(VISION_DETECTION), vision.publisher(SERVO_ODOMETRY)
        poll_until(lambda: all(p.matched() for p in publishers), 5.0)
        publishers[0].put(detection(0))
        poll_until(lambda: calls == ["step"], 5.0)
        can_step[0] = False
        publishers[0].put(detection(1))
        poll_until(lambda: calls == ["step", "step", "notify"], 5.0)
        publishers[1].put(Odometry(t_capture_ns=1, pan_rad=0.0, tilt_rad=0.0))
        poll_until(lambda: len(calls) == 4, 5.0)
        bus.notify()
        assert calls == ["step", "step", "notify", "notify", "notify"]
        assert [d.seq for d in detections.take()] == [0, 1] and len(odometry.take()) == 1


def test_the_bus_records_what_its_process_subscribes_and_publishes(rig) -> None:
    with Bus(rig, "test", router=True) as bus:
        bus.subscribe(SERVO_ODOMETRY)
        bus.subscribe(SIM_FRAME, immediate=True)
        bus.publisher(VISION_DETECTION)
        bus.subscribe(SERVO_ODOMETRY, capacity=4)
        assert bus.subscribes == {"servo/odometry", "sim/frame"}
        assert bus.publishes == {"vision/detection"}


def test_client_without_router_is_a_clear_error(tmp_path: Path) -> None:
    rig = load_rig(write_rig(tmp_path))
    with (
        pytest.raises(BusError, match=r"cannot reach the rig's bus at tcp/127\.0\.0\.1:"),
        Bus(rig, "vision"),
    ):
        pass


def test_sessions_do_not_scout_and_clients_do_not_listen(tmp_path: Path) -> None:
    """Nothing scouts by multicast. On a private loopback bus the rig's processes are peers
    listening on loopback alone (a port of the system's choosing), gossiping through the router;
    tools are clients that do not listen. With credentials, a zenoh config, peer_links off or
    an endpoint beyond loopback, every process is a client of the router."""
    bus = BusSection()
    router = session_config(bus, router=True)
    process = session_config(bus, router=False, identity="estimator")
    tool = session_config(bus, router=False)
    for config in (router, process, tool):
        assert json.loads(config.get_json("scouting/multicast/enabled")) is False
    assert json.loads(router.get_json("mode")) == "router"
    assert json.loads(router.get_json("listen/endpoints")) == ["tcp/127.0.0.1:7447"]
    assert json.loads(router.get_json("scouting/gossip/enabled")) is True
    assert json.loads(router.get_json("scouting/delay")) == 0  # opens without waiting
    assert json.loads(process.get_json("mode")) == "peer"
    assert json.loads(process.get_json("listen/endpoints")) == ["tcp/127.0.0.1:0"]
    assert json.loads(process.get_json("connect/endpoints")) == ["tcp/127.0.0.1:7447"]
    assert json.loads(process.get_json("scouting/gossip/enabled")) is True
    assert json.loads(tool.get_json("mode")) == "client"
    assert json.loads(tool.get_json("listen/endpoints")) == []
    assert json.loads(tool.get_json("connect/endpoints")) == ["tcp/127.0.0.1:7447"]
    assert json.loads(tool.get_json("scouting/gossip/enabled")) is False
    credentials, zenoh_config = tmp_path / "credentials", tmp_path / "zenoh.json5"
    credentials.write_text("estimator:secret\n")
    credentials.chmod(0o600)
    zenoh_config.write_text("{}\n")
    for private in (
        BusSection(peer_links=False),
        BusSection(listen=["tcp/0.0.0.0:7447"]),  # the router open beyond loopback
        BusSection(listen=["tcp/192.168.1.2:7447"]),
        BusSection(router=False, connect=["tcp/127.0.0.1:7447"]),  # a router elsewhere
        BusSection(credentials_path=credentials),
        BusSection(zenoh_config_path=zenoh_config),
    ):
        assert not private.direct
        client = session_config(private, router=False, identity="estimator")
        assert json.loads(client.get_json("mode")) == "client"
        assert json.loads(client.get_json("listen/endpoints")) == []
        assert json.loads(client.get_json("scouting/gossip/enabled")) is False
    assert BusSection(listen=["tcp/[::1]:7447"]).peer_listen == "tcp/[::1]:0"


def test_unspecified_listen_address_connects_over_loopback() -> None:
    bus = BusSection(listen=["tcp/0.0.0.0:7447"])
    assert bus.client_endpoints == ["tcp/127.0.0.1:7447"]
