"""`gazed replay run.mcap --rig RIG [--rate 1.0]`: a recording published back on a rig's bus.

Each message goes out on its recorded key, moved to the rig's name (`gazed/<rig>/<suffix>`),
with its topic's encoding, at its recorded time relative to the first message divided by
`--rate`. Frames are decoded from JPEG back to raw pixels with their header attachment.
"""

from __future__ import annotations

import argparse
import json
import socket
import sys
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

import zenoh
from tqdm import tqdm

from gazed.bus import JSON, OCTETS
from gazed.bustools.listen import common_arguments, target_of
from gazed.config import load_rig_or_exit
from gazed.messages import FrameHeader
from gazed.record import frame_image
from gazed.record.mcap_reader import (
    DamagedRecording,
    Recorded,
    read_recording,
    recording_span_s,
)
from gazed.record.stopping import stop_on_signals
from gazed.session import BusError, open_session
from gazed.topics import PREFIX, split_key, topic_for

# How long replay waits for a subscriber before it starts (nobody may be listening).
SUBSCRIBERS_WAIT_S = 1.0


def replay_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", type=Path, help="an MCAP file written by `gazed record`")
    common_arguments(parser)
    parser.add_argument(
        "--rate", type=float, default=1.0, help="speed relative to the recording (default 1.0)"
    )
    parser.add_argument(
        "--reprocess",
        action="store_true",
        help="feed the recorded frames and odometry to fresh vision, estimator and gaze with the "
        "rig's settings (on a private bus) and compare their decisions with the recorded ones",
    )


def replay_command(args: argparse.Namespace) -> int:
    if args.rate <= 0:
        print("gazed replay: --rate must be > 0", file=sys.stderr)
        return 2
    if not args.recording.is_file():
        print(f"gazed replay: {args.recording}: no such file", file=sys.stderr)
        return 2
    if args.reprocess:
        return _reprocess(args)
    target = target_of(args)
    if target.rig == "*":
        print("gazed replay: which rig? give --rig RIG or --rig-name NAME", file=sys.stderr)
        return 2
    try:
        session = open_session(target.bus)
    except BusError as exc:
        print(f"gazed replay: no bus answers: {exc}", file=sys.stderr)
        return 1
    with stop_on_signals() as stop, progress(args.recording, "replay", args.json) as bar:
        replayer = Replayer(session, target.rig, args.rate, stop)
        try:
            for recorded in read_recording(args.recording):
                if not replayer.publish(recorded):
                    break
                bar.update(replayer.position_s - bar.n)
        except DamagedRecording as exc:
            print(f"gazed replay: {exc}", file=sys.stderr)
            return 1
        finally:
            session.close()
            if args.json:
                print(json.dumps({"published": replayer.published, "skipped": replayer.skipped}))
            else:
                print(replayer.summary(), file=sys.stderr)
    return 0


def progress(recording: Path, what: str, quiet: bool) -> tqdm:
    """A progress bar on the terminal over the recording's seconds (with the time left when the
    file's summary gives its length); silent when stderr is not a terminal or with --json."""
    span_s = recording_span_s(recording)
    return tqdm(
        total=span_s,
        desc=f"{what} {recording.name}",
        unit="s",
        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} s [{elapsed}<{remaining}]"
        if span_s
        else "{desc}: {n:.1f} s [{elapsed}]",
        disable=quiet or not sys.stderr.isatty(),
        leave=False,
    )


def _reprocess(args: argparse.Namespace) -> int:
    from gazed.record.reprocess import reprocess

    if args.rig is None:
        print("gazed replay --reprocess: give --rig RIG (its settings are used)", file=sys.stderr)
        return 2
    load_rig_or_exit(args.rig)
    with socket.socket() as probe:  # a free loopback port for the private bus
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    with stop_on_signals() as stop:
        try:
            with progress(args.recording, "reprocess", args.json) as bar:
                report = reprocess(args.recording, args.rig, args.rate, stop, port, bar)
        except RuntimeError as exc:
            print(f"gazed replay --reprocess: {exc}", file=sys.stderr)
            return 1
    print(json.dumps(report, indent=None if args.json else 2))
    if "damage" in report:
        print(f"gazed replay: {report['damage']}", file=sys.stderr)
        return 1
    return 0


