"""What the bus tools share: the bus and rig to listen to (`--rig`, `--rig-name`, `--connect`),
and each sample decoded as far as it is one of gazed's messages."""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import zenoh

from gazed.config import BusSection, load_rig_or_exit
from gazed.messages import Message
from gazed.session import BusError, open_session
from gazed.topics import split_key, topic_for

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"


@dataclass(frozen=True)
class Target:
    """Which bus to join and which rig(s) to listen to."""

    bus: BusSection
    rig: str  # a rig name or "*"


def target_of(args: argparse.Namespace) -> Target:
    if args.rig is not None:
        rig = load_rig_or_exit(args.rig)
        bus = (
            rig.bus
            if not args.connect
            else BusSection(listen=[args.connect], connect=[args.connect])
        )
        return Target(bus, rig.name)
    endpoint = args.connect or DEFAULT_ENDPOINT
    return Target(BusSection(listen=[endpoint], connect=[endpoint]), args.rig_name or "*")


def common_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", type=Path, help="rig file: its [bus] endpoints and its name")
    parser.add_argument("--rig-name", help="listen to this rig only (without --rig: every rig)")
    parser.add_argument(
        "--connect", help=f"bus endpoint to join (default: the rig's, or {DEFAULT_ENDPOINT})"
    )
    parser.add_argument("--json", action="store_true", help="machine-readable output")


def _open(target: Target) -> zenoh.Session:
    try:
        return open_session(target.bus)
    except BusError as exc:
        raise SystemExit(f"gazed: no bus answers: {exc}\n(is `gazed run RIG` running?)") from exc


@dataclass
class Seen:
    """One sample as the tools see it."""

    key: str
    schema: str
    received_ns: int
    message: Message | None  # None: not one of gazed's schemas, or malformed
    raw: bytes
    attachment: bytes | None

    @property
    def age_ms(self) -> float | None:
        if self.message is None:
            return None
        return (self.received_ns - self.message.t_capture_ns) / 1e6


def _seen(sample: zenoh.Sample) -> Seen:
    key = str(sample.key_expr)
    _, _, schema = str(sample.encoding).partition(";")
    raw = sample.payload.to_bytes()
    attachment = sample.attachment.to_bytes() if sample.attachment is not None else None
    message: Message | None = None
    parts = split_key(key)
    topic = topic_for(parts[1]) if parts else None
    if topic is not None:
        try:
            body = attachment if topic.frames else raw
            if body is not None:
                message = topic.model.model_validate_json(body)
        except ValueError:
            message = None
    return Seen(key, schema, time.time_ns(), message, raw, attachment)


def listen(target: Target, key_expr: str, on_seen: Callable[[Seen], None]) -> zenoh.Session:
    session = _open(target)
    session.declare_subscriber(
        key_expr, zenoh.handlers.Callback(lambda s: on_seen(_seen(s)), indirect=True)
    )
    return session
