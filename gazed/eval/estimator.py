"""`gazed eval estimator`: score the estimation modes offline, without a bus.

- `--scenario rounded-square` (seed 000 §4.2, Table 1): the IMM on a seeded rounded square,
  position and velocity measured; segments of most-likely model, switch delays, turn rate.
- `--scenario kelly` (seed 003 §III, Table 3): the innovation mode on rest / accelerate /
  constant / decelerate / rest; innovation means per phase and model against Table 3's terms.
- `--data FILE`: every track of a pedestrian file filtered causally (position only); at each
  step the prediction to each horizon is compared with the recorded position then.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from gazed.config import EstimatorSection, RigError, load_rig
from gazed.estimation import Measurement, build_estimator
from gazed.estimation.estimator import TRACKING
from gazed.estimation.ground_imm import ImmEstimator
from gazed.estimation.kinematic_estimator import KinematicEstimator
from gazed.eval.metrics import error_summary, segments, switch_delays
from gazed.eval.pedestrians import Track, TrackFileError, read_tracks
from gazed.eval.scenarios import kelly, rounded_square

DATA_FILTERS = ("imm", "cv", "ca", "alphabeta", "innovation")
TRUE_TURN_RATE_RAD_S = math.radians(45.0)


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


def track_errors(
    section: EstimatorSection,
    tracks: list[Track],
    mode: str,
    horizons_s: list[float],
    noise_m: float,
    seed: int,
) -> dict[str, Any]:
    """All tracks filtered at once (one batch row per track, aligned by their step index)."""
    n = len(tracks)
    estimator = build_estimator(section, n_tracks=n, mode=mode)
    rng = np.random.default_rng(seed)
    length = np.array([len(tr.t_s) for tr in tracks])
    steps = int(length.max())
    t = np.full((n, steps), np.nan)
    xy = np.full((n, steps, 2), np.nan)
    for i, tr in enumerate(tracks):
        t[i, : length[i]] = tr.t_s
        xy[i, : length[i]] = tr.xy_m
    z = xy + rng.normal(0.0, noise_m, xy.shape) if noise_m > 0 else xy
    R = np.broadcast_to(np.eye(2) * (section.position_noise_m**2 + noise_m**2), (n, 2, 2))
    errors: dict[float, list[np.ndarray]] = {h: [] for h in horizons_s}
    for k in range(steps):
        present = k < length
        estimator.step(t[:, k], np.nan_to_num(z[:, k]), R, present)
        if k == 0:
            continue
        for h in horizons_s:
            target_t = t[:, k] + h
            truth, known = _recorded(t, xy, length, target_t)
            use = (
                present
                & known
                & estimator.forecast(np.where(present, target_t, estimator.t_s)).valid
            )
            if not use.any():
                continue
            f = estimator.forecast(
                np.where(use, target_t, np.where(np.isfinite(estimator.t_s), estimator.t_s, 0.0))
            )
            errors[h].append(np.linalg.norm(f.position[use] - truth[use], axis=-1))
    return {
        "filter": mode,
        "tracks": n,
        "points": int(length.sum()),
        "error_m": {
            f"{h:g}": error_summary(np.concatenate(errors[h]) if errors[h] else np.array([]))
            for h in horizons_s
        },
    }


def _recorded(
    t: np.ndarray, xy: np.ndarray, length: np.ndarray, target_t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The recorded position of each track at target_t (linear between samples; rows of t are
    sorted, NaN-padded) and whether the track covers that time."""
    rows = np.arange(len(length))
    with np.errstate(invalid="ignore"):
        after = np.minimum(
            (t <= target_t[:, None] + 1e-9).sum(axis=1), length - 1
        )  # right neighbour
        before = np.maximum(after - 1, 0)
        t0, t1 = t[rows, before], t[rows, after]
        known = (t[:, 0] <= target_t) & (target_t <= t[rows, length - 1] + 1e-9)
        w = np.where(t1 > t0, (target_t - t0) / np.where(t1 > t0, t1 - t0, 1.0), 1.0)
    w = np.clip(np.nan_to_num(w), 0.0, 1.0)[:, None]
    return (1.0 - w) * xy[rows, before] + w * xy[rows, after], known


def data_report(
    section: EstimatorSection,
    path: Path,
    mode: str,
    horizons_s: list[float],
    noise_m: float,
    seed: int,
) -> dict[str, Any]:
    tracks = read_tracks(path)
    if mode == "all":
        results = {
            m: track_errors(section, tracks, m, horizons_s, noise_m, seed) for m in DATA_FILTERS
        }
        return {"data": str(path), "noise_m": noise_m, "tracks": len(tracks), "filters": results}
    return {
        "data": str(path),
        "noise_m": noise_m,
        **track_errors(section, tracks, mode, horizons_s, noise_m, seed),
    }


