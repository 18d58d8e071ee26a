"""The rig description: every error class exits 2 and names the key; the shipped rigs load."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from gazed import cli
from gazed.config import (
    SERVICE_NAMES,
    Rig,
    RigError,
    ServiceSpec,
    ServicesSection,
    load_rig,
    load_rig_or_exit,
    parse_rig,
)
from gazed.topics import PROCESSES

REPO = Path(__file__).resolve().parents[1]


def check(tmp_path: Path, text: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    path = tmp_path / "rig.toml"
    path.write_text(text)
    code = cli.main(["check", str(path)])
    err = capsys.readouterr().err
    return code, [line for line in err.splitlines() if line]


@pytest.mark.parametrize("path", sorted((REPO / "configs").glob("*.toml")), ids=lambda p: p.name)
def test_shipped_rigs_load(path: Path) -> None:
    rig = load_rig(path)
    assert rig.name
    assert rig.source_path == path


def test_sim_rig_is_the_default_rig() -> None:
    rig = load_rig(REPO / "configs" / "sim.toml")
    assert rig.camera.source == "sim"
    assert [
        n for n in ("sim", "servo", "vision", "estimator", "gaze") if rig.services.spec(n).enabled
    ] == [
        "sim",
        "servo",
        "vision",
        "estimator",
        "gaze",
    ]


def test_valid_rig_exits_0(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "ok.toml"
    path.write_text('[rig]\nname = "ok"\n')
    assert cli.main(["check", str(path)]) == 0
    assert "ok" in capsys.readouterr().out


def test_syntax_error_reports_line_and_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, lines = check(tmp_path, '[rig]\nname = "x"\n[head]\npan_max_deg = = 3\n', capsys)
    assert code == 2
    assert lines == [
        f"{tmp_path / 'rig.toml'}: TOML syntax error: Invalid value (at line 4, column 15)"
    ]


def test_missing_key(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, lines = check(tmp_path, '[head]\nkinematics = "pan-tilt"\n', capsys)
    assert code == 2
    assert len(lines) == 1
    assert lines[0].startswith(
        f"{tmp_path / 'rig.toml'}: rig: missing required key (expected a table"
    )


def test_wrong_type(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, lines = check(tmp_path, '[rig]\nname = "x"\n[camera]\nwidth_px = "wide"\n', capsys)
    assert code == 2
    assert len(lines) == 1
    assert ": camera.width_px: input should be a valid integer" in lines[0]
    assert "got 'wide' (expected an integer >= 16 and <= 8192 — Image width in pixels.)" in lines[0]


def test_out_of_range(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, lines = check(
        tmp_path, '[rig]\nname = "x"\n[estimator]\nstay_probability = 1.5\n', capsys
    )
    assert code == 2
    assert (
        ": estimator.stay_probability: input should be less than 1, got 1.5 "
        "(expected a number > 0 and < 1" in lines[0]
    )


def test_unknown_key_suggests_the_closest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, lines = check(tmp_path, '[rig]\nname = "x"\n[head]\npan_max_dg = 3\n', capsys)
    assert code == 2
    assert lines == [
        f"{tmp_path / 'rig.toml'}: head.pan_max_dg: unknown key (did you mean 'pan_max_deg'?)"
    ]


def test_unknown_section_suggests_the_closest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, lines = check(tmp_path, '[rig]\nname = "x"\n[servoo]\nport = "x"\n', capsys)
    assert code == 2
    assert lines[0].endswith("servoo: unknown key (did you mean 'servo'?)")


def test_every_problem_is_reported_not_only_the_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (
        '[rig]\nname = "bad name"\n'
        "[head]\npan_min_deg = 10\npan_max_deg = 0\ntilt_rate_max_deg_s = -1\n"
        '[servo]\nprotocol = "visca"\naddress = 9\nspeed = 3\n'
    )
    code, lines = check(tmp_path, text, capsys)
    assert code == 2
    keys = [line.split(": ")[1] for line in lines]
    assert sorted(keys) == ["head.tilt_rate_max_deg_s", "rig.name", "servo.address", "servo.speed"]
    assert any("servo.speed: unknown key (did you mean 'pan_speed'?)" in line for line in lines)


def test_cross_field_check_names_its_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, lines = check(
        tmp_path, '[rig]\nname = "x"\n[head]\npan_min_deg = 10\npan_max_deg = 0\n', capsys
    )
    assert code == 2
    assert lines == [
        f"{tmp_path / 'rig.toml'}: head.pan_max_deg: must be above pan_min_deg "
        "(expected pan_min_deg < pan_max_deg)"
    ]


def test_servo_protocol_is_a_discriminator(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, lines = check(tmp_path, '[rig]\nname = "x"\n[servo]\nprotocol = "pelco"\n', capsys)
    assert code == 2
    assert lines[0].endswith(
        "servo.protocol: unknown protocol 'pelco' "
        "(expected one of 'pelco-d', 'visca', 'flir-ptu', 'dynamixel', 'digital', 'onvif')"
    )


def test_unreadable_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["check", str(tmp_path / "absent.toml")]) == 2
    assert "absent.toml: cannot read" in capsys.readouterr().err


@pytest.mark.e2e  # the console entry point as a process
def test_check_console_entry_exits_2(tmp_path: Path) -> None:
    path = tmp_path / "rig.toml"
    path.write_text('[rig]\nname = "x"\n[gaze]\nfovea_half_angel_deg = 2\n')
    result = subprocess.run(
        [sys.executable, "-m", "gazed.cli", "check", str(path)], capture_output=True, text=True
    )
    assert result.returncode == 2
    assert (
        "gaze.fovea_half_angel_deg: unknown key (did you mean 'fovea_half_angle_deg'?)"
        in result.stderr
    )


def test_schema_is_json_schema_with_every_section(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["schema"]) == 0
    schema = json.loads(capsys.readouterr().out)
    sections = {
        "rig",
        "bus",
        "camera",
        "head",
        "servo",
        "calibration",
        "vision",
        "estimator",
        "gaze",
        "sim",
        "services",
        "wide",
        "view",
    }
    assert set(schema["properties"]) == sections
    assert schema["required"] == ["rig"]
    head = schema["$defs"]["HeadSection"]["properties"]
    assert head["pan_max_deg"]["description"]
    assert schema["$defs"]["HeadSection"]["additionalProperties"] is False


def test_every_field_has_a_description() -> None:
    from gazed.config import Rig

    def walk(model: type) -> list[tuple[str, str, object]]:
        out = []
        for name, field in model.model_fields.items():
            out.append((f"{model.__name__}.{name}", name, field))
            annotation = field.annotation
            for candidate in getattr(annotation, "__args__", (annotation,)):
                if isinstance(candidate, type) and hasattr(candidate, "model_fields"):
                    out += walk(candidate)
        return out

    fields = walk(Rig)
    missing = [
        path for path, _, field in fields if not field.description and not path.startswith("Rig.")
    ]
    assert missing == []


def test_relative_zenoh_config_is_resolved_from_the_rig_file(tmp_path: Path) -> None:
    rig = parse_rig(
        '[rig]\nname = "x"\n[bus]\nzenoh_config_path = "zenoh.json5"\n', tmp_path / "r.toml"
    )
    assert rig.bus.zenoh_config_path == tmp_path / "zenoh.json5"


def test_rig_error_lists_problems() -> None:
    with pytest.raises(RigError) as info:
        parse_rig('[rig]\nname = "x"\n[bus]\nrouter = false\n', "r.toml")
    assert info.value.problems == [
        "r.toml: bus.connect: must name the router's endpoint(s) when router = false "
        "(expected a list of endpoints)"
    ]


@pytest.mark.parametrize("endpoint", ["tcp/127.0.0.1:752020", "tcp/127.0.0.1", "udp/[::1]:port"])
def test_an_endpoint_without_a_real_port_is_a_rig_error(endpoint: str) -> None:
    with pytest.raises(RigError) as info:
        parse_rig(f'[rig]\nname = "x"\n[bus]\nlisten = ["{endpoint}"]\n', "r.toml")
    (problem,) = info.value.problems
    assert problem.startswith("r.toml: bus.listen") and "no port 0-65535" in problem


def test_endpoints_with_ports_and_sockets_load() -> None:
    rig = parse_rig(
        '[rig]\nname = "x"\n[bus]\nlisten = ["tcp/0.0.0.0:7447", "tls/[::]:7448#iface=lo", '
        '"unixsock-stream//tmp/gazed.sock"]\nconnect = ["tcp/10.0.0.2:0"]\n'
    )
    assert len(rig.bus.listen) == 3


def test_the_services_section_has_one_entry_per_declared_process() -> None:
    """[services] names the processes gazed.topics declares, in their start order, and each
    process's sections are sections of the rig (besides [rig] and [bus], read by all)."""
    entries = [
        name
        for name, field in ServicesSection.model_fields.items()
        if field.annotation is ServiceSpec
    ]
    assert entries == [p.name for p in PROCESSES] == list(SERVICE_NAMES)
    sections = set(Rig.model_fields) - {"rig", "bus", "services"}
    for process in PROCESSES:
        assert process.sections and set(process.sections) <= sections, process.name


