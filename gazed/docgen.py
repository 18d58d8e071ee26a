"""The generated parts of the docs, rendered from the one source of each contract.

- `docs/architecture.md`, block `processes`: which process reads and publishes which key, from
  `gazed.topics` (`PROCESSES`, `TOOLS`, `TOPICS`);
- `docs/configuration.md`, block `rig-keys`: every rig key with its type, default, bounds and
  description, from the rig's JSON Schema (`gazed.config.Rig`, what `gazed schema` prints).

Each block sits between `<!-- generated: NAME ... -->` and `<!-- end generated: NAME -->`.
`python -m gazed.docgen` rewrites the blocks in place; `python -m gazed.docgen --check` rewrites
nothing and exits 1 naming the blocks that differ (tests/test_docs.py checks the same), so a key
added to a process or to the rig without regenerating the docs fails the tests.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gazed import topics
from gazed.config import Rig

REPO = Path(__file__).resolve().parents[1]


def begin_marker(name: str) -> str:
    return f"<!-- generated: {name} (python -m gazed.docgen rewrites this block) -->"


def end_marker(name: str) -> str:
    return f"<!-- end generated: {name} -->"


# ---------------------------------------------------------------------------------------------
# The process/topic contract


def _keys(items: tuple[topics.Topic, ...]) -> str:
    return ", ".join(f"`{t.suffix}`" for t in items) or "—"


def _names(names: tuple[str, ...]) -> str:
    return ", ".join(f"`{n}`" for n in names) or "—"


def render_processes() -> str:
    """Three tables: the rig's processes, the tools that take part, and every key."""
    lines = [
        "The rig's processes, in start order (`python -m services.<name> --rig RIG`), and the rig",
        "sections each reads besides `[rig]` and `[bus]`:",
        "",
        "| process | what it does | reads | publishes | rig sections |",
        "|---|---|---|---|---|",
    ]
    for p in topics.PROCESSES:
        sections = ", ".join(f"`[{s}]`" for s in p.sections) or "—"
        lines.append(
            f"| `{p.name}` | {_cell(p.summary)} | {_keys(p.reads)} | {_keys(p.publishes)} "
            f"| {sections} |"
        )
    lines += [
        "",
        "The supervisor and the commands that take part in the loop's traffic:",
        "",
        "| command | what it does | reads | publishes |",
        "|---|---|---|---|",
    ]
    for p in topics.TOOLS:
        lines.append(
            f"| `{p.name}` | {_cell(p.summary)} | {_keys(p.reads)} | {_keys(p.publishes)} |"
        )
    lines += [
        "",
        "Every key, below `gazed/<rig>/`, with its payload schema:",
        "",
        "| key | payload | published by | read by | carries |",
        "|---|---|---|---|---|",
    ]
    for t in topics.TOPICS:
        payload = f"`{t.model.schema_id()}`"
        if t.frames:
            payload += " (attachment) + raw pixels"
        lines.append(
            f"| `{t.suffix}` | {payload} | {_names(topics.publishers_of(t))} "
            f"| {_names(topics.readers_of(t))} | {_cell(t.summary)} |"
        )
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# The rig keys, from the JSON Schema


def _cell(text: str) -> str:
    """Text safe inside a Markdown table cell."""
    return " ".join(text.split()).replace("|", "\\|")


def _number(value: float | int) -> str:
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e7:
        return str(int(value))
    return repr(value)


