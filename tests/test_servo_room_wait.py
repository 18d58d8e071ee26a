"""`RoomWait`, the one rule the set-point writer and the zoom drive share: a command held for a
socket past the driver's read timeout is taken to have lost its completion, and goes to the
driver; behind a head that is not a serial driver a hold never expires."""

from __future__ import annotations

from gazed.servo.driver import RoomWait, ServoDriver
from gazed.servo.visca import ViscaCodec


class NoLine:
    """A transport that is never opened: the rule reads only the driver's timeout."""


def test_a_hold_starts_once_expires_at_the_read_timeout_and_ends() -> None:
    driver = ServoDriver(ViscaCodec(), NoLine(), timeout_s=0.25)  # type: ignore[arg-type]
    room = RoomWait(driver)
    assert not room.holding and not room.expired(10.0)  # nothing waits: nothing expires
    assert room.hold(1.0)  # the hold starts ...
    assert not room.hold(1.1)  # ... once: a later step keeps its start
    assert room.holding and room.since_s == 1.0
    assert not room.expired(1.0 + 0.249)
    assert room.expired(1.0 + 0.25)
    room.end()
    assert not room.holding and not room.expired(5.0)
    assert room.hold(5.0) and not room.expired(5.1)  # a new hold runs from its own start


def test_a_hold_behind_a_head_without_a_serial_driver_never_expires() -> None:
    room = RoomWait(object())
    assert room.hold(0.0)
    assert room.holding and not room.expired(1e9)