def estimator_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--scenario",
        choices=("rounded-square", "kelly"),
        help="seeded simulation: rounded-square (seed 000 Table 1, imm) or kelly (seed 003 Table 3, innovation)",
    )
    source.add_argument(
        "--data", type=Path, help="pedestrian track file: 'frame_id ped_id x y' lines"
    )
    parser.add_argument(
        "--filter",
        default="imm",
        choices=(*DATA_FILTERS, "all"),
        help="with --data: the mode to score, or all of them (default imm)",
    )
    parser.add_argument(
        "--horizons",
        default="0.4,0.8,1.2",
        help="with --data: prediction horizons in s, comma-separated",
    )
    parser.add_argument(
        "--noise-m",
        type=float,
        default=None,
        help="position noise std added to the measurements (m); default: none for --data, "
        "0.05 for rounded-square (velocity 0.2 m/s), 0.01 for kelly",
    )
    parser.add_argument(
        "--velocity-noise-m-s",
        type=float,
        default=None,
        help="with --scenario rounded-square: the velocity measurements' noise std (m/s; "
        "default 0.2)",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the simulated noise")
    parser.add_argument("--rig", type=Path, help="take the [estimator] settings from this rig file")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def _refuse(message: str) -> int:
    print(f"gazed eval estimator: {message}", file=sys.stderr)
    return 2


def estimator_command(args: argparse.Namespace) -> int:
    try:
        section = load_rig(args.rig).estimator if args.rig else EstimatorSection()
    except RigError as exc:
        print(exc, file=sys.stderr)
        return 2
    # a scenario's measurements need some noise (their covariance is the filter's R); the noise
    # added to recorded tracks may be none
    for option, value, zero_ok in (
        ("--noise-m", args.noise_m, args.data is not None),
        ("--velocity-noise-m-s", args.velocity_noise_m_s, False),
    ):
        if value is not None and not (
            math.isfinite(value) and (value > 0 or (zero_ok and value == 0))
        ):
            least = ">= 0" if zero_ok else "> 0"
            return _refuse(f"{option} must be a finite number {least}, got {value}")
    if args.velocity_noise_m_s is not None and args.scenario != "rounded-square":
        return _refuse("--velocity-noise-m-s goes with --scenario rounded-square")
    if args.scenario == "rounded-square":
        report = rounded_square_report(section, args.seed, args.noise_m, args.velocity_noise_m_s)
    elif args.scenario == "kelly":
        report = kelly_report(section, args.seed, args.noise_m)
    else:
        try:
            horizons = [float(h) for h in args.horizons.split(",")]
        except ValueError:
            horizons = []
        if not horizons or not all(math.isfinite(h) and h > 0 for h in horizons):
            print(
                f"gazed eval estimator: --horizons: expected positive seconds like 0.4,0.8, got {args.horizons!r}",
                file=sys.stderr,
            )
            return 2
        try:
            report = data_report(
                section, args.data, args.filter, horizons, args.noise_m or 0.0, args.seed
            )
        except TrackFileError as exc:
            print(f"gazed eval estimator: {exc}", file=sys.stderr)
            return 2
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    return 0


def format_report(report: dict[str, Any]) -> str:
    """A human-readable table of a report."""
    lines: list[str] = []
    if report.get("scenario") == "rounded-square":
        lines.append(
            f"rounded square, imm, seed {report['seed']}: {report['observations']} observations at {report['period_s']} s"
        )
        lines.append(
            f"{'model':<6}{'true':<6}{'actual':>7}{'estim.':>7}  {'p_CSD':>6}{'p_CS':>6}{'p_CD':>6}  {'s_dot m/s2':>10}{'theta_dot rad/s':>16}"
        )
        for r in report["segments"]:
            p = r["mean_probability"]
            lines.append(
                f"{r['model']:<6}{r['true_model']:<6}{r['actual_obs']:>7}{r['estimated_obs']:>7}  "
                f"{p['CSD']:>6.3f}{p['CS']:>6.3f}{p['CD']:>6.3f}  {r['mean_s_dot_m_s2']:>10.3f}{r['mean_theta_dot_rad_s']:>16.3f}"
            )
        d = report["switch_delay_obs"]
        tr = report["turn_rate_rad_s"]
        lines.append(f"switch delay: median {d['median']:g} obs, max {d['max']} obs")
        lines.append(
            f"turn rate in CS segments: {tr['cs_segments']:.3f} rad/s (CS model) vs {tr['true']:.3f} "
            f"true: relative error {report['turn_rate_rel_error']:.1%}; IMM combined "
            f"{tr['cs_segments_combined']:.3f} ({report['turn_rate_rel_error_combined']:.1%})"
        )
    elif report.get("scenario") == "kelly":
        lines.append(f"kelly, innovation, seed {report['seed']}, T = {report['period_s']} s")
        lines.append(f"{'phase':<11}{'selected':>9}   innovation mean (Table 3 expected) m")
        for ph in report["phases"]:
            cells = "  ".join(
                f"{n} {_fmt(ph['innovation_mean_m'][n])} ({_fmt(ph['table3_expected_m'][n])})"
                for n in ph["innovation_mean_m"]
            )
            lines.append(f"{ph['phase']:<11}{ph['selected'] or '-':>9}   {cells}")
    else:
        results = report["filters"] if "filters" in report else {report["filter"]: report}
        lines.append(
            f"{report['data']}: {report['tracks']} tracks, added noise {report['noise_m']} m"
        )
        lines.append(
            f"{'filter':<11}{'horizon s':>10}{'mean m':>9}{'median m':>10}{'p90 m':>8}{'n':>7}"
        )
        for name, r in results.items():
            for h, e in r["error_m"].items():
                lines.append(
                    f"{name:<11}{h:>10}{e['mean']:>9.3f}{e['median']:>10.3f}{e['p90']:>8.3f}{e['n']:>7}"
                )
    return "\n".join(lines)


def _fmt(value: float | None) -> str:
    return "   -   " if value is None else f"{value:+.4f}"
