"""Recent positions of one tracked image point, and its velocity from them.

Positions are kept in the current frame's pixel coordinates: when a new frame comes, the stored
ones are moved by the head's rotation (`HeadStep.transport`), as a point fixed in the world
would move. What is left of their motion is the target's own, so the least-squares slope of
u(t), v(t) is its independent image velocity (seed 000 §2, `ṙ_ind`).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from gazed.vision.ego_motion import HeadStep


class PositionHistory:
    def __init__(self, length: int) -> None:
        if length < 2:
            raise ValueError(f"a velocity needs at least 2 positions (length = {length})")
        self._points: deque[tuple[float, float, float]] = deque(maxlen=length)

    def __len__(self) -> int:
        return len(self._points)

    def transport(self, step: HeadStep) -> None:
        """Move the stored positions into the next frame's coordinates."""
        self._points = deque(
            ((t, *step.transport(u, v)) for t, u, v in self._points), maxlen=self._points.maxlen
        )

    def add(self, t_s: float, u_px: float, v_px: float, gate_px: float = np.inf) -> None:
        """Append a position; one further than `gate_px` from where the stored ones predict it
        is taken for another object and starts the history afresh."""
        last = self._points[-1] if self._points else None
        if last is not None:
            du, dv = self.velocity() or (0.0, 0.0)
            dt = t_s - last[0]
            miss = np.hypot(u_px - last[1] - du * dt, v_px - last[2] - dv * dt)
            if miss > gate_px:
                self._points.clear()
        self._points.append((t_s, u_px, v_px))

    def velocity(self) -> tuple[float, float] | None:
        """Least-squares slope (px/s) of the stored positions; None with fewer than two."""
        if len(self._points) < 2:
            return None
        t, u, v = (np.array(c) for c in zip(*self._points, strict=True))
        t = t - t.mean()
        denominator = float(t @ t)
        if denominator <= 0.0:
            return None
        return float(t @ (u - u.mean()) / denominator), float(t @ (v - v.mean()) / denominator)

    def last(self) -> tuple[float, float, float] | None:
        return self._points[-1] if self._points else None

    def clear(self) -> None:
        self._points.clear()
