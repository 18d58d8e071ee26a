"""The zenoh bus: one process's session, typed publish/subscribe, liveliness.

Sessions (`gazed.session`): the supervisor's router, the rig's processes as its clients or
peers, the tools as clients, each with its own identity.

Subscriptions decode and validate each sample as it arrives (in zenoh's receive thread, so no
hidden queue builds up behind a slow process) into a bounded deque; frame topics keep only the
newest frame. A payload that fails validation is dropped and counted, never raised. A sample
then tells the bus's owner (`on_arrival`): it wakes the owner's loop, or, on an `immediate`
subscription, first offers the owner to step right away in the receive thread.

The bus records the topics its process subscribes and publishes (`subscribes`, `publishes`):
each process reports them in its health, and a test checks them against `gazed.topics`.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import time
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np
import zenoh
from pydantic import ValidationError

from gazed.config import Rig
from gazed.messages import FrameHeader, Message
from gazed.session import BusError, identity_of, is_peer, open_session
from gazed.topics import Topic, alive_key, split_alive_key

log = logging.getLogger("gazed.bus")

M = TypeVar("M", bound=Message)

JSON = "application/json"
OCTETS = "application/octet-stream"


@dataclass(frozen=True)
class Frame:
    """A frame as received: its header (stamps, size, encoding), pixels, and when it arrived
    (wall clock ns, taken as the bus delivered it)."""

    header: FrameHeader
    pixels: np.ndarray
    t_received_ns: int


class Stats:
    """Counters of one process's bus traffic (thread-safe)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.counters: Counter[str] = Counter()
        self.received: Counter[str] = Counter()
        self.last_malformed: str | None = None

    def count(self, name: str, n: int = 1) -> None:
        with self._lock:
            self.counters[name] += n

    def malformed(self, where: str, why: str) -> bool:
        """Count a dropped message at `where` (a key suffix) and keep why; True for the first
        at `where`."""
        with self._lock:
            self.counters["malformed"] += 1
            self.counters[f"malformed:{where}"] += 1
            self.last_malformed = f"{where}: {why}"
            return self.counters[f"malformed:{where}"] == 1

    def receive(self, suffix: str) -> None:
        with self._lock:
            self.received[suffix] += 1

    def snapshot(self) -> tuple[dict[str, int], dict[str, int]]:
        with self._lock:
            return dict(self.counters), dict(self.received)


class Subscription(Generic[M]):
    """Messages of one topic, decoded and validated as they arrive.

    `take()` returns everything received since the last call (oldest first, at most `capacity`:
    older ones are dropped and counted); frame topics keep only the newest.
    """

    def __init__(self, bus: Bus, topic: Topic, capacity: int, immediate: bool = False) -> None:
        self.topic = topic
        self.immediate = immediate
        self._bus = bus
        self._items: deque[Any] = deque(maxlen=1 if topic.frames else capacity)
        self._subscriber = bus.session.declare_subscriber(
            topic.key(bus.rig.name), zenoh.handlers.Callback(self._on_sample, indirect=False)
        )

    def _on_sample(self, sample: zenoh.Sample) -> None:
        if sample.kind != zenoh.SampleKind.PUT:
            return
        item = decode_sample(self.topic, sample, self._bus.stats)
        if item is None:
            return
        if len(self._items) == self._items.maxlen:
            self._bus.stats.count("replaced" if self.topic.frames else "dropped")
        self._items.append(item)
        self._bus.stats.receive(self.topic.suffix)
        self._bus._arrived(self.immediate)

    def take(self) -> list[Any]:
        items = []
        while self._items:
            items.append(self._items.popleft())
        return items

    def latest(self) -> Any | None:
        """The newest item, discarding older ones; None if nothing arrived since the last call."""
        items = self.take()
        return items[-1] if items else None

    def close(self) -> None:
        self._subscriber.undeclare()


