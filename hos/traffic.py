"""Where the traffic goes: a map learnt from the background model's foreground (beyond the paper).

The paper's mixture (eq. 23) explains the HOS as rain (a Gaussian) and noise spread evenly over
the orientations (the uniform part). Over a road, the foreground is mostly vehicles: their
bright fragments (lights, windscreens, reflections on the wet road) and their spray pass the
photometric and size rules, and they are so many that the rain's share Pi of the HOS stays under
any threshold, however clear the streaks are against the trees beside the road (``docs/method.md``,
"Real clips").

Rain and vehicles differ in how they fill the foreground. A streak is one or two pixels wide: a
cell of ``cell`` x ``cell`` pixels (8 at 480 rows) is at most a quarter foreground where a streak
crosses it, and little more where two cross. A vehicle, a pedestrian or a plume of spray is a
body that fills whole cells. Cells filled beyond ``density`` are a *body*; their running rate
over ``frames`` frames says where bodies pass: the lanes, the pavement. A blob whose centroid is
in a body cell now (grown by one cell: fragments sit at a body's rim) or in a cell where bodies
pass more often than ``rate`` is left out of the HOS. Rain over the lanes is lost with them; it
is the same rain that falls over the rest of the view.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = ["TrafficMap", "grid_cells"]

_SQUARE = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
_BLOCK = np.ones((2, 2), np.uint8)


def grid_cells(x: np.ndarray, y: np.ndarray, cell: float, grid: tuple[int, int]) -> np.ndarray:
    """(N,) intp: the flat index, in a ``grid`` (rows, columns) of cells of ``cell`` pixels
    from the top left corner, of the cell each point (pixels) lies in; points beyond the grid
    take its edge cell."""
    # NaN (a label without pixels) goes to cell 0; such a blob is in no rule's way
    gy = np.nan_to_num(np.asarray(y, dtype=np.float64) / cell).astype(np.intp)
    gx = np.nan_to_num(np.asarray(x, dtype=np.float64) / cell).astype(np.intp)
    gy = np.clip(gy, 0, grid[0] - 1)
    gx = np.clip(gx, 0, grid[1] - 1)
    return gy * grid[1] + gx


class TrafficMap:
    """Per-cell rate of foreground bodies, and the cells whose blobs are traffic.

    Parameters
    ----------
    shape : (H, W) of the frames
    cell : cell side in pixels at this resolution (>= 1)
    width : the foreground is eroded by a square of this side first (1: not at all), so that
        streaks up to ``width - 1`` pixels wide leave nothing
    density : a cell whose eroded foreground fraction exceeds this is dense
    frames : time constant of the running rate of dense cells, in frames (a plain mean over
        the frames seen until then)
    rate, ratio : cells dense more often than ``max(rate, ratio * median rate)`` are traffic
        (the median: rain, however dense, is dense everywhere alike); ``rate = 0``: no map
    hits : ... once they have been dense this many times (a body or two seen in the first
        frames, whose mean is then high, make no lane)
    now : also the bodies of the current frame (dense cells in a block of 2 x 2 at least:
        a lone dense cell can be streaks crossing), grown by one cell
    """

    def __init__(
        self,
        shape: tuple[int, int],
        *,
        cell: int,
        width: int,
        density: float,
        frames: int,
        rate: float,
        ratio: float = 0.0,
        now: bool = True,
        hits: float = 0.0,
        below: int = 0,
    ) -> None:
        h, w = shape
        self.cell = max(int(cell), 1)
        side = max(int(width), 1)
        self.kernel = None if side <= 1 else np.ones((side, side), np.uint8)
        self.grid = (max(math.ceil(h / self.cell), 1), max(math.ceil(w / self.cell), 1))
        self.density = float(density)
        self.k = 1.0 / max(int(frames), 1)
        self.threshold = float(rate)
        self.ratio = float(ratio)
        self.now = bool(now)
        self.hits = float(hits)
        self.below = max(int(below), 0)
        self._down = np.ones((self.below + 1, 1), np.uint8)
        self.learnt = 0
        self.rate = np.zeros(self.grid, dtype=np.float32)
        self.mask = np.zeros(self.grid, dtype=bool)

    def dense(self, foreground: np.ndarray) -> np.ndarray:
        """(gh, gw) uint8, 1 where a cell of ``foreground`` (uint8, 255 = foreground, as both
        segmenters give it) is dense once eroded."""
        gh, gw = self.grid
        h, w = foreground.shape
        ph, pw = gh * self.cell - h, gw * self.cell - w
        fg = foreground if self.kernel is None else cv2.erode(foreground, self.kernel)
        if ph or pw:  # pad to whole cells (the padding is background)
            fg = cv2.copyMakeBorder(fg, 0, ph, 0, pw, cv2.BORDER_CONSTANT, value=0)
        frac = cv2.resize(fg, (gw, gh), interpolation=cv2.INTER_AREA)
        return (frac > np.float32(self.density * 255.0)).view(np.uint8)

    def grow(self, cells: np.ndarray) -> np.ndarray:
        """(gh, gw) uint8: ``cells`` grown by one cell all round (fragments and spray sit at a
        body's rim), and by ``below`` more downward (a vehicle's lights mirrored in a wet road
        hang under it, about as far as the lights are high)."""
        grown = cv2.dilate(cells, _SQUARE)
        if self.below:
            grown = cv2.dilate(grown, self._down, anchor=(0, self.below))
        return grown

    def bodies(self, dense: np.ndarray) -> np.ndarray:
        """(gh, gw) bool: dense cells that belong to a block of 2 x 2 dense cells (an opening,
        marked at each block's corner and spread back over it), grown (:meth:`grow`)."""
        corner = cv2.erode(dense, _BLOCK, anchor=(0, 0), borderType=cv2.BORDER_CONSTANT)
        core = cv2.dilate(corner, _BLOCK, anchor=(1, 1), borderType=cv2.BORDER_CONSTANT)
        return self.grow(core).view(bool)

    def update(
        self, foreground: np.ndarray, *, learn: bool, exclude: np.ndarray | None = None
    ) -> np.ndarray:
        """Take one frame's foreground; ``learn``: also update the running rate. ``exclude``:
        an image of any size, non-zero where the foreground is not bodies (a cloud's shade
        being corrected): the cells it covers by half or more are not learnt as dense in
        this frame (they still count for its own bodies). Returns the (gh, gw) bool traffic
        mask of this frame."""
        dense = self.dense(foreground)
        if learn:
            self.learnt += 1
            bodies = dense
            if exclude is not None:
                gh, gw = self.grid
                share = cv2.resize(
                    np.asarray(exclude, dtype=np.float32), (gw, gh), interpolation=cv2.INTER_AREA
                )
                bodies = dense.copy()
                bodies[share >= 0.5] = 0
            cv2.accumulateWeighted(self.grow(bodies).astype(np.float32), self.rate, self.k)
        mask = self.bodies(dense) if self.now else np.zeros(self.grid, dtype=bool)
        if self.threshold > 0 and self.learnt:
            # The running mean from zero, corrected for its start (the mean of the frames
            # learnt so far, then the running mean); a cell is traffic once it has also been
            # dense ``hits`` times, so that a body or two seen early make no lane.
            seen = 1.0 - (1.0 - self.k) ** self.learnt
            rate = self.rate / np.float32(seen)
            level = self.threshold
            if self.ratio > 0:
                level = max(level, self.ratio * float(np.median(rate)))
            lane = rate > level
            if self.hits > 0:
                lane &= rate * np.float32(min(self.learnt, 1.0 / self.k)) >= self.hits
            mask |= lane
        self.mask = mask
        return self.mask

    def cells(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(N,) intp: the flat index of the cell each point (pixels) lies in."""
        return grid_cells(x, y, self.cell, self.grid)

    def covers(self, cells: np.ndarray) -> np.ndarray:
        """(N,) bool: whether each cell (flat indices from :meth:`cells`) is a traffic cell of
        the last frame."""
        return self.mask.reshape(-1)[cells]

    def lookup(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(N,) bool: whether each point (pixels) lies in a traffic cell of the last frame."""
        return self.covers(self.cells(x, y))
