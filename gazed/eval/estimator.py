"""`gazed eval estimator`: score the estimation modes offline, without a bus.

- `--scenario rounded-square` (seed 000 §4.2, Table 1) and `--scenario kelly` (seed 003 §III,
  Table 3): seeded simulations scored against the papers' tables (`scenario_reports`).
- `--data FILE`: every track of a pedestrian file filtered causally; the prediction errors at
  each horizon (`track_prediction`), with its progress on a terminal (`progress`).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

from gazed.config import EstimatorSection, RigError, load_rig
from gazed.eval.pedestrians import TrackFileError
from gazed.eval.progress import EvalProgress
from gazed.eval.scenario_reports import kelly_report, rounded_square_report
from gazed.eval.track_prediction import BASELINES, DATA_FILTERS, data_report


def estimator_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--scenario",
        choices=("rounded-square", "kelly"),
        help="seeded simulation: rounded-square (seed 000 Table 1, imm) "
        "or kelly (seed 003 Table 3, innovation)",
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
    parser.add_argument(
        "--half",
        type=int,
        choices=(1, 2),
        help="with --data: score half of the tracks (alternate walkers in order of appearance) "
        "and fit cv-ml to the other half",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the simulated noise")
    parser.add_argument("--rig", type=Path, help="take the [estimator] settings from this rig file")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--plot", type=Path, help="write the run's figures (PNG) into this folder")


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
    if args.half is not None and (args.data is None or args.plot is not None):
        return _refuse("--half goes with --data, and without --plot (which draws the whole file)")
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
                "gazed eval estimator: --horizons: expected positive seconds like 0.4,0.8, "
                f"got {args.horizons!r}",
                file=sys.stderr,
            )
            return 2
        filters = len(DATA_FILTERS) if args.filter == "all" else 1
        try:
            with EvalProgress(len(BASELINES) + filters, args.json) as progress:
                noise_m = args.noise_m or 0.0
                report = data_report(
                    section,
                    args.data,
                    args.filter,
                    horizons,
                    noise_m,
                    args.seed,
                    progress.steps,
                    args.half,
                )
        except TrackFileError as exc:
            print(f"gazed eval estimator: {exc}", file=sys.stderr)
            return 2
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    if args.plot is not None:
        from gazed.plots.plot_cli import plot_estimator_run

        plot_estimator_run(args, section, args.plot)
    return 0


def format_report(report: dict[str, Any]) -> str:
    """A human-readable table of a report."""
    lines: list[str] = []
    if report.get("scenario") == "rounded-square":
        lines.append(
            f"rounded square, imm, seed {report['seed']}: "
            f"{report['observations']} observations at {report['period_s']} s"
        )
        lines.append(
            f"{'model':<6}{'true':<6}{'actual':>7}{'estim.':>7}  "
            f"{'p_CSD':>6}{'p_CS':>6}{'p_CD':>6}  "
            f"{'s_dot m/s2':>10}{'theta_dot rad/s':>16}"
        )
        for r in report["segments"]:
            p = r["mean_probability"]
            lines.append(
                f"{r['model']:<6}{r['true_model']:<6}{r['actual_obs']:>7}{r['estimated_obs']:>7}  "
                f"{p['CSD']:>6.3f}{p['CS']:>6.3f}{p['CD']:>6.3f}  "
                f"{r['mean_s_dot_m_s2']:>10.3f}{r['mean_theta_dot_rad_s']:>16.3f}"
            )
        d = report["switch_delay_obs"]
        tr = report["turn_rate_rad_s"]
        lines.append(
            f"switch delay: median {d['median']:g} obs, max {d['max']} obs; the ideal detector "
            f"at {d['threshold_nats']:.2f} nats: {d['ideal']} obs; observations to switch "
            f"{d['ratio_to_ideal']:.2f}x the ideal's"
        )
        lines.append(
            f"turn rate in CS segments: {tr['cs_segments']:.3f} rad/s (CS model) "
            f"vs {tr['true']:.3f} "
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
        results = {**results, **report["baselines"]}
        half = f" (half {report['half']})" if "half" in report else ""
        lines.append(
            f"{report['data']}{half}: {report['tracks']} tracks, added noise {report['noise_m']} m"
        )
        lines.append(
            f"{'predictor':<18}{'horizon s':>10}{'mean m':>9}{'median m':>10}{'p90 m':>8}{'n':>7}"
        )
        for name, r in results.items():
            for h, e in r["error_m"].items():
                lines.append(
                    f"{name:<18}{h:>10}{e['mean']:>9.3f}{e['median']:>10.3f}{e['p90']:>8.3f}{e['n']:>7}"
                )
        fit = report["baselines"]["cv-ml"]
        lines.append(
            f"cv-ml: q = {fit['q']:.3g} m²/s³, r = {fit['r']:.3g} m² (maximum likelihood on "
            f"{fit['fitted_on']})"
        )
    return "\n".join(lines)


def _fmt(value: float | None) -> str:
    return "   -   " if value is None else f"{value:+.4f}"
