"""The example rig of each real protocol loads, and its [servo] keys build that protocol's codec."""

from __future__ import annotations

import pytest
from conftest import REPO

from gazed.config import load_rig
from gazed.servo import make_codec


@pytest.mark.parametrize("protocol", ["pelco-d", "visca", "flir-ptu", "dynamixel"])
def test_example_rig(protocol: str) -> None:
    rig = load_rig(REPO / "configs" / f"{protocol}.toml")
    assert rig.servo.protocol == protocol
    codec = make_codec(rig.servo.protocol, **rig.servo_params())
    assert codec.protocol == protocol
    assert not rig.services.sim.enabled  # a real head: no simulated world
    assert rig.servo.port.startswith("/dev/")
