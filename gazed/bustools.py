"""The operator's view of a running rig: `gazed tail`, `gazed status`, `gazed latency`.

Each connects to a rig's bus as a client (endpoints from `--rig RIG`'s [bus], or `--connect`),
listens, and prints; each exits 1 with a clear message when nothing answers.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from collections import Counter, defaultdict
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import zenoh

from gazed.bus import BusError, open_session
from gazed.config import BusSection, load_rig
from gazed.messages import FrameHeader, Health, Message, SupervisorStatus
from gazed.topics import PREFIX, alive_key, split_key, topic_for

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
# health counters `gazed status` shows: the ones that say something went wrong
TROUBLE_COUNTERS = (
    "drop",
    "malformed",
    "error",
    "timeout",
    "clamp",
    "refused",
    "replaced",
    "rejected",
    "future",
    "off_the",
    "overload",
)


@dataclass(frozen=True)
class Target:
    """Which bus to join and which rig(s) to listen to."""

    bus: BusSection
    rig: str  # a rig name or "*"


def _target(args: argparse.Namespace) -> Target:
    if args.rig is not None:
        rig = load_rig(args.rig)
        bus = (
            rig.bus
            if not args.connect
            else BusSection(listen=[args.connect], connect=[args.connect])
        )
        return Target(bus, rig.name)
    endpoint = args.connect or DEFAULT_ENDPOINT
    return Target(BusSection(listen=[endpoint], connect=[endpoint]), args.rig_name or "*")


def _common_arguments(parser: argparse.ArgumentParser) -> None:
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


def _listen(target: Target, key_expr: str, on_seen: Callable[[Seen], None]) -> zenoh.Session:
    session = _open(target)
    session.declare_subscriber(
        key_expr, zenoh.handlers.Callback(lambda s: on_seen(_seen(s)), indirect=True)
    )
    return session


# -- tail --------------------------------------------------------------------------------------


def tail_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "keyexpr",
        nargs="?",
        help="key expression; relative ones are below gazed/<rig>/ (default: every key)",
    )
    _common_arguments(parser)
    parser.add_argument("--seconds", type=float, help="stop after this long")
    parser.add_argument("--count", type=int, help="stop after this many messages")


def tail_command(args: argparse.Namespace) -> int:
    target = _target(args)
    key_expr = _tail_key(args.keyexpr, target.rig)
    done = threading.Event()
    counted = [0]

    def on_seen(seen: Seen) -> None:
        if done.is_set():
            return
        print(_tail_json(seen) if args.json else _tail_line(seen), flush=True)
        counted[0] += 1
        if args.count is not None and counted[0] >= args.count:
            done.set()

    session = _listen(target, key_expr, on_seen)
    try:
        if not done.wait(min(args.seconds or 5.0, 5.0)) and counted[0] == 0:
            print(
                f"gazed tail: nothing published on {key_expr} yet; still listening", file=sys.stderr
            )
        remaining = None if args.seconds is None else max(0.0, args.seconds - 5.0)
        done.wait(remaining)
    except KeyboardInterrupt:
        pass
    finally:
        done.set()
        session.close()
    if counted[0] == 0:
        print(f"gazed tail: nothing was published on {key_expr}", file=sys.stderr)
        return 1
    return 0


def _tail_key(keyexpr: str | None, rig: str) -> str:
    if keyexpr is None:
        return f"{PREFIX}/{rig}/**"
    if keyexpr.startswith(f"{PREFIX}/"):
        return keyexpr
    return f"{PREFIX}/{rig}/{keyexpr}"


def _tail_line(seen: Seen) -> str:
    age = f"{seen.age_ms:8.1f}ms" if seen.age_ms is not None else "       ?ms"
    return f"{seen.key} {seen.schema or '-'} {age} {_compact(seen)}"


def _tail_json(seen: Seen) -> str:
    payload: Any
    if isinstance(seen.message, FrameHeader):
        payload = {"header": seen.message.model_dump(mode="json"), "bytes": len(seen.raw)}
    elif seen.message is not None:
        payload = seen.message.model_dump(mode="json")
    else:
        payload = seen.raw.decode(errors="replace")
    return json.dumps(
        {"key": seen.key, "schema": seen.schema, "age_ms": seen.age_ms, "payload": payload}
    )


def _compact(seen: Seen) -> str:
    if isinstance(seen.message, FrameHeader):
        h = seen.message
        return f"<frame {h.width}x{h.height} {h.encoding} seq={h.seq} {len(seen.raw)} bytes>"
    if seen.schema.startswith(FrameHeader.SCHEMA):
        return f"<frame, bad header, {len(seen.raw)} bytes>"
    if seen.message is None:
        text = seen.raw[:200].decode(errors="replace")
        return f"<not a gazed message> {text}"
    data = seen.message.model_dump(mode="json", exclude={"t_capture_ns", "stamps"})
    return json.dumps(_rounded(data), separators=(",", ":"))


def _rounded(value: Any) -> Any:
    if isinstance(value, float):
        return round(value, 4)
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_rounded(v) for v in value]
    return value


# -- status ------------------------------------------------------------------------------------


def status_arguments(parser: argparse.ArgumentParser) -> None:
    _common_arguments(parser)
    parser.add_argument("--seconds", type=float, default=2.0, help="listen this long (default 2)")


def status_command(args: argparse.Namespace) -> int:
    target = _target(args)
    counts: Counter[str] = Counter()
    health: dict[str, Health] = {}
    supervisor: dict[str, SupervisorStatus] = {}
    lock = threading.Lock()

    def on_seen(seen: Seen) -> None:
        with lock:
            counts[seen.key] += 1
            if isinstance(seen.message, Health):
                health[seen.key] = seen.message
            elif isinstance(seen.message, SupervisorStatus):
                supervisor[f"{seen.key}#{seen.message.host}"] = seen.message  # one per host

    session = _listen(target, f"{PREFIX}/{target.rig}/**", on_seen)
    try:
        alive = _alive(session, target.rig)
        time.sleep(args.seconds)  # listening window: what arrives meanwhile is the report
    finally:
        session.close()
    if not alive and not counts:
        print(
            f"gazed status: nothing answers for rig '{target.rig}' on {', '.join(target.bus.client_endpoints)}",
            file=sys.stderr,
        )
        return 1
    report = _status_report(target.rig, alive, counts, health, supervisor, args.seconds)
    print(json.dumps(report, indent=2) if args.json else _status_text(report))
    return 0


def _alive(session: zenoh.Session, rig: str) -> dict[str, list[str]]:
    """rig -> names of its processes with a liveliness token."""
    found: dict[str, list[str]] = defaultdict(list)
    for reply in session.liveliness().get(alive_key(rig), timeout=1.0):
        if reply.ok is not None:
            parts = split_key(str(reply.ok.key_expr))
            if parts:
                name = parts[1].rsplit("/", 1)[-1]
                if name not in found[parts[0]]:
                    found[parts[0]].append(name)
    return found


def _status_report(
    rig: str,
    alive: dict[str, list[str]],
    counts: Counter[str],
    health: dict[str, Health],
    supervisor: dict[str, SupervisorStatus],
    seconds: float,
) -> dict[str, Any]:
    rigs: dict[str, Any] = {}
    names = set(alive) | {p[0] for p in map(split_key, counts) if p}
    for name in sorted(names):
        key = f"{PREFIX}/{name}/supervisor/status#"
        sups = [status for k, status in sorted(supervisor.items()) if k.startswith(key)]
        processes: dict[str, Any] = {}
        for sup in sups:  # a rig over several hosts: each process from the host that runs it
            for p in sup.processes:
                if p.state in ("disabled", "missing") and p.name in processes:
                    continue
                processes[p.name] = {
                    "state": p.state,
                    "pid": p.pid,
                    "restarts": p.restarts,
                    "message": p.message,
                    "host": sup.host,
                }
        for process in alive.get(name, []):
            processes.setdefault(process, {})["alive"] = True
        for entry in processes.values():
            entry.setdefault("alive", False)
        for key, h in health.items():
            if key.startswith(f"{PREFIX}/{name}/"):
                entry = processes.setdefault(h.process, {"alive": h.process in alive.get(name, [])})
                entry["counters"] = {
                    k: v
                    for k, v in h.counters.items()
                    if v and any(word in k for word in TROUBLE_COUNTERS)
                }
                entry["notes"] = h.notes
        rates = {
            key.split("/", 2)[2]: round(n / seconds, 2)
            for key, n in sorted(counts.items())
            if key.startswith(f"{PREFIX}/{name}/")
        }
        rigs[name] = {
            "supervisor": "; ".join(f"{s.host}: {s.state}" for s in sups)
            if len(sups) > 1
            else (sups[0].state if sups else None),
            "processes": processes,
            "rates_hz": rates,
        }
    return {"rigs": rigs, "seconds": seconds}


def _status_text(report: dict[str, Any]) -> str:
    lines = []
    for name, rig in report["rigs"].items():
        lines.append(f"rig {name}: supervisor {rig['supervisor'] or 'not seen'}")
        for process, p in sorted(rig["processes"].items()):
            state = p.get("state", "?")
            alive = "alive" if p["alive"] else "NOT ALIVE"
            extra = f" restarts={p['restarts']}" if "restarts" in p else ""
            counters = " ".join(f"{k}={v}" for k, v in p.get("counters", {}).items())
            lines.append(f"  {process:<10} {state:<9} {alive:<9}{extra} {counters}".rstrip())
            if p.get("message") and state not in ("running",):
                lines.append(f"             {p['message']}")
        lines.append("  rates:")
        for key, rate in rig["rates_hz"].items():
            lines.append(f"    {key:<28} {rate:8.2f} Hz")
    return "\n".join(lines)


# -- latency -----------------------------------------------------------------------------------


def latency_arguments(parser: argparse.ArgumentParser) -> None:
    _common_arguments(parser)
    parser.add_argument("--seconds", type=float, default=5.0, help="listen this long (default 5)")


def latency_command(args: argparse.Namespace) -> int:
    target = _target(args)
    stamped: list[tuple[str, Message]] = []
    lock = threading.Lock()

    def on_seen(seen: Seen) -> None:
        if seen.message is not None and seen.message.stamps:
            with lock:
                stamped.append((seen.key, seen.message))

    session = _listen(target, f"{PREFIX}/{target.rig}/**", on_seen)
    try:
        time.sleep(args.seconds)  # listening window
    finally:
        session.close()
    if not stamped:
        print(
            f"gazed latency: no stamped messages for rig '{target.rig}' in {args.seconds:g} s",
            file=sys.stderr,
        )
        return 1
    report = latency_report(stamped)
    print(json.dumps(report, indent=2) if args.json else _latency_text(report))
    return 0


def latency_report(stamped: list[tuple[str, Message]]) -> dict[str, Any]:
    """Per key: each stage's latency (its stamp minus the previous one, the first minus
    t_capture) and end to end (last stamp minus t_capture), p50/p95/p99 in ms."""
    stages: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    end_to_end: dict[str, list[float]] = defaultdict(list)
    for key, message in stamped:
        suffix = key.split("/", 2)[2] if key.count("/") >= 2 else key
        previous = message.t_capture_ns
        for stage, t_ns in message.stamps:
            stages[suffix][stage].append((t_ns - previous) / 1e6)
            previous = t_ns
        end_to_end[suffix].append((message.stamps[-1][1] - message.t_capture_ns) / 1e6)
    return {
        "keys": {
            suffix: {
                "n": len(end_to_end[suffix]),
                "stages_ms": {stage: _percentiles(values) for stage, values in per_stage.items()},
                "end_to_end_ms": _percentiles(end_to_end[suffix]),
            }
            for suffix, per_stage in sorted(stages.items())
        }
    }


def _percentiles(values: list[float]) -> dict[str, float]:
    p50, p95, p99 = np.percentile(np.asarray(values), [50, 95, 99])
    return {"p50": round(float(p50), 3), "p95": round(float(p95), 3), "p99": round(float(p99), 3)}


def _latency_text(report: dict[str, Any]) -> str:
    lines = [f"{'key / stage':<36} {'p50':>9} {'p95':>9} {'p99':>9}  (ms)"]
    for suffix, entry in report["keys"].items():
        e = entry["end_to_end_ms"]
        lines.append(
            f"{suffix + ' (end to end, n=' + str(entry['n']) + ')':<36} {e['p50']:9.2f} {e['p95']:9.2f} {e['p99']:9.2f}"
        )
        for stage, s in entry["stages_ms"].items():
            lines.append(f"  {stage:<34} {s['p50']:9.2f} {s['p95']:9.2f} {s['p99']:9.2f}")
    return "\n".join(lines)
