"""The live view without a rig: `[view]` and its password, what is drawn over a frame, the page's
state, and the server's WebSocket (frames only after the page acknowledges the last one, clicks
as `GazeSelect` with the frame's head pose, the buttons as `GazeCommand`, basic auth when the
rig has a password)."""

from __future__ import annotations

import asyncio
import base64
import json
import math
import socket
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from aiohttp import WSMsgType, web
from aiohttp.test_utils import TestClient, TestServer

from gazed.bus import BusError, Frame
from gazed.config import parse_rig
from gazed.config.view import ViewError, ViewSection
from gazed.geometry.camera import CameraModel
from gazed.geometry.kinematics import HeadKinematics
from gazed.messages import (
    Detection,
    EstimatorState,
    FrameHeader,
    GazeCommand,
    GazeDemand,
    GazeSelect,
    GazeState,
    HeadPose,
    Odometry,
    Track,
)
from gazed.plots.latency_hops import hop_latencies_ms
from gazed.view.bus_link import CONTRACT, ViewLink
from gazed.view.frame_feed import FrameFeed
from gazed.view.live_state import LiveState
from gazed.view.projection import ImageProjection
from gazed.view.server import ViewServer
from gazed.view.view_cli import _listen

T0 = 1_700_000_000_000_000_000


def projection() -> ImageProjection:
    camera = CameraModel.from_fov(640, 480, math.radians(60))
    return ImageProjection(camera, HeadKinematics("pan-tilt"), math.radians(6))


def track(id_: int, pan_rad: float, tilt_rad: float, **extra: Any) -> Track:
    return Track(
        id=id_, confirmed=True, pan_rad=pan_rad, tilt_rad=tilt_rad, age_s=1, hits=3, **extra
    )


# -- [view] ---------------------------------------------------------------------------------


def test_a_view_beyond_loopback_needs_a_password() -> None:
    with pytest.raises(Exception, match="beyond loopback"):
        parse_rig('[rig]\nname = "t"\n[view]\nhost = "0.0.0.0"\n')
    rig = parse_rig('[rig]\nname = "t"\n[view]\nhost = "0.0.0.0"\npassword_env = "GAZED_VIEW"\n')
    assert rig.serves_view and rig.view.password_env == "GAZED_VIEW"
    assert not parse_rig('[rig]\nname = "t"\n').serves_view
    assert parse_rig('[rig]\nname = "t"\n[view]\n').serves_view  # an empty [view]: defaults


def test_the_password_comes_from_a_private_file_or_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    secret = tmp_path / "view-password"
    secret.write_text("s3cret\n")
    secret.chmod(0o640)
    view = ViewSection(password_file=Path("view-password"))
    assert view.password(tmp_path) == "s3cret"
    secret.chmod(0o644)
    with pytest.raises(ViewError, match="open to every user"):
        view.password(tmp_path)
    monkeypatch.delenv("GAZED_VIEW_PW", raising=False)
    with pytest.raises(ViewError, match="not set"):
        ViewSection(password_env="GAZED_VIEW_PW").password(tmp_path)
    monkeypatch.setenv("GAZED_VIEW_PW", "pw")
    assert ViewSection(password_env="GAZED_VIEW_PW").password(tmp_path) == "pw"
    assert ViewSection().password(tmp_path) is None


# -- what is drawn --------------------------------------------------------------------------


def test_a_track_is_drawn_where_its_angles_appear_in_the_frame() -> None:
    p = projection()
    head = HeadPose(pan_rad=0.1, tilt_rad=-0.2)
    u, v = p.pixel(head, 0.1, -0.2)  # the head's own gaze: the principal point
    assert (u, v) == pytest.approx(p.centre_px, abs=1e-6)
    right, _ = p.pixel(head, 0.15, -0.2)  # more pan: to the right (u grows)
    _, below = p.pixel(head, 0.1, -0.25)  # less tilt: lower in the image (v grows)
    assert right > u + 10 and below > v + 10
    assert p.pixel(head, 0.1 + math.pi, -0.2) is None  # behind the camera
    assert p.fovea_px == pytest.approx(2 * 554.256 * math.tan(math.radians(3)), rel=1e-3)


