"""The rig loader under random input: any text, any TOML document and any value
for any key of any section either loads or raises `RigError` — never another exception — and
every problem line names the file and then a key (one in the document, or a field of the section
it sits in: a missing key, a cross-field check). Only document-level problems (TOML syntax,
unreadable file) name a position or the file instead of a key."""

from __future__ import annotations

import datetime as dt
import functools
import math
import re
import tomllib
import types
import typing
from pathlib import Path
from typing import Any

import tomlkit
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

from gazed.config import Rig, RigError, load_rig, parse_rig

PATH = Path("/rigs/random.toml")
DOCUMENT_LEVEL = ("TOML syntax error: ", "not a valid TOML document: ")
ITEM_THEN_MESSAGE = re.compile(r"(\[\d+\])*: ")  # a key may be followed by a missing item's index


def models_in(annotation: Any) -> list[type[BaseModel]]:
    """Every model an annotation can hold (through unions, Annotated, lists, tuples, dicts)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    found: list[type[BaseModel]] = []
    for arg in typing.get_args(annotation):
        found += models_in(arg)
    return found


def sub_models(models: list[type[BaseModel]], key: str) -> list[type[BaseModel]]:
    found: list[type[BaseModel]] = []
    for model in models:
        field = model.model_fields.get(key)
        if field is not None:
            found += models_in(field.annotation)
    return found


def key_paths(value: Any, models: list[type[BaseModel]], prefix: str = "") -> set[str]:
    """The key paths a problem line may name: every entry of the document, and every field of
    the models at each table (missing keys, cross-field checks), as `a.b[0].c`."""

    def join(key: str) -> str:
        return f"{prefix}.{key}" if prefix else key

    paths = {join(name) for model in models for name in model.model_fields}
    if isinstance(value, dict):
        for key, item in value.items():
            paths.add(join(key))
            paths |= key_paths(item, sub_models(models, key), join(key))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            paths.add(f"{prefix}[{index}]")
            paths |= key_paths(item, models, f"{prefix}[{index}]")
    return paths


def assert_names_keys(problems: list[str], document: dict[str, Any] | None) -> None:
    """Each line is `FILE: KEY: what` with KEY from `key_paths` (or a document-level line)."""
    assert problems, "a RigError without problems"
    candidates = key_paths(document, [Rig]) if document is not None else set()
    for line in problems:
        assert line.startswith(f"{PATH}: "), line
        rest = line[len(f"{PATH}: ") :]
        if rest.startswith(DOCUMENT_LEVEL):
            assert document is None, f"a parsed document gave a document-level problem: {line}"
            continue
        assert document is not None, f"unparsed text gave a key-level problem: {line}"
        assert any(
            rest.startswith(key) and ITEM_THEN_MESSAGE.match(rest, len(key)) for key in candidates
        ), f"names no key: {line}"


def load(text: str) -> tuple[Rig | None, list[str]]:
    """parse_rig's outcome; any exception other than RigError fails the test."""
    try:
        return parse_rig(text, PATH), []
    except RigError as exc:
        assert str(exc) == "\n".join(exc.problems)
        return None, exc.problems


# --- strategies -----------------------------------------------------------------------------

SECTIONS = {name: models_in(info.annotation) for name, info in Rig.model_fields.items()}
FIELDS = sorted({f for models in SECTIONS.values() for m in models for f in m.model_fields})
KEYS = st.one_of(
    st.sampled_from(sorted(SECTIONS) + FIELDS),
    st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), min_size=1, max_size=12),
)
SCALARS = st.one_of(
    st.booleans(),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-1e3, max_value=1e3),
    st.text(max_size=20),
    st.sampled_from(
        ["sim", "pelco-d", "visca", "flir-ptu", "dynamixel", "imm", "oval", "tcp/127.0.0.1:7447"]
    ),
    st.datetimes(min_value=dt.datetime(1900, 1, 1), max_value=dt.datetime(2100, 1, 1)),
    st.dates(min_value=dt.date(1900, 1, 1), max_value=dt.date(2100, 1, 1)),
    st.times(),
)
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(KEYS, inner, max_size=4)),
    max_leaves=12,
)


