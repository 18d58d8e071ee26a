"""Which tracks a mover's silhouette can hold: the image test of a blob's members.

A detector that sees two people as one blob reports one box round both, so each member of a
blob is inside that box. The ground-plane blob hypothesis (`association.find_blobs`) cannot tell
this by itself: the blob's point lies anywhere between its members' predictions, so any
detection between two tracks, however far apart they are, fits it. In the image the test is
direct: a track can be a member of a mover's blob only where its predicted point, seen through
the frame's camera, can lie inside the mover's box.

A mover reports its point and its box's size, not where in the box the point lies, so the box is
bounded by the size on each side of the point: `[u - w, u + w] x [v - h, v + h]` holds the box
wherever the point lies in it. A track's predicted pixel `p` has the covariance
`C = J P Jᵀ + σ² I` (`J` the ground-to-pixel Jacobian at the prediction, `P` its position
covariance, `σ` the detector's pixel noise); the track can lie in the box where the pixel
difference `Δ` from `p` to the box's nearest point has `Δᵀ C⁻¹ Δ` inside the χ² gate of two
dimensions (Bar-Shalom, Willett & Tian, "Tracking and Data Fusion", 2011, §2.3).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

# ground point (x, y) m -> its pixel (2,) in the frame; ValueError where the camera cannot see it
ToPixel = Callable[[float, float], np.ndarray]
JACOBIAN_STEP_M = 0.01


def reach_box(u_px: float, v_px: float, width_px: float, height_px: float) -> np.ndarray | None:
    """(u0, v0, u1, v1): the pixels a mover's box can cover, its point anywhere in it; None for a
    mover without a box."""
    if width_px <= 0.0 or height_px <= 0.0:
        return None
    return np.array([u_px - width_px, v_px - height_px, u_px + width_px, v_px + height_px])


def held(
    predicted: np.ndarray,
    P: np.ndarray,
    boxes: list[np.ndarray | None],
    to_pixel: ToPixel,
    pixel_var_px2: float,
    gate_d2: float,
) -> np.ndarray:
    """(T, D): whether track t's prediction (predicted (T, 2), covariances P (T, 2, 2)) can lie in
    mover d's box (`reach_box`; None: a mover without one holds any track)."""
    T, D = len(predicted), len(boxes)
    out = np.ones((T, D), bool)
    with_box = [d for d, box in enumerate(boxes) if box is not None]
    if not with_box:
        return out
    for t in range(T):
        x, y = (float(c) for c in predicted[t])
        try:
            p = to_pixel(x, y)
            J = np.column_stack(
                [
                    (to_pixel(x + JACOBIAN_STEP_M, y) - to_pixel(x - JACOBIAN_STEP_M, y)),
                    (to_pixel(x, y + JACOBIAN_STEP_M) - to_pixel(x, y - JACOBIAN_STEP_M)),
                ]
            ) / (2 * JACOBIAN_STEP_M)
        except ValueError:  # behind the camera: in no box
            out[t, with_box] = False
            continue
        C = J @ P[t] @ J.T + pixel_var_px2 * np.eye(2)
        for d in with_box:
            box = boxes[d]
            assert box is not None
            delta = p - np.clip(p, box[:2], box[2:])
            out[t, d] = float(delta @ np.linalg.solve(C, delta)) <= gate_d2
    return out
