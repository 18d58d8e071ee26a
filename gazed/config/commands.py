"""`gazed check RIG` and `gazed schema`: validate a rig file, print the rig file's JSON Schema."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from gazed.config.loading import load_rig_or_exit
from gazed.config.rig import Rig
from gazed.topics import SERVICE_NAMES


def check_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("rig", type=Path, help="rig description (TOML)")


def check_command(args: argparse.Namespace) -> int:
    rig = load_rig_or_exit(args.rig)
    enabled = [n for n in SERVICE_NAMES if rig.services.spec(n).enabled]
    print(
        f"{args.rig}: ok (rig '{rig.name}', servo {rig.servo.protocol} on {rig.servo.port}, "
        f"processes: {', '.join(enabled) or 'none'})"
    )
    return 0


def schema_arguments(parser: argparse.ArgumentParser) -> None:
    del parser


def schema_command(args: argparse.Namespace) -> int:
    del args
    schema = Rig.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "gazed rig description"
    print(json.dumps(schema, indent=2))
    return 0