def test_the_overlay_has_every_track_the_target_and_the_detection() -> None:
    state = LiveState(projection())
    head = HeadPose(pan_rad=0.0, tilt_rad=0.0)
    state.take(
        EstimatorState(
            t_capture_ns=T0,
            filter="imm",
            x=(0.0,),
            P=((1.0,),),
            target_id=7,
            tracks=(track(7, 0.05, 0.0), track(9, -0.05, 0.0)),
        )
    )
    state.take(
        Detection(
            t_capture_ns=T0,
            seq=3,
            detector="flow",
            found=True,
            u_px=100,
            v_px=50,
            width_px=640,
            height_px=480,
        )
    )
    overlay = state.overlay(head)
    assert [t["id"] for t in overlay["tracks"]] == [7, 9]
    assert overlay["target_id"] == 7
    assert overlay["tracks"][0]["u"] > 320 > overlay["tracks"][1]["u"]
    assert overlay["detection"] == {"found": True, "u": 100, "v": 50, "seq": 3}
    assert state.overlay(None)["tracks"] == []  # no pose: no projected tracks
    state.take(GazeState(t_capture_ns=T0, state="pursuit", reason="operator", target_id=9))
    assert state.overlay(head)["target_id"] == 9  # the gaze's choice wins


def test_the_snapshot_has_the_ground_tracks_models_and_latency_per_hop() -> None:
    state = LiveState(projection())
    cov = ((0.04, 0.01), (0.01, 0.09))
    state.take(
        EstimatorState(
            t_capture_ns=T0,
            filter="imm",
            x=(0.0,),
            P=((1.0,),),
            model_probabilities={"CSD": 0.7, "CS": 0.2, "CD": 0.1},
            most_likely="CSD",
            tracks=(track(1, 0, 0, ground_xy_m=(1.0, 2.0), ground_cov_m2=cov),),
        )
    )
    command = GazeDemand(
        t_capture_ns=T0,
        kind="pursuit",
        pan_rad=0,
        tilt_rad=0,
        stamps=(
            ("sim", T0 + 150_000_000),
            ("vision", T0 + 152_000_000),
            ("servo", T0 + 155_500_000),
        ),
    )
    state.take(command)
    snapshot = state.snapshot()
    assert snapshot["models"] == {"CSD": 0.7, "CS": 0.2, "CD": 0.1}
    assert snapshot["tracks"][0]["xy"] == (1.0, 2.0) and snapshot["tracks"][0]["cov"] == cov
    assert snapshot["latency_ms"] == pytest.approx({"sim": 150.0, "vision": 2.0, "servo": 3.5})
    assert hop_latencies_ms(command) == snapshot["latency_ms"]
    json.dumps(snapshot)  # the page's JSON


# -- the server -----------------------------------------------------------------------------


def frame(seq: int) -> Frame:
    header = FrameHeader(
        t_capture_ns=T0 + seq * 40_000_000, seq=seq, width=64, height=48, encoding="gray8"
    )
    return Frame(header, np.full((48, 64), seq % 255, np.uint8), T0)


def parts(data: bytes) -> tuple[dict[str, Any], bytes]:
    (length,) = struct.unpack(">I", data[:4])
    return json.loads(data[4 : 4 + length]), data[4 + length :]


async def next_of(ws: Any, kind: WSMsgType, timeout_s: float = 2.0) -> Any:
    """The next message of `kind` within `timeout_s` (others are skipped)."""

    async def receive() -> Any:
        while True:
            message = await ws.receive()
            if message.type == kind:
                return message.data

    return await asyncio.wait_for(receive(), timeout_s)


def serve(password: str | None = None) -> tuple[ViewServer, LiveState, FrameFeed, list[GazeSelect]]:
    state = LiveState(projection())
    for k in range(3):  # the head's odometry around the frames
        state.take(Odometry(t_capture_ns=T0 + k * 100_000_000, pan_rad=0.1, tilt_rad=0.2))
    feed = FrameFeed(jpeg_quality=80)
    published: list[GazeSelect] = []
    server = ViewServer(
        state,
        feed,
        published.append,
        COMMANDS.append,
        password=password,
        state_period_s=0.05,
        on_clients=lambda n: PAGES.append(n),
    )
    return server, state, feed, published


PAGES: list[int] = []  # the open pages as the server reported them
COMMANDS: list[GazeCommand] = []  # what the page's buttons published


