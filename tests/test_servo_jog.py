"""`gazed servo jog`: one command to the head, every byte and every reply shown decoded."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from conftest import poll_until

from gazed.cli import main
from gazed.config import load_rig
from gazed.sim.head_emulator import HeadEmulator


def rig_file(tmp_path: Path, protocol: str, extra: str = "") -> Path:
    path = tmp_path / "rig.toml"
    path.write_text(
        f'[rig]\nname = "jog"\n[servo]\nprotocol = "{protocol}"\nport = "{tmp_path / "head"}"\n'
        f"baud = 115200\n{extra}\n[head]\npan_rate_max_deg_s = 600\npan_accel_max_deg_s2 = 6000\n"
    )
    return path


def jog(path: Path, *args: str, listen_ms: int = 200) -> int:
    return main(["servo", "jog", "--rig", str(path), "--listen-ms", str(listen_ms), *args])


def test_visca_move_shows_ack_and_completion(tmp_path: Path, capsys) -> None:
    path = rig_file(tmp_path, "visca")
    with HeadEmulator(load_rig(path)) as head:
        # the move takes ~0.1 s; the listen ends once its completion is heard, long before the
        # listen's bound, which only a head that never completes reaches
        started = time.monotonic()
        assert jog(path, "--pan-deg", "7.5", "--tilt-deg", "-3", listen_ms=10_000) == 0
        assert time.monotonic() - started < 10.0
        out = capsys.readouterr().out
        assert "-> 81 01 06 02 18 14 00 00 06 04 0f 0f 0d 08 ff" in out  # 100 and -40 units
        assert "<- 90 41 ff   ack socket 1" in out
        assert "<- 90 51 ff   completion socket 1 [async]" in out  # heard while listening
        poll_until(lambda: head.settled, timeout_s=5.0)
        assert jog(path, "--query") == 0
        out = capsys.readouterr().out
        assert "position pan 7.500 deg tilt -3.000 deg" in out
        assert "joint: pan 7.500 deg, tilt -3.000 deg" in out


def test_ptu_query_shows_the_ascii_exchange(tmp_path: Path, capsys) -> None:
    path = rig_file(tmp_path, "flir-ptu", "pan_arcsec_per_position = 92.5714")
    with HeadEmulator(load_rig(path)):
        assert jog(path, "--query") == 0
    out = capsys.readouterr().out
    assert "-> 'PP '" in out and "<- '* 0'   position pan 0.000 deg" in out
    assert "joint: tilt 0.000 deg" in out


def test_dynamixel_stop_reads_the_position_first(tmp_path: Path, capsys) -> None:
    path = rig_file(tmp_path, "dynamixel")
    with HeadEmulator(load_rig(path)):
        assert jog(path, "--stop") == 0
    out = capsys.readouterr().out
    sync_read, stop = "ff ff fd 00 fe 09 00 82 84 00 04 00 01 02", "ff ff fd 00 fe 11 00 83 74"
    assert out.index(sync_read) < out.index(stop)
    assert "(no reply expected)" in out


def test_pelco_without_feedback_says_so(tmp_path: Path, capsys) -> None:
    path = rig_file(tmp_path, "pelco-d", "position_feedback = false")
    with HeadEmulator(load_rig(path)):
        assert jog(path, "--query") == 1
    assert "cannot report its position" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--pan-deg", "200", "--tilt-deg", "0"), "outside [head] -170.0..170.0 deg"),
        (("--pan-deg", "10"), "go together"),
        (("--pan-deg", "nan", "--tilt-deg", "0"), "finite"),
    ],
)
def test_bad_angles_are_refused_before_anything_is_sent(
    tmp_path: Path, capsys, args, message
) -> None:
    path = rig_file(tmp_path, "pelco-d")
    assert jog(path, *args) == 2
    assert message in capsys.readouterr().out


def test_no_head_at_the_port(tmp_path: Path, capsys) -> None:
    path = rig_file(tmp_path, "pelco-d")
    started = time.monotonic()
    assert jog(path, "--query") == 1
    assert "failed: cannot open" in capsys.readouterr().out
    assert time.monotonic() - started < 5.0
