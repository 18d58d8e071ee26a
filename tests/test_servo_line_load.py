"""How full the serial line is (`gazed.servo.line_load`): once a period the share of it the line
carried bytes; a full line counted each period and warned about once as it turns full; a link
without a baud rate has no load."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import pytest

from gazed.servo.line_load import LINE_LOAD_WARN, LineLoadMeter


@dataclass
class FakeLine:
    url: str = "/dev/ttyUSB0"
    baud: int = 9600
    byte_time_s: float = 10 / 9600
    line_s: float = 0.0


def test_no_load_before_a_period_then_the_share_of_it_on_the_line() -> None:
    line, meter = FakeLine(), LineLoadMeter(period_s=1.0)
    meter.reset(10.0, line)
    line.line_s = 0.3
    meter.measure(10.5, line)
    assert meter.load is None
    line.line_s = 0.5
    meter.measure(11.25, line)
    assert meter.load == pytest.approx(0.5 / 1.25)
    line.line_s = 0.7
    meter.measure(12.25, line)  # from the last measurement on
    assert meter.load == pytest.approx(0.2)
    assert meter.overloaded_s == 0


def test_a_full_line_is_counted_each_period_and_warned_about_as_it_turns_full(
    caplog: pytest.LogCaptureFixture,
) -> None:
    line, meter = FakeLine(), LineLoadMeter(period_s=1.0)
    meter.reset(0.0, line)
    with caplog.at_level(logging.WARNING, logger="gazed.servo"):
        for second in range(1, 4):
            line.line_s += 1.0
            meter.measure(float(second), line)
    assert meter.load == pytest.approx(1.0) and meter.load > LINE_LOAD_WARN
    assert meter.overloaded_s == 3
    warnings = [r.getMessage() for r in caplog.records]
    assert len(warnings) == 1
    assert "/dev/ttyUSB0 at 9600 baud was 100% busy over the last second" in warnings[0]
    # it empties, then fills again: a second warning
    with caplog.at_level(logging.WARNING, logger="gazed.servo"):
        meter.measure(4.0, line)
        line.line_s += 1.0
        meter.measure(5.0, line)
    assert meter.overloaded_s == 4
    assert len(caplog.records) == 2


def test_a_link_without_a_baud_rate_has_no_load() -> None:
    line, meter = FakeLine(byte_time_s=0.0), LineLoadMeter(period_s=1.0)
    meter.reset(0.0, line)
    meter.measure(2.0, line)
    assert meter.load is None and meter.overloaded_s == 0


def test_reset_forgets_the_load() -> None:
    line, meter = FakeLine(), LineLoadMeter(period_s=1.0)
    meter.reset(0.0, line)
    line.line_s = 0.5
    meter.measure(1.0, line)
    assert meter.load == pytest.approx(0.5)
    meter.reset(1.0, line)
    assert meter.load is None
