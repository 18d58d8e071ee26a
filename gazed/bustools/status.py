"""`gazed status`: which processes are alive, their restarts and trouble counters, and the rate
of every key."""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from collections import Counter, defaultdict
from typing import Any

import zenoh

from gazed.bustools.listen import Seen, common_arguments, listen, target_of
from gazed.messages import Health, SupervisorStatus
from gazed.topics import PREFIX, alive_key, split_alive_key, split_key

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


def status_arguments(parser: argparse.ArgumentParser) -> None:
    common_arguments(parser)
    parser.add_argument("--seconds", type=float, default=2.0, help="listen this long (default 2)")


def status_command(args: argparse.Namespace) -> int:
    target = target_of(args)
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

    session = listen(target, f"{PREFIX}/{target.rig}/**", on_seen)
    try:
        alive = _alive(session, target.rig)
        time.sleep(args.seconds)  # listening window: what arrives meanwhile is the report
    finally:
        session.close()
    if not alive and not counts:
        print(
            f"gazed status: nothing answers for rig '{target.rig}' "
            f"on {', '.join(target.bus.client_endpoints)}",
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
        parts = split_alive_key(str(reply.ok.key_expr)) if reply.ok is not None else None
        if parts is not None and parts[1] not in found[parts[0]]:
            found[parts[0]].append(parts[1])
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
