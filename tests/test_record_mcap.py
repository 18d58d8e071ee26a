"""MCAP recordings: what `gazed record` writes opens with the `mcap` reader, frames round-trip
through JPEG, a damaged file yields its good part and says where the damage starts, and a
full queue drops rather than blocks the bus."""

from __future__ import annotations

import io
import json
import threading
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from gazed.messages import FrameHeader, Odometry
from gazed.record import frame_image
from gazed.record.mcap_reader import DamagedRecording, read_recording
from gazed.record.mcap_writer import McapRecording, QueuedRecorder, Sample

RIG = "rec"
T0_NS = 1_700_000_000_000_000_000


def odometry_sample(i: int) -> Sample:
    message = Odometry(t_capture_ns=T0_NS + i * 10_000_000, pan_rad=0.01 * i, tilt_rad=-0.02)
    return Sample(f"gazed/{RIG}/servo/odometry", message.to_json(), None, T0_NS + i * 10_000_500)


def frame_pixels(seed: int, shape: tuple[int, ...] = (48, 64, 3)) -> np.ndarray:
    """A smooth image (JPEG keeps it closely) with a seed-dependent offset."""
    v, u = np.mgrid[0 : shape[0], 0 : shape[1]]
    base = (u * 3 + v * 2 + seed * 7) % 200 + 20
    return np.broadcast_to(base[..., None] if len(shape) == 3 else base, shape).astype(np.uint8)


def frame_sample(i: int, encoding: str = "bgr8") -> Sample:
    shape = (48, 64) if encoding == "gray8" else (48, 64, 3)
    header = FrameHeader(
        t_capture_ns=T0_NS + i * 33_000_000, seq=i, width=64, height=48, encoding=encoding
    )
    pixels = frame_pixels(i, shape)
    return Sample(f"gazed/{RIG}/sim/frame", pixels.tobytes(), header.to_json(), T0_NS + i)


def write_file(path: Path, samples: list[Sample]) -> McapRecording:
    with path.open("wb") as stream:
        recording = McapRecording(stream)
        for sample in samples:
            recording.write(sample)
        recording.close()
    return recording


def test_recording_opens_with_the_mcap_reader(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    samples = [odometry_sample(i) for i in range(30)] + [frame_sample(i) for i in range(5)]
    write_file(path, samples)
    with path.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        topics = {c.id: c.topic for c in summary.channels.values()}
        counts = {topics[i]: n for i, n in summary.statistics.channel_message_counts.items()}
        assert counts == {f"gazed/{RIG}/servo/odometry": 30, f"gazed/{RIG}/sim/frame": 5}
        assert {c.message_encoding for c in summary.channels.values()} == {"json"}
        schemas = {s.name: s for s in summary.schemas.values()}
        assert set(schemas) == {Odometry.schema_id(), "foxglove.CompressedImage"}
        assert {s.encoding for s in schemas.values()} == {"jsonschema"}
        assert json.loads(schemas[Odometry.schema_id()].data) == Odometry.model_json_schema()
        assert json.loads(schemas["foxglove.CompressedImage"].data) == frame_image.SCHEMA
        messages = list(reader.iter_messages(topics=[f"gazed/{RIG}/servo/odometry"]))
    first = Odometry.model_validate_json(messages[0][2].data)
    assert first == Odometry.model_validate_json(samples[0].payload)
    assert messages[3][2].publish_time == T0_NS + 3 * 10_000_000  # t_capture_ns
    assert messages[3][2].log_time == samples[3].received_ns  # the receive time


@pytest.mark.parametrize("encoding", ["bgr8", "rgb8", "gray8"])
def test_frames_round_trip_through_jpeg(encoding: str) -> None:
    sample = frame_sample(3, encoding)
    header = FrameHeader.model_validate_json(sample.attachment or b"")
    pixels = np.frombuffer(sample.payload, dtype=np.uint8).reshape(header.shape)
    data = frame_image.encode_frame(header, pixels)
    message = json.loads(data)
    assert message["format"] == "jpeg"
    assert message["timestamp"] == {"sec": T0_NS // 10**9, "nsec": header.t_capture_ns % 10**9}
    decoded_header, decoded = frame_image.decode_frame(data)
    assert decoded_header == header
    assert decoded.shape == pixels.shape and decoded.dtype == np.uint8
    assert np.abs(decoded.astype(int) - pixels.astype(int)).mean() < 2.0


def test_malformed_samples_are_counted_not_written(tmp_path: Path) -> None:
    bad = Sample(f"gazed/{RIG}/servo/odometry", b'{"pan_rad": "x"}', None, T0_NS)
    headless = Sample(f"gazed/{RIG}/sim/frame", b"\0" * 10, None, T0_NS)
    recording = write_file(tmp_path / "bad.mcap", [bad, headless, odometry_sample(1)])
    assert recording.written == {f"gazed/{RIG}/servo/odometry": 1}
    assert sum(recording.malformed.values()) == 2
    assert [r.key for r in read_recording(tmp_path / "bad.mcap")] == [bad.key]


def test_a_cut_file_yields_its_first_part_and_says_where_it_breaks(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    # noisy frames do not compress: many small chunks
    samples = []
    rng = np.random.default_rng(0)
    for i in range(40):
        header = FrameHeader(t_capture_ns=T0_NS + i, seq=i, width=64, height=48)
        pixels = rng.integers(0, 255, (48, 64, 3), dtype=np.uint8)
        samples.append(Sample(f"gazed/{RIG}/sim/frame", pixels.tobytes(), header.to_json(), i))
        samples.append(odometry_sample(i))
    write_file(path, samples)
    whole = path.read_bytes()
    cut = len(whole) // 2
    path.write_bytes(whole[:cut])
    seen = []
    with pytest.raises(DamagedRecording) as damage:
        seen.extend(read_recording(path))
    assert 0 < len(seen) < len(samples)
    assert [r.log_time_ns for r in seen] == [s.received_ns for s in samples[: len(seen)]]
    assert damage.value.messages == len(seen)
    assert 0 < damage.value.offset <= cut
    assert f"byte {damage.value.offset}" in str(damage.value)


def test_a_file_that_is_not_mcap_is_damaged_from_byte_0(tmp_path: Path) -> None:
    path = tmp_path / "junk.mcap"
    path.write_bytes(b"not an mcap file at all")
    with pytest.raises(DamagedRecording) as damage:
        list(read_recording(path))
    assert (damage.value.offset, damage.value.messages) == (0, 0)


class GatedRecording(McapRecording):
    """Writes only once `gate` is set, as a writer held up by a slow disk."""

    def __init__(self, stream: io.BytesIO, gate: threading.Event) -> None:
        super().__init__(stream)
        self.gate = gate

    def write(self, sample: Sample) -> bool:
        self.gate.wait()
        return super().write(sample)


def test_a_full_queue_drops_and_counts_without_blocking() -> None:
    gate = threading.Event()
    recorder = QueuedRecorder(GatedRecording(io.BytesIO(), gate), capacity=5)
    for i in range(20):  # the writer holds one, the queue five: the rest are dropped
        recorder.offer(odometry_sample(i))
    gate.set()
    recorder.close()
    key = f"gazed/{RIG}/servo/odometry"
    assert recorder.dropped[key] + recorder.recording.written[key] == 20
    assert recorder.dropped[key] >= 14
