"""The `gazed` command: every subcommand is declared once in `gazed.cli.COMMANDS`, its module
has the handler the registry names, handlers are imported only to run, and `gazed calibrate
points` works without the bus (zenoh is never imported)."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys

import pytest
from conftest import REPO, child_env

from gazed import cli

LAWN_POINTS = REPO / "configs" / "calibration" / "lawn_points.toml"


def leaves() -> list[tuple[str, str, cli.Command]]:
    """(command line, leaf name, entry) of every command in the registry."""
    found = []
    for name, entry in cli.COMMANDS.items():
        if isinstance(entry, cli.Group):
            found += [(f"{name} {sub}", sub, leaf) for sub, leaf in entry.commands.items()]
        else:
            found.append((name, name, entry))
    return found


@pytest.mark.parametrize(("line", "name", "entry"), leaves(), ids=lambda v: str(v))
def test_every_command_has_its_handler(line: str, name: str, entry: cli.Command) -> None:
    module = importlib.import_module(entry.module)
    assert callable(getattr(module, f"{name}_arguments")), line
    assert callable(getattr(module, f"{name}_command")), line
    assert entry.help


def test_the_commands_and_their_groups_are_listed(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["--help"]) == 0
    out = capsys.readouterr().out
    assert all(f"  {name} " in out for name in cli.COMMANDS)
    assert cli.main(["calibrate", "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: gazed calibrate COMMAND")
    assert all(f"  {name} " in out for name in ("points", "lines", "trace"))
    assert cli.main([]) == 2 and cli.main(["eval"]) == 2
    assert "loop" in capsys.readouterr().out


def test_an_unknown_command_suggests_the_closest(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["calibrat"]) == 2
    assert (
        "gazed: unknown command 'calibrat' (did you mean 'calibrate'?)" in capsys.readouterr().err
    )
    assert cli.main(["calibrate", "pionts"]) == 2
    assert (
        "gazed calibrate: unknown command 'pionts' (did you mean 'points'?)"
        in capsys.readouterr().err
    )


def quit_arguments(parser: object) -> None:
    """A command with no arguments ..."""


def quit_command(args: object) -> int:
    """... that exits as the bus tools do when nothing answers."""
    raise SystemExit("no bus answers")


def test_a_command_that_exits_with_a_message_returns_1(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(cli.COMMANDS, "quit", cli.Command(__name__, "exits"))
    assert cli.main(["quit"]) == 1
    assert "no bus answers" in capsys.readouterr().err


def run_python(code: str) -> dict[str, object]:
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=child_env(), timeout=60
    )
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.splitlines()[-1])


def test_calibrate_points_does_not_import_the_bus() -> None:
    report = run_python(
        "import json, sys\n"
        "from gazed.cli import main\n"
        f"code = main(['calibrate', 'points', {str(LAWN_POINTS)!r}, '--json'])\n"
        "print(json.dumps({'code': code, 'modules': sorted(sys.modules)}))\n"
    )
    assert report["code"] == 0
    modules = set(report["modules"])  # type: ignore[arg-type]
    assert "gazed.geometry.calibrate_cli" in modules
    assert not {"zenoh", "gazed.bus", "gazed.gaze.trace_cli"} & modules


def test_listing_the_commands_imports_no_handler() -> None:
    report = run_python(
        "import contextlib, io, json, sys\n"
        "from gazed.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    main(['--help']); main(['calibrate', '--help']); main(['eval', '--help'])\n"
        "print(json.dumps({'modules': sorted(sys.modules)}))\n"
    )
    handlers = {leaf.module for _, _, leaf in leaves()}
    assert not handlers & set(report["modules"])  # type: ignore[arg-type]


def test_calibrate_and_trace_do_not_import_each_other() -> None:
    """The trace method builds on the calibrate command, never the other way round."""
    report = run_python(
        "import json, sys\n"
        "import gazed.geometry.calibrate_cli\n"
        "print(json.dumps({'modules': sorted(sys.modules)}))\n"
    )
    assert "gazed.gaze.trace_cli" not in report["modules"]  # type: ignore[operator]
