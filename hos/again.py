"""Blobs found again: what the last frame showed a little way off is not a new drop (beyond the
paper; docs/method.md, departure 23).

A drop is seen once. Between two frames it falls at least as far as its streak is long (the
exposure is at most the frame interval; eq. 6's streak length is the fall during the
exposure), so the streak of frame t+1 is at least its own length, less its width, away from the
streak of frame t. What is found again *a little way off* in the next frame is something else:
the texture of a tree's crown or of a hedge flickering with the camera's last sub-pixel sway, a
distant vehicle's fragments creeping along its lane before the traffic map knows the lane, a
pedestrian's parts. The structure rule catches what recurs *in place* over seconds; these move
by a pixel or two, and on a real motorway in heavy rain they filled the uniform part of the
mixture (eq. 23) so that Pi stayed under the threshold on two thirds of the frames.

So a streak-sized blob whose centroid lies within ``radius`` of a streak-sized blob of the last
judged frame, displaced by more than nothing, takes no part in the HOS. ``radius`` is 3 pixels
at 480 rows (scaled with the height): a streak 4 pixels long or longer cannot be found again
within it, whatever the drop's speed.

Two exceptions keep what the rule must not remove:

* *Exact copies* (displacement zero: the very same pixels) are a video encoder's skipped
  blocks, which keep the last frame's blobs, streaks and clutter alike, for a frame or two.
  Such a copy repeats the last frame's mixture in its proportions; it does not bias Pi. (The
  stale rule of the pipeline already leaves out copies whose pixels did not change at all.)
* *What is found again lower down* is snow falling slowly: flakes seen a fraction of a pixel
  to a pixel or two lower in the next frame. When the pairs found again fall, that is when
  over the last ``frames`` frames the pairs displaced down the camera's vertical outnumber
  those displaced up by ``fall_z`` standard deviations (the statistic of ``hos/fall.py``,
  here for steps of at least ``_SLOW_STEP`` px), the rule stands aside for the blobs found
  lower down, within the down cone that the statistic counts (``lower_only``; departure
  41). Clutter sways both ways, and what it shows beside or above where it was is still
  left out: a crown bent down by a gust makes the pairs fall too (real leaves in rain,
  where standing aside for every blob let a hundred fragments a frame vote). With
  ``lower_only=False`` the rule stands aside for every blob, as before departure 41.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from .fall import down_up, excess_z, kd_tree

__all__ = ["FoundAgain"]

#: Displacements along the vertical smaller than this (pixels) count neither way in the fall
#: test: an edge's flicker in place.
_SLOW_STEP = 0.25
#: Tangent of the half-angle of the down and up cones (as ``hos.fall.fall_pairs``).
_CONE = 0.6
#: The flicker measure's chance level: the last frame's voting points moved sideways by this
#: many radii, found again as often as chance finds them.
_CHANCE_SHIFT = 3.0


class FoundAgain:
    """The rule of the module's docstring, frame after frame.

    ``update(points)`` with each judged frame's streak-sized blobs (centroids, pixels) returns
    which of them were found again; ``reset()`` when a frame cannot be judged (the next one
    is not compared with the last).

    Parameters
    ----------
    radius : pixels at this frame size (> 0)
    frames : window of the fall test, in frames (>= 1)
    fall_z : the pairs found again fall when their z reaches this; 0: they never do
    vertical : the camera's vertical as an orientation in [0, pi) (``decision.vertical``)
    lower_only : while they fall, only the blobs found lower down count as not found again
        (True, departure 41); False: none does
    """

    def __init__(
        self,
        *,
        radius: float,
        frames: int = 25,
        fall_z: float = 8.0,
        vertical: float = math.pi / 2,
        lower_only: bool = True,
    ) -> None:
        if not radius > 0:
            raise ValueError("radius must be > 0")
        if frames < 1:
            raise ValueError("frames must be >= 1")
        self.radius = float(radius)
        self.fall_z = float(fall_z)
        self.lower_only = bool(lower_only)
        self.vertical = float(vertical)
        self._before = None  # the last frame's k-d tree (scipy), or None
        self._counts: deque[tuple[int, int]] = deque(maxlen=int(frames))
        self._down = self._up = 0
        #: which of the last frame's points voted in its HOS (:meth:`voted`), or None
        self._voted: np.ndarray | None = None
        #: of the last frame's voting points, (how many this frame found again beyond
        #: chance, how many there were) (:meth:`update`); None when there was none
        self.flicker: tuple[float, int] | None = None

    def reset(self) -> None:
        self._before = None
        self._counts.clear()
        self._down = self._up = 0
        self._voted = None
        self.flicker = None

    def voted(self, mask: np.ndarray) -> None:
        """Which of the points of the last :meth:`update` voted in the frame's HOS: the next
        update measures how many of them it finds again (:attr:`flicker`)."""
        self._voted = np.asarray(mask, dtype=bool).copy()

    @property
    def z(self) -> float:
        """(down - up) / sqrt(down + up) of the pairs found again over the window."""
        return excess_z(self._down, self._up)

    @property
    def falling(self) -> bool:
        return self.fall_z > 0 and self.z >= self.fall_z

    def update(self, points: np.ndarray) -> np.ndarray:
        """(M,) bool: which of this frame's ``points`` (M, 2) were found again."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        found = np.zeros(len(points), dtype=bool)
        tree = kd_tree(points)  # scipy's, imported only when the rule is on
        down = up = 0
        lower = np.zeros(len(points), dtype=bool)
        self.flicker = self._flicker(tree)
        self._voted = None
        if self._before is not None and tree is not None:
            dist, j = self._before.query(points, k=1, distance_upper_bound=self.radius)
            found = np.isfinite(dist) & (dist > 0.0)  # an exact copy is not "found again"
            d = points[found] - self._before.data[j[found]]
            is_down, is_up, _ = down_up(d, self.vertical, min_step=_SLOW_STEP, cone=_CONE)
            down, up = int(np.count_nonzero(is_down)), int(np.count_nonzero(is_up))
            lower[np.flatnonzero(found)[is_down]] = True
        if len(self._counts) == self._counts.maxlen:
            old_down, old_up = self._counts[0]
            self._down -= old_down
            self._up -= old_up
        self._counts.append((down, up))
        self._down += down
        self._up += up
        self._before = tree
        if self.falling:
            # slow snow: what is found again lower down is the flakes
            if self.lower_only:
                found &= ~lower
            else:
                found[:] = False
            self.flicker = None
        return found

    def _flicker(self, tree) -> tuple[float, int] | None:
        """(How many of the last frame's voted points ``tree``, this frame's, holds again a
        little way off, beyond chance; how many voted), or None when none did. Drops are
        never seen again, so for rain the first is chance and is taken off; a crown's leaves,
        stirred by a gust, stay where they were stirred (docs/method.md, departure 29). Found
        lower down counts only as often as found higher up: the excess is flakes falling."""
        if self._before is None or self._voted is None:
            return None
        before = self._before.data[self._voted]
        if len(before) == 0:
            return None
        if tree is None:
            return 0.0, len(before)
        dist, j = tree.query(before, k=1, distance_upper_bound=self.radius)
        hit = np.isfinite(dist) & (dist > 0.0)
        d = tree.data[j[hit]] - before[hit]
        is_down, is_up, _ = down_up(d, self.vertical, min_step=_SLOW_STEP, cone=_CONE)
        # a sway moves as often up as down: the pairs found lower down are counted as many
        # as were found higher up, the rest being a flake's fall
        swayed = np.count_nonzero(hit) - np.count_nonzero(is_down) + np.count_nonzero(is_up)
        # ... less what chance finds: the same points moved sideways by _CHANCE_SHIFT radii
        # (beyond the object they stood on, in the same part of the view), either way
        shift = np.array([_CHANCE_SHIFT * self.radius, 0.0])
        dist, _ = tree.query(
            np.concatenate((before - shift, before + shift)), k=1, distance_upper_bound=self.radius
        )
        chance = np.count_nonzero(np.isfinite(dist))
        return float(swayed) - 0.5 * chance, len(before)
