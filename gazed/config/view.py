"""`[view]`: the live view in the browser (`gazed view`, and `gazed run` when the rig has it).

The page listens on loopback unless the rig names another address, and then only behind a
password. The password itself is never in the rig: the rig names a file (not readable by other
users, as the bus credentials) or an environment variable that holds it.
"""

from __future__ import annotations

import os
from pathlib import Path

from pydantic import Field, model_validator

from gazed.config.bus import LOOPBACK_HOSTS
from gazed.config.section import Section


class ViewError(ValueError):
    """The view's password cannot be read."""


class ViewSection(Section):
    port: int = Field(8091, ge=1, le=65535, description="TCP port of the page.")
    host: str = Field(
        "127.0.0.1",
        min_length=1,
        description="Address the page listens on: loopback unless the rig says otherwise; any "
        "other address needs password_file or password_env.",
    )
    password_file: Path | None = Field(
        None,
        description="File whose first line is the page's password (HTTP basic auth, any user "
        "name); not readable by other users. Relative paths are from the rig file.",
    )
    password_env: str | None = Field(
        None,
        pattern=r"^[A-Za-z_][A-Za-z0-9_]*$",
        description="Environment variable holding the page's password (instead of a file).",
    )
    jpeg_quality: int = Field(75, ge=10, le=100, description="JPEG quality of the frames sent.")
    state_rate_hz: float = Field(
        10.0, gt=0, le=100, description="How often the overlays and plots are sent."
    )

    @property
    def loopback(self) -> bool:
        return self.host in LOOPBACK_HOSTS or self.host == "::1"

    @model_validator(mode="after")
    def _password_beyond_loopback(self) -> ViewSection:
        if self.password_file is not None and self.password_env is not None:
            raise ValueError("give one of password_file and password_env, not both")
        if not self.loopback and self.password_file is None and self.password_env is None:
            raise ValueError(
                f"host: {self.host!r} is beyond loopback: set password_file or password_env "
                "(expected a password for any address but 127.0.0.1, ::1 or localhost)"
            )
        return self

    def password(self, folder: Path) -> str | None:
        """The page's password (None: no password, loopback only); raises `ViewError` if the file
        or variable named cannot give one. A relative file is taken from `folder`."""
        if self.password_env is not None:
            value = os.environ.get(self.password_env, "")
            if not value:
                raise ViewError(f"view.password_env: ${self.password_env} is not set or empty")
            return value
        if self.password_file is None:
            return None
        path = (
            self.password_file if self.password_file.is_absolute() else folder / self.password_file
        )
        try:
            mode = path.stat().st_mode
            lines = path.read_text(encoding="utf-8").splitlines()
        except (OSError, UnicodeDecodeError) as exc:
            raise ViewError(f"view.password_file: cannot read {path}: {exc}") from exc
        if mode & 0o007:
            raise ViewError(
                f"view.password_file: {path} is open to every user (mode {mode & 0o777:o}); "
                "chmod o-rwx it"
            )
        if not lines or not lines[0].strip():
            raise ViewError(f"view.password_file: {path} is empty")
        return lines[0].strip()
