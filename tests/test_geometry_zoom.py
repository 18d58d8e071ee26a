"""The zoom lens: intrinsics interpolated from the rig's table, a fixed lens without one."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from gazed.config import CameraSection
from gazed.geometry.zoom import ZoomLens


def lens(table: list[list[float]]) -> ZoomLens:
    return ZoomLens.from_section(
        CameraSection(width_px=640, height_px=480, fx_px=500.0, fy_px=510.0, zoom_focal_px=table)
    )


def test_a_fixed_lens_ignores_zoom() -> None:
    fixed = lens([])
    assert not fixed.zooms_lens
    assert fixed.camera_at(0.7) is fixed.base
    assert fixed.focal_px(0.7) == pytest.approx(505.0)


def test_focal_length_and_principal_point_interpolate_between_rows() -> None:
    zoom = lens([[0.0, 500.0, 320.0, 240.0], [0.5, 1500.0, 330.0, 230.0], [1.0, 5000.0]])
    camera = zoom.camera_at(0.25)
    assert camera.K[0, 0] == pytest.approx(1000.0)
    assert camera.K[1, 1] == pytest.approx(1000.0 * 510.0 / 500.0)  # the aspect stays the lens's
    assert camera.K[0, 2] == pytest.approx(325.0)
    assert camera.K[1, 2] == pytest.approx(235.0)
    assert zoom.camera_at(0.75).K[0, 0] == pytest.approx(3250.0)
    assert zoom.camera_at(1.5).K[0, 0] == pytest.approx(5000.0)  # clamped to the table
    assert zoom.zoom_for_focal(3250.0) == pytest.approx(0.75)
    assert zoom.camera_at(None) is zoom.base


@pytest.mark.parametrize(
    "table, key",
    [
        ([[0.0, 500.0]], "one row"),
        ([[0.0, 500.0], [0.0, 900.0]], "does not increase"),
        ([[0.0, 500.0], [1.2, 900.0]], "0 <= zoom <= 1"),
        ([[0.0, 500.0, 1.0], [1.0, 900.0]], "3 numbers"),
    ],
)
def test_a_bad_table_names_the_key(table: list[list[float]], key: str) -> None:
    with pytest.raises(ValidationError, match="zoom_focal_px") as error:
        CameraSection(zoom_focal_px=table)
    assert key in str(error.value)


def test_the_emulated_head_zooms_at_its_rate_and_interpolates_its_history() -> None:
    from gazed.config import HeadSection, SimSection
    from gazed.sim.head_mechanics import HeadMechanics

    mechanics = HeadMechanics(HeadSection(zoom_rate_max_s=0.5), SimSection(), t0_s=0.0)
    mechanics.schedule(0.0, lambda m: m.zoom.move_to(1.0))
    assert mechanics.pose_at(0.0).zoom == 0.0
    assert mechanics.pose_at(1.0).zoom == pytest.approx(0.45, abs=0.02)  # 0.1 s to reach 0.5/s
    assert mechanics.pose_at(2.5).zoom == pytest.approx(1.0)
    assert mechanics.pose_at(0.5).zoom == pytest.approx(0.2, abs=0.02)  # from the history
