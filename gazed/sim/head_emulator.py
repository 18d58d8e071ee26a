"""The head emulator: a pan/tilt head that answers the rig's protocol on a pseudo-terminal
(DESIGN §9, STYLE 3: the fake speaks the real bytes).

It opens a pty, points the rig's `[servo] port` at it with a symlink (so the `servo` process
opens it through pyserial as it would a USB adapter), decodes what the host writes with the
protocol's device model (`head_pelco_d`, `head_visca`, `head_flir_ptu`, `head_dynamixel`),
answers as the device would, and moves the two axes of a `HeadMechanics` — all of which is the
`HeadLine`, including the line's timing at the rig's baud rate.

A rig whose port is `visca-udp://host:port` gets the camera on that loopback UDP port instead,
speaking Sony's VISCA-over-IP framing (`head_visca_ip`) around the same VISCA camera; its
bytes take no line time.

Embedding (the `sim` process): `HeadEmulator(rig)` as a context manager runs its own thread;
`pose_at(t)` gives the camera's true joint angles at any monotonic instant of the last two
seconds. Alone: `python -m gazed.sim.head_emulator --rig RIG`.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import pty
import select
import signal
import socket
import sys
import threading
import time
import tty
from collections.abc import Callable
from pathlib import Path

from gazed.config import Rig, RigError, load_rig
from gazed.config.head import HeadSection
from gazed.geometry.kinematics import joint_from_device
from gazed.messages import HeadPose
from gazed.servo.visca_ip_transport import SCHEME, address_of
from gazed.sim.head_line import HeadLine
from gazed.sim.head_mechanics import AxisSample
from gazed.sim.head_visca_ip import ViscaIpSession

POLL_S = 0.002
READ_CHUNK = 4096


class EmulatorError(RuntimeError):
    """The emulator cannot take the rig's port (not a path, or a real file is in the way)."""


def joint_pose(head: HeadSection, sample: AxisSample, zoom_lens: bool = False) -> HeadPose:
    """A head's joint angles and rates from its device's axes (their zero and sense), and its
    zoom position where the camera has a zoom lens."""
    pan, tilt = joint_from_device(head, sample.pan_rad, sample.tilt_rad)
    return HeadPose(
        pan_rad=pan,
        tilt_rad=tilt,
        pan_rate_rad_s=head.pan_sign * sample.pan_rate_rad_s,
        tilt_rate_rad_s=head.tilt_sign * sample.tilt_rate_rad_s,
        zoom=sample.zoom if zoom_lens else None,
    )


