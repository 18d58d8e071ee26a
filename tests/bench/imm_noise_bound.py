"""The best the IMM can predict on each pedestrian file with any one noise setting, chosen in
hindsight: a bound on what any noise estimator, adaptive or fixed, reaches with one setting
per file, beside the baselines.

    python tests/bench/imm_noise_bound.py [--horizons 0.4,0.8] [FILE ...]

The grid scales every process noise of the IMM by λ (the factor the noise adaptation learns)
and sets its position noise r (m²), with the adaptation off; for each horizon it prints the
setting with the least mean error, the default's error, the baselines', and the IMM's best over
λ with r set to cv-ml's (the file's maximum-likelihood measurement noise: what an estimator
that makes the noise consistent with the innovations finds).
"""

from __future__ import annotations

import argparse
import itertools
import math
from pathlib import Path

from gazed.config import EstimatorSection
from gazed.eval.pedestrians import read_tracks
from gazed.eval.track_prediction import baseline_errors, track_errors

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
FILES = (
    DATA / "pedestrians" / "biwi_eth.txt",
    DATA / "pedestrians" / "biwi_hotel.txt",
    DATA / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv",
)
SCALES = (0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0)
POSITION_VARIANCES_M2 = (1e-6, 1e-5, 1e-4, 1e-3, 3e-3, 1e-2, 3e-2)
PROCESS_NOISES = (
    "csd_speed_rate_noise_m_s2",
    "csd_turn_rate_noise_rad_s",
    "cs_speed_rate_noise_m_s2",
    "cs_turn_accel_noise_rad_s2",
    "cd_jerk_noise_m_s3",
    "cd_turn_rate_noise_rad_s",
)


def scaled(section: EstimatorSection, scale: float, r_m2: float) -> EstimatorSection:
    """The section with every IMM process-noise variance times `scale` and position noise r."""
    update = {k: getattr(section, k) * math.sqrt(scale) for k in PROCESS_NOISES}
    return section.model_copy(update={**update, "position_noise_m": math.sqrt(r_m2)})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=Path, default=list(FILES))
    parser.add_argument("--horizons", default="0.4,0.8")
    args = parser.parse_args()
    horizons = [float(h) for h in args.horizons.split(",")]
    keys = [f"{h:g}" for h in horizons]
    default = EstimatorSection(adapt_noise=False)
    for path in args.files:
        if not path.is_file():
            print(f"{path}: absent, skipped")
            continue
        tracks = read_tracks(path)

        def means(report: dict) -> list[float]:
            return [report["error_m"][k]["mean"] for k in keys]

        grid = {
            (scale, r): means(
                track_errors(scaled(default, scale, r), tracks, "imm", horizons, 0, 0)
            )
            for scale, r in itertools.product(SCALES, POSITION_VARIANCES_M2)
        }
        baselines = baseline_errors(tracks, horizons, 0.0, 0)
        print(f"{path.name} (mean error m at {', '.join(keys)} s)")
        default_errors = means(track_errors(default, tracks, "imm", horizons, 0, 0))
        print(f"  imm default        {'  '.join(f'{e:.4f}' for e in default_errors)}")
        for i, key in enumerate(keys):
            (scale, r), errors = min(grid.items(), key=lambda item: item[1][i])
            best = "  ".join(f"{e:.4f}" for e in errors)
            print(f"  imm best at {key} s  {best}   (λ = {scale:g}, r = {r:g} m²)")
        fitted_r = baselines["cv-ml"]["r"]
        at_ml = {
            scale: means(
                track_errors(scaled(default, scale, fitted_r), tracks, "imm", horizons, 0, 0)
            )
            for scale in SCALES
        }
        scale, errors = min(at_ml.items(), key=lambda item: item[1][0])
        at = "  ".join(f"{e:.4f}" for e in errors)
        print(f"  imm at cv-ml's r   {at}   (λ = {scale:g}, the best at {keys[0]} s)")
        for name, report in baselines.items():
            print(f"  {name:<18} {'  '.join(f'{e:.4f}' for e in means(report))}")
        print(
            f"  cv-ml's r = {baselines['cv-ml']['r']:.3g} m², "
            f"q = {baselines['cv-ml']['q']:.3g} m²/s³"
        )


if __name__ == "__main__":
    main()
