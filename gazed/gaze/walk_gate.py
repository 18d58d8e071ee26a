"""Where a person can have walked: the gates the gaze's choice of track uses on the ground
(`target_choice`'s docstring says how).

A lost person is taken on along their last velocity with a covariance grown so that the χ²
gate's edge lies as far as a person walks (`WALK_MAX_M_S`) in the time (`walked_on`); a track
is compared with another by the squared Mahalanobis distance of their ground positions against
the sum of their covariances (`ground_distance2`), and with an operator's ground point by the
likelihood that its person was there when the point was chosen (`point_fit`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from gazed.messages import GazeSelect, Track

WALK_MAX_M_S = 2.5  # the upper end of walking speeds: how far a person gets in a given time
PERSON_WIDTH_M = 0.5  # a shoulder width: a point, and a track's, anywhere on one person
# a point and a track's position each anywhere across a person's width: the variance of the
# difference of two uniform positions
PERSON_EXTENT_M2 = 2.0 * PERSON_WIDTH_M**2 / 12.0


def walked_on(track: Track, dt_s: float, gate_d2: float) -> Track:
    """A track's person `dt_s` after its last state: on along its velocity, its covariance grown
    so that the edge of the gate `gate_d2` (a squared Mahalanobis distance) lies as far as a
    person can stray from that in the time (module docstring)."""
    if track.ground_xy_m is None or track.ground_cov_m2 is None or dt_s <= 0.0:
        return track
    velocity = np.asarray(track.ground_velocity_m_s or (0.0, 0.0))
    xy = np.asarray(track.ground_xy_m) + velocity * dt_s
    stray_m2 = (WALK_MAX_M_S * dt_s) ** 2 / gate_d2
    cov = np.asarray(track.ground_cov_m2) + stray_m2 * np.eye(2)
    return track.model_copy(
        update={
            "ground_xy_m": (float(xy[0]), float(xy[1])),
            "ground_cov_m2": tuple(tuple(float(c) for c in row) for row in cov),
        }
    )


def point_fit(select: GazeSelect, track: Track, t_ns: int, gate_d2: float) -> float | None:
    """The likelihood that `track`'s person was at the request's ground point when it was made
    (the Gaussian density of their distance), or None outside the gate `gate_d2` or without a
    ground position and covariance (module docstring)."""
    if select.ground_xy_m is None or track.ground_xy_m is None:
        return None
    dt_s = max(0.0, (t_ns - select.t_capture_ns) * 1e-9)
    back_s, spread = _back_along_velocity(track, dt_s)
    velocity = np.asarray(track.ground_velocity_m_s or (0.0, 0.0))
    delta = np.asarray(track.ground_xy_m) - velocity * back_s - np.asarray(select.ground_xy_m)
    unseen_s = dt_s - min(dt_s, track.age_s)  # before its birth: they may have turned
    stray_m2 = (WALK_MAX_M_S * unseen_s) ** 2 / gate_d2  # as `walked_on`
    spread = spread + (PERSON_EXTENT_M2 + stray_m2) * np.eye(2)
    try:
        d2 = float(delta @ np.linalg.solve(spread, delta))
    except np.linalg.LinAlgError:
        return None
    if d2 > gate_d2:
        return None
    return math.exp(-0.5 * d2) / (2.0 * math.pi * math.sqrt(float(np.linalg.det(spread))))


def _back_along_velocity(track: Track, dt_s: float) -> tuple[float, np.ndarray]:
    """How far back (seconds) towards `dt_s` ago a track's position is taken along its velocity,
    and the covariance of the position there. Where the track carries its velocity's covariance,
    all the way, with that uncertainty over the time (`p - v·dt` has the covariance
    `Pp - dt·(Ppv + Ppvᵀ) + dt²·Pv`); else only to its birth, with the position's own covariance
    (a velocity of unknown quality is taken no further than it was measured)."""
    own = np.asarray(track.ground_cov_m2) if track.ground_cov_m2 is not None else np.zeros((2, 2))
    velocity_cov, cross = track.ground_velocity_cov_m2_s2, track.ground_position_velocity_cov_m2_s
    if velocity_cov is None or cross is None:
        return min(dt_s, track.age_s), own
    Ppv = np.asarray(cross)
    return dt_s, own - dt_s * (Ppv + Ppv.T) + dt_s**2 * np.asarray(velocity_cov)


def most_likely(
    select: GazeSelect,
    tracks: Iterable[Track],
    t_ns: int,
    gate_d2: float,
    better_than: float = 0.0,
) -> tuple[Track | None, float]:
    """The track of `tracks` that best explains the request's ground point (`point_fit`) and
    its fit, where that fit exceeds `better_than`; (None, `better_than`) where none does."""
    best, best_fit = None, better_than
    for track in tracks:
        fit = point_fit(select, track, t_ns, gate_d2)
        if fit is not None and fit > best_fit:
            best, best_fit = track, fit
    return best, best_fit


def ground_distance2(a: Track, b: Track) -> float | None:
    """Δᵀ (Pa + Pb)⁻¹ Δ of two tracks' ground positions; None without both positions and
    covariances (or a singular sum)."""
    if a.ground_xy_m is None or b.ground_xy_m is None or a.ground_cov_m2 is None:
        return None
    if b.ground_cov_m2 is None:
        return None
    delta = np.subtract(a.ground_xy_m, b.ground_xy_m)
    C = np.add(a.ground_cov_m2, b.ground_cov_m2)
    try:
        return float(delta @ np.linalg.solve(C, delta))
    except np.linalg.LinAlgError:
        return None
