"""The latency of each hop of one message, from its stamps (as `gazed latency` counts them):
each stage's stamp minus the previous one, the first minus the capture time."""

from __future__ import annotations

from gazed.messages import Message


def hop_latencies_ms(message: Message) -> dict[str, float]:
    """{stage: ms spent reaching it} for each of the message's stamps, in order."""
    hops: dict[str, float] = {}
    previous_ns = message.t_capture_ns
    for stage, t_ns in message.stamps:
        hops[stage] = (t_ns - previous_ns) / 1e6
        previous_ns = t_ns
    return hops