class Replayer:
    """Publishes recorded messages on `rig`'s keys at their recorded pace. With `retime`, every
    time in them (`t_capture_ns`, the other `*_ns` fields, the stamps) moves by the time since
    the recording, so that processes that judge a message by its age take it as live."""

    def __init__(
        self,
        session: zenoh.Session,
        rig: str,
        rate: float,
        stop: threading.Event,
        *,
        retime: bool = False,
    ):
        self._session = session
        self._rig = rig
        self._rate = rate
        self._stop = stop
        self._retime = retime
        self.shift_ns = 0
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._start: tuple[int, float] | None = None  # (first log time ns, monotonic s)
        self.position_s = 0.0  # recorded time of the last message published, from the first
        self.published: Counter[str] = Counter()
        self.skipped: Counter[str] = Counter()

    def publish(self, recorded: Recorded) -> bool:
        """Wait for the message's time, then publish it; False once stopped."""
        if self._start is None:
            self._await_subscribers(recorded.key)
            self._start = (recorded.log_time_ns, time.monotonic())
            self.shift_ns = time.time_ns() - recorded.log_time_ns if self._retime else 0
        first_ns, started_s = self._start
        self.position_s = (recorded.log_time_ns - first_ns) / 1e9
        due_s = started_s + (recorded.log_time_ns - first_ns) / 1e9 / self._rate
        if self._stop.wait(max(0.0, due_s - time.monotonic())):
            return False
        parts = split_key(recorded.key)
        if parts is None:
            self.skipped[recorded.key] += 1
            return True
        suffix = parts[1]
        topic = topic_for(suffix)
        if topic is not None and topic.frames:
            try:
                header, pixels = frame_image.decode_frame(recorded.data)
            except (ValueError, KeyError) as exc:
                self.skipped[f"{suffix}: {exc}"] += 1
                return True
            header = FrameHeader.model_validate(self._shifted(header.model_dump()))
            self._publisher(suffix).put(pixels.tobytes(), attachment=header.to_json())
        elif self.shift_ns:
            try:
                body = json.loads(recorded.data)
            except ValueError:
                self.skipped[f"{suffix}: not JSON"] += 1
                return True
            self._publisher(suffix).put(json.dumps(self._shifted(body)).encode())
        else:
            self._publisher(suffix).put(recorded.data)
        self.published[suffix] += 1
        return True

    def _shifted(self, body: Any) -> Any:
        """A message's JSON with its times moved by `shift_ns` (as is without `retime`)."""
        if not self.shift_ns or not isinstance(body, dict):
            return body
        moved = {
            k: v + self.shift_ns if k.endswith("_ns") and isinstance(v, int) and v > 0 else v
            for k, v in body.items()
        }
        if isinstance(body.get("stamps"), list):
            moved["stamps"] = [[stage, t + self.shift_ns] for stage, t in body["stamps"]]
        return moved

    def _await_subscribers(self, key: str) -> None:
        """Wait (at most `SUBSCRIBERS_WAIT_S`) until the bus has told this new session of a
        subscriber to the first key: a message published before that is not sent at all."""
        parts = split_key(key)
        if parts is None:
            return
        publisher = self._publisher(parts[1])
        matched = threading.Event()
        listener = publisher.declare_matching_listener(
            lambda status: matched.set() if status.matching else None
        )
        if not publisher.matching_status.matching:
            matched.wait(SUBSCRIBERS_WAIT_S)
        listener.undeclare()

    def summary(self) -> str:
        total = sum(self.published.values())
        lines = [f"gazed replay: {total} messages published on gazed/{self._rig}/"]
        lines += [f"  {suffix}: {n}" for suffix, n in sorted(self.published.items())]
        lines += [f"  skipped {key}: {n}" for key, n in sorted(self.skipped.items())]
        return "\n".join(lines)

    def _publisher(self, suffix: str) -> zenoh.Publisher:
        if suffix not in self._publishers:
            topic = topic_for(suffix)
            encoding = zenoh.Encoding(OCTETS if topic and topic.frames else JSON)
            if topic is not None:
                encoding = encoding.with_schema(topic.model.schema_id())
            # a replay keeps every message, frames included: it waits rather than drops
            self._publishers[suffix] = self._session.declare_publisher(
                f"{PREFIX}/{self._rig}/{suffix}",
                encoding=encoding,
                congestion_control=zenoh.CongestionControl.BLOCK,
            )
        return self._publishers[suffix]
