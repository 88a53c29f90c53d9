"""Rain or snow? The camera's own precipitation type, from the streaks it sees (beyond the paper).

The paper detects "rain or snow" and says which it is from outside (its snow sequences are
labelled by hand). A roadside camera without a present-weather sensor still has to say which,
and what it sees is enough to tell the two apart most of the time:

- a raindrop falls at 4-9 m/s and is drawn by the exposure as a **long, thin** streak, all
  streaks **nearly parallel** (a narrow HOS peak, small fitted sigma);
- a snowflake falls at about 1 m/s and tumbles and drifts: it is drawn as a **short, wide**
  blob, nearly round, whose orientations **spread widely** around the vertical.

A raindrop is also transparent and crosses a pixel in a small part of the exposure, so its
streak is **faint**; a flake is white, opaque and slow: it is **bright** against the background.
A soft lens spreads both, and a streak's mean brightness falls with its width: a blurred flake
is as dim as a sharp streak. What the blur keeps is the brightness summed *across* the streak
(its mean brightness times its width), so that is what is compared (departure 39), the
width measured as the minor semi-axis b of eq. 16.

Per frame, :func:`streak_shape` reduces the blobs that vote for the fitted Gaussian (the rain
blobs of section 6) to robust numbers: the median elongation a/b (eqs. 15-16), the fitted sigma
(eqs. 23-25) and the median brightness summed across a blob: its contrast over the background
(eq. 8's difference, averaged over each blob by :func:`blob_contrast`) times its minor
semi-axis b (eq. 16).
:func:`frame_score` scores each against its typical rain and snow values and averages;
:func:`frame_vote` turns the score into a vote.
:class:`PrecipitationTypeVote` keeps the votes of the last frames and says ``rain`` or ``snow``
once a clear majority agrees, with hysteresis; ``unknown`` when the detector sees no
precipitation, or the evidence is too thin or split.

Everything here is pure numpy over all blobs at once; the only state is the vote window.
Fall speed is not used here: it needs the same streak followed between frames, and the
elongation already carries it (a streak's length is the fall speed times the exposure time).
Where flakes *are* followed, found lower down in the next frame (``hos/fall.py``), the detector
votes snow instead of this frame's vote, whatever the streaks look like (``hos/pipeline.py``).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .blobs import blob_mean

__all__ = [
    "RAIN",
    "SNOW",
    "UNKNOWN",
    "PrecipitationTypeVote",
    "PtypeParams",
    "StreakShape",
    "blob_contrast",
    "frame_score",
    "frame_vote",
    "streak_shape",
]

RAIN = "rain"
SNOW = "snow"
UNKNOWN = "unknown"


@dataclass(frozen=True)
class PtypeParams:
    """How the camera tells rain from snow (``docs/method.md``, "Precipitation type").

    The ``[detector.precipitation_type]`` table of the configuration (angles as ``*_deg``).

    The boundary values and weights were set on the tuning scenes of ``bench/ptype_eval.py``
    and checked on scenes with other seeds and settings.
    """

    #: A frame votes only with at least this many rain blobs (fewer: no vote).
    min_blobs: int = 12
    #: Widths are compared at this frame height (the size rule's reference, 480 rows).
    reference_height: int = 480
    #: The typical value of each feature in rain and in snow (medians over the tuning scenes'
    #: frames): the elongation a/b of the rain blobs, the fitted sigma (radians) and the blobs'
    #: brightness. Each feature scores -1 at its rain value, +1 at its snow value, linearly in
    #: its logarithm, clipped to +-``max_term``.
    elongation_rain: float = 2.8
    elongation_snow: float = 1.94
    sigma_rain: float = math.radians(14.6)
    sigma_snow: float = math.radians(30.7)
    #: The blobs' brightness: ``"across"`` (departure 39), the median over them of their
    #: contrast over the background times their minor semi-axis b (eq. 16) in the frame's
    #: pixels, the brightness summed across them (grey levels x px), which a soft lens keeps;
    #: ``"mean"``, their median contrast (grey levels; the releases before), which a soft lens
    #: dims until a flake is as faint as a drop. One feature either way, so that a headlight's
    #: glare cannot outvote the shape. The typical sums across were chosen on two tuning sets
    #: (docs/method.md, 39), not taken as medians.
    brightness: Literal["across", "mean"] = "across"
    across_rain: float = 26.0
    across_snow: float = 52.0
    contrast_rain: float = 21.0
    contrast_snow: float = 47.0
    max_term: float = 2.0
    #: A frame whose |score| (the mean of the features' scores) is under this does not vote.
    min_score: float = 0.25
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
        _check(self.brightness in ("across", "mean"), "brightness", "must be across or mean")
        for key in ("elongation", "sigma", "across", "contrast"):
            rain, snow = getattr(self, f"{key}_rain"), getattr(self, f"{key}_snow")
            _check(rain > 0 and snow > 0 and rain != snow, f"{key}_*", "must be > 0 and differ")
        _check(self.max_term > 0, "max_term", "must be > 0")
        _check(self.min_score >= 0, "min_score", "must be >= 0")
        _check(self.window_frames >= 1, "window_frames", "must be >= 1")
        _check(1 <= self.min_votes <= self.window_frames, "min_votes", "in 1..window_frames")
        _check(0.5 < self.switch_share <= 1, "switch_share", "must be in (0.5, 1]")
        _check(self.forget_frames >= 1, "forget_frames", "must be >= 1")


def _check(ok: bool, key: str, what: str) -> None:
    if not ok:
        raise ValueError(f"{key}: {what}")


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
    contrast : median over the blobs of their mean brightness over the background, grey
        levels; NaN when unknown
    across : median over the blobs of that brightness times their minor semi-axis b (eq. 16)
        in the frame's own pixels: the brightness summed across the streak, grey levels x px,
        which a blur spreads without changing; NaN when unknown
    """

    n: int
    elongation: float
    width_px: float
    length_px: float
    sigma: float
    contrast: float = math.nan
    across: float = math.nan


