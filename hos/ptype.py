"""Rain or snow? The camera's own precipitation type, from the streaks it sees (beyond the paper).

The paper detects "rain or snow" and says which it is from outside (its snow sequences are
labelled by hand). A roadside camera without a present-weather sensor still has to say which,
and what it sees is enough to tell the two apart most of the time:

- a raindrop falls at 4-9 m/s and is drawn by the exposure as a **long, thin** streak, all
  streaks **nearly parallel** (a narrow HOS peak, small fitted sigma);
- a snowflake falls at about 1 m/s and tumbles and drifts: it is drawn as a **short, wide**
  blob, nearly round, whose orientations **spread widely** around the vertical.

Per frame, :func:`streak_shape` reduces the blobs that vote for the fitted Gaussian (the rain
blobs of section 6) to three robust numbers: the median elongation a/b (eqs. 15-16), the median
width b at the reference height, and the fitted sigma (eqs. 23-25). :func:`frame_vote` turns
them into a vote: a weighted sum of log-ratios against the boundary between the two classes.
:class:`PrecipitationTypeVote` keeps the votes of the last frames and says ``rain`` or ``snow``
once a clear majority agrees, with hysteresis; ``unknown`` when the detector sees no
precipitation, or the evidence is too thin or split.

Everything here is pure numpy over all blobs at once; the only state is the vote window.
Fall speed is not used: it needs the same streak followed between frames, and the elongation
already carries it (a streak's length is the fall speed times the exposure time).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

__all__ = [
    "RAIN",
    "SNOW",
    "UNKNOWN",
    "PrecipitationTypeVote",
    "PtypeParams",
    "StreakShape",
    "frame_vote",
    "streak_shape",
]

RAIN = "rain"
SNOW = "snow"
UNKNOWN = "unknown"


@dataclass(frozen=True)
class PtypeParams:
    """How the camera tells rain from snow (``docs/method.md``, "Precipitation type").

    The boundary values and weights were set on the tuning scenes of ``bench/ptype_eval.py``
    and checked on scenes with other seeds and settings.
    """

    #: A frame votes only with at least this many rain blobs (fewer: no vote).
    min_blobs: int = 12
    #: Widths are compared at this frame height (the size rule's reference, 480 rows).
    reference_height: int = 480
    #: The boundary between the classes: elongation a/b, width b (px at the reference height),
    #: fitted sigma (radians). A frame with all three at the boundary scores 0.
    elongation_mid: float = 2.6
    width_mid_px: float = 1.85
    sigma_mid: float = math.radians(17.0)
    #: Weights of the log-ratios in the score (positive: snow). The elongation and the
    #: sigma are scale-free; the width depends on the lens, so it weighs less.
    w_elongation: float = 2.0
    w_width: float = 1.0
    w_sigma: float = 1.5
    #: A frame whose |score| is under this does not vote.
    min_score: float = 0.3
    #: Temporal vote: the last ``window_frames`` votes; the type is said once
    #: ``min_votes`` frames voted and a share ``switch_share`` of them agree, and changed only
    #: when that share agrees with the other type (hysteresis).
    window_frames: int = 50
    min_votes: int = 10
    switch_share: float = 0.7
    #: After this many frames without precipitation the vote is forgotten.
    forget_frames: int = 250

    def __post_init__(self) -> None:
        _check(self.min_blobs >= 1, "min_blobs", "must be >= 1")
        _check(self.reference_height >= 1, "reference_height", "must be >= 1")
        _check(self.elongation_mid > 1, "elongation_mid", "must be > 1")
        _check(self.width_mid_px > 0, "width_mid_px", "must be > 0")
        _check(0 < self.sigma_mid < math.pi / 2, "sigma_mid", "must be in (0, 90) degrees")
        _check(min(self.w_elongation, self.w_width, self.w_sigma) >= 0, "w_*", "must be >= 0")
        _check(self.min_score >= 0, "min_score", "must be >= 0")
        _check(self.window_frames >= 1, "window_frames", "must be >= 1")
        _check(1 <= self.min_votes <= self.window_frames, "min_votes", "in 1..window_frames")
        _check(0.5 < self.switch_share <= 1, "switch_share", "must be in (0.5, 1]")
        _check(self.forget_frames >= 1, "forget_frames", "must be >= 1")


def _check(ok: bool, key: str, what: str) -> None:
    if not ok:
        raise ValueError(f"precipitation_type.{key}: {what}")


@dataclass(frozen=True)
class StreakShape:
    """What the rain blobs of one frame look like.

    Attributes
    ----------
    n : number of blobs summarised
    elongation : median a/b of the blobs (eqs. 15-16), >= 1; NaN without blobs
    width_px : median minor semi-axis b of eq. 16, px, scaled to the reference height
    length_px : median major semi-axis a of eq. 15, px, scaled to the reference height
    sigma : radians, the fitted sigma of the frame's HOS (eq. 25), NaN without a valid fit
    """

    n: int
    elongation: float
    width_px: float
    length_px: float
    sigma: float


def streak_shape(
    a: np.ndarray,
    b: np.ndarray,
    *,
    sigma: float,
    height: int,
    reference_height: int = 480,
) -> StreakShape:
    """Summarise the blobs that vote for the rain's Gaussian, all at once.

    Parameters
    ----------
    a, b : (N,) float, major and minor semi-axes of the blobs, px (eqs. 15-16)
    sigma : float, radians, the frame's fitted sigma (eq. 25); NaN when the fit failed
    height : rows of the frame; lengths are rescaled to ``reference_height`` rows, as the
        size rule's areas are, so that one setting serves every resolution

    Returns
    -------
    StreakShape; medians are NaN when ``a`` is empty.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"a and b must be (N,) arrays of one shape, got {a.shape} and {b.shape}")
    if height < 1:
        raise ValueError(f"height must be >= 1, got {height}")
    n = int(a.size)
    if n == 0:
        return StreakShape(0, math.nan, math.nan, math.nan, float(sigma))
    scale = reference_height / float(height)
    # b >= 2 sqrt(1/12) for any blob of whole pixels (moments.py adds a pixel's own moment)
    elongation = float(np.median(a / np.maximum(b, 1e-6)))
    return StreakShape(
        n=n,
        elongation=elongation,
        width_px=float(np.median(b)) * scale,
        length_px=float(np.median(a)) * scale,
        sigma=float(sigma),
    )


