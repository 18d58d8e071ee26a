"""A camera that takes raw VISCA over TCP (PTZOptics, port 5678) for tests: a loopback TCP
port bridged to the emulated head's pty, so a rig's `socket://127.0.0.1:PORT` reaches the one
VISCA emulator through pyserial's socket transport. `drop()` cuts the connection; while
`refusing`, a connection is accepted and closed at once (the camera's port is up, its VISCA
service is not), and each attempt's time is kept."""

from __future__ import annotations

import contextlib
import os
import selectors
import socket
import threading
import time
import tty
from pathlib import Path


class TcpBridge:
    """TCP on 127.0.0.1 (a free port) to the pty at `pty_path`, one connection at a time."""

    def __init__(self, pty_path: Path) -> None:
        self.pty_path = pty_path
        self.refusing = False
        self.attempts_s: list[float] = []  # when each connection came (monotonic)
        self._server = socket.create_server(("127.0.0.1", 0))
        self.port = int(self._server.getsockname()[1])
        self._client: socket.socket | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="tcp-bridge", daemon=True)

    @property
    def url(self) -> str:
        return f"socket://127.0.0.1:{self.port}"

    def __enter__(self) -> TcpBridge:
        self._thread.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self._stop.set()
        self.drop()
        self._server.close()
        self._thread.join(timeout=2.0)

    def drop(self) -> None:
        """Close the connection in use (the camera's end), if any."""
        client, self._client = self._client, None
        if client is not None:
            with contextlib.suppress(OSError):
                client.shutdown(socket.SHUT_RDWR)
            client.close()

    def _serve(self) -> None:
        self._server.settimeout(0.05)
        while not self._stop.is_set():
            try:
                client, _ = self._server.accept()
            except (TimeoutError, OSError):
                continue
            self.attempts_s.append(time.monotonic())
            if self.refusing:
                client.close()
                continue
            self._client = client
            self._pump(client)

    def _pump(self, client: socket.socket) -> None:
        """Bytes both ways until either end closes."""
        fd = os.open(self.pty_path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(fd)
        try:
            with selectors.DefaultSelector() as selector:
                selector.register(client, selectors.EVENT_READ)
                selector.register(fd, selectors.EVENT_READ)
                while not self._stop.is_set() and self._client is client:
                    for key, _ in selector.select(timeout=0.05):
                        if key.fileobj is client:
                            data = client.recv(4096)
                            if not data:
                                return
                            os.write(fd, data)
                        else:
                            client.sendall(os.read(fd, 4096))
        except OSError:
            return
        finally:
            os.close(fd)
            self.drop()
