"""The systemd side: the unit lints clean, the notify protocol speaks to a fake NOTIFY_SOCKET."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import NotifySocket, poll_until

from gazed.sdnotify import Notifier

REPO = Path(__file__).resolve().parents[1]
UNIT = REPO / "deploy" / "gazed@.service"


def test_unit_lints_clean_with_systemd_analyze(tmp_path: Path) -> None:
    analyze = shutil.which("systemd-analyze")
    if analyze is None:
        pytest.skip("systemd-analyze is not installed (Debian package: systemd)")
    if shutil.which("unshare") is None or os.geteuid() != 0:
        pytest.skip(
            "needs root and unshare to install `gazed` into /usr/local/bin "
            "inside a private mount namespace"
        )
    gazed = Path(sys.executable).parent / "gazed"
    assert gazed.exists(), "the gazed console script is not installed beside this Python"
    instance = tmp_path / "gazed@lab.service"
    shutil.copy(UNIT, instance)
    # As the README's install steps do: `gazed` on systemd's executable search path. The tmpfs
    # lives only in this private mount namespace.
    script = (
        "mount -t tmpfs tmpfs /usr/local/bin && "
        f"ln -s {gazed} /usr/local/bin/gazed && "
        f"exec {analyze} verify {instance}"
    )
    result = subprocess.run(
        ["unshare", "--mount", "sh", "-c", script], capture_output=True, text=True
    )
    assert result.stderr == ""
    assert result.returncode == 0


def test_unit_has_the_settings_the_design_asks_for() -> None:
    text = UNIT.read_text()
    for line in (
        "Type=notify",
        "ExecStart=gazed run /etc/gazed/%i.toml",
        "Restart=on-failure",
        "NoNewPrivileges=yes",
        "ProtectSystem=strict",
        "PrivateTmp=yes",
        "SupplementaryGroups=dialout",
        "StandardOutput=journal",
    ):
        assert line in text.splitlines()
    assert any(line.startswith("WatchdogSec=") for line in text.splitlines())


def test_notifier_sends_datagrams(tmp_path: Path) -> None:
    sock = NotifySocket(tmp_path / "n.sock")
    try:
        notifier = Notifier({"NOTIFY_SOCKET": str(sock.path), "WATCHDOG_USEC": "3000000"})
        assert notifier.enabled and notifier.watchdog_interval_s == 1.5
        notifier.ready("all up")
        notifier.watchdog()
        notifier.stopping("bye")
        poll_until(lambda: "STOPPING=1" in sock.messages, 5.0)
        assert sock.messages == [
            "READY=1",
            "STATUS=all up",
            "WATCHDOG=1",
            "STOPPING=1",
            "STATUS=bye",
        ]
    finally:
        sock.close()


def test_notifier_abstract_socket_and_absent_systemd() -> None:
    assert Notifier({}).notify("READY=1") is False
    assert Notifier({}).watchdog_interval_s is None
    assert Notifier({"WATCHDOG_USEC": "1000000", "WATCHDOG_PID": "1"}).watchdog_interval_s is None
    abstract = Notifier({"NOTIFY_SOCKET": "@gazed-test-nobody-listens"})
    assert abstract.enabled
    assert abstract.notify("READY=1") is False  # nobody bound it: reported, not raised
