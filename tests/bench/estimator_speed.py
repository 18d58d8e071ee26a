"""Estimator speed: µs per step for one track (every mode, and filterpy's IMMEstimator on the
same three 6-state linear models as our IMM core), and track-steps per second in batch mode.

    python tests/bench/estimator_speed.py [--repeats 7]

Prints the median (and the best) of the wall time over repeats, and the load average before
and after: other work on the machine makes single runs noisy and slow, so figures compare
only between runs at a similar load.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable

import numpy as np
from filterpy.kalman import IMMEstimator, KalmanFilter

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.estimation.imm import ImmFilter
from gazed.estimation.kinematic_models import KinematicModelBank, kinematic_model

J = np.array([[0.96, 0.02, 0.02], [0.02, 0.96, 0.02], [0.02, 0.02, 0.96]])


def step_us(run: Callable[[int], None], steps: int, repeats: int) -> list[float]:
    """The time per step (µs) of run(steps), once per repeat."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run(steps)
        times.append((time.perf_counter() - start) / steps * 1e6)
    return times


def load() -> str:
    return "load average " + " ".join(f"{a:.2f}" for a in os.getloadavg())


def measurements(n: int, with_velocity: bool, seed: int = 0) -> list[Measurement]:
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        t = k * 0.04
        p = np.array([np.cos(0.3 * t), np.sin(0.3 * t)]) * 3 + rng.normal(0, 0.05, 2)
        v = np.array([-np.sin(0.3 * t), np.cos(0.3 * t)]) * 0.9 + rng.normal(0, 0.2, 2)
        if with_velocity:
            out.append(Measurement.ground(t, p, np.eye(2) * 0.0025, v, np.eye(2) * 0.04))
        else:
            out.append(Measurement.ground(t, p, np.eye(2) * 0.0025))
    return out


def mode_step_us(mode: str, with_velocity: bool, steps: int, repeats: int) -> list[float]:
    """µs per `update` of one track (10 untimed warm-up updates per repeat)."""
    data = measurements(steps + 10, with_velocity)
    times = []
    for _ in range(repeats):
        estimator = build_estimator(EstimatorSection(), mode=mode)
        for m in data[:10]:
            estimator.update(m)
        start = time.perf_counter()
        for m in data[10 : 10 + steps]:
            estimator.update(m)
        times.append((time.perf_counter() - start) / steps * 1e6)
    return times


def linear_imm_pair() -> tuple[IMMEstimator, ImmFilter, np.ndarray]:
    """filterpy's IMMEstimator and our IMM core on the same CP/CV/CA 6-state models."""
    bank = KinematicModelBank(
        (kinematic_model("CP", 0.04), kinematic_model("CV", 0.25), kinematic_model("CA", 0.25))
    )
    F, Q = bank.matrices(np.array(0.04))
    Q = Q + 1e-6 * np.eye(6)
    H = np.zeros((2, 6))
    H[0, 0] = H[1, 3] = 1.0
    R = np.eye(2) * 0.0025
    filters = []
    for m in range(3):
        kf = KalmanFilter(6, 2)
        kf.F, kf.Q, kf.H, kf.R = F[m], Q[m], H, R
        filters.append(kf)
    reference = IMMEstimator(filters, np.full(3, 1 / 3), J)

    class Models:
        names = bank.names

        def matrices(self, dt):
            return F[None], Q[None]

    ours = ImmFilter.empty(Models(), J, 1, 6, H={2: H})
    return reference, ours, R


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--steps", type=int, default=400)
    args = parser.parse_args()
    steps, repeats = args.steps, args.repeats

    print(load())
    print(f"one track, µs per update: median (best) of {repeats} runs of {steps} updates")
    for mode, with_velocity in [
        ("imm", True),
        ("imm", False),
        ("innovation", False),
        ("alphabeta", False),
        ("image-cv", False),
        ("cv", False),
        ("ca", False),
    ]:
        label = f"{mode} ({'position+velocity' if with_velocity else 'position'})"
        times = mode_step_us(mode, with_velocity, steps, repeats)
        print(f"  {label:<32} {statistics.median(times):8.1f} ({min(times):.1f})")

    reference, ours, R = linear_imm_pair()
    rng = np.random.default_rng(1)
    zs = rng.normal(0, 0.05, (steps, 2)) + np.arange(steps)[:, None] * 0.01

    def run_reference(n: int) -> None:
        for z in zs[:n]:
            reference.predict()
            reference.update(z)

    def run_ours(n: int) -> None:
        dt = np.array([0.04])
        for z in zs[:n]:
            ours.predict(slice(None), dt)
            ours.correct(slice(None), ours.innovate(slice(None), z[None], R[None]))

    ref_us, our_us = [], []
    for _ in range(repeats):  # interleaved, so that both see the same load
        ref_us += step_us(run_reference, steps, 1)
        our_us += step_us(run_ours, steps, 1)
    ref, ours_median = statistics.median(ref_us), statistics.median(our_us)
    print("IMM core, three 6-state linear models, one track, µs per predict+update")
    print(f"  filterpy IMMEstimator            {ref:8.1f} ({min(ref_us):.1f})")
    print(
        f"  gazed ImmFilter                  {ours_median:8.1f} ({min(our_us):.1f})"
        f"   {ref / ours_median:.1f}x faster"
    )

    print("batch: imm estimator step (position+velocity), track-steps per second: median (best)")
    for n in (1, 100, 10_000):
        times = batch_step_s(n, 50 if n < 10_000 else 10, 3 if n == 10_000 else repeats)
        per_step = statistics.median(times)
        print(
            f"  N = {n:>6}: {n / per_step:12.0f} ({n / min(times):.0f}) track-steps/s"
            f"  ({per_step * 1e3:.2f} ms per step)"
        )
    print(load())


def batch_step_s(n: int, steps: int, repeats: int) -> list[float]:
    """Seconds per `step` of n IMM tracks, once per repeat (10 warm-up steps not timed)."""
    data = measurements(10 + steps, True)
    z = np.stack([m.z for m in data])
    R = np.broadcast_to(data[0].R, (n, 4, 4))
    offsets = np.random.default_rng(2).normal(0, 5, (n, 1)) * [1, 1, 0, 0]
    times = []
    for _ in range(repeats):
        estimator = build_estimator(EstimatorSection(), n_tracks=n, mode="imm")
        for k in range(10 + steps):
            if k == 10:
                start = time.perf_counter()
            estimator.step(np.full(n, data[k].t_s), z[k] + offsets, R)
        times.append((time.perf_counter() - start) / steps)
    return times


if __name__ == "__main__":
    main()
