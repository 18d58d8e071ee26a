"""A zoom set-point held for a VISCA socket past the driver's read timeout goes to the driver: a
completion lost on the way leaves the codec counting a socket busy that the camera has freed,
and without the timeout the pan-tilt takes the one socket left and cancels every zoom that
gets into it, so the lens never moves again. The driver runs against the emulated camera on a
clock of the test's own (`test_servo_visca_sockets`)."""

from __future__ import annotations

import math

from servo_link_support import demand
from test_servo_visca_no_wait import Writer

from gazed.servo.zoom_drive import ZoomDrive


def lost_completion(w: Writer) -> None:
    """A move in socket 2 completes at the camera, its completion lost: the codec still counts
    the socket busy."""
    w.driver.set_position(math.radians(1.0), 0.0)
    w.driver.set_position(math.radians(2.0), 0.0)  # both sockets, as the codec sees them
    w.camera.t_s += 1.0  # the move long done
    w.camera.line.service(w.camera.t_s)  # the camera frees both ...
    assert w.driver.has_command_room()  # (the completions read)
    w.driver.codec.sockets_busy.update({1, 2})  # ... and the codec never hears of it


def test_a_zoom_held_past_the_read_timeout_goes_to_the_driver_and_the_lens_moves() -> None:
    w = Writer()
    zoom = ZoomDrive(w.driver, rate_max_s=0.5)
    zoom.reset(0.0)
    w.writer.make_room = zoom.yield_socket
    lost_completion(w)
    zoom.demand(0.5)
    zoom.write(0.0)
    zoom.write(0.1)  # 0.05 due, no socket as the codec sees it
    assert zoom.held_for_a_socket == 1 and zoom.writes == 0
    zoom.write(0.1 + w.driver.timeout_s / 2)
    assert zoom.writes == 0  # within the read timeout it still waits
    zoom.write(0.1 + w.driver.timeout_s)
    assert zoom.writes == 1  # the driver waited for room, at most its read timeout
    assert w.driver.counters["room_waits_expired"] == 1
    w.write(demand(5.0, 0.0))  # the pan-tilt finds the socket left, the zoom runs on
    assert zoom.cancelled == 0 and len(w.commands) == 1
    while w.camera.line.mechanics.zoom.target_rad == 0.0:
        w.driver.query_position()  # the clock runs until the zoom takes effect
    assert w.camera.line.mechanics.zoom.target_rad > 0.0


def test_a_zoom_that_waits_for_a_socket_briefly_is_held_not_forced() -> None:
    w = Writer()
    zoom = ZoomDrive(w.driver, rate_max_s=0.5)
    zoom.reset(0.0)
    zoom.demand(0.5)
    zoom.write(0.0)
    w.driver.set_position(math.radians(90.0), 0.0)
    w.driver.set_zoom(0.2)  # both sockets busy, for real
    zoom.write(0.1)
    zoom.write(0.1 + w.driver.timeout_s * 0.9)
    assert zoom.writes == 0 and zoom.held_for_a_socket == 2
    assert w.driver.counters["waits_for_room"] == 0
    zoom.demand(0.0)  # nothing due any more: the wait ends
    zoom.reset(0.0)
    zoom.write(0.1 + w.driver.timeout_s * 2)
    assert zoom.writes == 0 and w.driver.counters["waits_for_room"] == 0