def test_the_buttons_publish_the_operators_commands_and_nothing_else() -> None:
    async def answer(ws: Any, body: dict[str, Any]) -> dict[str, Any]:
        await ws.send_json(body)
        while (reply := json.loads(await next_of(ws, WSMsgType.TEXT)))["type"] != "commanded":
            pass
        return reply

    async def scenario() -> None:
        server, *_ = serve()
        async with TestClient(TestServer(server.app())) as client:
            ws = await client.ws_connect("/ws")
            for name in ("park", "resume", "hold", "search"):
                reply = await answer(ws, {"type": "command", "command": name})
                assert reply == {
                    "type": "commanded",
                    "ok": True,
                    "command": name,
                    "message": f"{name} sent",
                }
            for bad in ("trace", "stop", None, ["park"]):  # a trace is `gazed calibrate trace`'s
                reply = await answer(ws, {"type": "command", "command": bad})
                assert (
                    reply["ok"] is False
                    and "not one of park, search, hold, resume" in (reply["message"])
                )
            await ws.close()
        assert server.commands == 4

    COMMANDS.clear()
    asyncio.run(scenario())
    assert [c.command for c in COMMANDS] == ["park", "resume", "hold", "search"]
    assert len({c.request_id for c in COMMANDS}) == 4


def test_a_view_not_yet_on_the_bus_says_so_instead_of_closing_the_page() -> None:
    def refuse(_message: Any) -> None:
        raise BusError("the view is not on the bus yet")

    async def scenario() -> None:
        server = ViewServer(LiveState(projection()), FrameFeed(80), refuse, refuse)
        async with TestClient(TestServer(server.app())) as client:
            ws = await client.ws_connect("/ws")
            await ws.send_json({"type": "command", "command": "park"})
            await ws.send_json({"type": "select"})
            replies = {}
            while len(replies) < 2:
                reply = json.loads(await next_of(ws, WSMsgType.TEXT))
                if reply["type"] != "state":
                    replies[reply["type"]] = reply
            for reply in replies.values():
                assert reply["ok"] is False and reply["message"] == "the view is not on the bus yet"
            assert not ws.closed
            await ws.close()

    asyncio.run(scenario())


def test_frames_go_out_one_at_a_time_after_each_acknowledgement() -> None:
    async def scenario() -> None:
        server, _state, feed, published = serve()
        async with TestClient(TestServer(server.app())) as client:
            page = await client.get("/")
            assert page.status == 200 and "live view" in await page.text()
            assert (await client.get("/static/view.js")).status == 200
            ws = await client.ws_connect("/ws")
            feed.offer(frame(1))
            meta, jpeg = parts(await next_of(ws, WSMsgType.BINARY))
            assert meta["seq"] == 1 and jpeg[:2] == b"\xff\xd8"  # a JPEG
            assert meta["head"]["pan_rad"] == pytest.approx(0.1)
            feed.offer(frame(2))
            feed.offer(frame(3))
            with pytest.raises(TimeoutError):  # not acknowledged: nothing more is sent
                await next_of(ws, WSMsgType.BINARY, 0.3)
            await ws.send_json({"type": "ack", "seq": 1})
            meta, _ = parts(await next_of(ws, WSMsgType.BINARY))
            assert meta["seq"] == 3  # the newest; frame 2 was skipped
            assert server.frames_sent == 2 and feed.encoded == 2
            state = json.loads(await next_of(ws, WSMsgType.TEXT))
            assert state["type"] == "state"

            await ws.send_json({"type": "select", "seq": 3, "u": 10.5, "v": 20})
            answer = json.loads(await next_of(ws, WSMsgType.TEXT))
            while answer["type"] != "selected":
                answer = json.loads(await next_of(ws, WSMsgType.TEXT))
            assert answer["ok"] is True
            assert published[0].pixel_px == (10.5, 20.0)
            assert published[0].head is not None and published[0].head.tilt_rad == pytest.approx(
                0.2
            )
            await ws.send_json({"type": "select", "seq": 99, "u": 1, "v": 1})  # never sent
            answer = json.loads(await next_of(ws, WSMsgType.TEXT))
            while answer["type"] != "selected":
                answer = json.loads(await next_of(ws, WSMsgType.TEXT))
            assert answer["ok"] is False and len(published) == 1
            await ws.send_json({"type": "select"})  # back to the rig's rule
            while len(published) < 2:
                await next_of(ws, WSMsgType.TEXT)
            assert published[1].pixel_px is None and published[1].track_id is None
            await ws.close()

    PAGES.clear()
    asyncio.run(scenario())
    assert PAGES == [1, 0]  # the frames are wanted while the page is open


