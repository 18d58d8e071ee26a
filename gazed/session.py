"""zenoh sessions from the rig's [bus]: the topology, each session's identity and credentials.

Topology (DESIGN §3): the supervisor opens a router-mode session listening on the rig's loopback
endpoint; every tool connects to it as a client, and so does every process of a rig whose bus
has credentials, a zenoh config or endpoints beyond loopback (the router authenticates and
filters everything). On a private loopback bus (`[bus] peer_links`, the default) the rig's
processes are peers instead: each also listens on a loopback port of the system's choosing,
learns the others' from the router (gossip scouting, on for the router and the peers alone) and
sends them its messages directly — one hop instead of two through the router. Multicast
scouting is off everywhere, so nothing is announced beyond the configured endpoints.

Identity (DESIGN §3, docs/security.md): with `[bus] credentials_path` every
session authenticates with zenoh's user/password scheme as its own identity: each of the rig's
processes as its name (`supervisor`, `sim`, `servo`, `vision`, `estimator`, `gaze`), everything
else (`gazed tail`/`status`/`latency`, observers, evaluations) as `tools`; a router hosted by the
supervisor checks every connection against the same file. Access control (who may publish what)
is the router's: the rig's zenoh config may carry `access_control` (deploy/zenoh-rig.json5), which
clients leave to the router.
"""

from __future__ import annotations

import json
from pathlib import Path

import zenoh

from gazed.config import BusSection
from gazed.topics import SERVICE_NAMES

_log_initialised = False


class BusError(ConnectionError):
    """The bus cannot be reached or a session cannot be opened."""


TOOLS_IDENTITY = "tools"
PROCESS_IDENTITIES = ("supervisor", *SERVICE_NAMES)


def identity_of(process: str) -> str:
    """The identity a session authenticates as: a rig process's own name, else `tools`."""
    return process if process in PROCESS_IDENTITIES else TOOLS_IDENTITY


def read_credentials(path: Path, identity: str) -> str:
    """`identity`'s password from a file of `NAME:PASSWORD` lines (zenoh's usrpwd dictionary
    format); raises `BusError` if the file is unreadable, readable by everyone, or lacks it."""
    try:
        mode = path.stat().st_mode
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise BusError(f"{path}: cannot read the bus credentials: {exc}") from exc
    if mode & 0o007:
        raise BusError(
            f"{path}: the bus credentials are open to every user (mode {mode & 0o777:o}); "
            "chmod o-rwx it"
        )
    for line in text.splitlines():
        name, sep, password = line.partition(":")
        if sep and name == identity and password:
            return password
    raise BusError(
        f"{path}: no credentials for '{identity}' (expected a line '{identity}:PASSWORD')"
    )


def session_config(
    bus: BusSection, *, router: bool, identity: str = TOOLS_IDENTITY
) -> zenoh.Config:
    """A zenoh config for this rig: the router listens on `bus.listen`; clients connect to
    `bus.client_endpoints`. Scouting is off. `bus.zenoh_config_path` (TLS, access control) is the
    base; `bus.credentials_path` gives the session its user/password as `identity`, and a router
    its dictionary of every identity. Access control is enforced by the router alone."""
    config = _base_config(bus.zenoh_config_path)
    peer = is_peer(bus, router=router, identity=identity)
    mode = "router" if router else "peer" if peer else "client"
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("scouting/multicast/enabled", "false")
    if router:  # its scouting delay waits for multicast answers, and there are none
        config.insert_json5("scouting/delay", "0")
    config.insert_json5("scouting/gossip/enabled", json.dumps(bus.direct and (router or peer)))
    listen = list(bus.listen) if router else [bus.peer_listen] if peer else []
    config.insert_json5("listen/endpoints", json.dumps(listen))
    if peer:  # like a client, fail to open without the router (a peer would run on alone)
        config.insert_json5("connect/timeout_ms", "0")
        config.insert_json5("connect/exit_on_failure", "true")
    config.insert_json5("connect/endpoints", json.dumps([] if router else bus.client_endpoints))
    config.insert_json5("transport/link/tx/lease", str(bus.lease_ms))
    config.insert_json5("adminspace/enabled", "false")
    if bus.credentials_path is not None:
        password = read_credentials(bus.credentials_path, identity)
        config.insert_json5("transport/auth/usrpwd/user", json.dumps(identity))
        config.insert_json5("transport/auth/usrpwd/password", json.dumps(password))
        if router:
            dictionary = json.dumps(str(bus.credentials_path))
            config.insert_json5("transport/auth/usrpwd/dictionary_file", dictionary)
    if not router:
        config.insert_json5("access_control/enabled", "false")
    return config


def is_peer(bus: BusSection, *, router: bool, identity: str) -> bool:
    """A rig process on a private loopback bus is a peer: it listens on loopback, learns the
    other processes' endpoints from the router (gossip) and sends them its messages directly;
    everything else is the router or its client."""
    return not router and bus.direct and identity in SERVICE_NAMES


def _base_config(path: Path | None) -> zenoh.Config:
    if path is None:
        return zenoh.Config()
    try:
        return zenoh.Config.from_file(str(path))
    except (zenoh.ZError, OSError) as exc:
        raise BusError(f"{path}: not a usable zenoh config: {exc}") from exc


def open_session(
    bus: BusSection, *, router: bool = False, identity: str = TOOLS_IDENTITY
) -> zenoh.Session:
    """Open a session or raise `BusError` saying which endpoints did not answer."""
    global _log_initialised
    if not _log_initialised:
        zenoh.init_log_from_env_or("error")
        _log_initialised = True
    config = session_config(bus, router=router, identity=identity)
    try:
        return zenoh.open(config)
    except zenoh.ZError as exc:
        where = ", ".join(bus.listen if router else bus.client_endpoints)
        verb = "listen on" if router else "reach the rig's bus at"
        who = f" as '{identity}'" if bus.credentials_path is not None else ""
        raise BusError(f"cannot {verb} {where}{who}: {exc}") from exc