def value_for(annotation: Any) -> st.SearchStrategy[Any]:
    """Values of roughly the field's type (so they reach its bounds and checks) or anything."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin is typing.Annotated:
        return value_for(args[0])
    if origin in (typing.Union, types.UnionType):
        return st.one_of(*(value_for(a) for a in args if a is not type(None)))
    if origin is typing.Literal:
        return st.one_of(st.sampled_from(args), st.text(max_size=8))
    if origin in (list, tuple):
        inner = [a for a in args if a is not Ellipsis] or [float]
        return st.lists(st.one_of(*(value_for(a) for a in inner)), max_size=5)
    if annotation is bool:
        return st.booleans()
    if annotation is int:
        return st.integers(min_value=-(2**63), max_value=2**63 - 1)
    if annotation is float:
        return st.one_of(
            st.floats(allow_nan=True, allow_infinity=True),
            st.sampled_from([0.0, -0.0, 1e-300, -1.0, 90.0, 180.0, 360.0, 1e9]),
        )
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return st.dictionaries(
            st.sampled_from(sorted(annotation.model_fields)), SCALARS, max_size=3
        )
    return st.one_of(st.text(max_size=30), st.just("../../etc/passwd"))


# Each strategy is built once: hypothesis works out a strategy's properties on its first draw
SECTION_NAMES = st.sampled_from(sorted(SECTIONS))
SECTION_MODELS = {section: st.sampled_from(models) for section, models in SECTIONS.items()}
MODEL_FIELDS = {
    model: st.sampled_from(sorted(model.model_fields))
    for models in SECTIONS.values()
    for model in models
}


@functools.cache
def field_values(model: type[BaseModel], field: str) -> st.SearchStrategy[Any]:
    """Values for one field of a section: typed for it, or anything."""
    return st.one_of(value_for(model.model_fields[field].annotation), VALUES)


@st.composite
def section_values(draw: st.DrawFn) -> dict[str, Any]:
    """A valid [rig] plus random values (typed or not) for random keys of random sections."""
    document: dict[str, Any] = {"rig": {"name": "r"}}
    for _ in range(draw(st.integers(1, 4))):
        section = draw(SECTION_NAMES)
        model = draw(SECTION_MODELS[section])
        table = document.setdefault(section, {})
        if not isinstance(table, dict):
            continue
        if section == "servo" and "protocol" in model.model_fields:
            table.setdefault(
                "protocol", typing.get_args(model.model_fields["protocol"].annotation)[0]
            )
        field = draw(MODEL_FIELDS[model])
        table[field] = draw(field_values(model, field))
    return document


def toml_text(document: dict[str, Any]) -> str:
    text = tomlkit.dumps(document)
    assert _comparable(tomllib.loads(text)) == _comparable(document), "tomlkit changed it"
    return text


def _comparable(value: Any) -> Any:
    """NaN != NaN: compare documents with NaN replaced by a marker."""
    if isinstance(value, float) and math.isnan(value):
        return "NaN"
    if isinstance(value, dict):
        return {k: _comparable(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_comparable(v) for v in value]
    return value


# --- properties -----------------------------------------------------------------------------


def examples(n: int) -> settings:
    return settings(max_examples=n, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@examples(300)
@given(st.text(max_size=300))
@example("a=" + "[" * 5000 + "]" * 5000)  # nesting deeper than the parser's recursion
@example("x=" + "{a=" * 3000 + "1" + "}" * 3000)
@example('[rig]\nname = "r"\n[camera]\nwidth_px = ' + "9" * 5000)  # beyond int() digit limit
@example('[rig]\nname = "r"\n[rig]\nname = "s"\n')  # a table defined twice
@example('[rig]\nname = "r"\nname = "s"\n')
@example("\ufeff[rig]\nname = 'r'\n")
@example('[rig]\nname = "r"\n[bus]\nzenoh_config_path = "\\u0000"\n')
def test_any_text_loads_or_raises_rig_error(text: str) -> None:
    try:
        document = _comparable(tomllib.loads(text))
    except (tomllib.TOMLDecodeError, RecursionError, ValueError):
        document = None
    _, problems = load(text)
    if problems:
        assert_names_keys(problems, document)


@examples(150)
@given(st.dictionaries(KEYS, VALUES, max_size=6))
def test_any_document_loads_or_names_its_keys(document: dict[str, Any]) -> None:
    rig, problems = load(toml_text(document))
    if rig is None:
        assert_names_keys(problems, _comparable(document))
    else:
        assert rig.name == document["rig"]["name"]


@examples(300)
@given(section_values())
@example({"rig": {"name": "r"}, "gaze": {"zoom_control": True}})  # a check across sections
def test_any_value_of_any_section_loads_or_names_its_key(document: dict[str, Any]) -> None:
    rig, problems = load(toml_text(document))
    if rig is None:
        assert_names_keys(problems, _comparable(document))
        keys = [line.split(": ", 2)[1] for line in problems]
        sections = {k.split(".", 1)[0].split("[", 1)[0] for k in keys}
        assert sections <= set(document), f"a problem outside the sections written: {problems}"
    else:  # what loaded is what was written: numbers, flags and strings kept as given
        for section, table in document.items():
            for key, value in table.items():
                loaded = getattr(getattr(rig, section), key)
                if type(value) in (bool, int, float, str) and type(loaded) is type(value):
                    assert loaded == value, f"{section}.{key}: wrote {value!r}, loaded {loaded!r}"


@examples(100)
@given(st.binary(min_size=1, max_size=200))
def test_any_bytes_in_a_file_load_or_raise_rig_error(tmp_path_factory: Any, data: bytes) -> None:
    path = tmp_path_factory.mktemp("rig") / "random.toml"
    path.write_bytes(data)
    try:
        load_rig(path)
    except RigError as exc:
        assert exc.problems and all(line.startswith(f"{path}: ") for line in exc.problems)
