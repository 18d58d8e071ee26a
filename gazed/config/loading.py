"""Reading a rig file: `load_rig`, `parse_rig`, and `load_rig_or_exit` for commands and
processes."""

from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path

from pydantic import ValidationError

from gazed.config.errors import RigError, describe_errors
from gazed.config.rig import Rig


def load_rig(path: str | Path) -> Rig:
    """Read and validate a rig file; raises `RigError` listing every problem."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise RigError([f"{path}: cannot read: {exc.strerror or exc}"]) from exc
    except UnicodeDecodeError as exc:
        raise RigError([f"{path}: not UTF-8 text: {exc}"]) from exc
    return parse_rig(text, path)


def load_rig_or_exit(path: str | Path) -> Rig:
    """The rig of a command or a process: on a bad rig, every problem on stderr and exit 2."""
    try:
        return load_rig(path)
    except RigError as exc:
        print(exc, file=sys.stderr)
        raise SystemExit(2) from exc


def cannot_start(rig: Rig) -> list[str]:
    """Why a valid rig cannot start on this machine: a digital head without a wide camera, or
    footage to play that is not here. Such a rig loads (its keys are right), but `gazed run`
    and its processes exit 2 with these problems."""
    where = rig.source_path or "<rig>"
    source = rig.wide_source
    if source is None:
        if rig.servo.protocol == "digital":
            return [
                f"{where}: wide.source: missing "
                "(expected the wide camera the digital head looks through)"
            ]
        return []
    if source.isdigit() or "://" in source or Path(source).is_file():
        return []
    return [f"{where}: wide.source: no such file {source} (the footage is absent on this machine)"]


def exit_if_cannot_start(rig: Rig) -> None:
    """Print why the rig cannot start, and exit 2; return if it can."""
    problems = cannot_start(rig)
    if problems:
        print("\n".join(problems), file=sys.stderr)
        raise SystemExit(2)


def parse_rig(text: str, path: str | Path = "<rig>") -> Rig:
    """Validate rig TOML text; `path` names the file in errors and anchors relative paths."""
    path = Path(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RigError([f"{path}: TOML syntax error: {_syntax_message(exc)}"]) from exc
    except (RecursionError, ValueError) as exc:  # nested too deep, an integer too long for int()
        raise RigError([f"{path}: not a valid TOML document: {exc}"]) from exc
    try:
        rig = Rig.model_validate(data)
    except ValidationError as exc:
        raise RigError([f"{path}: {line}" for line in describe_errors(exc, data)]) from exc
    relative = {
        key: path.parent / value
        for key in ("zenoh_config_path", "credentials_path")
        if (value := getattr(rig.bus, key)) is not None and not value.is_absolute()
    }
    if relative:
        rig = rig.model_copy(update={"bus": rig.bus.model_copy(update=relative)})
    rig._source_path = path
    return rig


def _syntax_message(exc: tomllib.TOMLDecodeError) -> str:
    """tomllib says '… (at line 3, column 7)'; keep that and make sure line/column are present."""
    message = str(exc)
    if re.search(r"line \d+, column \d+", message):
        return message
    lineno = getattr(exc, "lineno", None)
    colno = getattr(exc, "colno", None)
    return f"{message} (at line {lineno}, column {colno})"
