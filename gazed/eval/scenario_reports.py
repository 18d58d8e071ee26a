"""Estimation modes scored on seeded scenarios against the papers' tables.

- rounded square (seed 000 §4.2, Table 1): the IMM with position and velocity measured;
  segments of most-likely model, switch delays beside the ideal detector's, turn rate.
- kelly (seed 003 §III, Table 3): the innovation mode on rest / accelerate / constant /
  decelerate / rest; innovation means per phase and model against Table 3's terms.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.estimation.estimator import TRACKING
from gazed.estimation.ground_imm import ImmEstimator
from gazed.estimation.kinematic_estimator import KinematicEstimator
from gazed.eval.metrics import segments, switch_delays
from gazed.eval.scenarios import kelly, rounded_square

TRUE_TURN_RATE_RAD_S = math.radians(45.0)


def turn_evidence_nats(
    observations: int,
    speed_m_s: float,
    turn_rate_rad_s: float,
    period_s: float,
    position_noise_m: float,
    velocity_noise_m_s: float,
) -> np.ndarray:
    """The expected log-likelihood ratio (nats) for a turn against going straight (or the
    reverse) after 1..observations observations, for a detector that knows the state at the
    switch, both motions and the switch's time (docs/estimation.md, "How fast the switch can
    be"): Σ_k |Δp_k|²/2σ_p² + |Δv_k|²/2σ_v², where after t = kT the two paths differ by
    Δp = (s/ω) |(sin ωt - ωt, 1 - cos ωt)| and Δv = 2 s sin(ωt/2)."""
    u = turn_rate_rad_s * period_s * np.arange(1, observations + 1)
    dp = speed_m_s / turn_rate_rad_s * np.hypot(np.sin(u) - u, 1.0 - np.cos(u))
    dv = 2.0 * speed_m_s * np.sin(u / 2.0)
    return np.cumsum(dp**2 / (2 * position_noise_m**2) + dv**2 / (2 * velocity_noise_m_s**2))


def ideal_switch_delay_obs(threshold_nats: float, **motion: float) -> int:
    """The delay (in the convention of `switch_delays`: 0 = on the first observation of the
    new motion) at which the ideal detector's expected evidence first reaches threshold_nats;
    `motion` as `turn_evidence_nats` takes it."""
    evidence = turn_evidence_nats(1000, **motion)
    reached = np.flatnonzero(evidence >= threshold_nats)
    return int(reached[0]) if len(reached) else len(evidence)


def switch_threshold_nats(stay_probability: float, n_models: int) -> float:
    """The IMM's prior odds against one switch, ln(J_d / J_ij): the evidence at which the new
    model's probability overtakes the old one's in a step."""
    return math.log(stay_probability * (n_models - 1) / (1.0 - stay_probability))


def rounded_square_report(
    section: EstimatorSection,
    seed: int,
    noise_m: float | None,
    velocity_noise_m_s: float | None = None,
) -> dict[str, Any]:
    """Table 1 of seed 000 for the IMM: one row per segment of the most likely model."""
    noises = {"position_noise_m": noise_m, "velocity_noise_m_s": velocity_noise_m_s}
    scenario = rounded_square(seed, **{k: v for k, v in noises.items() if v is not None})
    estimator = build_estimator(section, mode="imm")
    assert isinstance(estimator, ImmEstimator)
    p_var = scenario.position_noise_m**2
    v_var = scenario.velocity_noise_m_s**2
    names = estimator.model_names
    probabilities, combined, own, likely = [], [], [], []
    for t, p, v in zip(scenario.t_s, scenario.z_position, scenario.z_velocity, strict=True):
        estimator.update(Measurement.ground(t, p, np.eye(2) * p_var, v, np.eye(2) * v_var))
        probabilities.append(estimator.probabilities[0].copy())
        x, _ = estimator.combined_state()
        combined.append(x[0, 4:6].copy())
        own.append(np.concatenate(estimator.model_rates()))
        likely.append(estimator.most_likely())
    probabilities_a, combined_a, own_a = np.array(probabilities), np.array(combined), np.array(own)
    truth = list(scenario.phase)
    true_segments = segments(truth)

    def summary(start: int, stop: int) -> dict[str, Any]:
        return {
            "mean_probability": {
                n: round(float(probabilities_a[start:stop, i].mean()), 3)
                for i, n in enumerate(names)
            },
            "mean_s_dot_m_s2": round(float(own_a[start:stop, 0].mean()), 4),
            "mean_theta_dot_rad_s": round(float(own_a[start:stop, 1].mean()), 4),
            "combined_s_dot_m_s2": round(float(combined_a[start:stop, 0].mean()), 4),
            "combined_theta_dot_rad_s": round(float(combined_a[start:stop, 1].mean()), 4),
        }

    rows = []
    for seg in segments(likely):
        overlap = [min(seg.stop, t.stop) - max(seg.start, t.start) for t in true_segments]
        true = true_segments[int(np.argmax(overlap))]
        rows.append(
            {
                "model": seg.label,
                "start_obs": seg.start,
                "estimated_obs": seg.length,
                "true_model": true.label,
                "actual_obs": true.length,
                **summary(seg.start, seg.stop),
            }
        )
    delays = switch_delays(truth, likely)
    threshold = switch_threshold_nats(section.stay_probability, len(names))
    ideal = ideal_switch_delay_obs(
        threshold,
        speed_m_s=float(scenario.truth[0, 2]),
        turn_rate_rad_s=TRUE_TURN_RATE_RAD_S,
        period_s=float(scenario.t_s[1] - scenario.t_s[0]),
        position_noise_m=scenario.position_noise_m,
        velocity_noise_m_s=scenario.velocity_noise_m_s,
    )
    in_cs = np.array([m == "CS" for m in likely])
    own_turn = float(own_a[in_cs, 1].mean()) if in_cs.any() else 0.0
    combined_turn = float(combined_a[in_cs, 1].mean()) if in_cs.any() else 0.0
    return {
        "scenario": "rounded-square",
        "filter": "imm",
        "seed": seed,
        "observations": len(truth),
        "period_s": float(scenario.t_s[1] - scenario.t_s[0]),
        "position_noise_m": scenario.position_noise_m,
        "velocity_noise_m_s": scenario.velocity_noise_m_s,
        "stay_probability": section.stay_probability,
        "segments": rows,
        "true_segments": [
            {
                "model": t.label,
                "start_obs": t.start,
                "actual_obs": t.length,
                **summary(t.start, t.stop),
            }
            for t in true_segments
        ],
        "switch_delay_obs": {
            "median": float(np.median(delays)),
            "max": int(max(delays)),
            "all": delays,
            "ideal": ideal,
            "threshold_nats": threshold,
            "ratio_to_ideal": (float(np.median(delays)) + 1.0) / (ideal + 1.0),
        },
        "turn_rate_rad_s": {
            "true": TRUE_TURN_RATE_RAD_S,
            "cs_segments": own_turn,
            "cs_segments_combined": combined_turn,
        },
        "turn_rate_rel_error": abs(own_turn - TRUE_TURN_RATE_RAD_S) / TRUE_TURN_RATE_RAD_S,
        "turn_rate_rel_error_combined": abs(combined_turn - TRUE_TURN_RATE_RAD_S)
        / TRUE_TURN_RATE_RAD_S,
        "accuracy": float(np.mean(np.array(likely) == np.array(truth))),
    }


def kelly_report(section: EstimatorSection, seed: int, noise_m: float | None) -> dict[str, Any]:
    """Table 3 of seed 003: per phase and model, the mean innovation measured and its two terms
    H Ã E[e(k|k)] (filter error) and H ΔÃ x(k) (model error: CP Tẋ + T²ẍ/2, CV T²ẍ/2, CA 0)."""
    scenario = kelly(seed, position_noise_m=0.01 if noise_m is None else noise_m)
    estimator = build_estimator(section, mode="innovation")
    assert isinstance(estimator, KinematicEstimator) and estimator.selector is not None
    T = float(scenario.t_s[1] - scenario.t_s[0])
    names = estimator.model_names
    F_model, _ = estimator.bank.matrices(np.array(T))  # Ã per model (M, 6, 6)
    A_true = np.array([[1.0, T, T * T / 2], [0.0, 1.0, T], [0.0, 0.0, 1.0]])
    R = np.eye(2) * scenario.position_noise_m**2
    innovations = np.full((len(scenario.t_s), len(names)), np.nan)
    filter_term = np.full_like(innovations, np.nan)
    model_term = np.full_like(innovations, np.nan)
    selected: list[str | None] = []
    previous_x: np.ndarray | None = None
    for k, (t, p) in enumerate(zip(scenario.t_s, scenario.z_position, strict=True)):
        outcome = estimator.update(Measurement.ground(t, p, R))
        truth_prev = (
            np.array([scenario.truth[k - 1, 0], scenario.truth[k - 1, 2], scenario.truth[k - 1, 4]])
            if k
            else None
        )
        if outcome.name == "ACCEPTED" and previous_x is not None and truth_prev is not None:
            innovations[k] = estimator.selector.latest()[:, 0]
            for m in range(len(names)):
                At = F_model[m, :3, :3]
                filter_term[k, m] = (At @ (truth_prev - previous_x[m]))[0]
                model_term[k, m] = ((A_true - At) @ truth_prev)[0]
        previous_x = estimator.x[0, :, :3].copy() if estimator.status[0] == TRACKING else None
        selected.append(estimator.most_likely() if estimator.status[0] == TRACKING else None)
    phases = []
    for seg in segments(list(scenario.phase)):
        span = slice(seg.start, seg.stop)  # ν(k) shows the motion of (k-1, k], phase[k]
        chosen = [s for s in selected[seg.start : seg.stop] if s is not None]
        counts = {n: chosen.count(n) for n in names}
        phases.append(
            {
                "phase": seg.label,
                "k": [seg.start, seg.stop],
                "selected": max(counts, key=lambda n: counts[n]) if chosen else None,
                "selected_fraction": {
                    n: round(c / max(len(chosen), 1), 3) for n, c in counts.items()
                },
                "innovation_mean_m": {n: _mean(innovations[span, i]) for i, n in enumerate(names)},
                "table3_filter_term_m": {
                    n: _mean(filter_term[span, i]) for i, n in enumerate(names)
                },
                "table3_model_term_m": {n: _mean(model_term[span, i]) for i, n in enumerate(names)},
                "table3_expected_m": {
                    n: _mean(filter_term[span, i] + model_term[span, i])
                    for i, n in enumerate(names)
                },
            }
        )
    return {
        "scenario": "kelly",
        "filter": "innovation",
        "seed": seed,
        "period_s": T,
        "position_noise_m": scenario.position_noise_m,
        "selection_window": section.selection_window,
        "phases": phases,
    }


def _mean(values: np.ndarray) -> float | None:
    values = values[np.isfinite(values)]
    return round(float(values.mean()), 5) if len(values) else None
