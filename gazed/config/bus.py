"""`[bus]`: the zenoh endpoints, the router, the lease and the bus's security settings."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

from pydantic import AfterValidator, Field, model_validator

from gazed.config.section import Section

ENDPOINT_PATTERN = r"^(tcp|udp|tls|quic|ws|unixsock-stream)/.+$"


def _has_port(endpoint: str) -> str:
    """A network endpoint ends in a port that exists (zenoh refuses one only at start-up)."""
    protocol, _, address = endpoint.partition("/")
    port = address.split("#", 1)[0].rpartition(":")[2]
    if protocol != "unixsock-stream" and not (port.isdigit() and int(port) <= 65535):
        raise ValueError(f"{endpoint!r} has no port 0-65535 (expected e.g. tcp/127.0.0.1:7447)")
    return endpoint


Endpoint = Annotated[str, Field(pattern=ENDPOINT_PATTERN), AfterValidator(_has_port)]
LOOPBACK_HOSTS = ("127.0.0.1", "[::1]", "localhost")


def _loopback(endpoint: str) -> bool:
    """A tcp/udp endpoint on this machine's loopback."""
    protocol, _, address = endpoint.partition("/")
    return protocol in ("tcp", "udp") and address.rsplit(":", 1)[0] in LOOPBACK_HOSTS


class BusSection(Section):
    listen: list[Endpoint] = Field(
        default_factory=lambda: ["tcp/127.0.0.1:7447"],
        description="zenoh endpoints the supervisor's router listens on. Loopback only by default.",
    )
    connect: list[Endpoint] = Field(
        default_factory=list,
        description="Endpoints the processes and tools connect to; "
        "empty means the listen endpoints.",
    )
    router: bool = Field(
        True,
        description="The supervisor hosts the zenoh router. False when a router runs elsewhere "
        "(multi-host rigs); processes then connect to `connect`.",
    )
    lease_ms: int = Field(
        1000,
        ge=100,
        le=60000,
        description="zenoh link lease: a frozen process is declared dead after ~3/4 of it.",
    )
    zenoh_config_path: Path | None = Field(
        None,
        description="JSON5 zenoh config merged under gazed's settings (user/password, TLS, access "
        "control) for rigs that span hosts. Relative paths are from the rig file.",
    )
    credentials_path: Path | None = Field(
        None,
        description="File of NAME:PASSWORD lines (zenoh's user/password dictionary, "
        "not readable by other users): every process authenticates as its own name "
        "(supervisor, sim, servo, vision, estimator, gaze; bus tools as 'tools') and the "
        "supervisor's router checks each against it. Relative paths are from the rig file.",
    )

    peer_links: bool = Field(
        True,
        description="The rig's own processes also link to each other directly, as zenoh peers "
        "on loopback (one hop instead of two through the router). "
        "Only where the bus is the supervisor's router on loopback with neither credentials nor "
        "a zenoh config: elsewhere the router's authentication and access control see every "
        "message, and the processes stay its clients.",
    )

    @property
    def direct(self) -> bool:
        """Whether the rig's processes link to each other directly (see `peer_links`)."""
        return (
            self.peer_links
            and self.router
            and self.credentials_path is None
            and self.zenoh_config_path is None
            and all(_loopback(e) for e in (*self.listen, *self.client_endpoints))
        )

    @property
    def peer_listen(self) -> str:
        """Where a process listens for its peers: the loopback of the router's first endpoint,
        on a port the system chooses."""
        protocol, _, address = self.client_endpoints[0].partition("/")
        host = address.rsplit(":", 1)[0]
        return f"{protocol}/{host}:0"

    @model_validator(mode="after")
    def _connectable(self) -> BusSection:
        if not self.router and not self.connect:
            raise ValueError(
                "connect: must name the router's endpoint(s) when router = false "
                "(expected a list of endpoints)"
            )
        return self

    @property
    def client_endpoints(self) -> list[str]:
        """Where processes and tools connect: `connect`, or the router's listen endpoints with
        unspecified addresses replaced by loopback."""
        if self.connect:
            return list(self.connect)
        return [e.replace("0.0.0.0", "127.0.0.1").replace("[::]", "[::1]") for e in self.listen]
