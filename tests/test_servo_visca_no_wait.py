"""The set-point writer and the zoom drive never wait for a VISCA socket: while a move and a zoom
hold both, each keeps its newest set-point, writes nothing and reads nothing that waits, and
writes that newest set-point as soon as a completion frees a socket; a pan-tilt set-point with
a fresh demand has the move it supersedes cancelled (Sony's `8x 2y FF`), or where that frees
nothing the zoom's command, rather than wait behind them; one held past the read timeout goes
to the driver (`RoomWait`); odometry inquiries use no socket and are answered at once. The
driver runs against the emulated camera on a clock of the test's own
(`test_servo_visca_sockets`), which moves only when something waits for a reply."""

from __future__ import annotations

import math

import pytest
from servo_link_support import Demands, demand
from test_servo_visca_sockets import LATENCY_S, Camera, H, driver_on_camera, rig_text

from gazed.config import parse_rig
from gazed.messages import GazeDemand
from gazed.servo.codec import CodecError
from gazed.servo.driver import ServoDriver
from gazed.servo.setpoint_writer import ROOM_RETRY_S, SetpointWriter
from gazed.servo.visca import ViscaCodec
from gazed.servo.zoom_drive import ZoomDrive

ZOOM_UNIT = 1 / 0x4000


def both_sockets_busy(driver: ServoDriver) -> None:
    """A long pan move (socket 1) and a zoom (socket 2), as in pursuit with the lens moving."""
    driver.set_position(math.radians(90.0), 0.0)
    driver.set_zoom(0.5)
    assert driver.codec.sockets_busy == {1, 2}


def the_zoom_completes(camera: Camera) -> None:
    """The camera's clock passes the zoom's taking effect; its completion waits to be read."""
    camera.t_s += 2 * LATENCY_S


class Writer:
    def __init__(self) -> None:
        self.driver, self.camera = driver_on_camera()
        self.demands = Demands()
        self.commands: list[GazeDemand] = []
        self.writer = SetpointWriter(
            parse_rig(rig_text()).head,
            self.driver,
            self.demands.take,
            lambda command, _t_ns: self.commands.append(command),
            command_period_s=0.02,
            command_timeout_s=0.3,
            t_s=self.camera.t_s,
        )
        self.writer.reset(0.0, 0.0, self.camera.t_s)

    def write(self, *demands: GazeDemand) -> None:
        self.demands.put(*demands)
        self.writer.take_demands(self.camera.t_s, executable=True)
        self.writer.write(self.camera.t_s)


def test_a_set_point_waits_for_no_socket_and_the_newest_demand_goes_out_when_one_frees() -> None:
    w = Writer()
    both_sockets_busy(w.driver)
    written, t_s = w.driver.counters["frames_written"], w.camera.t_s
    w.write(demand(5.0, 0.0))
    w.write(demand(6.0, 1.0))  # newer, still no socket
    assert w.driver.counters["frames_written"] == written  # nothing sent, nothing refused
    assert w.camera.t_s == t_s  # and nothing waited for a reply
    assert w.commands == [] and w.writer.counts["held_for_a_socket"] == 1
    assert t_s + ROOM_RETRY_S in w.writer.wake_times_s()  # it looks again soon
    the_zoom_completes(w.camera)
    w.write()
    assert [math.degrees(c.pan_rad) for c in w.commands] == [pytest.approx(6.0)]
    assert math.degrees(w.commands[0].tilt_rad) == pytest.approx(1.0)
    assert w.driver.counters["refused_as_busy"] == 0
    assert w.driver.counters["waits_for_room"] == 0


def test_a_zoom_waits_for_no_socket_and_its_newest_set_point_goes_out_when_one_frees() -> None:
    driver, camera = driver_on_camera()
    zoom = ZoomDrive(driver, rate_max_s=0.5)
    zoom.reset(0.0)
    zoom.demand(0.5)
    zoom.write(0.0)  # starts the slew, on a clock of its own
    both_sockets_busy(driver)
    written, t_s = driver.counters["frames_written"], camera.t_s
    zoom.write(0.1)  # 0.05 due, no socket
    assert driver.counters["frames_written"] == written and camera.t_s == t_s
    assert zoom.held_for_a_socket == 1 and zoom.writes == 0
    zoom.demand(0.02)  # the newest demand turns the lens back
    the_zoom_completes(camera)
    zoom.write(0.13)
    assert zoom.writes == 1 and zoom.setpoint == pytest.approx(0.035)
    while camera.line.mechanics.zoom.target_rad == 0.5:
        driver.query_position()  # the clock runs until the zoom takes effect
    assert camera.line.mechanics.zoom.target_rad == pytest.approx(0.035, abs=ZOOM_UNIT)
    assert driver.counters["waits_for_room"] == 0


def test_odometry_inquiries_take_no_socket_and_are_answered_while_both_are_busy() -> None:
    driver, _ = driver_on_camera()
    both_sockets_busy(driver)
    position = driver.query_position()
    assert position.pan_rad == pytest.approx(0.0, abs=math.radians(1.0))
    assert driver.query_zoom() == pytest.approx(0.0, abs=ZOOM_UNIT)
    assert driver.counters["waits_for_room"] == 0
    assert driver.codec.has_room(H("81 09 06 12 FF"))
    assert not driver.has_command_room()  # still both busy


