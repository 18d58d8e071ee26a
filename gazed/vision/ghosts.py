"""Ghosts: foreground where the background model, not the frame, holds an object.

A background model started with people in view learns them as the scene. When they walk on,
the ground they uncover differs from the model and is foreground: a ghost of their shape where
nobody is. Held out of the model as a stopped walker is (`gazed.vision.silhouettes`), a ghost
would last as long as the model's memory, and a tracker takes it for a person who stands still.

A silhouette's outline lies on the edges of the image that holds its object. A walker's lies
on the edges between them and the ground in the frame; a ghost's on the edges between the
learnt person and the ground in the model's background image, while the frame there shows
bare ground. So a blob whose outline has more gradient energy in the background image than in
the frame is a ghost: the edge test that tells an object removed from the scene from one left
in it (Connell, Senior, Hampapur, Tian, Brown & Pankanti, "Detection and tracking in the IBM
PeopleVision system", ICME 2004). A ghost is not a walker, and is learnt as the scene it is.

A walker still beside the place where they were learnt is one blob with their ghost, and the
blob's outline is the walker's as much as the ghost's. Where the blob is split into the bodies
it holds side by side (`gazed.vision.movers.split_blob`), each body is judged on its own outline
(`is_ghost`), so the ghost beside a walker is left out while the walker is kept.
"""

from __future__ import annotations

import cv2
import numpy as np

_OUTLINE_KERNEL = np.ones((3, 3), np.uint8)


def edge_energy(image: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The squared gradient magnitude (3x3 Sobel, the border replicated) of a grey (H, W) or
    colour (H, W, 3) image at the pixels (rows, cols), summed over its channels (a colour edge
    of equal brightness counts)."""
    height, width = image.shape[:2]
    up, down = np.maximum(rows - 1, 0), np.minimum(rows + 1, height - 1)
    left, right = np.maximum(cols - 1, 0), np.minimum(cols + 1, width - 1)

    def at(r: np.ndarray, c: np.ndarray) -> np.ndarray:
        return image[r, c].astype(np.int32)

    corners = at(down, right) - at(up, left)  # both gradients take it with weight 1
    anti = at(up, right) - at(down, left)  # dx with +1, dy with -1
    dx = corners + anti + 2 * (at(rows, right) - at(rows, left))
    dy = corners - anti + 2 * (at(down, cols) - at(up, cols))
    energy = dx * dx + dy * dy
    return energy if energy.ndim == 1 else energy.sum(axis=1)


def ghost_mask(mask: np.ndarray, frame: np.ndarray, background: np.ndarray) -> np.ndarray:
    """The pixels of `mask`'s 8-connected blobs (uint8, nonzero: foreground) whose outline has
    more edge energy in the model's `background` image than in `frame` (both the mask's size,
    grey or colour alike), as a bool mask."""
    fg = (mask > 0).astype(np.uint8)
    count, labels = cv2.connectedComponents(fg, connectivity=8)
    rows, cols = _outline(fg)
    ids = labels[rows, cols]
    in_frame = np.bincount(ids, edge_energy(frame, rows, cols), minlength=count)
    in_background = np.bincount(ids, edge_energy(background, rows, cols), minlength=count)
    is_ghost = in_background > in_frame
    is_ghost[0] = False
    return is_ghost[labels]


def is_ghost(body: np.ndarray, x: int, y: int, frame: np.ndarray, background: np.ndarray) -> bool:
    """Whether one silhouette (a bool mask over its box at (x, y) in the images' pixels) has
    more edge energy along its outline in the model's `background` image than in `frame`."""
    fg = np.pad(body, 1).astype(np.uint8)  # the box's edge is the silhouette's outline too
    rows, cols = _outline(fg)
    rows, cols = rows + y - 1, cols + x - 1
    return int(edge_energy(background, rows, cols).sum()) > int(
        edge_energy(frame, rows, cols).sum()
    )


def _outline(fg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows and columns of a 0/1 mask's (uint8) outline: its set pixels with an unset one
    among their eight neighbours."""
    return np.nonzero(fg & (cv2.erode(fg, _OUTLINE_KERNEL) == 0))
