"""`gazed tail [KEYEXPR]`: print the messages on a rig's bus, one line (or JSON object) each.

A line is meant to be read as it scrolls by: a list of more than `LONG_LIST` numbers (a mover's
colour histogram, a track's appearance template) is shown as its length, `"<64 numbers>"`;
`--json` prints every message whole."""

from __future__ import annotations

import argparse
import json
import sys
import threading
from typing import Any

from gazed.bustools.listen import Seen, common_arguments, listen, target_of
from gazed.messages import FrameHeader
from gazed.topics import PREFIX

LONG_LIST = 8  # numbers a line shows in a list; a longer one is shown as its length


def tail_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "keyexpr",
        nargs="?",
        help="key expression; relative ones are below gazed/<rig>/ (default: every key)",
    )
    common_arguments(parser)
    parser.add_argument("--seconds", type=float, help="stop after this long")
    parser.add_argument("--count", type=int, help="stop after this many messages")


def tail_command(args: argparse.Namespace) -> int:
    target = target_of(args)
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

    session = listen(target, key_expr, on_seen)
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
        numbers = all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        if len(value) > LONG_LIST and numbers:
            return f"<{len(value)} numbers>"
        return [_rounded(v) for v in value]
    return value