def test_cancel_is_sonys_bytes_and_holds_follows_one_command_in_its_socket() -> None:
    codec = ViscaCodec()
    assert codec.encode_cancel(1) == [H("81 21 FF")]
    assert codec.encode_cancel(2) == [H("81 22 FF")]
    with pytest.raises(CodecError, match="socket 3"):
        codec.encode_cancel(3)
    codec.feed(H("90 42 FF"))
    zoom = codec.last_ack
    assert zoom is not None and codec.holds(zoom)
    codec.feed(H("90 52 FF 90 42 FF"))  # it completes; a move takes socket 2
    assert not codec.holds(zoom) and codec.holds(codec.last_ack)
    codec.feed(H("90 62 04 FF"))  # cancelled
    assert codec.sockets_busy == set()


def zoom_link() -> tuple[Writer, ZoomDrive]:
    """The writer and a zoom drive on one camera, wired as the link wires them."""
    w = Writer()
    zoom = ZoomDrive(w.driver, rate_max_s=0.5)
    zoom.reset(0.0)
    w.writer.make_room = zoom.yield_socket
    return w, zoom


def test_a_set_point_that_finds_a_move_and_a_zoom_executing_has_the_zoom_cancelled() -> None:
    w, zoom = zoom_link()
    w.driver.set_position(math.radians(90.0), 0.0)  # socket 1
    zoom.demand(0.5)
    zoom.write(0.0)
    zoom.write(0.1)  # 0.05 into socket 2
    assert zoom.writes == 1 and w.driver.codec.sockets_busy == {1, 2}
    w.write(demand(5.0, 0.0))
    # the zoom's command cancelled, the set-point written at once, the move in socket 1 superseded
    assert zoom.cancelled == 1 and len(w.commands) == 1
    assert w.writer.counts["held_for_a_socket"] == 0 and w.driver.counters["waits_for_room"] == 0
    assert w.driver.codec.sockets_busy == {2}
    zoom.write(0.11)  # the newest zoom set-point again, though no period has passed
    assert zoom.writes == 2 and w.driver.codec.sockets_busy == {1, 2}


def test_a_fresh_demand_cancels_the_move_it_supersedes_and_the_zoom_runs_on() -> None:
    w, zoom = zoom_link()
    w.write(demand(90.0, 0.0))  # the writer's own move, socket 1
    zoom.demand(0.5)
    zoom.write(0.0)
    zoom.write(0.1)  # socket 2
    assert w.driver.codec.sockets_busy == {1, 2}
    written = w.driver.counters["frames_written"]
    w.write(demand(5.0, 0.0))
    # the out-of-date move cancelled, the new set-point in its socket, the zoom left running
    assert w.writer.counts["superseded"] == 1 and zoom.cancelled == 0 and len(w.commands) == 2
    assert w.driver.counters["frames_written"] == written + 2  # Cancel, then the set-point
    assert w.writer.counts["held_for_a_socket"] == 0 and w.driver.counters["waits_for_room"] == 0
    assert w.driver.codec.sockets_busy == {1, 2}


def test_a_zoom_that_has_completed_is_not_cancelled() -> None:
    w, zoom = zoom_link()
    zoom.demand(0.5)
    zoom.write(0.0)
    zoom.write(0.1)
    w.camera.t_s += 2 * LATENCY_S  # the zoom completes
    w.driver.set_position(math.radians(90.0), 0.0)  # reads the completion, takes socket 1
    written = w.driver.counters["frames_written"]
    w.write(demand(5.0, 0.0))
    assert zoom.cancelled == 0 and len(w.commands) == 1
    assert w.driver.counters["frames_written"] == written + 1  # the set-point, no Cancel


def test_a_set_point_held_past_the_read_timeout_goes_to_the_driver() -> None:
    """Completions lost: the codec keeps both sockets busy though the camera has freed them."""
    w = Writer()
    both_sockets_busy(w.driver)
    w.write(demand(5.0, 0.0))
    assert w.writer.counts["held_for_a_socket"] == 1 and not w.commands
    w.driver.codec.sockets_busy.update({1, 2})  # as if the zoom's completion never came
    the_zoom_completes(w.camera)
    w.camera.line.service(w.camera.t_s)  # ... and it is lost
    w.camera.t_s += w.driver.timeout_s
    w.write()
    assert len(w.commands) == 1  # the driver waited for room, at most its read timeout
    assert w.driver.counters["waits_for_room"] == 1


def test_the_generators_own_set_points_wait_for_the_zoom_rather_than_cancel_it() -> None:
    w, zoom = zoom_link()
    w.write(demand(20.0, 0.0))  # a move under way: the generator has set-points to come
    zoom.demand(0.5)
    zoom.write(0.0)
    zoom.write(0.1)
    assert w.driver.codec.sockets_busy == {1, 2}
    w.writer.write(w.camera.t_s + 0.02)  # the next set-point, no fresh demand
    assert zoom.cancelled == 0 and w.writer.counts["held_for_a_socket"] == 1
    assert len(w.commands) == 1