def _toml(value: Any) -> str:
    """A default as it would be written in the rig file."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)


def _branches(prop: dict[str, Any]) -> tuple[list[dict[str, Any]], bool]:
    """The non-null alternatives of a property, and whether null (unset) is allowed."""
    if "anyOf" in prop:
        options = [b for b in prop["anyOf"] if b.get("type") != "null"]
        return options, len(options) < len(prop["anyOf"])
    return [prop], False


SCALARS = {"number": "float", "integer": "int", "string": "string", "boolean": "bool"}


def _type(prop: dict[str, Any]) -> str:
    options, _ = _branches(prop)
    return " or ".join(_single_type(option) for option in options)


def _single_type(prop: dict[str, Any]) -> str:
    if "const" in prop:
        return f"`{_toml(prop['const'])}`"
    if "enum" in prop:
        return " \\| ".join(f"`{_toml(v)}`" for v in prop["enum"])
    kind = prop.get("type")
    if kind == "array":
        if "prefixItems" in prop:
            return "[" + ", ".join(_single_type(p) for p in prop["prefixItems"]) + "]"
        inner = prop.get("items", {})
        n = prop.get("minItems")
        if n is not None and n == prop.get("maxItems"):
            m = inner.get("minItems")
            if inner.get("type") == "array" and m is not None and m == inner.get("maxItems"):
                return f"{n}×{m} {_single_type(inner.get('items', {}))}"
            return f"{n} × {_single_type(inner)}"
        return f"list of {_single_type(inner)}"
    if kind == "string" and prop.get("format") == "path":
        return "path"
    return SCALARS.get(str(kind), str(kind))


def _bounds(prop: dict[str, Any]) -> str:
    options, _ = _branches(prop)
    parts: list[str] = []
    for option in options:
        parts += _single_bounds(option)
        items = option.get("items")
        if isinstance(items, dict) and items.get("type") != "array":
            parts += [f"each {b}" for b in _single_bounds(items)]
    return ", ".join(parts)


def _single_bounds(prop: dict[str, Any]) -> list[str]:
    parts = []
    for key, sign in (
        ("minimum", "≥"),
        ("exclusiveMinimum", ">"),
        ("maximum", "≤"),
        ("exclusiveMaximum", "<"),
    ):
        if key in prop:
            parts.append(f"{sign} {_number(prop[key])}")
    if "pattern" in prop:
        parts.append(f"matches `{prop['pattern']}`".replace("|", "\\|"))
    if prop.get("type") == "array" and prop.get("minItems") != prop.get("maxItems"):
        if "maxItems" in prop:
            parts.append(f"at most {prop['maxItems']} items")
        if "minItems" in prop:
            parts.append(f"at least {prop['minItems']} items")
    return parts


def _row(key: str, prop: dict[str, Any], default: Any, required: bool) -> str:
    shown = f"`{_toml(default)}`"
    if required or default is None:
        shown = "required" if required else "unset"
    return (
        f"| `{key}` | {_type(prop)} | {shown} | {_bounds(prop)} "
        f"| {_cell(prop.get('description', ''))} |"
    )


def _defaults(**sections: Any) -> dict[str, Any]:
    """The rig's value of every key when the file gives only what `sections` says (and a name):
    the defaults as the rig sees them, default factories included."""
    return Rig.model_validate({"rig": {"name": "rig"}, **sections}).model_dump(mode="json")


TABLE_HEAD = ["| key | type | default | bounds | description |", "|---|---|---|---|---|"]


def _resolve(prop: dict[str, Any], defs: dict[str, Any]) -> dict[str, Any]:
    ref = prop.get("$ref")
    return defs[ref.rsplit("/", 1)[-1]] if ref else prop


def _section_rows(
    section: dict[str, Any], defs: dict[str, Any], defaults: dict[str, Any], prefix: str = ""
) -> list[str]:
    """One row per key; a sub-table (`[services.sim]`) becomes dotted keys."""
    rows = []
    required = set(section.get("required", ()))
    for key, prop in section.get("properties", {}).items():
        if "$ref" in prop:
            rows += _section_rows(_resolve(prop, defs), defs, defaults[key], f"{prefix}{key}.")
        else:
            rows.append(_row(f"{prefix}{key}", prop, defaults[key], key in required))
    return rows


def _readers(section: str) -> str:
    names = [p.name for p in topics.PROCESSES if section in p.sections]
    if section in ("rig", "bus"):
        return "every process and the supervisor"
    return ", ".join(f"`{n}`" for n in names) or "the supervisor"


def _servo_section(prop: dict[str, Any], defs: dict[str, Any]) -> list[str]:
    """`[servo]` is chosen by `protocol`: the keys every protocol has, then each one's own."""
    mapping: dict[str, str] = prop["discriminator"]["mapping"]
    variants = {name: _resolve({"$ref": ref}, defs) for name, ref in mapping.items()}
    order = [_resolve(o, defs)["properties"]["protocol"]["const"] for o in prop["oneOf"]]
    first = variants[order[0]]["properties"]
    shared = [
        key
        for key, p in first.items()
        if key != "protocol" and all(v["properties"].get(key) == p for v in variants.values())
    ]
    default = _defaults()["servo"]
    choices = " \\| ".join(f"`{_toml(name)}`" for name in order)
    lines = [
        *TABLE_HEAD,
        f"| `protocol` | {choices} | `{_toml(default['protocol'])}` | | the head's protocol; "
        "the keys below depend on it |",
    ]
    lines += [_row(key, first[key], default[key], False) for key in shared]
    for name in order:
        variant = variants[name]
        own = {
            k: p for k, p in variant["properties"].items() if k != "protocol" and k not in shared
        }
        description = variant["properties"]["protocol"].get("description", "")
        lines += ["", f'#### `protocol = "{name}"`: {description}', ""]
        if not own:
            lines.append("No keys of its own.")
            continue
        values = _defaults(servo={"protocol": name})["servo"]
        lines += TABLE_HEAD + [_row(k, p, values[k], False) for k, p in own.items()]
    return lines