def frame_score(shape: StreakShape, params: PtypeParams | None = None) -> float:
    """Evidence of one frame: > 0 for snow, < 0 for rain, NaN when it cannot vote.

    ``w_e log(e_mid / e) + w_b log(b / b_mid) + w_s log(sigma / sigma_mid)``: a short, wide blob
    with spread orientations scores positive (snow); a long, thin, parallel one negative
    (rain). Without a valid fit the sigma term is left out.
    """
    p = params or PtypeParams()
    if shape.n < p.min_blobs or not math.isfinite(shape.elongation):
        return math.nan
    score = p.w_elongation * math.log(p.elongation_mid / max(shape.elongation, 1.0))
    score += p.w_width * math.log(max(shape.width_px, 1e-3) / p.width_mid_px)
    if math.isfinite(shape.sigma) and shape.sigma > 0:
        score += p.w_sigma * math.log(shape.sigma / p.sigma_mid)
    return score


def frame_vote(shape: StreakShape, params: PtypeParams | None = None) -> str:
    """One frame's vote: ``rain``, ``snow``, or ``unknown`` (too few blobs, or a score within
    ``min_score`` of the boundary)."""
    p = params or PtypeParams()
    score = frame_score(shape, p)
    if not math.isfinite(score) or abs(score) < p.min_score:
        return UNKNOWN
    return SNOW if score > 0 else RAIN


class PrecipitationTypeVote:
    """The type over recent frames: a majority vote with hysteresis, so it does not flicker.

    ``update(vote, precipitating)`` once per frame, in order. While the detector sees no
    precipitation the answer is ``unknown``; the votes are kept for ``forget_frames`` (a short
    gap in a shower does not start the count again), then forgotten.
    """

    def __init__(self, params: PtypeParams | None = None):
        self.params = params or PtypeParams()
        self._votes: deque[str] = deque(maxlen=self.params.window_frames)
        self._type = UNKNOWN
        self._dry = 0

    @property
    def current(self) -> str:
        """The type said while precipitating (``unknown`` until a majority formed)."""
        return self._type

    def reset(self) -> None:
        self._votes.clear()
        self._type = UNKNOWN
        self._dry = 0

    def update(self, vote: str, *, precipitating: bool) -> str:
        """Add one frame's vote; return the type to report for this frame."""
        p = self.params
        if vote not in (RAIN, SNOW, UNKNOWN):
            raise ValueError(f"vote must be rain, snow or unknown, got {vote!r}")
        if not precipitating:
            self._dry += 1
            if self._dry >= p.forget_frames:
                self.reset()
            return UNKNOWN
        self._dry = 0
        self._votes.append(vote)
        n_rain = self._votes.count(RAIN)
        n_snow = self._votes.count(SNOW)
        n = n_rain + n_snow
        if n >= p.min_votes:
            if n_rain >= p.switch_share * n:
                self._type = RAIN
            elif n_snow >= p.switch_share * n:
                self._type = SNOW
        return self._type
