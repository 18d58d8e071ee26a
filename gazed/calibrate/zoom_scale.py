"""The image scale between two views of a still scene from one camera at two zoom positions.

A zoom changes only the intrinsics: a pixel x of the wider view and x' of the longer one see
the same ray when x' = K' K^-1 x = s x + t, with s = f'/f the ratio of the focal lengths and
t = c' - s c the principal point's move. The map is an affine of scale `s` and shift `t` and no
rotation, whatever the scene's depth.

It is measured by direct image alignment, in two stages:

1. **Coarse: a scale search by normalised cross-correlation.** Small grey copies of both views
   (160 pixels wide), their shading taken off (a wide blur subtracted): for each scale of a
   geometric grid the longer view, shrunk by it, is looked for in the wider one
   (`cv2.matchTemplate`). The best scale and where it matched start the fine stage.
2. **Fine: ECC.** `cv2.findTransformECC` (an affine motion) maximises the enhanced correlation
   coefficient between the longer view and the wider one warped, at full resolution. The scale
   is the square root of the affine's determinant.

Direct alignment rather than feature matches: a zoomed-in view of a smooth texture (gravel,
grass, a wall) has few corners, and ORB finds too few to match there, while intensity alignment
uses every pixel. Cross-correlation rather than phase correlation for the search:
phase correlation whitens the spectrum, and on a smooth texture the sensor noise then outweighs
the texture. A scale search rather than log-polar phase correlation of the spectra: the Hanning
window's own spectrum pins that correlation at scale 1, and its log-polar grid limits its
precision; the ECC stage gives the precision instead. ECC's correlation coefficient
(1 for views that agree perfectly) says whether the views matched at all, and the affine's
two principal scales whether what matched is a zoom: they differ where something other than
the zoom changed the view (the scene moved, or haze hides at one zoom what the other shows),
and the fit is then refused rather than trusted.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

SEARCH_WIDTH_PX = 160  # width of the coarse stage's grey copies
SEARCH_STEP = 1.02  # ratio between neighbouring scales of the coarse search
SEARCH_CROP = 0.75  # the template's largest share of the view: room to find its shift
SHADING_SIGMA_PX = 3.0  # blur (small copy's pixels) whose removal leaves the texture
MIN_TEMPLATE_PX = 8  # the shrunk longer view must keep this much to be looked for
MIN_SCALE = 0.8  # the longer view may be a little wider than expected (a backlash, a tie)
ECC_ITERATIONS = 200
ECC_EPS = 1e-6
ECC_SMOOTHING_PX = 5  # Gaussian filter ECC applies to both views: a smooth cost
MIN_CORRELATION = 0.8  # ECC's coefficient below which the views did not match
MAX_ANISOTROPY = 0.01  # a zoom scales alike in every direction: more, and the fit is wrong


class ZoomMatchError(ValueError):
    """Two views could not be aligned; the message says which and why."""


@dataclass(frozen=True)
class ZoomMatch:
    """The map from the wider view's pixels to the longer view's, `x' = A x + t` (`affine`
    2x3), its scale, and ECC's correlation coefficient."""

    affine: np.ndarray
    scale: float
    correlation: float


def match_zoom(wide: np.ndarray, long: np.ndarray, max_scale: float = 4.0) -> ZoomMatch:
    """The zoom from the grey view `wide` to the grey view `long` (same size, uint8 or
    float), its scale between MIN_SCALE and `max_scale`. Raises ZoomMatchError when the views
    do not align."""
    if wide.shape != long.shape or wide.ndim != 2:
        raise ZoomMatchError(f"views of different sizes: {wide.shape} and {long.shape}")
    initial = coarse_zoom(wide, long, max_scale)
    # ECC finds W with long(x) ~ wide(W x): the inverse of the map from wide to long
    warp = cv2.invertAffineTransform(initial).astype(np.float32)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, ECC_ITERATIONS, ECC_EPS)
    try:
        correlation, warp = cv2.findTransformECC(
            long.astype(np.float32),
            wide.astype(np.float32),
            warp,
            cv2.MOTION_AFFINE,
            criteria,
            None,
            ECC_SMOOTHING_PX,
        )
    except cv2.error as exc:  # ECC diverged or the views are blank
        raise ZoomMatchError(f"the views do not align ({exc.err})") from exc
    if not correlation >= MIN_CORRELATION:
        raise ZoomMatchError(
            f"the views do not align (correlation {correlation:.2f} < {MIN_CORRELATION})"
        )
    affine = cv2.invertAffineTransform(warp).astype(float)
    singular = np.linalg.svd(affine[:, :2], compute_uv=False)
    if singular[0] / singular[1] - 1.0 > MAX_ANISOTROPY:
        raise ZoomMatchError(
            f"the views differ by more than a zoom (scales {singular[1]:.3f} and "
            f"{singular[0]:.3f} across the image): a moving scene, haze, or a parallax"
        )
    scale = float(np.sqrt(singular[0] * singular[1]))
    if not MIN_SCALE <= scale <= max_scale:
        raise ZoomMatchError(f"the views align at scale {scale:.3f}, outside the search")
    return ZoomMatch(affine, scale, float(correlation))


