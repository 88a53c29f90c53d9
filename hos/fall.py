"""Precipitation seen by its fall (beyond the paper; docs/method.md, departure 22).

The HOS sees streaks: drops or flakes that move far during the exposure. Snow filmed with a
short exposure shows round flakes and specks of 1-4 pixels instead, whose orientation is
unknown (eq. 19) and whose votes land in the mixture's uniform part: on a real clip of snow
over a forest track the camera said snow on 16 % of its frames. What such flakes still do is
*fall*: between two frames, a flake seen in the first is found a few pixels lower in the
second.

So the small blobs of two consecutive frames are paired (every pair within ``radius``
pixels), and the pairs displaced *down* the camera's vertical (within a cone of it) are
counted against the pairs displaced as far *up* (the mirror cone). Blobs that have nothing
to do with each other (noise, compression, a flake and another flake) pair as often one way
as the other; so do the parts of a tree swaying back and forth and the edges of a camera in
the wind. Gravity does not: only what falls makes the down cone fuller than the up one. Over
the last ``window`` frames,

    z = (down - up) / sqrt(down + up),

the excess in units of its standard deviation if pairs were independent and symmetric.
``fall_px`` is where the excess is: the displacement along the vertical (pixels a frame) at
which down pairs outnumber their mirror up pairs most, the flakes' typical fall speed.

What else falls on a camera's image: vehicles that come towards a camera over the road
(their fragments move down the image; most are in the traffic map's cells and left out),
leaves in autumn, drips from the housing. The threshold (``decision.fall_z``) was set from
dry scenes only (docs/method.md).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

__all__ = ["FallMeter", "down_up", "excess_z", "fall_pairs", "kd_tree"]


def fall_pairs(
    before: np.ndarray,
    now: np.ndarray,
    *,
    radius: float,
    vertical: float = math.pi / 2,
    min_step: float = 1.5,
    cone: float = 0.6,
) -> tuple[int, int, np.ndarray, np.ndarray]:
    """Pairs of points of two frames displaced down or up the vertical.

    Parameters
    ----------
    before, now : (N, 2), (M, 2) float, the points' (x, y) in two consecutive frames, pixels
        (y down, as in the image)
    radius : pairs further apart than this (Chebyshev distance, pixels) are not counted
    vertical : the camera's vertical as an orientation in [0, pi), measured from x toward y
        (``decision.vertical``); the fall is along (cos, sin), which has y > 0: down the image
    min_step : pairs displaced less than this along the vertical count neither way (what
        stays in place: compression blocks, an edge)
    cone : tangent of the half-angle of the cones: a pair counts if its displacement across
        the vertical is at most ``cone`` times its displacement along it

    Returns
    -------
    (down, up, down_steps, up_steps): the two counts and the displacement along the vertical
    of each pair counted (down positive, up as a positive distance too), pixels.
    """
    return _pairs(
        kd_tree(before), before, kd_tree(now), now, radius, vertical, min_step=min_step, cone=cone
    )


def kd_tree(points: np.ndarray):
    """scipy's k-d tree of ``points``, or None when there is none. Imported here:
    scipy.spatial costs start-up time, and a detector with neither this rule nor
    ``hos.again``'s on never needs it."""
    from scipy.spatial import cKDTree

    return cKDTree(points) if len(points) else None


def _pairs(tree_before, before, tree_now, now, radius, vertical, *, min_step=1.5, cone=0.6):
    empty = np.zeros(0)
    if tree_before is None or tree_now is None:
        return 0, 0, empty, empty
    pairs = tree_before.sparse_distance_matrix(tree_now, radius, p=np.inf, output_type="ndarray")
    if pairs.size == 0:
        return 0, 0, empty, empty
    d = now[pairs["j"]] - before[pairs["i"]]
    down, up, along = down_up(d, vertical, min_step=min_step, cone=cone)
    return int(np.count_nonzero(down)), int(np.count_nonzero(up)), along[down], -along[up]