def blob_contrast(
    image: np.ndarray,
    background: np.ndarray,
    index: np.ndarray,
    pixel_labels: np.ndarray,
    n_labels: int,
) -> np.ndarray:
    """Mean brightness of each blob over the background, (n_labels,) float64, grey levels.

    Parameters
    ----------
    image, background : (H, W) uint8, the frame and the background it is compared with
    index : (N,) int, flat indices of the candidate pixels; pixel_labels : (N,) int, their blob
    n_labels : number of labels including 0

    A raindrop is transparent and crosses a pixel in a fraction of the exposure: its streak is
    faint (Garg & Nayar). A flake is opaque, white and slow: it is bright. NaN for empty labels.
    """
    index = np.asarray(index, dtype=np.intp)
    diff = image.reshape(-1)[index].astype(np.float64) - background.reshape(-1)[index]
    return blob_mean(diff, pixel_labels, n_labels)


def streak_shape(
    a: np.ndarray,
    b: np.ndarray,
    *,
    sigma: float,
    height: int,
    contrast: np.ndarray | None = None,
    reference_height: int = 480,
) -> StreakShape:
    """Summarise the blobs that vote for the rain's Gaussian, all at once.

    Parameters
    ----------
    a, b : (N,) float, major and minor semi-axes of the blobs, px (eqs. 15-16)
    sigma : float, radians, the frame's fitted sigma (eq. 25); NaN when the fit failed
    height : rows of the frame; lengths are rescaled to ``reference_height`` rows, as the
        size rule's areas are, so that one setting serves every resolution
    contrast : (N,) float, grey levels, each blob's brightness over the background
        (:func:`blob_contrast`), or None when unknown

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
    mean = across = math.nan
    if contrast is not None:
        contrast = np.asarray(contrast, dtype=np.float64)
        if contrast.shape != a.shape:
            raise ValueError(f"contrast must be {a.shape}, got {contrast.shape}")
        if np.isfinite(contrast).any():
            mean = float(np.nanmedian(contrast))
            # in the frame's own pixels, not rescaled to the reference height as width_px
            # is: the streaks seen are the drops near focus, a pixel or two wide at any frame
            # size, and rescaled, 320x240 rain came out as bright as snow (docs/method.md, 39)
            across = float(np.nanmedian(contrast * b))
    return StreakShape(
        n=n,
        elongation=elongation,
        width_px=float(np.median(b)) * scale,
        length_px=float(np.median(a)) * scale,
        sigma=float(sigma),
        contrast=mean,
        across=across,
    )


def frame_score(shape: StreakShape, params: PtypeParams | None = None) -> float:
    """Evidence of one frame: > 0 for snow, < 0 for rain, NaN when it cannot vote.

    Each feature x with typical values x_rain and x_snow scores
    ``(ln x - ln sqrt(x_rain x_snow)) / (ln sqrt(x_snow / x_rain))``: -1 at x_rain, +1 at
    x_snow, clipped to +-``max_term`` so that no single feature decides alone. The score is the
    mean over the features the frame has (no valid fit: no sigma; no background: no
    brightness). The brightness is ``shape.across`` or ``shape.contrast``, as
    ``params.brightness`` says.
    """
    p = params or PtypeParams()
    if shape.n < p.min_blobs:
        return math.nan
    if p.brightness == "across":
        bright = (shape.across, p.across_rain, p.across_snow)
    else:
        bright = (shape.contrast, p.contrast_rain, p.contrast_snow)
    # each feature's (value, typical in rain, typical in snow)
    rows = [
        (shape.elongation, p.elongation_rain, p.elongation_snow),
        (shape.sigma, p.sigma_rain, p.sigma_snow),
        bright,
    ]
    x, rain, snow = np.array(rows, dtype=np.float64).T
    ok = np.isfinite(x) & (x > 0)
    if not ok[0]:
        return math.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        terms = (np.log(x) - 0.5 * np.log(rain * snow)) / (0.5 * np.log(snow / rain))
    terms = np.clip(terms[ok], -p.max_term, p.max_term)
    return float(terms.mean())


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