def test_with_a_password_every_request_needs_it() -> None:
    async def scenario() -> None:
        server, *_ = serve(password="pw")
        async with TestClient(TestServer(server.app())) as client:
            assert (await client.get("/")).status == 401
            wrong = base64.b64encode(b"op:nope").decode()
            assert (
                await client.get("/", headers={"Authorization": f"Basic {wrong}"})
            ).status == 401
            right = base64.b64encode(b"op:pw").decode()
            assert (
                await client.get("/", headers={"Authorization": f"Basic {right}"})
            ).status == 200
            assert (await client.get("/ws")).status == 401

    asyncio.run(scenario())


def test_a_taken_port_stops_gazed_view_but_not_a_supervised_view() -> None:
    async def scenario() -> None:
        with socket.socket() as taken:
            taken.bind(("127.0.0.1", 0))
            taken.listen()
            view = ViewSection(port=taken.getsockname()[1])
            runner = web.AppRunner(web.Application())
            await runner.setup()
            stop = asyncio.Event()
            with pytest.raises(OSError):
                await _listen(runner, view, stop, keep_trying=False)
            asyncio.get_running_loop().call_later(0.2, stop.set)
            assert await _listen(runner, view, stop, keep_trying=True) is False  # kept trying
            await runner.cleanup()

    asyncio.run(scenario())


class FakeSubscription:
    def __init__(self, topic: Any) -> None:
        self.topic = topic
        self.closed = False
        self.items: list[Any] = []

    def close(self) -> None:
        self.closed = True

    def take(self) -> list[Any]:
        items, self.items = self.items, []
        return items

    def latest(self) -> Any:
        items = self.take()
        return items[-1] if items else None


class FakePublisher:
    def __init__(self, sent: list[Any]) -> None:
        self.sent = sent

    def put(self, message: Any) -> None:
        self.sent.append(message)


class FakeBus:
    """What the view's link uses of its bus."""

    def __init__(self) -> None:
        self.subscriptions: list[FakeSubscription] = []
        self.published: dict[str, list[Any]] = {}  # by topic suffix

    def open(self) -> None:
        pass

    def on_arrival(self, notify: Any) -> None:
        pass

    def subscribe(self, topic: Any) -> FakeSubscription:
        self.subscriptions.append(FakeSubscription(topic))
        return self.subscriptions[-1]

    def publisher(self, topic: Any) -> FakePublisher:
        return FakePublisher(self.published.setdefault(topic.suffix, []))

    def declare_alive(self) -> None:
        pass

    def open_suffixes(self) -> list[str]:
        return sorted(s.topic.suffix for s in self.subscriptions if not s.closed)


def test_the_view_takes_frames_and_streams_off_the_bus_only_while_a_page_is_open() -> None:
    async def scenario() -> None:
        state, feed = LiveState(projection()), FrameFeed(80)
        link = ViewLink(parse_rig('[rig]\nname = "t"\n'), state, feed, asyncio.get_running_loop())
        bus = FakeBus()
        link.bus = bus  # type: ignore[assignment]
        await link.connect()
        assert bus.open_suffixes() == ["gaze/state"]  # no page: only the rare transitions
        link.watch(True)
        assert bus.open_suffixes() == sorted(t.suffix for t in CONTRACT.reads)
        frames = next(s for s in bus.subscriptions if s.topic.frames)
        frames.items.append(frame(4))
        link.drain()
        assert feed.newest is not None and feed.newest.frame.header.seq == 4
        frames.items.append(frame(5))
        link.watch(False)
        assert bus.open_suffixes() == ["gaze/state"] and frames.items == []  # let go

    asyncio.run(scenario())


def test_the_view_publishes_selections_and_commands_on_their_topics_once_on_the_bus() -> None:
    async def scenario() -> None:
        state, feed = LiveState(projection()), FrameFeed(80)
        link = ViewLink(parse_rig('[rig]\nname = "t"\n'), state, feed, asyncio.get_running_loop())
        command = GazeCommand(t_capture_ns=T0, command="hold", request_id="view-1")
        with pytest.raises(BusError, match="not on the bus yet"):
            link.publish_command(command)
        bus = FakeBus()
        link.bus = bus  # type: ignore[assignment]
        await link.connect()
        link.publish_command(command)
        link.publish_select(GazeSelect(t_capture_ns=T0, track_id=2))
        assert bus.published["gaze/command"] == [command]
        assert [s.track_id for s in bus.published["gaze/select"]] == [2]

    asyncio.run(scenario())