class HeadEmulator:
    """The rig's head on a pty. `link` overrides where the symlink goes (default: the rig's
    `[servo] port`); `clock` is the monotonic clock of its timing (seconds)."""

    def __init__(
        self,
        rig: Rig,
        *,
        link: str | Path | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        port = str(link if link is not None else rig.servo.port)
        self.udp_address: tuple[str, int] | None = None
        if port.startswith(f"{SCHEME}://"):
            if rig.servo.protocol != "visca":
                raise EmulatorError(
                    f"[servo] port {port!r} carries VISCA, not {rig.servo.protocol}"
                )
            self.udp_address = address_of(port)
        elif "://" in port:
            raise EmulatorError(f"[servo] port {port!r} is a URL; the emulator needs a file path")
        self.rig = rig
        self.link_path = Path(port)
        self._clock = clock
        self._lock = threading.RLock()
        self.line = HeadLine(rig, clock(), serial=self.udp_address is None)
        self.session = ViscaIpSession()
        self._udp: socket.socket | None = None
        self._client: tuple[str, int] | None = None
        self.mechanics = self.line.mechanics
        self.pty_path: str | None = None
        self.bytes_received = 0
        self.bytes_sent = 0
        self.bytes_dropped = 0
        self._master: int | None = None
        self._slave: int | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    def __enter__(self) -> HeadEmulator:
        self.open()
        self.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    # --- lifecycle -------------------------------------------------------------------------

    def open(self) -> None:
        """Create the pty (raw, no echo) and the symlink at the rig's port, or bind the UDP
        port."""
        if self._master is not None or self._udp is not None:
            return
        if self.udp_address is not None:
            udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                udp.bind(self.udp_address)
            except OSError as exc:
                udp.close()
                raise EmulatorError(f"cannot bind {self.udp_address}: {exc}") from exc
            udp.setblocking(False)
            self._udp = udp
            return
        if self.link_path.exists() and not self.link_path.is_symlink():
            raise EmulatorError(f"{self.link_path} exists and is not a symlink; not replacing it")
        master, slave = pty.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self.pty_path = os.ttyname(slave)
        temporary = self.link_path.with_name(f".{self.link_path.name}.{os.getpid()}.tmp")
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()
        os.symlink(self.pty_path, temporary)
        os.replace(temporary, self.link_path)

    def start(self) -> None:
        """Serve the pty from a thread of its own."""
        if self._thread is None:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="head-emulator", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
            self._thread = None

    def close(self) -> None:
        """Stop, remove the symlink if it is still ours, close the pty: the host sees the port
        vanish as when a USB adapter is pulled."""
        self.stop()
        if self.pty_path is not None:
            with contextlib.suppress(OSError):
                if os.readlink(self.link_path) == self.pty_path:
                    self.link_path.unlink()
        for fd in (self._master, self._slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = None
        self.pty_path = None
        if self._udp is not None:
            self._udp.close()
            self._udp = None

    def _run(self) -> None:
        while not self._stop.is_set():
            self.service(POLL_S)

    # --- the line --------------------------------------------------------------------------

    def service(self, timeout_s: float) -> None:
        """One round: wait up to `timeout_s` for bytes (less if something falls due), hand them
        to the line, write what has reached the host."""
        fd = self._udp.fileno() if self._udp is not None else self._master
        if fd is None:
            raise EmulatorError("the emulator is not open")
        with self._lock:
            due_s = self.line.next_due_s()
        wait_s = timeout_s if due_s is None else min(timeout_s, due_s - self._clock())
        readable, _, _ = select.select([fd], [], [], max(0.0, wait_s))
        data = self._read() if readable else b""
        now = self._clock()
        with self._lock:
            self.line.receive(data, now)
            out = self.line.service(now)
        if out:
            self._write(out)

    def _read(self) -> bytes:
        if self._udp is not None:
            return self._receive_datagrams(self._udp)
        assert self._master is not None
        try:
            data = os.read(self._master, READ_CHUNK)
        except OSError:
            return b""  # EAGAIN, EINTR, or EIO while no host has the port open
        self.bytes_received += len(data)
        return data

    def _write(self, data: bytes) -> None:
        if self._udp is not None:
            for datagram in self.session.send(data):
                self._send_datagram(datagram)
            return
        assert self._master is not None
        try:
            written = os.write(self._master, data)
        except OSError:
            written = 0  # nobody reads the port: the bytes are lost, as on a real line
        self.bytes_sent += written
        self.bytes_dropped += len(data) - written

    def _receive_datagrams(self, udp: socket.socket) -> bytes:
        """The VISCA bytes of every datagram waiting; control replies go back at once."""
        out = bytearray()
        while True:
            try:
                datagram, self._client = udp.recvfrom(READ_CHUNK)
            except OSError:
                return bytes(out)  # nothing more waiting
            self.bytes_received += len(datagram)
            data, replies = self.session.receive(datagram)
            out += data
            for reply in replies:
                self._send_datagram(reply)

    def _send_datagram(self, datagram: bytes) -> None:
        """One datagram to the host last heard from (lost if none, or if it has gone)."""
        sent = 0
        if self._udp is not None and self._client is not None:
            with contextlib.suppress(OSError):
                sent = self._udp.sendto(datagram, self._client)
        self.bytes_sent += sent
        self.bytes_dropped += len(datagram) - sent

    # --- truth -----------------------------------------------------------------------------

    def device_pose_at(self, t_s: float) -> AxisSample:
        """The camera side of the axes in device angles at monotonic `t_s`."""
        with self._lock:
            return self.mechanics.pose_at(t_s)

    def pose_at(self, t_s: float) -> HeadPose:
        """The camera's true joint angles and rates at monotonic `t_s` (for the renderer)."""
        return joint_pose(
            self.rig.head, self.device_pose_at(t_s), zoom_lens=bool(self.rig.camera.zoom_focal_px)
        )

    @property
    def settled(self) -> bool:
        """Nothing commanded is still to happen."""
        with self._lock:
            return self.mechanics.settled


def main(argv: list[str] | None = None) -> int:
    """`python -m gazed.sim.head_emulator --rig RIG`: serve the rig's head until SIGTERM/SIGINT."""
    parser = argparse.ArgumentParser(
        prog="python -m gazed.sim.head_emulator",
        description="Emulate the rig's pan/tilt head on a pty at its [servo] port.",
    )
    parser.add_argument("--rig", required=True, type=Path, help="rig description (TOML)")
    parser.add_argument("--link", help="symlink to create instead of the rig's [servo] port")
    args = parser.parse_args(argv)
    try:
        rig = load_rig(args.rig)
        emulator = HeadEmulator(rig, link=args.link)
    except (RigError, EmulatorError) as exc:
        print(exc, file=sys.stderr)
        return 2
    stopping = [False]  # set by the handler: no lock (one taken in a handler can deadlock)
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: stopping.__setitem__(0, True))
    try:
        with emulator:
            where = (
                f"udp {emulator.udp_address}"
                if emulator.udp_address
                else f"{emulator.pty_path} -> {emulator.link_path} at {rig.servo.baud} baud"
            )
            print(f"{rig.servo.protocol} head on {where}", flush=True)
            while not stopping[0]:
                time.sleep(0.1)
    except (OSError, EmulatorError) as exc:
        print(f"head emulator: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
