"""`gazed record --rig RIG -o run.mcap [--seconds S] [KEYEXPR...]`: the bus into an MCAP file."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import zenoh

from gazed.bustools.listen import common_arguments, target_of
from gazed.record.mcap_writer import McapRecording, QueuedRecorder, Sample
from gazed.record.stopping import stop_on_signals
from gazed.session import BusError, open_session
from gazed.topics import PREFIX


def record_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "keyexpr",
        nargs="*",
        help="key expressions; relative ones are below gazed/<rig>/ (default: every key)",
    )
    parser.add_argument("-o", "--output", type=Path, required=True, help="the MCAP file to write")
    common_arguments(parser)
    parser.add_argument("--seconds", type=float, help="stop after this long (default: SIGINT)")


def record_command(args: argparse.Namespace) -> int:
    if not args.output.parent.is_dir():
        print(f"gazed record: {args.output.parent}: no such directory", file=sys.stderr)
        return 2
    target = target_of(args)
    keys = [_absolute(k, target.rig) for k in args.keyexpr] or [f"{PREFIX}/{target.rig}/**"]
    try:
        session = open_session(target.bus)
    except BusError as exc:
        print(f"gazed record: no bus answers: {exc}", file=sys.stderr)
        return 1
    with stop_on_signals() as done, args.output.open("wb") as stream:
        recorder = QueuedRecorder(McapRecording(stream))

        def on_sample(sample: zenoh.Sample) -> None:
            if sample.kind == zenoh.SampleKind.PUT:
                attachment = sample.attachment
                recorder.offer(
                    Sample(
                        str(sample.key_expr),
                        sample.payload.to_bytes(),
                        attachment.to_bytes() if attachment is not None else None,
                        time.time_ns(),
                    )
                )

        for key in keys:
            session.declare_subscriber(key, zenoh.handlers.Callback(on_sample, indirect=False))
        print(f"gazed record: {', '.join(keys)} -> {args.output}", file=sys.stderr)
        done.wait(args.seconds)
        session.close()
        recorder.close()
    _report(recorder, args.json)
    return 0


def _absolute(keyexpr: str, rig: str) -> str:
    return keyexpr if keyexpr.startswith(f"{PREFIX}/") else f"{PREFIX}/{rig}/{keyexpr}"


def _report(recorder: QueuedRecorder, as_json: bool) -> None:
    written = recorder.recording.written
    malformed = recorder.recording.malformed
    if as_json:
        print(
            json.dumps(
                {
                    "written": dict(written),
                    "dropped": dict(recorder.dropped),
                    "malformed": dict(malformed),
                }
            )
        )
        return
    width = max((len(k) for k in (*written, *recorder.dropped)), default=3)
    print(f"{'key':<{width}}  {'written':>8}  {'dropped':>8}")
    for key in sorted({*written, *recorder.dropped}):
        print(f"{key:<{width}}  {written[key]:>8}  {recorder.dropped[key]:>8}")
    for reason, count in malformed.items():
        print(f"malformed ({count}): {reason}")
