"""The messages of an MCAP recording in file order, up to any damage.

The file is read as a stream of records (`mcap.stream_reader`), so a truncated file (a killed
recorder writes no summary) or a corrupt chunk still yields every message before the damage;
then `DamagedRecording` says at which byte offset, after how many messages, the damage starts.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from mcap.reader import make_reader
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader


@dataclass(frozen=True)
class Recorded:
    """One recorded message: its key (channel topic), stamps and JSON bytes."""

    key: str
    schema_name: str  # "" for a channel without a schema
    log_time_ns: int
    publish_time_ns: int
    data: bytes


class DamagedRecording(Exception):
    """The file is damaged from `offset` on (bytes), after `messages` good messages."""

    def __init__(self, path: Path, offset: int, messages: int, reason: str) -> None:
        super().__init__(
            f"{path}: damaged from byte {offset} on, after message {messages} ({reason})"
        )
        self.offset = offset
        self.messages = messages


def read_recording(path: Path) -> Iterator[Recorded]:
    """Every message of the file in order; raises `DamagedRecording` where the file is damaged
    (after yielding everything before it)."""
    schemas: dict[int, str] = {0: ""}
    channels: dict[int, tuple[str, str]] = {}
    count = 0
    with path.open("rb") as stream:
        size = path.stat().st_size
        good_offset = 0
        records = StreamReader(stream, validate_crcs=True, record_size_limit=size).records
        while True:
            try:
                record = next(records)
            except StopIteration:
                return
            # any failure to decode a record (short read, bad CRC, bad compression, bad lengths)
            # is damage at the first byte not yet accounted for
            except Exception as exc:
                reason = f"{type(exc).__name__}: {exc}".splitlines()[0][:200]
                raise DamagedRecording(path, good_offset, count, reason) from exc
            good_offset = stream.tell()
            if isinstance(record, Schema):
                schemas[record.id] = record.name
            elif isinstance(record, Channel):
                channels[record.id] = (record.topic, schemas.get(record.schema_id, ""))
            elif isinstance(record, Message) and record.channel_id in channels:
                key, schema_name = channels[record.channel_id]
                count += 1
                yield Recorded(key, schema_name, record.log_time, record.publish_time, record.data)


def recording_span_s(path: Path) -> float | None:
    """Seconds from the first message's log time to the last's, from the file's summary; None
    when it has none (a file cut short) or cannot be read."""
    try:
        with path.open("rb") as stream:
            summary = make_reader(stream).get_summary()
    except Exception:  # a damaged file: the replay itself reports where
        return None
    if summary is None or summary.statistics is None:
        return None
    statistics = summary.statistics
    return (statistics.message_end_time - statistics.message_start_time) / 1e9