def test_a_bad_rig_exits_2_from_the_one_loader(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "rig.toml"
    path.write_text('[rig]\nname = "x"\n[gaze]\nrate_hz = 0\n')
    with pytest.raises(SystemExit) as info:
        load_rig_or_exit(path)
    assert info.value.code == 2
    assert f"{path}: gaze.rate_hz: input should be greater than 0" in capsys.readouterr().err
    path.write_text('[rig]\nname = "x"\n')
    assert load_rig_or_exit(path).name == "x"


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_a_number_that_is_not_finite_is_refused_naming_its_key(value: str) -> None:
    with pytest.raises(RigError, match=r"camera\.cx_px"):
        parse_rig(f'[rig]\nname = "x"\n[camera]\ncx_px = {value}\n')


def test_zoom_control_without_a_zoom_lens_names_the_key() -> None:
    with pytest.raises(RigError, match=r"gaze\.zoom_control: needs a zoom lens"):
        parse_rig('[rig]\nname = "x"\n[gaze]\nzoom_control = true\n')


def test_a_digital_head_has_no_pose_noise() -> None:
    """The pose a frame is registered through: the head's reported angles, off by
    `[head] angle_noise_deg`; a digital head's view is rendered at the pose it reports."""
    digital = load_rig(REPO / "configs" / "pets.toml")
    assert digital.servo.protocol == "digital"
    assert digital.pose_noise_rad == 0.0
    ptz = load_rig(REPO / "configs" / "sim-zoom.toml")
    assert ptz.pose_noise_rad == pytest.approx(ptz.head.angle_noise_rad)
