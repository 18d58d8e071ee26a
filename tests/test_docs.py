"""The README and docs/: generated tables current, links that resolve, no dates or hashes.

The process/topic table and the rig keys are rendered from their one source (`gazed.docgen`);
when a key is added to a process in `gazed.topics`, or to the rig's schema, the committed docs
differ from the rendering until `python -m gazed.docgen` rewrites them, and these tests fail.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from pydantic import BaseModel, Field, create_model

from gazed import docgen, topics
from gazed.config import Rig

REPO = Path(__file__).resolve().parents[1]
DOCS = sorted((REPO / "docs").glob("*.md"))
PROSE = [REPO / "README.md", *DOCS]

DATE = re.compile(r"\b(?:19|20)\d{2}-\d{2}-\d{2}\b")
# 7 to 40 hex digits with at least one letter and one digit, not part of a decimal number
COMMIT = re.compile(r"(?<![.\w])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}\b")
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$")
FENCE = re.compile(r"^\s*(```|~~~)")


def prose_lines(path: Path) -> list[str]:
    """The file's lines outside fenced code blocks, inline code removed."""
    lines, fenced = [], False
    for line in path.read_text(encoding="utf-8").splitlines():
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            lines.append(re.sub(r"`[^`]*`", "", line))
    return lines


def anchors(path: Path) -> set[str]:
    """GitHub's heading anchors: lower case, punctuation dropped, spaces to hyphens, repeats
    numbered."""
    seen: dict[str, int] = {}
    result = set()
    fenced = False
    for line in path.read_text(encoding="utf-8").splitlines():
        if FENCE.match(line):
            fenced = not fenced
            continue
        match = None if fenced else HEADING.match(line)
        if match is None:
            continue
        text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", match.group(1)).replace("`", "")
        slug = re.sub(r"[^\w\- ]", "", text.lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        result.add(slug if n == 0 else f"{slug}-{n}")
    return result


# --- the generated tables ------------------------------------------------------------------


def test_the_committed_tables_are_what_docgen_renders_now() -> None:
    assert docgen.stale(REPO) == [], "the docs' generated tables are stale: python -m gazed.docgen"


def test_a_key_added_to_a_process_makes_the_topic_table_stale(monkeypatch) -> None:
    extra = topics.Topic("vision/extra", topics.Detection, "a key nobody documented")
    vision = topics.process("vision")
    changed = topics.Process(
        vision.name, vision.summary, vision.reads, (*vision.publishes, extra), vision.sections
    )
    monkeypatch.setattr(
        topics, "PROCESSES", tuple(changed if p is vision else p for p in topics.PROCESSES)
    )
    monkeypatch.setattr(topics, "TOPICS", (*topics.TOPICS, extra))
    assert docgen.stale(REPO) == ["docs/architecture.md"]
    assert "`vision/extra`" in docgen.render_processes()


def test_a_key_added_to_the_rig_makes_the_configuration_stale(monkeypatch) -> None:
    camera_type = Rig.model_fields["camera"].annotation
    camera = create_model(
        "CameraSection",
        __base__=camera_type,
        exposure_ms=(float, Field(10.0, gt=0, description="A key nobody documented.")),
    )
    rig = create_model("Rig", __base__=Rig, camera=(camera, Field(default_factory=camera)))
    monkeypatch.setattr(docgen, "Rig", rig)
    assert docgen.stale(REPO) == ["docs/configuration.md"]
    assert "| `exposure_ms` | float | `10.0` | > 0 | A key nobody documented. |" in (
        docgen.render_rig_keys()
    )


def _fields(model: type[BaseModel]) -> set[str]:
    names = set()
    for name, field in model.model_fields.items():
        annotation = field.annotation
        if isinstance(annotation, type) and issubclass(annotation, BaseModel):
            names |= {f"{name}.{sub}" for sub in _fields(annotation)}
        else:
            names.add(name)
    return names


def test_every_key_of_every_section_has_a_row() -> None:
    rendered = docgen.render_rig_keys()
    sections = {name: field.annotation for name, field in Rig.model_fields.items()}
    servo_variants = sections.pop("servo").__args__  # a discriminated union of one per protocol
    for name, model in sections.items():
        assert f"### `[{name}]`" in rendered
        for key in _fields(model):
            assert f"| `{key}` |" in rendered, f"[{name}] {key}"
    for variant in servo_variants:
        protocol = variant.model_fields["protocol"].annotation.__args__[0]
        assert f'#### `protocol = "{protocol}"`' in rendered
        for key in variant.model_fields:
            assert f"| `{key}` |" in rendered, f"[servo] {key} ({protocol})"


def test_defaults_bounds_and_types_are_rendered_as_a_rig_file_writes_them() -> None:
    rendered = docgen.render_rig_keys()
    assert "| `name` | string | required |" in rendered
    assert '| `listen` | list of string | `["tcp/127.0.0.1:7447"]` |' in rendered  # a factory
    assert '| `kinematics` | `"pan-tilt"` \\| `"tilt-pan"` | `"pan-tilt"` |' in rendered
    assert "| `hfov_deg` | float | `60.0` | > 0, < 180 |" in rendered
    assert "| `fx_px` | float | unset | > 0 |" in rendered
    assert "| `homography` | 3×3 float | unset |" in rendered
    assert "| `sim.enabled` | bool | `true` |" in rendered
    assert "| `address` | int | `1` | ≥ 1, ≤ 7 |" in rendered  # VISCA's, not Pelco-D's 255


def test_every_process_and_topic_has_a_row() -> None:
    rendered = docgen.render_processes()
    for p in (*topics.PROCESSES, *topics.TOOLS):
        assert f"| `{p.name}` |" in rendered
    for t in topics.TOPICS:
        assert f"| `{t.suffix}` | `{t.model.schema_id()}`" in rendered


def test_replace_block_needs_its_markers_exactly_once() -> None:
    begin, end = docgen.begin_marker("x"), docgen.end_marker("x")
    text = f"before\n{begin}\nold\n{end}\nafter\n"
    assert docgen.replace_block(text, "x", "new") == f"before\n{begin}\n\nnew\n\n{end}\nafter\n"
    with pytest.raises(ValueError, match="'x'"):
        docgen.replace_block("no markers", "x", "new")
    with pytest.raises(ValueError, match="'x'"):
        docgen.replace_block(text + text, "x", "new")


def test_docgen_check_and_rewrite(tmp_path: Path, capsys) -> None:
    shutil.copytree(REPO / "docs", tmp_path / "docs")
    assert docgen.main(["--root", str(tmp_path), "--check"]) == 0
    path = tmp_path / "docs" / "architecture.md"
    path.write_text(path.read_text().replace("| `sim/truth` |", "| `sim/lies` |"))
    assert docgen.main(["--root", str(tmp_path), "--check"]) == 1
    assert "docs/architecture.md is stale" in capsys.readouterr().err
    assert docgen.main(["--root", str(tmp_path)]) == 0
    assert docgen.main(["--root", str(tmp_path), "--check"]) == 0
    assert path.read_text() == (REPO / "docs" / "architecture.md").read_text()
    assert docgen.main(["--root", str(tmp_path / "nowhere")]) == 2


# --- the prose -------------------------------------------------------------------------------


def test_the_readme_is_for_users_and_short() -> None:
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 300
    assert "python3 -m pip install -e '.[test]' && gazed run configs/sim.toml" in text
    assert "python3 -m pip install -e '.[test]' && python3 -m pytest" in text
    assert 'python3 -m pytest -m "not e2e"' in text


@pytest.mark.parametrize("path", PROSE, ids=lambda p: p.name)
def test_no_dates_or_commit_hashes(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    assert not DATE.findall(text), f"{path.name}: dates belong in git"
    assert not COMMIT.findall(text), f"{path.name}: commit hashes belong in git"


def test_no_dates_or_commit_hashes_in_the_code() -> None:
    found = []
    for path in sorted([*(REPO / "gazed").rglob("*.py"), *(REPO / "services").rglob("*.py")]):
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if DATE.search(line) or COMMIT.search(line):
                found.append(f"{path.relative_to(REPO)}:{number}: {line.strip()}")
    assert not found, "\n".join(found)


def test_the_patterns_catch_what_they_are_for() -> None:
    assert DATE.search("measured on 2026-11-25 at noon")
    assert COMMIT.search("at commit cd313da, then") and COMMIT.search("(6b89456)")
    for innocent in ("1000000 baud", "-1.9062764837502163e-08", "deadbeef", "0x4B", "`e2e`"):
        assert not COMMIT.search(innocent), innocent


@pytest.mark.parametrize("path", PROSE, ids=lambda p: p.name)
def test_relative_links_point_to_existing_files_and_headings(path: Path) -> None:
    broken = []
    for line in prose_lines(path):
        for target in LINK.findall(line):
            if re.match(r"[a-z][a-z0-9+.-]*:", target):  # https:, mailto:
                continue
            file_part, _, anchor = target.partition("#")
            linked = (path.parent / file_part).resolve() if file_part else path
            if not linked.exists():
                broken.append(f"{target}: no such file")
            elif anchor and linked.suffix == ".md" and anchor not in anchors(linked):
                broken.append(f"{target}: no heading #{anchor} in {linked.name}")
    assert not broken, f"{path.name}: " + "; ".join(broken)


def test_every_doc_is_linked_from_the_readme() -> None:
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    for path in DOCS:
        assert f"(docs/{path.name}" in readme, path.name