def decode_sample(topic: Topic, sample: zenoh.Sample, stats: Stats) -> Any | None:
    """A sample's payload as its topic's model (or `Frame`); None, counted, if malformed."""
    try:
        if topic.frames:
            return _decode_frame(topic, sample)
        _check_schema(str(sample.encoding), topic.model)
        return topic.model.model_validate_json(sample.payload.to_bytes())
    except (ValidationError, ValueError) as exc:
        stats.malformed(topic.suffix, str(exc).splitlines()[0])
        return None


def _check_schema(encoding: str, model: type[Message]) -> None:
    _, _, schema = encoding.partition(";")
    if schema and schema != model.schema_id():
        raise ValueError(f"schema {schema!r}, expected {model.schema_id()!r}")


def _decode_frame(topic: Topic, sample: zenoh.Sample) -> Frame:
    if sample.attachment is None:
        raise ValueError("frame without header attachment")
    header = topic.model.model_validate_json(sample.attachment.to_bytes())
    assert isinstance(header, FrameHeader)
    data = sample.payload.to_bytes()
    if len(data) != header.nbytes:
        raise ValueError(f"frame has {len(data)} bytes, header says {header.nbytes}")
    pixels = np.frombuffer(data, dtype=np.uint8).reshape(header.shape)
    return Frame(header, pixels, time.time_ns())


class Publisher(Generic[M]):
    """Publishes one topic's messages, checking each is of the topic's model."""

    def __init__(self, bus: Bus, topic: Topic) -> None:
        self.topic = topic
        encoding = zenoh.Encoding(OCTETS if topic.frames else JSON).with_schema(
            topic.model.schema_id()
        )
        self._publisher = bus.session.declare_publisher(
            topic.key(bus.rig.name),
            encoding=encoding,
            # a late frame is worth nothing, a lost demand or detection is worth a lot
            congestion_control=zenoh.CongestionControl.DROP
            if topic.frames
            else zenoh.CongestionControl.BLOCK,
            express=True,
        )

    def put(self, message: M) -> None:
        if not isinstance(message, self.topic.model) or self.topic.frames:
            raise TypeError(
                f"{self.topic.suffix} carries {self.topic.model.__name__}, "
                f"not {type(message).__name__}"
            )
        self._publisher.put(message.to_json())

    def put_frame(self, header: FrameHeader, pixels: np.ndarray) -> None:
        if not self.topic.frames:
            raise TypeError(f"{self.topic.suffix} is not a frame topic")
        if pixels.dtype != np.uint8 or pixels.shape != header.shape:
            raise ValueError(
                f"pixels {pixels.dtype}{pixels.shape} do not match header {header.shape}"
            )
        self._publisher.put(np.ascontiguousarray(pixels).tobytes(), attachment=header.to_json())

    def matched(self) -> bool:
        """True when at least one subscriber matches this key."""
        return bool(self._publisher.matching_status.matching)

    def close(self) -> None:
        self._publisher.undeclare()


