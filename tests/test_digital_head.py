"""The digital head (`[servo] protocol = "digital"`) behind the servo's head link, on a virtual
clock: never outside `[head]`'s limits, its rate limited, its latency honoured, its odometry the
model's exact pose."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

from servo_link_support import HEAD_SECTION, Demands, demand

from gazed import cli
from gazed.config import parse_rig
from gazed.servo.head_link import HeadLink

STEP_S = 0.005
LATENCY_MS = 80.0


@dataclass
class Instant:
    mono_s: float
    immediate: bool = False

    @property
    def wall_ns(self) -> int:
        return round(self.mono_s * 1e9)


def digital_link():
    rig = parse_rig(
        f"""
[rig]
name = "digital"
[servo]
protocol = "digital"
latency_ms = {LATENCY_MS}
odometry_rate_hz = 200
command_timeout_ms = 10000
{HEAD_SECTION}"""
    )
    clock = Instant(0.0)
    demands = Demands()
    link = HeadLink(
        rig,
        demands.take,
        lambda *_: None,
        mono_s=lambda: clock.mono_s,
        wall_ns=lambda: clock.wall_ns,
        sleep=lambda s: setattr(clock, "mono_s", clock.mono_s + s),
    )
    return rig, clock, demands, link


def run(link: HeadLink, clock: Instant, until_s: float) -> list:
    readings = []
    while clock.mono_s < until_s:
        result = link.step(clock)
        if result.odometry is not None:
            readings.append(result.odometry)
        clock.mono_s += STEP_S
    return readings


def test_digital_head_moves_within_limits_and_rates_after_its_latency():
    rig, clock, demands, link = digital_link()
    readings = run(link, clock, 0.2)
    assert link.link == "connected"
    park_pan = rig.head.park_rad[0]
    assert all(math.isclose(r.pan_rad, park_pan, abs_tol=1e-9) for r in readings)
    t_demand_s = clock.mono_s
    demands.put(demand(170.0, -90.0))  # far past both limits
    readings = run(link, clock, t_demand_s + 2.0)
    moved = [r for r in readings if abs(r.pan_rad - park_pan) > 1e-6]
    assert moved[0].t_ns / 1e9 >= t_demand_s + LATENCY_MS / 1e3 - STEP_S
    (pan_lo, pan_hi), (tilt_lo, tilt_hi) = rig.head.pan_limits_rad, rig.head.tilt_limits_rad
    assert all(pan_lo - 1e-9 <= r.pan_rad <= pan_hi + 1e-9 for r in readings)
    assert all(tilt_lo - 1e-9 <= r.tilt_rad <= tilt_hi + 1e-9 for r in readings)
    assert math.isclose(readings[-1].pan_rad, pan_hi, abs_tol=1e-6)
    assert math.isclose(readings[-1].tilt_rad, tilt_lo, abs_tol=1e-6)
    pan_rate_max, tilt_rate_max = rig.head.rate_max_rad_s
    for a, b in itertools.pairwise(readings):
        dt_s = (b.t_ns - a.t_ns) / 1e9
        assert abs(b.pan_rad - a.pan_rad) <= pan_rate_max * dt_s * 1.001 + 1e-9
        assert abs(b.tilt_rad - a.tilt_rad) <= tilt_rate_max * dt_s * 1.001 + 1e-9


def test_digital_odometry_is_the_models_exact_pose():
    _, clock, demands, link = digital_link()
    run(link, clock, 0.1)
    demands.put(demand(30.0, 10.0))
    readings = run(link, clock, 0.5)
    model = link.driver.mechanics
    for reading in readings[-20:]:
        pose = model.pose_at(reading.t_ns / 1e9)
        assert math.isclose(reading.pan_rad, pose.pan_rad, abs_tol=1e-12)
        assert math.isclose(reading.tilt_rad, pose.tilt_rad, abs_tol=1e-12)


def test_digital_head_parks_on_close():
    rig, clock, demands, link = digital_link()
    run(link, clock, 0.1)
    demands.put(demand(40.0, 10.0))
    run(link, clock, 1.5)
    link.close()
    pose = link.driver.mechanics.pose_at(clock.mono_s + 1.0)
    assert math.isclose(pose.pan_rad, rig.head.park_rad[0], abs_tol=1e-3)


def test_jog_refuses_the_digital_head(tmp_path, capsys):
    rig_path = tmp_path / "rig.toml"
    rig_path.write_text(f'[rig]\nname = "d"\n[servo]\nprotocol = "digital"\n{HEAD_SECTION}')
    assert cli.main(["servo", "jog", "--rig", str(rig_path), "--query"]) == 2
    assert "no serial port" in capsys.readouterr().out


def test_digital_link_reports_its_health_like_any_head():
    _, clock, _, link = digital_link()
    run(link, clock, 0.1)
    counters = link.counters()
    assert counters["odometry"] > 0 and counters["errors"] == 0
    assert not any(k.startswith("link_") for k in counters)  # no link of its own to count
    assert link.notes()["link"] == "connected"
