"""Seeded test motions with their ground truth.

- rounded square (seed 000 §4.2): straight for 50 observations, then 50 turning at 45°/s,
  repeated; constant speed; T = 0.04 s.
- kelly (seed 003 §III, Fig. 1): at rest, accelerating from k = 30 to k = 60 up to 5 m/s,
  constant speed to k = 90, decelerating to rest at k = 120, at rest after; T = 0.25 s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Scenario:
    """Truth and noisy measurements at times t_s (K,).

    truth: (K, 6) [X, Y, s, θ, ṡ, θ̇] at each observation, with the rates of the motion that
    follows it; phase (K,) the motion that led to each observation (the first observation
    takes the first motion's label), which is what observation k can show;
    z_position (K, 2), z_velocity (K, 2) noisy measurements with stds position_noise_m,
    velocity_noise_m_s.
    """

    name: str
    t_s: np.ndarray
    truth: np.ndarray
    phase: np.ndarray
    z_position: np.ndarray
    z_velocity: np.ndarray
    position_noise_m: float
    velocity_noise_m_s: float


def rounded_square(
    seed: int = 0,
    *,
    repeats: int = 4,
    straight_steps: int = 50,
    turn_steps: int = 50,
    period_s: float = 0.04,
    speed_m_s: float = 1.0,
    turn_rate_rad_s: float = math.radians(45.0),
    position_noise_m: float = 0.05,
    velocity_noise_m_s: float = 0.2,
) -> Scenario:
    """The "rounded square" of seed 000 §4.2 (straight: CSD, turning: CS)."""
    labels = (["CSD"] * straight_steps + ["CS"] * turn_steps) * repeats
    n = len(labels)
    truth = np.zeros((n, 6))
    x, y, th = 0.0, 0.0, 0.0
    for k, label in enumerate(labels):
        w = turn_rate_rad_s if label == "CS" else 0.0
        truth[k] = (x, y, speed_m_s, math.remainder(th, 2 * math.pi), 0.0, w)
        # exact constant-speed, constant-turn-rate step to the next observation
        if w == 0.0:
            x += speed_m_s * math.cos(th) * period_s
            y += speed_m_s * math.sin(th) * period_s
        else:
            x += speed_m_s / w * (math.sin(th + w * period_s) - math.sin(th))
            y += speed_m_s / w * (math.cos(th) - math.cos(th + w * period_s))
        th += w * period_s
    return _measured(
        "rounded-square", truth, labels, period_s, seed, position_noise_m, velocity_noise_m_s
    )


def kelly(
    seed: int = 0,
    *,
    steps: int = 150,
    period_s: float = 0.25,
    top_speed_m_s: float = 5.0,
    position_noise_m: float = 0.01,
    velocity_noise_m_s: float = 0.2,
) -> Scenario:
    """Seed 003 §III: rest, accelerate (k 30-60), constant 5 m/s (60-90), decelerate (90-120),
    rest; along +X."""
    accel = top_speed_m_s / (30 * period_s)
    truth = np.zeros((steps, 6))
    labels = []
    x, v = 0.0, 0.0
    for k in range(steps):
        if 30 <= k < 60:
            a, label = accel, "accelerate"
        elif 60 <= k < 90:
            a, label = 0.0, "constant"
        elif 90 <= k < 120:
            a, label = -accel, "decelerate"
        else:
            a, label = 0.0, "rest"
        truth[k] = (x, 0.0, v, 0.0, a, 0.0)
        labels.append(label)
        x += v * period_s + a * period_s**2 / 2.0
        v += a * period_s
    return _measured("kelly", truth, labels, period_s, seed, position_noise_m, velocity_noise_m_s)


def _measured(
    name: str,
    truth: np.ndarray,
    labels: list[str],
    period_s: float,
    seed: int,
    position_noise_m: float,
    velocity_noise_m_s: float,
) -> Scenario:
    rng = np.random.default_rng(seed)
    n = len(truth)
    labels = labels[:1] + labels[:-1]  # observation k shows the motion of (k-1, k]
    velocity = truth[:, 2:3] * np.stack([np.cos(truth[:, 3]), np.sin(truth[:, 3])], axis=-1)
    return Scenario(
        name,
        np.arange(n) * period_s,
        truth,
        np.array(labels),
        truth[:, :2] + rng.normal(0.0, position_noise_m, (n, 2)),
        velocity + rng.normal(0.0, velocity_noise_m_s, (n, 2)),
        position_noise_m,
        velocity_noise_m_s,
    )
