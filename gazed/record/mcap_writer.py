"""Bus samples into an MCAP file: one channel per key, JSON messages with their JSON Schema.

A key's channel is named after the key and carries the payload's JSON as it was published
(message encoding `json`), with the topic's model's JSON Schema (`gazed.topics.topic_for`);
frames are stored as Foxglove's `CompressedImage` (`gazed.record.frame_image`). The log time
is when the sample arrived, the publish time the message's `t_capture_ns`.

`QueuedRecorder` keeps the bus's receive thread free: offering a sample only appends it to a
bounded queue (a full queue drops the sample and counts it); a thread encodes and writes.
"""

from __future__ import annotations

import functools
import json
import queue
import threading
import time
from collections import Counter
from dataclasses import dataclass
from typing import IO

import numpy as np
from mcap.writer import CompressionType, Writer

from gazed.messages import FrameHeader, Message
from gazed.record import frame_image
from gazed.topics import split_key, topic_for

# A chunk is written (and survives a crash) once this many bytes are buffered: small, so a
# damaged or truncated file loses little.
CHUNK_SIZE_BYTES = 64 * 1024
# The file is flushed at least this often, so a killed recorder leaves what it wrote.
FLUSH_INTERVAL_S = 1.0
PROFILE = "gazed"


@dataclass(frozen=True)
class Sample:
    """One sample as it came off the bus."""

    key: str
    payload: bytes
    attachment: bytes | None
    received_ns: int


class McapRecording:
    """Writes samples into an open binary stream as MCAP; `close()` writes the summary."""

    def __init__(self, stream: IO[bytes]) -> None:
        self._stream = stream
        self._writer = Writer(stream, chunk_size=CHUNK_SIZE_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="gazed")
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._sequence: Counter[str] = Counter()
        self.written: Counter[str] = Counter()
        self.malformed: Counter[str] = Counter()

    def write(self, sample: Sample) -> bool:
        """Encode and write one sample; False (counted in `malformed`) if it cannot be."""
        try:
            data, t_capture_ns, schema = _encode(sample)
        except (ValueError, KeyError, TypeError) as exc:
            self.malformed[f"{sample.key}: {str(exc).splitlines()[0]}"[:200]] += 1
            return False
        channel = self._channel(sample.key, schema)
        self._writer.add_message(
            channel,
            log_time=sample.received_ns,
            data=data,
            publish_time=t_capture_ns,
            sequence=self._sequence[sample.key],
        )
        self._sequence[sample.key] += 1
        self.written[sample.key] += 1
        return True

    def flush(self) -> None:
        self._stream.flush()

    def close(self) -> None:
        self._writer.finish()
        self._stream.flush()

    def _channel(self, key: str, schema: tuple[str, bytes] | None) -> int:
        if key not in self._channels:
            schema_id = 0
            if schema is not None:
                name, text = schema
                if name not in self._schemas:
                    self._schemas[name] = self._writer.register_schema(
                        name=name, encoding="jsonschema", data=text
                    )
                schema_id = self._schemas[name]
            self._channels[key] = self._writer.register_channel(
                topic=key, message_encoding="json", schema_id=schema_id
            )
        return self._channels[key]


def _encode(sample: Sample) -> tuple[bytes, int, tuple[str, bytes] | None]:
    """The message's bytes, its capture time and its schema (name, text); None: no schema."""
    parts = split_key(sample.key)
    topic = topic_for(parts[1]) if parts else None
    if topic is not None and topic.frames:
        if sample.attachment is None:
            raise ValueError("frame without header attachment")
        header = FrameHeader.model_validate_json(sample.attachment)
        if len(sample.payload) != header.nbytes:
            raise ValueError(f"frame has {len(sample.payload)} bytes, header says {header.nbytes}")
        pixels = np.frombuffer(sample.payload, dtype=np.uint8).reshape(header.shape)
        schema = (frame_image.SCHEMA_NAME, json.dumps(frame_image.SCHEMA).encode())
        return frame_image.encode_frame(header, pixels), header.t_capture_ns, schema
    if topic is not None:
        message = topic.model.model_validate_json(sample.payload)
        return sample.payload, message.t_capture_ns, _json_schema(topic.model)
    body = json.loads(sample.payload)  # not one of gazed's keys: kept if it is JSON
    stamp = body.get("t_capture_ns") if isinstance(body, dict) else None
    return sample.payload, stamp if isinstance(stamp, int) else sample.received_ns, None


@functools.cache
def _json_schema(model: type[Message]) -> tuple[str, bytes]:
    """A model's schema name and JSON Schema text, generated once per model."""
    return model.schema_id(), json.dumps(model.model_json_schema()).encode()


class QueuedRecorder:
    """`offer()` from the bus's receive thread queues; a writer thread writes to `recording`."""

    def __init__(self, recording: McapRecording, capacity: int = 4096) -> None:
        self.recording = recording
        self.dropped: Counter[str] = Counter()
        self._queue: queue.Queue[Sample | None] = queue.Queue(maxsize=capacity)
        self._thread = threading.Thread(target=self._run, name="mcap-writer", daemon=True)
        self._thread.start()

    def offer(self, sample: Sample) -> None:
        """Queue a sample without waiting; a full queue drops it (counted in `dropped`)."""
        try:
            self._queue.put_nowait(sample)
        except queue.Full:
            self.dropped[sample.key] += 1

    def close(self) -> None:
        """Write what is queued, then the file's summary."""
        self._queue.put(None)
        self._thread.join()
        self.recording.close()

    def _run(self) -> None:
        flushed = time.monotonic()
        while True:
            try:
                sample = self._queue.get(timeout=FLUSH_INTERVAL_S)
            except queue.Empty:
                self.recording.flush()
                flushed = time.monotonic()
                continue
            if sample is None:
                return
            self.recording.write(sample)
            if time.monotonic() - flushed >= FLUSH_INTERVAL_S:
                self.recording.flush()
                flushed = time.monotonic()
