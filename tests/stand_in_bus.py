"""A bus for one service in-process: inboxes the test fills and the service takes from,
outboxes that encode each message as the bus would and keep it for the test to read.

Used by the tests that drive a service's `step` (or `gazed run`'s console) without zenoh, and
by `tests/bench/estimator_hop.py`.
"""

from __future__ import annotations

from typing import Any

from gazed.messages import Message


class Inbox:
    def __init__(self) -> None:
        self.items: list[Any] = []

    def take(self) -> list[Any]:
        items, self.items = self.items, []
        return items


class Outbox:
    def __init__(self, keep: bool) -> None:
        self.keep = keep
        self.sent: list[Message] = []

    def put(self, message: Message) -> None:
        message.to_json()  # the work of sending it
        if self.keep:
            self.sent.append(message)


class StandInBus:
    """`subscribe` and `publisher` by topic; `keep=False` for benchmarks that send thousands."""

    def __init__(self, keep: bool = True) -> None:
        self.keep = keep
        self.inboxes: dict[str, Inbox] = {}
        self.outboxes: dict[str, Outbox] = {}

    def subscribe(self, topic: Any, capacity: int = 0, immediate: bool = False) -> Inbox:
        return self.inboxes.setdefault(topic.suffix, Inbox())

    def publisher(self, topic: Any) -> Outbox:
        return self.outboxes.setdefault(topic.suffix, Outbox(self.keep))
