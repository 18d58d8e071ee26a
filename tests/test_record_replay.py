"""`gazed replay` on a bus opened in the test: every message comes back on the rig's keys,
frames as raw pixels with their header; a cut file replays its first part, then exits 1
saying where the damage starts."""

from __future__ import annotations

import json
import threading
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh
from conftest import poll_until, write_rig
from test_record_mcap import frame_sample, odometry_sample, write_file

from gazed.bus import Stats, decode_sample
from gazed.cli import main
from gazed.config import load_rig
from gazed.session import open_session
from gazed.topics import SIM_FRAME


class Router:
    """The rig's bus, hosted by the test, counting what arrives on the rig's keys."""

    def __init__(self, rig_path: Path) -> None:
        self.rig = load_rig(rig_path)
        self.session = open_session(self.rig.bus, router=True)
        self.counts: Counter[str] = Counter()
        self.frames: list[object] = []
        self._lock = threading.Lock()
        self.session.declare_subscriber(
            f"gazed/{self.rig.name}/**", zenoh.handlers.Callback(self._on, indirect=False)
        )

    def _on(self, sample: zenoh.Sample) -> None:
        suffix = str(sample.key_expr).split("/", 2)[2]
        if suffix == SIM_FRAME.suffix:
            frame = decode_sample(SIM_FRAME, sample, Stats())
            with self._lock:
                self.frames.append(frame)
        with self._lock:
            self.counts[suffix] += 1

    def total(self) -> int:
        with self._lock:
            return sum(self.counts.values())


@pytest.fixture
def router(tmp_path: Path) -> Iterator[tuple[Path, Router]]:
    rig_path = write_rig(tmp_path)
    bus = Router(rig_path)
    yield rig_path, bus
    bus.session.close()


def test_replay_publishes_every_message_on_the_rig(
    router: tuple[Path, Router], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rig_path, bus = router
    samples = [odometry_sample(i) for i in range(20)] + [frame_sample(i) for i in range(3)]
    write_file(tmp_path / "run.mcap", samples)
    args = ["replay", str(tmp_path / "run.mcap"), "--rig", str(rig_path), "--rate", "100"]
    assert main([*args, "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report == {"published": {"servo/odometry": 20, "sim/frame": 3}, "skipped": {}}
    poll_until(lambda: bus.total() == 23, 5.0)
    assert bus.counts == {"servo/odometry": 20, "sim/frame": 3}
    assert [f.header.seq for f in bus.frames] == [0, 1, 2]  # type: ignore[attr-defined]


def test_a_cut_file_replays_its_first_part_and_exits_1(
    router: tuple[Path, Router], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rig_path, bus = router
    path = tmp_path / "run.mcap"
    write_file(path, [frame_sample(i % 7) for i in range(60)] + [odometry_sample(1)])
    whole = path.read_bytes()
    path.write_bytes(whole[: len(whole) * 2 // 3])
    assert main(["replay", str(path), "--rig", str(rig_path), "--rate", "1000"]) == 1
    error = capsys.readouterr().err
    assert "damaged from byte" in error
    good = int(error.split("after message ")[1].split()[0])
    assert 0 < good < 61
    poll_until(lambda: bus.total() == good, 5.0)


def test_replay_needs_a_rig(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_file(tmp_path / "run.mcap", [odometry_sample(0)])
    assert main(["replay", str(tmp_path / "run.mcap"), "--connect", "tcp/127.0.0.1:1"]) == 2
    assert "which rig" in capsys.readouterr().err


def test_record_into_a_missing_directory_is_an_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    output = tmp_path / "absent" / "run.mcap"
    assert main(["record", "--rig-name", "x", "-o", str(output), "--seconds", "0"]) == 2
    assert "no such directory" in capsys.readouterr().err
