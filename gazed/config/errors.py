"""Problem lines for a rig that fails validation: `KEY.PATH: what was wrong (expected …)`, with
a "did you mean" for unknown keys."""

from __future__ import annotations

import difflib
import re
from pathlib import Path
from typing import Annotated, Any, Literal, get_args, get_origin

from pydantic import BaseModel, ValidationError
from pydantic.fields import FieldInfo

from gazed.config.rig import Rig
from gazed.config.servo import SERVO_MODELS, PelcoDServo


class RigError(Exception):
    """A rig that cannot be loaded; `problems` holds one `FILE: KEY.PATH: …` line each."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems


def describe_errors(exc: ValidationError, data: dict[str, Any]) -> list[str]:
    """One `KEY.PATH: …` line per problem pydantic found in `data`, the parsed rig file."""
    lines = []
    for error in exc.errors(include_url=False):
        loc = _strip_tags(error["loc"])
        kind = error["type"]
        if kind == "value_error":
            # cross-field checks name their key first: "pan_max_deg: must be above …", or its whole
            # path where they check across sections: "gaze.zoom_control: needs …"
            message = str(error["msg"]).removeprefix("Value error, ")
            key, sep, rest = message.partition(": ")
            if sep and re.fullmatch(r"[a-z_0-9]+(\.[a-z_0-9]+)*", key):
                loc, message = (*loc, key), rest
            lines.append(f"{_key_path(loc)}: {message}")
            continue
        field = _field_at(loc, data)
        if kind == "extra_forbidden":
            parent = _model_at(loc[:-1], data)
            known = list(parent.model_fields) if parent is not None else []
            close = difflib.get_close_matches(str(loc[-1]), known, n=1, cutoff=0.6)
            hint = (
                f"did you mean '{close[0]}'?" if close else "expected one of: " + ", ".join(known)
            )
            lines.append(f"{_key_path(loc)}: unknown key ({hint})")
        elif kind == "missing":
            what = "missing item" if isinstance(loc[-1], int) else "missing required key"
            lines.append(f"{_key_path(loc)}: {what} (expected {_expected(field)})")
        elif kind in ("union_tag_invalid", "union_tag_not_found"):
            tags = ", ".join(repr(t) for t in SERVO_MODELS)
            got = _value_at(data, (*loc, "protocol"))
            what = "missing" if kind == "union_tag_not_found" else f"unknown protocol {got!r}"
            lines.append(f"{_key_path(loc)}.protocol: {what} (expected one of {tags})")
        else:
            message = error["msg"][0].lower() + error["msg"][1:]
            got = error.get("input")
            lines.append(f"{_key_path(loc)}: {message}, got {got!r} (expected {_expected(field)})")
    return lines


def _key_path(loc: tuple[Any, ...]) -> str:
    """('calibration', 'homography', 0) -> 'calibration.homography[0]'."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(top level)"


def _strip_tags(loc: tuple[Any, ...]) -> tuple[Any, ...]:
    """Drop the discriminator tag pydantic inserts into locations (servo.pelco-d.address)."""
    if len(loc) >= 2 and loc[0] == "servo" and loc[1] in SERVO_MODELS:
        return (loc[0], *loc[2:])
    return loc


def _model_at(loc: tuple[Any, ...], data: dict[str, Any]) -> type[BaseModel] | None:
    """The section model at a location; the servo union is resolved by the file's protocol."""
    model: Any = Rig
    for depth, part in enumerate(loc):
        if isinstance(part, int):
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            return None
        info = model.model_fields.get(str(part))
        if info is None:
            return None
        if model is Rig and part == "servo":
            protocol = _value_at(data, ("servo", "protocol"))
            model = SERVO_MODELS.get(protocol, PelcoDServo) if depth == len(loc) - 1 else None
            if model is None:
                return None
            continue
        model = _model_of(info.annotation)
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def _model_of(annotation: Any) -> Any:
    if get_origin(annotation) is Annotated:
        annotation = get_args(annotation)[0]
    models = [a for a in get_args(annotation) if isinstance(a, type) and issubclass(a, BaseModel)]
    return models[0] if models else annotation


def _field_at(loc: tuple[Any, ...], data: dict[str, Any]) -> FieldInfo | None:
    names = [p for p in loc if not isinstance(p, int)]
    if not names:
        return None
    parent_loc = loc[: len(loc) - loc[::-1].index(names[-1]) - 1]
    parent = _model_at(parent_loc, data)
    return parent.model_fields.get(str(names[-1])) if parent is not None else None


def _expected(field: FieldInfo | None) -> str:
    """A human description of what a field accepts: type, bounds, and its description."""
    if field is None:
        return "a valid value"
    bounds = []
    for meta in field.metadata:
        for attr, sign in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            value = getattr(meta, attr, None)
            if value is not None:
                bounds.append(f"{sign} {value}")
    text = _type_name(field.annotation)
    if bounds:
        text += " " + " and ".join(bounds)
    if field.description:
        text += f" — {field.description}"
    return text


def _type_name(annotation: Any, plural: bool = False) -> str:
    origin = get_origin(annotation)
    if origin is Annotated:
        return _type_name(get_args(annotation)[0], plural)
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in get_args(annotation))
    if origin in (list, tuple):
        args = [a for a in get_args(annotation) if a is not Ellipsis]
        count = f"{len(args)} " if origin is tuple else ""
        inner = _type_name(args[0], plural=True) if args else "values"
        return ("lists of " if plural else "a list of ") + count + inner
    args = get_args(annotation)
    if args:
        names = [_type_name(a, plural) for a in args if a is not type(None)]
        suffix = " (or omitted)" if type(None) in args else ""
        return " or ".join(names) + suffix
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "tables" if plural else "a table"
    names = {
        bool: "true or false",
        int: "integer",
        float: "number",
        str: "string",
        Path: "file path",
    }
    name = names.get(annotation, getattr(annotation, "__name__", str(annotation)))
    if annotation is bool:
        return name
    return f"{name}s" if plural else f"a{'n' if name[0] in 'aeiou' else ''} {name}"


def _value_at(data: Any, loc: tuple[Any, ...]) -> Any:
    for part in loc:
        if isinstance(data, dict):
            data = data.get(part)
        else:
            return None
    return data
