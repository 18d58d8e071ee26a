"""A private copy of a rig file for one evaluation run: its own rig name, loopback bus port, head
port (a pty, or a free UDP or TCP port for an IP camera's emulator) and stream port, with the run's
scenario, seed, latency, estimation mode and control law. Paths the rig names relative to itself
are made absolute, as the copy lives elsewhere."""

from __future__ import annotations

import contextlib
import socket
import uuid
from pathlib import Path

import tomlkit

from gazed.config import load_rig


def private_rig(
    rig_path: Path,
    directory: Path,
    scenario: str,
    filter_mode: str | None,
    latency_ms: float | None,
    seed: int | None,
    control: str | None,
) -> Path:
    """A copy of the rig on a private bus and pty, with the run's settings, its simulator on."""
    document = private_document(rig_path, directory, filter_mode, control)
    sim = document.setdefault("sim", tomlkit.table())
    if scenario.startswith("file:"):
        path, hash_, ped = scenario[len("file:") :].partition("#")
        scenario = f"file:{(rig_path.resolve().parent / path).resolve()}{hash_}{ped}"
    sim["trajectory"] = scenario
    if latency_ms is not None:
        sim["visual_latency_ms"] = latency_ms
    if seed is not None:
        sim["seed"] = seed
    services = document.setdefault("services", tomlkit.table())
    sim_service = services.setdefault("sim", tomlkit.table())
    sim_service["enabled"] = True
    return write_rig(document, directory)


def private_document(
    rig_path: Path, directory: Path, filter_mode: str | None, control: str | None
) -> tomlkit.TOMLDocument:
    """The rig file with a private rig name, bus, head port and (for a digital head) stream
    port, and the run's estimation mode and control law."""
    document = tomlkit.parse(rig_path.read_text())
    base = rig_path.resolve().parent
    document["rig"]["name"] = f"eval{uuid.uuid4().hex[:8]}"
    bus = document.setdefault("bus", tomlkit.table())
    bus_port, stream_port = _free_ports(2, socket.SOCK_STREAM)
    bus["listen"] = [f"tcp/127.0.0.1:{bus_port}"]
    bus.pop("connect", None)
    bus["router"] = True
    for key in ("zenoh_config_path", "credentials_path"):  # relative to the original rig file
        if key in bus:
            bus[key] = str(base / str(bus[key]))
    wide = document.get("wide")
    if wide is not None:
        if "source" in wide:
            wide["source"] = load_rig(rig_path.resolve()).wide_source
        wide["stream_port"] = stream_port
    servo = document.setdefault("servo", tomlkit.table())
    if str(servo.get("port", "")).startswith("visca-udp://"):  # VISCA over IP: a private UDP port
        servo["port"] = f"visca-udp://127.0.0.1:{_free_ports(1, socket.SOCK_DGRAM)[0]}"
    elif str(servo.get("port", "")).startswith("onvif://"):  # ONVIF: a private TCP port
        servo["port"] = f"onvif://127.0.0.1:{_free_ports(1, socket.SOCK_STREAM)[0]}"
        if "password_file" in servo:  # relative to the original rig file
            servo["password_file"] = str(base / str(servo["password_file"]))
    else:
        servo["port"] = str(directory / "head")
    estimator = document.setdefault("estimator", tomlkit.table())
    if filter_mode == "none":
        estimator["filter"] = "imm"
        estimator["predict_over_latency"] = False
    elif filter_mode is not None:
        estimator["filter"] = filter_mode
    if control is not None:
        document.setdefault("gaze", tomlkit.table())["control"] = control
    return document


def write_rig(document: tomlkit.TOMLDocument, directory: Path) -> Path:
    path = directory / "rig.toml"
    path.write_text(tomlkit.dumps(document))
    return path


def _free_ports(count: int, kind: int) -> list[int]:
    """`count` distinct free loopback ports (each held while the next is found: the system may
    hand out a port again as soon as it is released)."""
    with contextlib.ExitStack() as held:
        ports = []
        for _ in range(count):
            s = held.enter_context(socket.socket(socket.AF_INET, kind))
            s.bind(("127.0.0.1", 0))
            ports.append(int(s.getsockname()[1]))
        return ports
