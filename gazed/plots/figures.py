"""The four figures of a run, in the manner of seed 000's Figs. 12–15: plain lines, one
quantity per panel, the models told apart by line style as the paper does (solid, dashed,
dotted).

Each function takes plain data (`RunSeries`) and returns a matplotlib `Figure` built without
pyplot, so nothing depends on a display or a global backend; `None` when the run has no data
for it. `write_figures` saves those that exist as PNG files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from gazed.plots.series import RunSeries

LINE_STYLES = ("-", "--", ":", "-.")
WIDTH_IN, HEIGHT_IN, DPI = 7.0, 4.5, 110


def trajectory_figure(run: RunSeries) -> Figure | None:
    """The ground-plane trajectory: the truth, the estimates and the predictions (Fig. 15c)."""
    if run.estimate_xy_m is None and run.truth_xy_m is None:
        return None
    figure = Figure(figsize=(WIDTH_IN, WIDTH_IN * 0.8), dpi=DPI)
    axes = figure.add_subplot()
    if run.truth_xy_m is not None:
        axes.plot(*run.truth_xy_m.T, "-", color="0.6", linewidth=3, label="truth")
    if run.estimate_xy_m is not None:
        axes.plot(*run.estimate_xy_m.T, "-", color="k", linewidth=1, label="estimate")
    if run.prediction_xy_m is not None:
        horizon = f" ({run.prediction_horizon_s:.2f} s ahead)" if run.prediction_horizon_s else ""
        axes.plot(
            *run.prediction_xy_m.T, ":", color="tab:red", linewidth=1, label=f"prediction{horizon}"
        )
    axes.set_aspect("equal", adjustable="datalim")
    axes.set_xlabel("X (m)")
    axes.set_ylabel("Y (m)")
    axes.set_title(f"{run.title}: ground-plane trajectory")
    axes.legend(loc="best", fontsize="small")
    axes.grid(True, alpha=0.3)
    return figure


def gaze_error_figure(run: RunSeries) -> Figure | None:
    """The gaze error over time with the saccades and the gaze's state changes marked
    (Fig. 15b)."""
    if run.error_t_s is None or run.error_deg is None:
        return None
    figure = Figure(figsize=(WIDTH_IN, HEIGHT_IN), dpi=DPI)
    axes = figure.add_subplot()
    axes.plot(run.error_t_s, run.error_deg, "-", color="k", linewidth=1, label="gaze error")
    if run.fovea_half_deg is not None:
        axes.axhline(run.fovea_half_deg, color="0.5", linestyle="--", linewidth=1, label="fovea")
    for k, t_s in enumerate(run.saccade_t_s):
        axes.axvline(t_s, color="tab:red", linewidth=1, label="saccade" if k == 0 else None)
    top = float(np.nanmax(run.error_deg)) if len(run.error_deg) else 1.0
    for t_s, state in run.state_changes:
        axes.axvline(t_s, color="0.7", linestyle=":", linewidth=1)
        axes.annotate(state, (t_s, top), rotation=90, fontsize="x-small", va="top", ha="right")
    axes.set_xlabel("time (s)")
    axes.set_ylabel("gaze error (deg)")
    axes.set_title(f"{run.title}: gaze error")
    axes.set_ylim(bottom=0)
    axes.legend(loc="upper right", fontsize="small")
    return figure


def model_probabilities_figure(run: RunSeries) -> Figure | None:
    """The probability of each motion model and the most likely one over time (Figs. 12–14,
    a and b)."""
    if run.model_t_s is None or not run.model_probabilities:
        return None
    names = list(run.model_probabilities)
    stacked = np.vstack([run.model_probabilities[n] for n in names])
    figure = Figure(figsize=(WIDTH_IN, HEIGHT_IN), dpi=DPI)
    top, bottom = figure.subplots(2, 1, sharex=True, height_ratios=(2, 1))
    for k, name in enumerate(names):
        top.plot(
            run.model_t_s,
            run.model_probabilities[name],
            LINE_STYLES[k % len(LINE_STYLES)],
            color="k",
            linewidth=1,
            label=name,
        )
    top.set_ylim(-0.02, 1.02)
    top.set_ylabel("probability")
    top.set_title(f"{run.title}: model probabilities")
    top.legend(loc="upper right", fontsize="small")
    bottom.step(run.model_t_s, np.argmax(stacked, axis=0), where="post", color="k", linewidth=1)
    bottom.set_yticks(range(len(names)), names)
    bottom.set_ylim(-0.5, len(names) - 0.5)
    bottom.set_ylabel("most likely")
    bottom.set_xlabel("time (s)")
    return figure


def latency_figure(run: RunSeries) -> Figure | None:
    """A histogram of the latency of each hop of the loop (from the commands' stamps), in the
    order of the loop, each up to its 99th percentile."""
    hops = {stage: values for stage, values in run.hops_ms.items() if values}
    if not hops:
        return None
    figure = Figure(figsize=(WIDTH_IN, 1.0 + 0.9 * len(hops)), dpi=DPI)
    panels = figure.subplots(len(hops), 1, squeeze=False)[:, 0]
    for axes, (stage, values) in zip(panels, hops.items(), strict=True):
        data = np.asarray(values)
        p50, p99 = np.percentile(data, [50, 99])
        low = float(data.min())
        # up to the 99th percentile, so that a few late ones do not squash the rest
        axes.hist(data, bins=40, range=(low, max(float(p99), low + 1e-3)), color="0.4")
        axes.set_ylabel(stage, rotation=0, ha="right", va="center", fontsize="small")
        axes.set_yticks([])
        axes.annotate(
            f"p50 {p50:.2f}  p99 {p99:.2f}  max {data.max():.1f} ms",
            (0.99, 0.8),
            xycoords="axes fraction",
            ha="right",
            fontsize="x-small",
        )
    panels[0].set_title(f"{run.title}: latency per hop (n = {len(next(iter(hops.values())))})")
    panels[-1].set_xlabel("latency (ms)")
    figure.subplots_adjust(left=0.22, hspace=0.4)
    return figure


FIGURES = {
    "trajectory": trajectory_figure,
    "gaze_error": gaze_error_figure,
    "model_probabilities": model_probabilities_figure,
    "latency": latency_figure,
}


def write_figures(run: RunSeries, directory: Path) -> list[Path]:
    """Each figure the run has data for as `DIRECTORY/<name>.png`; the files written."""
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for name, draw in FIGURES.items():
        figure = draw(run)
        if figure is not None:
            path = directory / f"{name}.png"
            figure.savefig(path, format="png")
            written.append(path)
    return written