def render_rig_keys() -> str:
    """A table per section of the rig file, in the schema's order."""
    schema = Rig.model_json_schema()
    defs = schema["$defs"]
    defaults = _defaults()
    lines: list[str] = []
    for section, prop in schema["properties"].items():
        lines += [f"### `[{section}]`", "", f"Read by {_readers(section)}.", ""]
        if "discriminator" in prop:
            lines += _servo_section(prop, defs)
        else:
            lines += TABLE_HEAD + _section_rows(_resolve(prop, defs), defs, defaults[section])
        lines.append("")
    return "\n".join(lines).rstrip()


# ---------------------------------------------------------------------------------------------
# Rewriting the docs

# block name -> (document, renderer)
BLOCKS: dict[str, tuple[str, Callable[[], str]]] = {
    "processes": ("docs/architecture.md", render_processes),
    "rig-keys": ("docs/configuration.md", render_rig_keys),
}


def replace_block(text: str, name: str, body: str) -> str:
    """`text` with the block `name` holding `body`; ValueError unless its markers occur once."""
    begin, end = begin_marker(name), end_marker(name)
    pattern = re.compile(re.escape(begin) + r"\n.*?" + re.escape(end), re.DOTALL)
    if len(pattern.findall(text)) != 1:
        raise ValueError(f"block {name!r}: expected one {begin!r} ... {end!r}")
    return pattern.sub(lambda _: f"{begin}\n\n{body}\n\n{end}", text)


def updated(root: Path) -> dict[Path, str]:
    """Each document with its generated blocks rendered now."""
    texts: dict[Path, str] = {}
    for name, (document, render) in BLOCKS.items():
        path = root / document
        if path not in texts:
            texts[path] = path.read_text(encoding="utf-8")
        texts[path] = replace_block(texts[path], name, render())
    return texts


def stale(root: Path = REPO) -> list[str]:
    """The documents whose generated blocks differ from what would be rendered now."""
    return [
        str(path.relative_to(root))
        for path, text in updated(root).items()
        if path.read_text(encoding="utf-8") != text
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gazed.docgen", description=__doc__)
    parser.add_argument(
        "--root", type=Path, default=REPO, help="the repository (default: %(default)s)"
    )
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 if stale")
    args = parser.parse_args(argv)
    if not (args.root / "docs").is_dir():
        print(f"docgen: no docs/ under {args.root}", file=sys.stderr)
        return 2
    try:
        texts = updated(args.root)
    except ValueError as exc:
        print(f"docgen: {exc}", file=sys.stderr)
        return 2
    changed = [p for p, text in texts.items() if p.read_text(encoding="utf-8") != text]
    for path in changed:
        name = path.relative_to(args.root)
        if args.check:
            print(f"docgen: {name} is stale: run python -m gazed.docgen", file=sys.stderr)
        else:
            path.write_text(texts[path], encoding="utf-8")
            print(f"docgen: rewrote {name}")
    return 1 if args.check and changed else 0


if __name__ == "__main__":
    sys.exit(main())