def coarse_zoom(wide: np.ndarray, long: np.ndarray, max_scale: float) -> np.ndarray:
    """The zoom (2x3 affine, full-size pixels) whose scale and shift match `long` best: for each
    scale of the search, `long` shrunk by it (its central part) is looked for in `wide` by
    normalised cross-correlation."""
    height, width = wide.shape
    size = (SEARCH_WIDTH_PX, max(16, round(height * SEARCH_WIDTH_PX / width)))
    k = width / size[0]  # full-size pixels per small one
    small_wide, small_long = (_texture(view, size) for view in (wide, long))
    most = (round(size[0] * SEARCH_CROP), round(size[1] * SEARCH_CROP))
    count = int(np.ceil(np.log(max_scale / MIN_SCALE) / np.log(SEARCH_STEP))) + 1
    best = (-np.inf, 1.0, np.zeros(2))
    for scale in np.geomspace(MIN_SCALE, max_scale, count):
        shrunk = cv2.resize(
            small_long, None, fx=1.0 / scale, fy=1.0 / scale, interpolation=cv2.INTER_AREA
        )
        h, w = shrunk.shape
        if min(h, w) < MIN_TEMPLATE_PX:
            break
        offset = np.array([(w - min(w, most[0])) // 2, (h - min(h, most[1])) // 2])
        template = shrunk[
            offset[1] : offset[1] + min(h, most[1]), offset[0] : offset[0] + min(w, most[0])
        ]
        scores = cv2.matchTemplate(small_wide, template, cv2.TM_CCOEFF_NORMED)
        _, score, _, found = cv2.minMaxLoc(scores)
        if score > best[0]:
            best = (score, float(scale), offset - np.array(found))
    _, scale, shift = best
    # long pixel p sits at p / scale in `shrunk`, at p / scale - offset + found in `wide`
    return np.hstack([np.eye(2) * scale, (k * scale * shift)[:, None]])


def _texture(view: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """A small copy of `view` with its shading (a wide blur) taken off: the texture alone. A
    large bright or dark area otherwise dominates the correlation and flattens its peak."""
    small = cv2.resize(view, size, interpolation=cv2.INTER_AREA).astype(np.float32)
    return small - cv2.GaussianBlur(small, (0, 0), SHADING_SIGMA_PX)


def compose(second: np.ndarray, first: np.ndarray) -> np.ndarray:
    """The 2x3 affine `second` after `first`."""
    return (np.vstack([second, [0.0, 0.0, 1.0]]) @ np.vstack([first, [0.0, 0.0, 1.0]]))[:2]


@dataclass(frozen=True)
class ZoomRow:
    """One zoom position's camera: focal length and principal point (pixels), and the scale
    from the widest view with the weakest link's ECC correlation on the way."""

    zoom: float
    fx_px: float
    cx_px: float
    cy_px: float
    scale: float
    correlation: float


def zoom_table(
    zooms: list[float],
    views: list[np.ndarray],
    fx_px: float,
    centre_px: tuple[float, float],
    max_scale: float = 4.0,
) -> list[ZoomRow]:
    """The camera at each zoom position from its view (grey, same size), `zooms` increasing
    from the widest, whose focal length `fx_px` and principal point `centre_px` the rig states.
    Each view is matched against the one before, and the maps are chained: a long zoom shares
    too little of the widest view to match it directly. With x_k = A x_0 + t the chained map,
    the scale is sqrt(det A), fx the wide fx times it, and the principal point A c_0 + t."""
    if len(zooms) != len(views) or len(zooms) < 2:
        raise ZoomMatchError("expected a view at each of two or more zoom positions")
    c0 = np.array(centre_px, dtype=float)
    chained = np.hstack([np.eye(2), np.zeros((2, 1))])
    rows = [ZoomRow(zooms[0], fx_px, c0[0], c0[1], 1.0, 1.0)]
    weakest = 1.0
    for k in range(1, len(views)):
        try:
            match = match_zoom(views[k - 1], views[k], max_scale)
        except ZoomMatchError as exc:
            raise ZoomMatchError(f"zoom {zooms[k - 1]:.3f} -> {zooms[k]:.3f}: {exc}") from exc
        chained = compose(match.affine, chained)
        weakest = min(weakest, match.correlation)
        scale = float(np.sqrt(abs(np.linalg.det(chained[:, :2]))))
        cx, cy = chained[:, :2] @ c0 + chained[:, 2]
        rows.append(ZoomRow(zooms[k], fx_px * scale, float(cx), float(cy), scale, weakest))
    return rows
