"""Innovation-based selection (seed 003): the simulated problem of §III (Fig. 1, Table 3)."""

from __future__ import annotations

import numpy as np
import pytest

from gazed.config import EstimatorSection
from gazed.estimation import Measurement, build_estimator
from gazed.eval.scenario_reports import kelly_report
from gazed.eval.scenarios import kelly


def test_kelly_phases_select_cp_ca_cv_ca_cp() -> None:
    report = kelly_report(EstimatorSection(), seed=0, noise_m=None)
    selected = {(p["phase"], p["k"][0]): p["selected"] for p in report["phases"]}
    assert selected == {
        ("rest", 0): "CP",
        ("accelerate", 31): "CA",  # observation 31 is the first to show the motion from k = 30
        ("constant", 61): "CV",
        ("decelerate", 91): "CA",
        ("rest", 121): "CP",
    }
    for phase in report["phases"]:
        for model, measured in phase["innovation_mean_m"].items():
            # Table 3: E[ν] = H Ã E[e(k|k)] + H ΔÃ x(k); the rest is the measurement noise mean
            assert measured == pytest.approx(phase["table3_expected_m"][model], abs=0.006)
    constant = report["phases"][2]
    # CP lags by T ẋ = 0.25 s × 5 m/s (its model term), CV and CA are unbiased
    assert constant["table3_model_term_m"]["CP"] == pytest.approx(1.25, abs=1e-4)
    assert abs(constant["innovation_mean_m"]["CV"]) < 0.01
    accelerate = report["phases"][1]
    # CV's offset while accelerating: T² ẍ / 2 (model term) = 0.0208 m plus its filter error
    assert accelerate["table3_model_term_m"]["CV"] == pytest.approx(0.25**2 / 2 * 5 / 7.5, rel=1e-3)
    assert accelerate["innovation_mean_m"]["CV"] > 0.02
    assert abs(accelerate["innovation_mean_m"]["CA"]) < 0.01


@pytest.mark.parametrize("seed", [1, 2])
def test_selection_holds_on_other_seeds(seed: int) -> None:
    report = kelly_report(EstimatorSection(), seed=seed, noise_m=None)
    assert [p["selected"] for p in report["phases"]] == ["CP", "CA", "CV", "CA", "CP"]


def test_report_carries_the_statistics_that_chose() -> None:
    scenario = kelly(0)
    estimator = build_estimator(EstimatorSection(), mode="innovation")
    assert estimator.selection_report() is None
    for k in range(75):  # into the constant-speed phase
        estimator.update(
            Measurement.ground(scenario.t_s[k], scenario.z_position[k], np.eye(2) * 1e-4)
        )
    report = estimator.selection_report()
    assert report.selected == "CV" == estimator.most_likely()
    assert estimator.model_probabilities() == {"CP": 0.0, "CV": 1.0, "CA": 0.0}
    assert report.window == 10
    assert not report.consistent["CP"] and report.consistent["CV"]
    assert report.bias_statistic["CP"] > report.bias_threshold
    assert report.innovation_mean["CP"][0] > 1.0  # lagging by about T ẋ
    assert report.nis_per_dof["CV"] <= report.nis_threshold_per_dof