class Bus:
    """One process's session on the rig's bus; use as a context manager.

    >>> with Bus(rig, "vision") as bus:
    ...     detections = bus.publisher(VISION_DETECTION)
    ...     odometry = bus.subscribe(SERVO_ODOMETRY)
    ...     bus.declare_alive()
    """

    def __init__(self, rig: Rig, process: str, *, router: bool = False) -> None:
        self.rig = rig
        self.process = process
        self.router = router
        self.stats = Stats()
        self.subscribes: set[str] = set()  # key suffixes subscribed
        self.publishes: set[str] = set()  # key suffixes with a declared publisher
        self._session: zenoh.Session | None = None
        self._closables: list[Any] = []
        self._notify: Callable[[], None] | None = None
        self._step_now: Callable[[], bool] | None = None

    def __enter__(self) -> Bus:
        self.open()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def open(self) -> None:
        if self._session is None:
            self._session = open_session(
                self.rig.bus, router=self.router, identity=identity_of(self.process)
            )

    def close(self) -> None:
        for item in reversed(self._closables):
            with contextlib.suppress(zenoh.ZError):
                item.undeclare() if hasattr(item, "undeclare") else item.close()
        self._closables.clear()
        if self._session is not None:
            self._session.close()
            self._session = None

    @property
    def session(self) -> zenoh.Session:
        if self._session is None:
            raise BusError("the bus session is not open (use `with Bus(...)`)")
        return self._session

    def publisher(self, topic: Topic) -> Publisher[Any]:
        publisher: Publisher[Any] = Publisher(self, topic)
        self._closables.append(publisher)
        self.publishes.add(topic.suffix)
        return publisher

    def subscribe(
        self, topic: Topic, *, capacity: int = 256, immediate: bool = False
    ) -> Subscription[Any]:
        """Messages of `topic` as they arrive (see `Subscription`); with `immediate`, each
        sample first offers the owner's `step_now` (see `on_arrival`)."""
        subscription: Subscription[Any] = Subscription(self, topic, capacity, immediate)
        self._closables.append(subscription)
        self.subscribes.add(topic.suffix)
        return subscription

    def on_arrival(
        self, notify: Callable[[], None], step_now: Callable[[], bool] | None = None
    ) -> None:
        """What a sample (or a liveliness change) does once it is kept: call `notify()`, which
        wakes the owner's loop (`gazed.wakeup.Wakeup.notify`). A sample of an `immediate`
        subscription first calls `step_now()` in the receive thread, and wakes the loop only
        if that returns False (it could not step)."""
        self._notify, self._step_now = notify, step_now

    def notify(self) -> None:
        """Wake the owner's loop (the `notify` given to `on_arrival`) with news that came
        another way, such as a camera's frame; safe from any thread."""
        if self._notify is not None:
            self._notify()

    def _arrived(self, immediate: bool) -> None:
        if not (immediate and self._step_now is not None and self._step_now()):
            self.notify()

    def declare_alive(self) -> None:
        """Declare `gazed/<rig>/alive/<process>/<pid>`, which vanishes as the session ends."""
        self._closables.append(
            self.session.liveliness().declare_token(
                alive_key(self.rig.name, self.process, os.getpid())
            )
        )

    def alive(self, timeout_s: float = 1.0) -> set[str]:
        """Names of the rig's processes whose liveliness tokens are present now."""
        replies = self.session.liveliness().get(alive_key(self.rig.name), timeout=timeout_s)
        names = set()
        for reply in replies:
            parts = split_alive_key(str(reply.ok.key_expr)) if reply.ok is not None else None
            if parts is not None:
                names.add(parts[1])
        return names

    def watch_alive(self, callback: Callable[[str, int, bool], None]) -> None:
        """Call `callback(process, pid, alive)` as tokens appear and vanish (present ones
        first). A token whose key is not `alive/<process>/<pid>` (a process of another
        version, or not gazed's) is dropped and counted, and the first is logged."""

        def on_sample(sample: zenoh.Sample) -> None:
            parts = split_alive_key(str(sample.key_expr))
            if parts is None:
                if self.stats.malformed("alive", f"not a liveliness key: {sample.key_expr}"):
                    log.warning(
                        "ignoring liveliness tokens such as %s: not alive/<process>/<pid>",
                        sample.key_expr,
                    )
                return
            callback(parts[1], parts[2], sample.kind == zenoh.SampleKind.PUT)
            self.notify()

        self._closables.append(
            self.session.liveliness().declare_subscriber(
                alive_key(self.rig.name, "*", "**"),
                zenoh.handlers.Callback(on_sample, indirect=False),
                history=True,
            )
        )

    @property
    def peer(self) -> bool:
        """True when this session links directly to the rig's other processes (`is_peer`)."""
        return is_peer(self.rig.bus, router=self.router, identity=identity_of(self.process))
