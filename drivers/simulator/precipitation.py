"""Rain streaks and snow flakes of one frame, with their ground truth: the paper's section 8.4.

The paper evaluates its rain-pixel classifier on synthetic streaks (section 8.4): streak
orientations drawn from a Gaussian, plus a share drawn from a uniform distribution ("noise"),
with a per-pixel ground truth from which a Dice coefficient is computed. This module draws such
streaks and draws snow flakes; :mod:`.scene` puts them on a street.

Read in order:

* :class:`StreakParams`, :func:`render_streaks`: additive rain streaks and their ground truth;
* :class:`SnowParams`, :func:`render_snow`: opaque flakes, composited with ``max``;
* :func:`composite`: a layer over a background, without touching either.

Orientation convention (project contract): image coordinates, x to the right, y downward,
theta measured from the x axis toward the y axis, in [0, pi). 90 degrees is a vertical streak,
45 degrees runs from top-left to bottom-right. A streak of orientation theta runs along
(cos theta, sin theta). Parameters take degrees (``*_deg``); arrays hold radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from ._common import _ONE, _SHIFT, _require

__all__ = [
    "VISIBLE_C",
    "SnowParams",
    "StreakLayer",
    "StreakParams",
    "composite",
    "render_falling_snow",
    "render_snow",
    "render_streaks",
]

#: A pixel belongs to a streak when the streak adds at least this many grey levels: what the
#: photometric rule of eq. 8 sees with the paper's c = 3.
VISIBLE_C = 3.0


@dataclass(frozen=True)
class StreakParams:
    """Rain streaks of one frame.

    Attributes
    ----------
    mu_deg, sigma_deg : mean and standard deviation of the Gaussian orientation, degrees
    noise_fraction : share of streaks whose orientation is uniform on [0, 180) degrees, the
        paper's "uniform noise" (each streak is one with this probability)
    length_px, length_jitter : mean length (px) and its relative standard deviation
    width_px : width, px. Up to 1.5 px, an antialiased line (profile about 1.4 px wide), made
        proportionally fainter below 1 px (partial coverage); wider, a filled rectangle.
    count : number of streaks per frame (a :class:`Scene` draws a Poisson number with this mean,
        times the schedule's multiplier)
    brightness, brightness_jitter : grey levels added at the core of a streak over what it
        occludes (rain is brighter than the background, eq. 7), and its relative std
    supersample : 1 draws OpenCV's antialiased lines: fast, but a short line leans toward the
        nearest diagonal, because its ends are cut square to the major axis, not to the line
        (a 5-px streak at 55 degrees measures 51.8 degrees, a 21-px one 54.7). n > 1 draws each
        streak as a rectangle with square ends at n times the resolution and averages it down:
        exact coverage, no lean (55.0-55.1 degrees at every length), for experiments on orientation
        accuracy (Fig. 6); slower.
    """

    mu_deg: float = 90.0
    sigma_deg: float = 10.0
    noise_fraction: float = 0.0
    length_px: float = 11.0
    length_jitter: float = 0.2
    width_px: float = 1.0
    count: int = 350
    brightness: float = 40.0
    brightness_jitter: float = 0.3
    supersample: int = 1

    def __post_init__(self) -> None:
        _check_population("StreakParams", self.sigma_deg, self.noise_fraction, self.count)
        _require(
            isinstance(self.supersample, int) and 1 <= self.supersample <= 16,
            "StreakParams.supersample",
            "must be an integer in 1..16",
        )
        _require(self.length_px > 0, "StreakParams.length_px", "must be > 0")
        _require(self.length_jitter >= 0, "StreakParams.length_jitter", "must be >= 0")
        _require(self.width_px > 0, "StreakParams.width_px", "must be > 0")
        _require(0 <= self.brightness <= 255, "StreakParams.brightness", "must be in [0, 255]")
        _require(self.brightness_jitter >= 0, "StreakParams.brightness_jitter", "must be >= 0")


@dataclass(frozen=True)
class SnowParams:
    """Snow flakes of one frame: small bright opaque blobs, slightly motion-blurred.

    Attributes
    ----------
    mu_deg, sigma_deg : orientation of the motion blur, degrees; flakes drift, so the spread is
        wide around the vertical
    noise_fraction : share of flakes whose blur orientation is uniform on [0, 180)
    count : number of flakes per frame (a :class:`Scene` draws a Poisson number)
    radius_px : (min, max) flake radius, px; small flakes are more frequent (r = min + (max -
        min) u^2, u uniform)
    blur_px, blur_jitter : mean length of the motion blur (px, slow fall) and its relative std
    level, level_jitter : grey level of a flake's core and its relative std; a flake is
        composited as ``max(background, flake)``, so it hides what is darker than itself
    softness_px : standard deviation (px) of the Gaussian that softens the flakes' edges
    """

    mu_deg: float = 90.0
    sigma_deg: float = 25.0
    noise_fraction: float = 0.0
    count: int = 250
    radius_px: tuple[float, float] = (1.0, 3.0)
    blur_px: float = 3.0
    blur_jitter: float = 0.5
    level: float = 225.0
    level_jitter: float = 0.08
    softness_px: float = 0.6
    #: 0: each frame draws its flakes anew (at random places). > 0: the flakes persist and fall
    #: this many pixels a frame on average, each at 0.5-1.5 times it (nearer flakes fall
    #: faster in the image) and drifting sideways by up to a fifth of it, as real snow does
    #: (:func:`render_falling_snow`).
    fall_px: float = 0.0

    def __post_init__(self) -> None:
        _check_population("SnowParams", self.sigma_deg, self.noise_fraction, self.count)
        lo, hi = self.radius_px
        _require(0.5 <= lo <= hi, "SnowParams.radius_px", "must satisfy 0.5 <= min <= max")
        _require(self.blur_px >= 0, "SnowParams.blur_px", "must be >= 0")
        _require(self.blur_jitter >= 0, "SnowParams.blur_jitter", "must be >= 0")
        _require(0 <= self.level <= 255, "SnowParams.level", "must be in [0, 255]")
        _require(self.level_jitter >= 0, "SnowParams.level_jitter", "must be >= 0")
        _require(self.softness_px >= 0, "SnowParams.softness_px", "must be >= 0")
        _require(self.fall_px >= 0, "SnowParams.fall_px", "must be >= 0")


def _check_population(where: str, sigma_deg: float, noise_fraction: float, count: int) -> None:
    _require(sigma_deg >= 0, f"{where}.sigma_deg", "must be >= 0")
    _require(0 <= noise_fraction <= 1, f"{where}.noise_fraction", "must be in [0, 1]")
    _require(int(count) == count and count >= 0, f"{where}.count", "must be an integer >= 0")


@dataclass(frozen=True)
class StreakLayer:
    """Rain streaks or snow flakes of one frame, with their ground truth.

    Attributes
    ----------
    layer : (H, W) float32, grey levels. ``blend == "add"`` (rain): added to the background.
        ``blend == "max"`` (snow): the flakes' own grey level, 0 outside them, composited as
        ``max(background, layer)``.
    mask : (H, W) bool, ``layer >= VISIBLE_C``: the streak pixels (for rain, what the
        photometric rule with c = 3 sees; for snow, the footprint on a black background)
    rain_mask, noise_mask : (H, W) bool, disjoint, their union is ``mask``: pixels whose
        strongest streak has a Gaussian orientation (``rain_mask``, the positives of a
        rain-pixel classifier) or a uniform one (``noise_mask``)
    theta : (N,) float64, radians in [0, pi), orientation of each streak (or flake blur)
    is_noise : (N,) bool, True for the streaks drawn from the uniform distribution
    centers : (N, 2) float64, (x, y) of each streak's centre, px
    lengths : (N,) float64, px, length of each streak (of each flake: blur + diameter)
    blend : "add" or "max"
    """

    layer: np.ndarray
    mask: np.ndarray
    rain_mask: np.ndarray
    noise_mask: np.ndarray
    theta: np.ndarray
    is_noise: np.ndarray
    centers: np.ndarray
    lengths: np.ndarray
    blend: str = "add"


def _orientations(
    n: int, mu_deg: float, sigma_deg: float, noise_fraction: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """(N,) radians in [0, pi) and (N,) bool: Gaussian ones, and uniform ones marked True."""
    is_noise = rng.random(n) < noise_fraction
    gauss = math.radians(mu_deg) + math.radians(sigma_deg) * rng.standard_normal(n)
    theta = np.mod(np.where(is_noise, rng.uniform(0.0, np.pi, n), gauss), np.pi)
    return np.where(theta >= np.pi, 0.0, theta), is_noise  # mod can round up to pi


def _draw_streaks(
    shape: tuple[int, int],
    centers: np.ndarray,
    theta: np.ndarray,
    lengths: np.ndarray,
    width: float,
    levels: np.ndarray,
    is_noise: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Two (H, W) uint8 canvases, Gaussian and uniform streaks, antialiased, 1/16 px endpoints.

    OpenCV antialiases 8-bit images only, so the canvases are uint8; where streaks cross, the
    later one is blended over the earlier one (occlusion). Up to 1.5 px wide, a streak is an
    antialiased line: a profile about 1.4 px wide whose core pixel gets 0.7-0.9 of the level
    depending on where the streak falls in it. Wider, it is a filled antialiased rectangle,
    narrowed by the half pixel that OpenCV's antialiasing adds on each side.
    """
    direction = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    along = 0.5 * lengths[:, None] * direction
    canvases = (np.zeros(shape, np.uint8), np.zeros(shape, np.uint8))
    values = np.rint(levels).tolist()
    if width <= 1.5:
        ends = np.concatenate([centers - along, centers + along], axis=1)
        ends = np.rint(ends * _ONE).astype(int).tolist()
        for (x0, y0, x1, y1), v, noise in zip(ends, values, is_noise.tolist(), strict=True):
            cv2.line(canvases[noise], (x0, y0), (x1, y1), v, 1, cv2.LINE_AA, _SHIFT)
        return canvases
    corners = _rectangles(centers, theta, lengths, 0.5 * width - 0.5)
    corners = np.rint(corners * _ONE).astype(np.int32)
    for quad, v, noise in zip(corners, values, is_noise.tolist(), strict=True):
        cv2.fillConvexPoly(canvases[noise], quad, v, cv2.LINE_AA, _SHIFT)
    return canvases


def _rectangles(
    centers: np.ndarray, theta: np.ndarray, lengths: np.ndarray, half_width: float
) -> np.ndarray:
    """(N, 4, 2) corners of each streak's rectangle: ``lengths`` along ``theta``, ``2 *
    half_width`` across, centred on ``centers`` (N, 2), ends square to the streak."""
    direction = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    along = 0.5 * lengths[:, None] * direction
    across = half_width * np.stack([-direction[:, 1], direction[:, 0]], axis=1)
    return np.stack(
        [
            centers - along - across,
            centers + along - across,
            centers + along + across,
            centers - along + across,
        ],
        axis=1,
    )


def _draw_streaks_supersampled(
    shape: tuple[int, int],
    centers: np.ndarray,
    theta: np.ndarray,
    lengths: np.ndarray,
    width: float,
    levels: np.ndarray,
    is_noise: np.ndarray,
    factor: int,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_draw_streaks` with exact geometry: each streak a ``length x width`` rectangle
    with ends square to the streak, filled at ``factor`` times the resolution, then averaged
    down (``INTER_AREA``): every pixel gets the level times the share of it the streak covers."""
    h, w = shape
    corners = _rectangles(centers, theta, lengths, 0.5 * width)  # pixel-centre coordinates
    # A frame pixel i spans [i - 1/2, i + 1/2]: at `factor` times the resolution, coordinate u
    # is factor * (u + 1/2) - 1/2.
    corners = np.rint((factor * (corners + 0.5) - 0.5) * _ONE).astype(np.int32)
    big = (
        np.zeros((h * factor, w * factor), np.uint8),
        np.zeros((h * factor, w * factor), np.uint8),
    )
    for quad, v, noise in zip(corners, np.rint(levels).tolist(), is_noise.tolist(), strict=True):
        cv2.fillConvexPoly(big[noise], quad, v, cv2.LINE_8, _SHIFT)
    return tuple(cv2.resize(c, (w, h), interpolation=cv2.INTER_AREA) for c in big)


def _draw_blobs(
    shape: tuple[int, int],
    centers: np.ndarray,
    theta: np.ndarray,
    semi_axes: np.ndarray,
    levels: np.ndarray,
    is_noise: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Two (H, W) uint8 canvases of filled antialiased ellipses, as :func:`_draw_streaks`.

    ``semi_axes`` (N, 2) px, along and across ``theta``; OpenCV's antialiasing adds about half a
    pixel all round, which is taken off here so that a flake covers the area asked for.
    """
    axes = np.maximum(np.rint((semi_axes - 0.5) * _ONE), 4).astype(int).tolist()
    pts = np.rint(centers * _ONE).astype(int).tolist()
    angles = np.degrees(theta).tolist()
    canvases = (np.zeros(shape, np.uint8), np.zeros(shape, np.uint8))
    for (x, y), (a, b), angle, v, noise in zip(
        pts, axes, angles, np.rint(levels).tolist(), is_noise.tolist(), strict=True
    ):
        cv2.ellipse(canvases[noise], (x, y), (a, b), angle, 0, 360, v, -1, cv2.LINE_AA, _SHIFT)
    return canvases


def _layer_from_canvases(
    gauss: np.ndarray,
    noise: np.ndarray,
    theta: np.ndarray,
    is_noise: np.ndarray,
    centers: np.ndarray,
    lengths: np.ndarray,
    blend: str,
) -> StreakLayer:
    layer = np.maximum(gauss, noise).astype(np.float32)
    mask = layer >= VISIBLE_C
    from_noise = noise > gauss
    return StreakLayer(
        layer=layer,
        mask=mask,
        rain_mask=mask & ~from_noise,
        noise_mask=mask & from_noise,
        theta=theta,
        is_noise=is_noise,
        centers=centers,
        lengths=lengths,
        blend=blend,
    )


def _shape2(shape: Sequence[int]) -> tuple[int, int]:
    h, w = (int(s) for s in tuple(shape)[:2])
    _require(h > 0 and w > 0, "shape", f"must be (H, W) with H, W > 0, got {tuple(shape)}")
    return h, w


def _as_rng(rng: np.random.Generator | int | None) -> np.random.Generator:
    """A Generator; an int seeds one; None means seed 0, so that renders are reproducible."""
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng or 0)


def render_streaks(
    shape: Sequence[int],
    params: StreakParams | None = None,
    rng: np.random.Generator | int | None = None,
) -> StreakLayer:
    """Rain streaks of one frame: an additive, antialiased layer and its ground truth.

    Streak centres are uniform over the frame (streaks near the border are clipped);
    orientations follow ``params`` (Gaussian plus a uniform share); each streak is a line
    segment with sub-pixel endpoints and antialiased edges.

    Parameters
    ----------
    shape : (H, W) of the frame, px
    params : StreakParams, defaults if None
    rng : numpy Generator, or an int seed; None is seed 0

    Returns
    -------
    StreakLayer with ``blend == "add"``; its ``layer`` is in grey levels to add to a frame.
    """
    h, w = _shape2(shape)
    p = params or StreakParams()
    rng = _as_rng(rng)
    n = int(p.count)
    theta, is_noise = _orientations(n, p.mu_deg, p.sigma_deg, p.noise_fraction, rng)
    centers = rng.uniform((-0.5, -0.5), (w - 0.5, h - 0.5), size=(n, 2))
    lengths = np.maximum(p.length_px * (1.0 + p.length_jitter * rng.standard_normal(n)), 1.0)
    # A sub-pixel width covers that share of the pixel: OpenCV's lines need telling, the
    # supersampled drawing gets it from the geometry.
    coverage = min(p.width_px, 1.0) if p.supersample == 1 else 1.0
    levels = p.brightness * coverage * (1.0 + p.brightness_jitter * rng.standard_normal(n))
    levels = np.clip(levels, 0.0, 255.0)
    if p.supersample > 1:
        gauss, noise = _draw_streaks_supersampled(
            (h, w), centers, theta, lengths, p.width_px, levels, is_noise, p.supersample
        )
    else:
        gauss, noise = _draw_streaks((h, w), centers, theta, lengths, p.width_px, levels, is_noise)
    return _layer_from_canvases(gauss, noise, theta, is_noise, centers, lengths, "add")


def render_snow(
    shape: Sequence[int],
    params: SnowParams | None = None,
    rng: np.random.Generator | int | None = None,
) -> StreakLayer:
    """Snow flakes of one frame: bright blobs of radius 1-3 px, blurred along their fall.

    Each flake is a filled ellipse: its minor semi-axis is the flake's radius, its major one
    the radius plus half the motion blur, along an orientation drawn from ``params``; edges are
    antialiased then softened.

    Parameters
    ----------
    shape : (H, W) of the frame, px
    params : SnowParams, defaults if None
    rng : numpy Generator, or an int seed; None is seed 0

    Returns
    -------
    StreakLayer with ``blend == "max"``: ``layer`` is the flakes' grey level (0 elsewhere), to be
    composited as ``max(background, layer)``.
    """
    h, w = _shape2(shape)
    p = params or SnowParams()
    rng = _as_rng(rng)
    n = int(p.count)
    theta, is_noise = _orientations(n, p.mu_deg, p.sigma_deg, p.noise_fraction, rng)
    centers = rng.uniform((-0.5, -0.5), (w - 0.5, h - 0.5), size=(n, 2))
    return _snow_layer((h, w), p, centers, theta, is_noise, rng)


def render_falling_snow(
    shape: Sequence[int],
    params: SnowParams,
    flakes: np.random.Generator | int,
    i: int,
    *,
    pool: int,
) -> StreakLayer:
    """Frame ``i`` of snow whose flakes persist from frame to frame and fall.

    ``flakes`` seeds the scene's flakes (the same seed for every frame): each has a place at
    frame 0, a fall speed of 0.5-1.5 times ``params.fall_px`` pixels a frame, a sideways drift
    of up to a fifth of it, and its own size, level and blur. At frame ``i`` it is ``i`` steps
    further on, wrapped round the frame (with a margin, so that a flake leaves at the bottom
    and comes back at the top). ``params.count`` flakes are drawn, the first ones of the
    scene's ``pool`` (the same for every frame: at most ``pool`` are drawn); their shape is
    :func:`render_snow`'s.
    """
    h, w = _shape2(shape)
    p = params
    _require(p.fall_px > 0, "render_falling_snow", "params.fall_px must be > 0")
    rng = _as_rng(flakes)
    _require(pool >= 1, "render_falling_snow", "pool must be >= 1")
    n = min(int(p.count), pool)
    # drawn for the whole pool, so that a flake is the same whatever the frame's count
    start = rng.uniform((0.0, 0.0), (1.0, 1.0), size=(pool, 2))
    speed = p.fall_px * rng.uniform(0.5, 1.5, pool)
    drift = speed * rng.uniform(-0.2, 0.2, pool)
    theta, is_noise = _orientations(pool, p.mu_deg, p.sigma_deg, p.noise_fraction, rng)
    margin = 8.0
    span_x, span_y = w + 2 * margin, h + 2 * margin
    x = np.mod(start[:n, 0] * span_x + drift[:n] * i, span_x) - margin
    y = np.mod(start[:n, 1] * span_y + speed[:n] * i, span_y) - margin
    shapes = np.random.default_rng(rng.integers(2**63))  # sizes and levels, fixed per flake
    return _snow_layer(
        (h, w), p, np.column_stack((x, y)), theta[:n], is_noise[:n], shapes, pool=pool
    )


def _snow_layer(
    shape: tuple[int, int],
    p: SnowParams,
    centers: np.ndarray,
    theta: np.ndarray,
    is_noise: np.ndarray,
    rng: np.random.Generator,
    *,
    pool: int | None = None,
) -> StreakLayer:
    """The flakes at ``centers``: sizes, blurs and levels drawn from ``rng`` (``pool`` of
    them, the first ones used, when the flakes persist), drawn and softened."""
    h, w = shape
    n = len(centers)
    m = n if pool is None else pool
    r_min, r_max = p.radius_px
    radius = (r_min + (r_max - r_min) * rng.random(m) ** 2)[:n]
    lengths = np.maximum(p.blur_px * (1.0 + p.blur_jitter * rng.standard_normal(m)), 0.0)[:n]
    levels = np.clip(p.level * (1.0 + p.level_jitter * rng.standard_normal(m)), 0.0, 255.0)[:n]
    semi_axes = np.stack([radius + 0.5 * lengths, radius], axis=1)
    gauss, noise = _draw_blobs((h, w), centers, theta, semi_axes, levels, is_noise)
    if p.softness_px > 0:
        gauss = cv2.GaussianBlur(gauss, (0, 0), p.softness_px)
        noise = cv2.GaussianBlur(noise, (0, 0), p.softness_px)
    return _layer_from_canvases(gauss, noise, theta, is_noise, centers, 2 * semi_axes[:, 0], "max")


def composite(background: np.ndarray, layer: StreakLayer | np.ndarray) -> np.ndarray:
    """A precipitation layer over a background; neither input is modified.

    Parameters
    ----------
    background : (H, W) or (H, W, 3) uint8
    layer : StreakLayer (``blend`` says how), or an (H, W) array of grey levels to add

    Returns
    -------
    uint8, the shape of ``background``: saturating ``background + layer`` for rain,
    ``max(background, layer)`` for snow.
    """
    bg = np.asarray(background)
    _require(bg.dtype == np.uint8, "composite: background", f"must be uint8, got {bg.dtype}")
    values, blend = (layer.layer, layer.blend) if isinstance(layer, StreakLayer) else (layer, "add")
    values = np.asarray(values, dtype=np.float32)
    _require(values.shape == bg.shape[:2], "composite: layer", f"shape {values.shape} != frame")
    if bg.ndim == 3:
        values = values[:, :, None]
    if blend == "max":
        out = np.maximum(bg.astype(np.float32), values)
    else:
        out = bg.astype(np.float32) + values
    return np.clip(out + 0.5, 0.0, 255.0).astype(np.uint8)