def down_up(
    d: np.ndarray, vertical: float, *, min_step: float, cone: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Displacements ``d`` (K, 2) in the down cone and in the up cone of the camera's
    ``vertical`` (at least ``min_step`` along it, at most ``cone`` times that across it), and
    each one's component along the vertical (down positive): ``(down, up, along)``."""
    ux, uy = math.cos(vertical), math.sin(vertical)
    along = d[:, 0] * ux + d[:, 1] * uy
    across = np.abs(d[:, 1] * ux - d[:, 0] * uy)
    down = (along >= min_step) & (across <= cone * along)
    up = (along <= -min_step) & (across <= -cone * along)
    return down, up, along


def excess_z(down: int, up: int) -> float:
    """(down - up) / sqrt(down + up): the excess of down pairs in standard deviations if the
    pairs were independent and as likely either way; 0 without a pair."""
    return (down - up) / math.sqrt(down + up) if down + up else 0.0


class FallMeter:
    """The fall's evidence over the last ``window`` frames (see the module's docstring).

    ``update(points)`` with each judged frame's small blobs (centroids); ``reset()`` when a
    frame cannot be judged (the next one is not paired with the last).
    """

    def __init__(
        self,
        *,
        window: int = 25,
        radius: float = 12.0,
        vertical: float = math.pi / 2,
        max_points: int = 3000,
    ) -> None:
        if window < 1:
            raise ValueError("window must be >= 1")
        if max_points < 1:
            raise ValueError("max_points must be >= 1")
        self.window = window
        self.radius = float(radius)
        self.vertical = float(vertical)
        self.max_points = max_points
        self._before: tuple[np.ndarray, object] | None = None  # points and their tree
        # the last frames' (down, up) counts and their excess by displacement (1-pixel bins up
        # to the longest step counted), and their running sums over the window
        self._bins = math.ceil(self.radius * (1.0 + 1.0 / 0.6)) + 1
        self._frames: deque[tuple[int, int, np.ndarray]] = deque()
        self._down = self._up = 0
        self._excess = np.zeros(self._bins)

    def reset(self) -> None:
        self._before = None
        self._frames.clear()
        self._down = self._up = 0
        self._excess[:] = 0.0

    def update(self, points: np.ndarray) -> tuple[float, float]:
        """Add a frame's points; return ``(z, fall_px)`` over the window (``fall_px`` NaN
        while ``z`` is not positive).

        More than ``max_points`` points are thinned to every k-th (the pairs, and their
        cost, grow with the square of the points; a share of them tells the same asymmetry,
        with less significance)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if len(points) > self.max_points:
            points = points[:: -(-len(points) // self.max_points)]
        tree = kd_tree(points)
        if self._before is not None:
            before, tree_before = self._before
            down, up, d_steps, u_steps = _pairs(
                tree_before, before, tree, points, self.radius, self.vertical
            )
            last = self._bins - 1
            excess = np.bincount(
                np.minimum(d_steps.astype(np.intp), last), minlength=self._bins
            ) - np.bincount(np.minimum(u_steps.astype(np.intp), last), minlength=self._bins)
            if len(self._frames) == self.window:
                old_down, old_up, old_excess = self._frames.popleft()
                self._down -= old_down
                self._up -= old_up
                self._excess -= old_excess
            self._frames.append((down, up, excess))
            self._down += down
            self._up += up
            self._excess += excess
        self._before = (points, tree)
        return self.z, self.fall_px

    @property
    def z(self) -> float:
        return excess_z(self._down, self._up)

    @property
    def fall_px(self) -> float:
        """Displacement along the vertical (pixels a frame) where down pairs outnumber the
        mirror up pairs most, in 1-pixel bins; NaN without an excess."""
        if self.z <= 0.0:
            return math.nan
        k = int(np.argmax(self._excess))
        return k + 0.5 if self._excess[k] > 0 else math.nan
