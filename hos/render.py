"""Synthetic rain and snow on a roadside scene, for tests, benchmarks and the demo camera.

The paper evaluates its rain-pixel classifier on synthetic streaks (section 8.4): streak
orientations drawn from a Gaussian, plus a share drawn from a uniform distribution ("noise"),
with a per-pixel ground truth from which a Dice coefficient is computed. This module draws such
streaks, draws snow flakes, and puts both on a procedural street scene with the distractors that
make a fixed camera hard to judge: cars, pedestrians, swaying foliage, auto-exposure steps,
sensor noise, JPEG artefacts, camera shake and night.

Read in order:

* :class:`StreakParams`, :func:`render_streaks`: additive rain streaks and their ground truth;
* :class:`SnowParams`, :func:`render_snow`: opaque flakes, composited with ``max``;
* :func:`composite`: a layer over a background, without touching either;
* :class:`SceneParams`, :class:`Scene`: the street; ``Scene.frame(i)`` is a pure function of
  the seed and ``i``, so any frame can be rendered again, alone, in any order;
* :func:`demo_frames`: the endless clear -> rain -> clear -> snow sequence of the demo camera;
* :func:`write_video`: frames to a video file with PyAV.

Orientation convention (project contract): image coordinates, x to the right, y downward,
theta measured from the x axis toward the y axis, in [0, pi). 90 degrees is a vertical streak,
45 degrees runs from top-left to bottom-right. A streak of orientation theta runs along
(cos theta, sin theta). Parameters take degrees (``*_deg``); arrays hold radians.
"""

from __future__ import annotations

import functools
import itertools
import math
import numbers
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

__all__ = [
    "VISIBLE_C",
    "FrameTruth",
    "Scene",
    "SceneParams",
    "SnowParams",
    "StreakLayer",
    "StreakParams",
    "composite",
    "demo_frames",
    "render_snow",
    "render_streaks",
    "write_video",
]

#: A pixel belongs to a streak when the streak adds at least this many grey levels: what the
#: photometric rule of eq. 8 sees with the paper's c = 3.
VISIBLE_C = 3.0

_SHIFT = 4  # fixed-point bits of OpenCV drawing coordinates: 1/16 px endpoints
_ONE = 1 << _SHIFT

#: Precipitation multiplier(s) per frame index: a callable, or a sequence indexed by frame.
Schedule = Callable[[int], float | tuple[float, float]] | Sequence[float | tuple[float, float]]


def _require(ok: bool, where: str, what: str) -> None:
    if not ok:
        raise ValueError(f"{where}: {what}")


# -- streaks and flakes ------------------------------------------------------------------------


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

    def __post_init__(self) -> None:
        _check_population("StreakParams", self.sigma_deg, self.noise_fraction, self.count)
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

    def __post_init__(self) -> None:
        _check_population("SnowParams", self.sigma_deg, self.noise_fraction, self.count)
        lo, hi = self.radius_px
        _require(0.5 <= lo <= hi, "SnowParams.radius_px", "must satisfy 0.5 <= min <= max")
        _require(self.blur_px >= 0, "SnowParams.blur_px", "must be >= 0")
        _require(self.blur_jitter >= 0, "SnowParams.blur_jitter", "must be >= 0")
        _require(0 <= self.level <= 255, "SnowParams.level", "must be in [0, 255]")
        _require(self.level_jitter >= 0, "SnowParams.level_jitter", "must be >= 0")
        _require(self.softness_px >= 0, "SnowParams.softness_px", "must be >= 0")


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
    across = (0.5 * width - 0.5) * np.stack([-direction[:, 1], direction[:, 0]], axis=1)
    corners = np.stack(
        [
            centers - along - across,
            centers + along - across,
            centers + along + across,
            centers - along + across,
        ],
        axis=1,
    )  # (N, 4, 2)
    corners = np.rint(corners * _ONE).astype(np.int32)
    for quad, v, noise in zip(corners, values, is_noise.tolist(), strict=True):
        cv2.fillConvexPoly(canvases[noise], quad, v, cv2.LINE_AA, _SHIFT)
    return canvases


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
    coverage = min(p.width_px, 1.0)  # a sub-pixel width covers that share of the pixel
    levels = p.brightness * coverage * (1.0 + p.brightness_jitter * rng.standard_normal(n))
    levels = np.clip(levels, 0.0, 255.0)
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
    r_min, r_max = p.radius_px
    radius = r_min + (r_max - r_min) * rng.random(n) ** 2
    lengths = np.maximum(p.blur_px * (1.0 + p.blur_jitter * rng.standard_normal(n)), 0.0)
    levels = np.clip(p.level * (1.0 + p.level_jitter * rng.standard_normal(n)), 0.0, 255.0)
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


# -- the scene ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class SceneParams:
    """What a :class:`Scene` shows besides its static street. Every distractor is off by default.

    Attributes
    ----------
    fps : frame rate, Hz: converts speeds and durations to frames
    cars : number of car "slots"; each slot sends a vehicle across the road now and then
        (about half of the time one is crossing), alternating the far lane (to the right) and
        the near lane (to the left). 0: no traffic.
    car_speed_kmh : (min, max) speed of a vehicle, km/h
    pedestrians : number of pedestrian slots on the far pavement; 0: nobody
    foliage_sway_px : amplitude of the wind's displacement of the tree's foliage, px
        (sinusoidal wave + gusts + leaf flutter); 0: still
    exposure_steps : simulate auto-exposure: the global gain jumps (or, sometimes, ramps) by
        ``exposure_step`` once per ``exposure_interval_s`` on average
    exposure_step : (min, max) relative size of one gain change
    exposure_interval_s : mean time between gain changes, s
    exposure_ramp_probability : share of the changes that are ramps (over 0.4-1.6 s)
    sensor_noise : standard deviation of the Gaussian sensor noise, grey levels, fresh each
        frame; 0: none
    jpeg_quality : if set, each frame goes through a JPEG encode/decode at this quality (1-100)
    shake_px : camera shake: the whole frame is translated by a smooth random motion (about
        3 Hz) plus a per-frame jitter, of typical amplitude ``shake_px`` px; 0: still
    darkness : global dimming, 0 (day) to 1 (black): the scene is multiplied by 1 - darkness
    rain, snow : the precipitation layers, or None
    schedule : intensity of the precipitation per frame: None (1 always), a number, a sequence
        indexed by frame (frames past its end take its last value), or a callable of the frame
        index. A value is a multiplier in [0, inf) of both rain and snow counts, or a pair
        ``(rain, snow)`` of multipliers; 0 is clear weather.
    """

    fps: float = 25.0
    cars: int = 0
    car_speed_kmh: tuple[float, float] = (30.0, 60.0)
    pedestrians: int = 0
    foliage_sway_px: float = 0.0
    exposure_steps: bool = False
    exposure_step: tuple[float, float] = (0.15, 0.25)
    exposure_interval_s: float = 4.0
    exposure_ramp_probability: float = 0.3
    sensor_noise: float = 0.0
    jpeg_quality: int | None = None
    shake_px: float = 0.0
    darkness: float = 0.0
    rain: StreakParams | None = None
    snow: SnowParams | None = None
    schedule: Schedule | float | None = None

    def __post_init__(self) -> None:
        _require(self.fps > 0, "SceneParams.fps", "must be > 0")
        _require(self.cars >= 0, "SceneParams.cars", "must be >= 0")
        lo, hi = self.car_speed_kmh
        _require(0 < lo <= hi, "SceneParams.car_speed_kmh", "must satisfy 0 < min <= max")
        _require(self.pedestrians >= 0, "SceneParams.pedestrians", "must be >= 0")
        _require(self.foliage_sway_px >= 0, "SceneParams.foliage_sway_px", "must be >= 0")
        lo, hi = self.exposure_step
        _require(0 <= lo <= hi < 1, "SceneParams.exposure_step", "must satisfy 0 <= min <= max < 1")
        _require(self.exposure_interval_s > 0, "SceneParams.exposure_interval_s", "must be > 0")
        _require(
            0 <= self.exposure_ramp_probability <= 1,
            "SceneParams.exposure_ramp_probability",
            "must be in [0, 1]",
        )
        _require(self.sensor_noise >= 0, "SceneParams.sensor_noise", "must be >= 0")
        _require(
            self.jpeg_quality is None or 1 <= self.jpeg_quality <= 100,
            "SceneParams.jpeg_quality",
            "must be None or in [1, 100]",
        )
        _require(self.shake_px >= 0, "SceneParams.shake_px", "must be >= 0")
        _require(0 <= self.darkness < 1, "SceneParams.darkness", "must be in [0, 1)")

    @classmethod
    def busy(cls, **overrides: object) -> SceneParams:
        """Every distractor on, at values seen on real roadside cameras; ``overrides`` win."""
        values: dict[str, object] = {
            "cars": 4,
            "pedestrians": 4,
            "foliage_sway_px": 2.0,
            "exposure_steps": True,
            "sensor_noise": 2.0,
            "jpeg_quality": 80,
            "shake_px": 0.5,
        }
        values.update(overrides)
        return cls(**values)  # type: ignore[arg-type]


@dataclass(frozen=True)
class FrameTruth:
    """What :meth:`Scene.frame` drew, for scoring a detector.

    Attributes
    ----------
    index : frame index
    precipitation : True when a precipitation layer is present with a multiplier > 0
    rain_intensity, snow_intensity : the schedule's multipliers (0 when absent)
    mu, sigma : radians, the true orientation distribution (rain's when it rains, else
        snow's); NaN in clear weather
    noise_fraction : the true uniform share (NaN in clear weather)
    theta : (N,) float64, radians, orientation of every streak and flake of the frame
    is_noise : (N,) bool, the ones drawn from the uniform distribution
    mask : (H, W) bool, streak and flake pixels that add at least ``VISIBLE_C`` grey levels to
        the frame after saturation, exposure and darkness (before sensor noise and JPEG),
        moved with the camera shake
    rain_mask, noise_mask : (H, W) bool, disjoint, union ``mask``: pixels of the Gaussian
        population (rain streaks or snow flakes) and of the uniform one
    gain : global gain applied to the scene (exposure times 1 - darkness)
    shake : (dx, dy), px, translation applied to the frame
    """

    index: int
    precipitation: bool
    rain_intensity: float
    snow_intensity: float
    mu: float
    sigma: float
    noise_fraction: float
    theta: np.ndarray
    is_noise: np.ndarray
    mask: np.ndarray
    rain_mask: np.ndarray
    noise_mask: np.ndarray
    gain: float
    shake: tuple[float, float]

    @property
    def kind(self) -> str:
        """The weather drawn: "clear", "rain", "snow" or "rain+snow"."""
        kinds = [k for k, v in (("rain", self.rain_intensity), ("snow", self.snow_intensity)) if v]
        return "+".join(kinds) if self.precipitation else "clear"


# Streams of the per-purpose random generators: np.random.default_rng([seed, stream, ...]).
# Separate streams keep, e.g., the rain of frame i the same whatever distractors are on.
_BACKGROUND, _RAIN, _SNOW, _NOISE, _JITTER, _SHAKE = range(6)
_GUST, _FLUTTER, _CAR, _PED, _EXPOSURE = range(6, 11)

# Layout, as fractions of the height: horizon, far pavement, road, near pavement.
_Y_HORIZON, _Y_PAVEMENT, _Y_ROAD, _Y_NEAR = 0.40, 0.56, 0.62, 0.88
_VP = (0.65, 0.42)  # vanishing point of the side street, fractions of (W, H)
#: px per metre (fraction of the height) on the far pavement, far lane and near lane.
_SCALE_PAVEMENT, _SCALE_FAR, _SCALE_NEAR = 0.032, 0.036, 0.045


class Scene:
    """A procedural roadside camera: static street + distractors + precipitation.

    The static background is a street seen from a mast: sky, façades with many windows and
    pilasters (strong vertical edges), lamp posts and a pole in the foreground, a side street and
    a zebra crossing whose edges run to a vanishing point, lane markings, a tree with textured
    foliage, and mild texture everywhere.

    Parameters
    ----------
    width, height : frame size, px (at least 64 x 36)
    seed : int >= 0; the background and every frame are functions of (seed, index)
    params : SceneParams, defaults (no distractors, no precipitation) if None
    """

    def __init__(
        self, width: int, height: int, *, seed: int = 0, params: SceneParams | None = None
    ):
        _require(width >= 64 and height >= 36, "Scene", f"size {width}x{height} is too small")
        _require(int(seed) == seed and seed >= 0, "Scene.seed", "must be an integer >= 0")
        self.width, self.height, self.seed = int(width), int(height), int(seed)
        self.params = params or SceneParams()
        rng = np.random.default_rng([self.seed, _BACKGROUND])
        bg, self._foliage = _paint_background(self.width, self.height, rng)
        self._sway = self.params.foliage_sway_px > 0
        self._static = bg if self._sway else self._foliage.over(bg)
        self._gain_starts = [1.0]  # gain at the start of each exposure slot, grown on demand
        self._noise_bank: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W)."""
        return self.height, self.width

    @property
    def background(self) -> np.ndarray:
        """(H, W) uint8: the empty street, foliage at rest, gain 1, no noise."""
        still = self._foliage.over(self._static) if self._sway else self._static
        return np.clip(still + 0.5, 0, 255).astype(np.uint8)

    def frames(
        self, start: int = 0, stop: int | None = None
    ) -> Iterator[tuple[np.ndarray, FrameTruth]]:
        """``frame(i)`` for i in [start, stop), endless when ``stop`` is None."""
        indices = itertools.count(start) if stop is None else range(start, stop)
        for i in indices:
            yield self.frame(i)

    def frame(self, i: int) -> tuple[np.ndarray, FrameTruth]:
        """Frame ``i``: (H, W) uint8 grey image and its :class:`FrameTruth`.

        Deterministic: the same seed, parameters and ``i`` give the same image.
        """
        _require(int(i) == i and i >= 0, "Scene.frame", f"index must be an integer >= 0, got {i}")
        i = int(i)
        p = self.params
        shape = self.shape
        img = self._static.copy()
        if self._sway:
            self._draw_foliage(img, i)
        if p.pedestrians:
            self._draw_pedestrians(img, i)
        if p.cars:
            self._draw_cars(img, i)

        rain_k, snow_k = self._intensity(i)
        gain = self._gain(i) * (1.0 - p.darkness)
        g = np.float32(gain)
        clear = img if gain == 1.0 else np.clip(img * g, 0, 255)  # the street is within [0, 255]
        layers: list[StreakLayer] = []
        wet = img
        if rain_k > 0 and p.rain is not None:
            rng = np.random.default_rng([self.seed, _RAIN, i])
            count = int(rng.poisson(p.rain.count * rain_k))
            layers.append(render_streaks(shape, replace(p.rain, count=count), rng))
            wet = wet + layers[-1].layer
        if snow_k > 0 and p.snow is not None:
            rng = np.random.default_rng([self.seed, _SNOW, i])
            count = int(rng.poisson(p.snow.count * snow_k))
            layers.append(render_snow(shape, replace(p.snow, count=count), rng))
            wet = np.maximum(wet, layers[-1].layer)
        if not layers:
            out = clear
        else:
            out = np.minimum(wet, 255) if gain == 1.0 else np.clip(wet * g, 0, 255)

        # Ground truth per pixel: 0 none, 1 Gaussian population, 2 uniform population.
        if layers:
            visible = (out - clear) >= VISIBLE_C
            streak = visible & np.logical_or.reduce([lay.mask for lay in layers])
            gauss = visible & np.logical_or.reduce([lay.rain_mask for lay in layers])
            labels = 2 * streak.view(np.uint8) - gauss.view(np.uint8)  # rain_mask within mask
        else:
            labels = np.zeros(shape, np.uint8)

        dx, dy = self._shake(i)
        if p.shake_px > 0:
            m = np.float32([[1, 0, dx], [0, 1, dy]])
            size = (self.width, self.height)
            out = cv2.warpAffine(
                out, m, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT
            )
            labels = cv2.warpAffine(
                labels, m, size, flags=cv2.INTER_NEAREST, borderMode=cv2.BORDER_REFLECT
            )
        if p.sensor_noise > 0:
            out = out + np.float32(p.sensor_noise) * self._sensor_noise(i)
        gray = np.clip(out + 0.5, 0, 255).astype(np.uint8)
        if p.jpeg_quality is not None:
            ok, buf = cv2.imencode(".jpg", gray, [cv2.IMWRITE_JPEG_QUALITY, int(p.jpeg_quality)])
            _require(ok, "Scene.frame", "JPEG encoding failed")
            gray = cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)

        source = p.rain if rain_k > 0 and p.rain is not None else (p.snow if layers else None)
        theta = np.concatenate([lay.theta for lay in layers]) if layers else np.zeros(0)
        is_noise = np.concatenate([lay.is_noise for lay in layers]) if layers else np.zeros(0, bool)
        truth = FrameTruth(
            index=i,
            precipitation=bool(layers),
            rain_intensity=rain_k if p.rain is not None else 0.0,
            snow_intensity=snow_k if p.snow is not None else 0.0,
            mu=math.radians(source.mu_deg) if source else math.nan,
            sigma=math.radians(source.sigma_deg) if source else math.nan,
            noise_fraction=source.noise_fraction if source else math.nan,
            theta=theta,
            is_noise=is_noise,
            mask=labels > 0,
            rain_mask=labels == 1,
            noise_mask=labels == 2,
            gain=float(gain),
            shake=(float(dx), float(dy)),
        )
        return gray, truth

    # -- time-varying parts, each a pure function of (seed, i) -----------------------------

    def _intensity(self, i: int) -> tuple[float, float]:
        """(rain, snow) multipliers of frame ``i`` from the schedule."""
        s = self.params.schedule
        if s is None:
            v: object = 1.0
        elif callable(s):
            v = s(i)
        elif isinstance(s, numbers.Real):
            v = s
        else:
            _require(len(s) > 0, "SceneParams.schedule", "must not be an empty sequence")
            v = s[min(i, len(s) - 1)]
        rain, snow = (v, v) if isinstance(v, numbers.Real) else tuple(v)  # type: ignore[arg-type]
        rain, snow = float(rain), float(snow)
        ok = math.isfinite(rain) and math.isfinite(snow) and rain >= 0 and snow >= 0
        _require(ok, "SceneParams.schedule", f"frame {i}: multipliers must be >= 0, got {v!r}")
        return rain, snow

    def _sensor_noise(self, i: int) -> np.ndarray:
        """(H, W) float32 N(0, 1) noise of frame ``i``: a random window of a fixed bank.

        Drawing 0.5 M normals costs 5 ms; a window at a random offset, with a random sign and
        flips, of a bank four frames large costs nothing, and no pixel sees the same sequence
        twice in practice (the bank holds 2H x 2W values, offsets repeat after ~H W frames).
        """
        h, w = self.shape
        if self._noise_bank is None:
            bank_rng = np.random.default_rng([self.seed, _NOISE])
            self._noise_bank = bank_rng.standard_normal((2 * h, 2 * w), np.float32)
        rng = np.random.default_rng([self.seed, _NOISE, i + 1])
        oy, ox = int(rng.integers(h + 1)), int(rng.integers(w + 1))
        window = self._noise_bank[oy : oy + h, ox : ox + w]
        fy, fx, sign = rng.choice((-1, 1), 3)
        return window[::fy, ::fx] if sign > 0 else -window[::fy, ::fx]

    def _knot(self, stream: int, k: int, shape: tuple[int, ...]) -> np.ndarray:
        return np.random.default_rng([self.seed, stream, k + 1]).standard_normal(shape)

    def _smooth_noise(self, stream: int, t: float, shape: tuple[int, ...] = ()) -> np.ndarray:
        """Smooth random signal at time ``t`` (knot periods): Catmull-Rom through N(0, 1) knots."""
        k = math.floor(t)
        u = t - k
        p0, p1, p2, p3 = (self._knot(stream, k + j, shape) for j in (-1, 0, 1, 2))
        return 0.5 * (
            2 * p1
            + (p2 - p0) * u
            + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u**2
            + (3 * p1 - p0 - 3 * p2 + p3) * u**3
        )

    def _shake(self, i: int) -> tuple[float, float]:
        """(dx, dy) px: smooth random motion (knots every 0.3 s) plus a per-frame jitter."""
        a = self.params.shake_px
        if a <= 0:
            return 0.0, 0.0
        slow = 0.8 * a * self._smooth_noise(_SHAKE, i / (0.3 * self.params.fps), (2,))
        jitter = 0.35 * a * np.random.default_rng([self.seed, _JITTER, i]).standard_normal(2)
        dx, dy = slow + jitter
        return float(dx), float(dy)

    def _gain(self, i: int) -> float:
        """Exposure gain of frame ``i``: one step or ramp at a random frame of every slot."""
        p = self.params
        if not p.exposure_steps:
            return 1.0
        slot_len = max(1, round(p.exposure_interval_s * p.fps))
        n, local = divmod(i, slot_len)
        while len(self._gain_starts) <= n:  # the level a slot starts at is where the last ended
            m = len(self._gain_starts) - 1
            self._gain_starts.append(self._exposure_event(m, slot_len)[3])
        start = self._gain_starts[n]
        offset, ramp_len, _, end = self._exposure_event(n, slot_len)
        if local < offset:
            return start
        return start + (end - start) * min(1.0, (local - offset + 1) / ramp_len)

    def _exposure_event(self, n: int, slot_len: int) -> tuple[int, int, float, float]:
        """(offset, duration, start, end) of slot ``n``'s gain change; duration 1 is a step."""
        p = self.params
        rng = np.random.default_rng([self.seed, _EXPOSURE, n])
        start = self._gain_starts[n]
        offset = int(rng.integers(slot_len))
        size = rng.uniform(*p.exposure_step)
        sign = -1.0 if start > 1.25 else 1.0 if start < 0.8 else rng.choice((-1.0, 1.0))
        ramp = rng.random() < p.exposure_ramp_probability
        duration = int(rng.uniform(0.4, 1.6) * p.fps) if ramp else 1
        duration = max(1, min(duration, slot_len - offset))
        return offset, duration, start, start * (1.0 + sign * size)

    def _draw_foliage(self, img: np.ndarray, i: int) -> None:
        """Composite the foliage, displaced by the wind, over ``img`` (in place, our buffer)."""
        f = self._foliage
        t = i / self.params.fps
        a = self.params.foliage_sway_px
        gust = float(self._smooth_noise(_GUST, t / 1.5))
        flutter = self._smooth_noise(_FLUTTER, t / 0.4, (2, *f.grid_phase.shape))
        wave = np.sin(2 * np.pi * 0.35 * t + f.grid_phase)
        dx = a * (0.55 * wave + 0.45 * gust + 0.3 * flutter[0])
        dy = a * (0.2 * wave + 0.3 * flutter[1])
        ph, pw = f.alpha.shape
        dx = cv2.resize(dx.astype(np.float32), (pw, ph), interpolation=cv2.INTER_CUBIC)
        dy = cv2.resize(dy.astype(np.float32), (pw, ph), interpolation=cv2.INTER_CUBIC)
        map_x, map_y = f.grid_x - dx, f.grid_y - dy
        value = cv2.remap(f.value, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        alpha = cv2.remap(f.alpha, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        y0, x0 = f.origin
        patch = img[y0 : y0 + ph, x0 : x0 + pw]
        patch += alpha * (value - patch)

    def _slot(self, stream: int, k: int, i: int, period: int) -> tuple[np.random.Generator, int]:
        """Generator of slot ``k``'s current cycle and the frame's position in that cycle."""
        phase = int(np.random.default_rng([self.seed, stream, k]).integers(period))
        cycle, local = divmod(i + phase, period)
        return np.random.default_rng([self.seed, stream, k, cycle]), local

    def _draw_cars(self, img: np.ndarray, i: int) -> None:
        p, h, w = self.params, self.height, self.width
        order = sorted(range(p.cars), key=lambda k: k % 2)  # far lane first: near cars occlude
        for k in order:
            near = k % 2 == 1
            px_m = (_SCALE_NEAR if near else _SCALE_FAR) * h
            base = (0.855 if near else 0.735) * h
            v_min = p.car_speed_kmh[0] / 3.6 / p.fps * px_m  # px/frame
            crossing_max = (w + 7.5 * px_m) / v_min
            period = math.ceil(2.0 * crossing_max)
            rng, local = self._slot(_CAR, k, i, period)
            v = rng.uniform(*p.car_speed_kmh) / 3.6 / p.fps * px_m
            van = rng.random() < 0.2
            length = rng.uniform(5.5, 7.0) if van else rng.uniform(3.8, 4.9)
            crossing = (w + length * px_m) / v
            start = rng.uniform(0, period - crossing)
            tau = local - start
            if not 0 <= tau <= crossing:
                continue
            direction = -1.0 if near else 1.0
            x_left = w - v * tau if near else -length * px_m + v * tau
            _draw_vehicle(img, x_left, base, px_m, length, direction, van, rng)

    def _draw_pedestrians(self, img: np.ndarray, i: int) -> None:
        p, h, w = self.params, self.height, self.width
        px_m = _SCALE_PAVEMENT * h
        for k in range(p.pedestrians):
            v_min = 1.0 / p.fps * px_m
            period = math.ceil(1.25 * (w + 2 * px_m) / v_min)
            rng, local = self._slot(_PED, k, i, period)
            v = rng.uniform(1.0, 1.6) / p.fps * px_m
            crossing = (w + 2 * px_m) / v
            start = rng.uniform(0, period - crossing)
            tau = local - start
            if not 0 <= tau <= crossing:
                continue
            right = rng.random() < 0.5
            x = -px_m + v * tau if right else w + px_m - v * tau
            base = (_Y_PAVEMENT + rng.uniform(0.35, 0.9) * (_Y_ROAD - _Y_PAVEMENT)) * h
            _draw_walker(img, x, base, px_m * rng.uniform(1.6, 1.85), tau / p.fps, rng)


# -- painting ----------------------------------------------------------------------------------


def _fx(points: Iterable[tuple[float, float]]) -> np.ndarray:
    """(N, 2) int32 fixed-point coordinates for OpenCV drawing with ``shift=_SHIFT``."""
    return np.rint(np.asarray(list(points), np.float64) * _ONE).astype(np.int32)


def _poly(img: np.ndarray, points: Iterable[tuple[float, float]], value: float) -> None:
    cv2.fillPoly(img, [_fx(points)], float(value), cv2.LINE_8, _SHIFT)


def _rect(img: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: float) -> None:
    _poly(img, ((x0, y0), (x1, y0), (x1, y1), (x0, y1)), value)


def _line(
    img: np.ndarray,
    p0: tuple[float, float],
    p1: tuple[float, float],
    value: float,
    thickness: float,
) -> None:
    a, b = _fx((p0, p1))
    cv2.line(
        img,
        tuple(a.tolist()),
        tuple(b.tolist()),
        float(value),
        max(1, round(thickness)),
        cv2.LINE_8,
        _SHIFT,
    )


def _circle(img: np.ndarray, c: tuple[float, float], r: float, value: float) -> None:
    ((cx, cy),) = _fx((c,))
    cv2.circle(
        img, (int(cx), int(cy)), max(1, round(r * _ONE)), float(value), -1, cv2.LINE_8, _SHIFT
    )


def _value_noise(shape: tuple[int, int], cell: float, rng: np.random.Generator) -> np.ndarray:
    """(H, W) float32 smooth noise of unit std, features about ``cell`` px wide."""
    h, w = shape
    coarse = rng.standard_normal((max(2, int(h / cell) + 2), max(2, int(w / cell) + 2)))
    smooth = cv2.resize(coarse.astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
    return smooth / max(float(smooth.std()), 1e-6)


@dataclass(frozen=True)
class _Foliage:
    """The tree's crown as a movable layer: grey value and opacity over a patch of the frame."""

    value: np.ndarray  # (ph, pw) float32 grey levels
    alpha: np.ndarray  # (ph, pw) float32 opacity in [0, 1]
    origin: tuple[int, int]  # (y0, x0) of the patch in the frame
    grid_x: np.ndarray  # (ph, pw) float32 pixel coordinates, for cv2.remap
    grid_y: np.ndarray
    grid_phase: np.ndarray  # (gh, gw) phase of the wind's wave over a coarse grid

    def over(self, img: np.ndarray) -> np.ndarray:
        """A copy of ``img`` with the crown at rest."""
        out = img.copy()
        y0, x0 = self.origin
        ph, pw = self.alpha.shape
        patch = out[y0 : y0 + ph, x0 : x0 + pw]
        patch += self.alpha * (self.value - patch)
        return out


def _paint_background(w: int, h: int, rng: np.random.Generator) -> tuple[np.ndarray, _Foliage]:
    """The static street, (H, W) float32 grey levels, and the tree's crown as a layer."""
    s = h / 540.0
    y_hz, y_pv, y_rd, y_nr = (f * h for f in (_Y_HORIZON, _Y_PAVEMENT, _Y_ROAD, _Y_NEAR))
    vx, vy = _VP[0] * w, _VP[1] * h
    img = np.empty((h, w), np.float32)

    # Sky: brighter toward the horizon, with soft clouds.
    rows = np.arange(h, dtype=np.float32)[:, None] / max(y_hz, 1.0)
    img[:] = 150.0 + 55.0 * np.minimum(rows, 1.0)
    img += 6.0 * _value_noise((h, w), w / 10, rng)

    # Distant hazy buildings behind everything (seen down the side street).
    x = 0.0
    while x < w:
        bw = rng.uniform(0.04, 0.09) * w
        top = rng.uniform(0.27, 0.36) * h
        grey = rng.uniform(150, 180)
        _rect(img, x, top, x + bw, y_pv, grey)
        for wx in np.arange(x + 0.01 * w, x + bw - 0.01 * w, 0.015 * w):
            _rect(img, wx, top + 0.02 * h, wx + 0.006 * w, y_pv - 0.02 * h, grey - 12)
        x += bw

    # Façades left and right of the side street.
    for xa, xb in ((-0.01 * w, 0.545 * w), (0.755 * w, 1.01 * w)):
        x = xa
        while x < xb - 1:
            bw = rng.uniform(0.07, 0.16) * w
            if xb - (x + bw) < 0.04 * w:
                bw = xb - x
            _paint_facade(img, x, x + bw, rng.uniform(0.06, 0.30) * h, y_pv, w, h, rng)
            x += bw

    # Far pavement, road and near pavement.
    img[int(y_pv) : int(y_rd) + 1] = 150.0
    road_rows = np.linspace(94.0, 80.0, int(y_nr) - int(y_rd), dtype=np.float32)[:, None]
    img[int(y_rd) : int(y_nr)] = road_rows
    img[int(y_nr) :] = 140.0

    # Side street running to the vanishing point, with its dashed centre line.
    def toward_vp(x_bottom: float, y: float) -> float:
        return vx + (x_bottom - vx) * (y - vy) / (y_rd - vy)

    _poly(img, ((vx - 1, vy), (vx + 1, vy), (0.75 * w, y_rd), (0.55 * w, y_rd)), 96.0)
    for z in np.arange(1.0, 8.0, 0.9):  # dashes at depths z (in units of the street's near end)
        ya, yb = vy + (y_rd - vy) / z, vy + (y_rd - vy) / (z + 0.45)
        half_a, half_b = 0.004 * w / z, 0.004 * w / (z + 0.45)
        _poly(
            img, ((vx - half_a, ya), (vx + half_a, ya), (vx + half_b, yb), (vx - half_b, yb)), 200.0
        )

    # Zebra crossing on the main road in line with the side street: stripes whose ends run to
    # the vanishing point (structured edges along vanishing lines).
    n_stripes = 7
    ys = np.linspace(y_rd + 0.01 * h, y_nr - 0.01 * h, 2 * n_stripes)
    for ya, yb in zip(ys[0::2], ys[1::2], strict=True):
        xl_a, xr_a = toward_vp(0.55 * w, ya), toward_vp(0.75 * w, ya)
        xl_b, xr_b = toward_vp(0.55 * w, yb), toward_vp(0.75 * w, yb)
        _poly(img, ((xl_a, ya), (xr_a, ya), (xr_b, yb), (xl_b, yb)), 205.0)

    # Lane markings: a dashed centre line and continuous edge lines, kerbs with their shadow.
    y_c = 0.5 * (y_rd + y_nr)
    dash, gap = 0.05 * w, 0.035 * w
    for x in np.arange(-rng.uniform(0, dash), w, dash + gap):
        if not toward_vp(0.55 * w, y_c) - dash < x < toward_vp(0.75 * w, y_c):
            _rect(img, x, y_c - 2.5 * s, x + dash, y_c + 2.5 * s, 200.0)
    _rect(img, 0, y_rd + 5 * s, w, y_rd + 7 * s, 190.0)
    _rect(img, 0, y_nr - 8 * s, w, y_nr - 5 * s, 190.0)
    _rect(img, 0, y_rd - 3 * s, w, y_rd, 185.0)
    _rect(img, 0, y_nr, w, y_nr + 4 * s, 195.0)
    _rect(img, 0, y_nr + 4 * s, w, y_nr + 6 * s, 105.0)

    # Paving joints on the near pavement: across, and along lines running to the vanishing point.
    for y in np.arange(y_nr + 0.035 * h, h, 0.04 * h):
        _line(img, (0, y), (w, y), 118.0, s)
    for xb in np.arange(-0.5 * w, 1.5 * w, 0.06 * w):
        y_top = y_nr + 6 * s
        _line(img, (toward_vp(xb, y_top), y_top), (toward_vp(xb, h), h), 118.0, s)

    # Lamp posts on the far pavement, a tall pole and a sign in the foreground.
    pw = max(2.0, 0.005 * w)
    for xp in (0.28 * w, 0.47 * w, 0.84 * w):
        top = 0.17 * h
        _rect(img, xp, top, xp + pw, y_pv + 0.035 * h, 55.0)
        _rect(img, xp - 0.03 * w, top, xp + pw, top + 2.5 * s, 60.0)
        _rect(img, xp - 0.035 * w, top + 2.5 * s, xp - 0.015 * w, top + 6 * s, 175.0)
    xp, pw = 0.92 * w, max(3.0, 0.012 * w)
    _rect(img, xp, 0.03 * h, xp + pw, h, 72.0)
    _rect(img, xp + 0.6 * pw, 0.03 * h, xp + pw, h, 118.0)
    _rect(img, xp - 0.02 * w, 0.22 * h, xp + pw + 0.02 * w, 0.31 * h, 60.0)
    _rect(img, xp - 0.017 * w, 0.225 * h, xp + pw + 0.017 * w, 0.305 * h, 215.0)

    # The tree's trunk (the crown is a separate, movable layer).
    xt = 0.15 * w
    _poly(
        img,
        (
            (xt - 0.013 * w, 0.96 * h),
            (xt + 0.013 * w, 0.96 * h),
            (xt + 0.006 * w, 0.35 * h),
            (xt - 0.006 * w, 0.35 * h),
        ),
        62.0,
    )

    # Mild texture everywhere, then the lens's blur.
    img += 3.0 * _value_noise((h, w), 6.0 * max(s, 0.5), rng)
    img += rng.normal(0.0, 1.5, (h, w)).astype(np.float32)
    img = cv2.GaussianBlur(img, (0, 0), 0.7)
    return np.clip(img, 0, 255), _paint_crown(w, h, xt, rng)


def _paint_facade(
    img: np.ndarray,
    x0: float,
    x1: float,
    top: float,
    bottom: float,
    w: int,
    h: int,
    rng: np.random.Generator,
) -> None:
    """A building front: wall, cornice, a grid of windows, pilasters, a shop front."""
    s = h / 540.0
    base = rng.uniform(95, 175)
    _rect(img, x0, top, x1, bottom, base)
    _rect(img, x0, top, x1, top + 5 * s, base - 35)
    cw, rh = rng.uniform(0.018, 0.03) * w, rng.uniform(0.045, 0.07) * h
    dark = rng.uniform(40, 75)
    cols = np.arange(x0 + 0.35 * cw, x1 - 0.8 * cw, cw)
    for y in np.arange(top + 0.03 * h, bottom - 0.09 * h - 0.6 * rh, rh):
        for x in cols:
            glass = dark if rng.random() < 0.8 else rng.uniform(160, 205)
            _rect(
                img,
                x - 1.5 * s,
                y - 1.5 * s,
                x + 0.55 * cw + 1.5 * s,
                y + 0.6 * rh + 1.5 * s,
                min(base + 25, 235),
            )
            _rect(img, x, y, x + 0.55 * cw, y + 0.6 * rh, glass)
    step = int(rng.integers(2, 5))
    for x in cols[::step]:
        _rect(
            img,
            x - 0.3 * cw,
            top + 5 * s,
            x - 0.3 * cw + max(2.0, 0.004 * w),
            bottom,
            base + rng.choice((-28.0, 28.0)),
        )
    shop = bottom - 0.06 * h
    _rect(img, x0, shop - 0.012 * h, x1, shop, base - 40)
    _rect(img, x0 + 0.01 * w, shop + 3 * s, x1 - 0.01 * w, bottom, rng.uniform(35, 70))
    door = rng.uniform(x0 + 0.02 * w, max(x0 + 0.02 * w, x1 - 0.04 * w))
    _rect(img, door, shop + 3 * s, door + 0.02 * w, bottom, rng.uniform(20, 50))
    _rect(img, x0, top, x0 + max(1.5, 2 * s), bottom, base - 45)


def _paint_crown(w: int, h: int, xt: float, rng: np.random.Generator) -> _Foliage:
    """The tree's crown: clumps of leaves of many greys, fine texture, gaps, soft edges."""
    s = h / 540.0
    cx, cy, rx, ry = xt, 0.30 * h, 0.11 * w, 0.19 * h
    margin = int(np.ceil(0.05 * h)) + 8
    x0, y0 = max(0, int(cx - rx) - margin), max(0, int(cy - ry) - margin)
    x1, y1 = min(w, int(cx + rx) + margin), min(h, int(cy + ry) + margin)
    ph, pw = y1 - y0, x1 - x0
    value = np.zeros((ph, pw), np.float32)
    alpha = np.zeros((ph, pw), np.float32)
    for _ in range(int(700 * max(rx * ry / (0.11 * 960 * 0.19 * 540), 0.3))):
        r, a = math.sqrt(rng.random()), rng.uniform(0, 2 * math.pi)
        ex, ey = r * math.cos(a), r * math.sin(a)
        c = (int((cx + ex * rx - x0) * _ONE), int((cy + ey * ry - y0) * _ONE))
        size = rng.uniform(0.008, 0.026) * h
        axes = (max(1, int(size * _ONE)), max(1, int(size * rng.uniform(0.55, 1.0) * _ONE)))
        grey = rng.uniform(40, 100) - 25.0 * (ex + ey) / 2  # lit from the top left
        angle = rng.uniform(0, 180)
        cv2.ellipse(value, c, axes, angle, 0, 360, float(grey), -1, cv2.LINE_8, _SHIFT)
        cv2.ellipse(alpha, c, axes, angle, 0, 360, 1.0, -1, cv2.LINE_8, _SHIFT)
    for _ in range(45):  # gaps where the sky shows through
        r, a = math.sqrt(rng.random()) * 0.85, rng.uniform(0, 2 * math.pi)
        c = (
            int((cx + r * math.cos(a) * rx - x0) * _ONE),
            int((cy + r * math.sin(a) * ry - y0) * _ONE),
        )
        axes = (max(1, int(rng.uniform(1.5, 5) * s * _ONE)),) * 2
        cv2.ellipse(alpha, c, axes, 0, 0, 360, 0.0, -1, cv2.LINE_8, _SHIFT)
    inside = alpha > 0
    value += 14.0 * rng.standard_normal((ph, pw)).astype(np.float32)
    value += 8.0 * _value_noise((ph, pw), 4.0 * max(s, 0.5), rng)
    speckle = (rng.random((ph, pw)) < 0.02) & inside
    value[speckle] += 60.0  # leaves catching the light
    value = cv2.GaussianBlur(np.clip(value, 0, 255), (0, 0), 0.6)
    alpha = cv2.GaussianBlur(alpha, (0, 0), 1.0)
    grid_y, grid_x = np.mgrid[0:ph, 0:pw].astype(np.float32)
    gy, gx = np.mgrid[0:6, 0:6] / 5.0
    phase = 2 * np.pi * (rng.uniform(0.4, 0.9) * gx + rng.uniform(0.2, 0.6) * gy)
    return _Foliage(value, alpha, (y0, x0), grid_x, grid_y, phase + rng.uniform(0, 2 * np.pi))


def _draw_vehicle(
    img: np.ndarray,
    x_left: float,
    base: float,
    px_m: float,
    length_m: float,
    direction: float,
    van: bool,
    rng: np.random.Generator,
) -> None:
    """A car or van, side view, wheels on ``base``; ``direction`` +1 drives to the right."""
    h, w = img.shape
    length = length_m * px_m
    x_right = x_left + length

    def at(f: float) -> float:  # position along the body, 0 = rear, 1 = front
        return x_left + length * (f if direction > 0 else 1.0 - f)

    # Shadow on the road.
    ys = slice(max(0, int(base - 0.12 * px_m)), min(h, int(base + 0.12 * px_m) + 1))
    xs = slice(max(0, int(x_left + 0.05 * length)), min(w, int(x_right - 0.05 * length) + 1))
    img[ys, xs] *= 0.55
    colour = rng.choice((rng.uniform(25, 70), rng.uniform(110, 150), rng.uniform(175, 230)))
    top_body = base - (2.3 if van else 0.95) * px_m
    _rect(img, x_left, top_body, x_right, base - 0.28 * px_m, colour)
    _rect(img, x_left, base - 0.55 * px_m, x_right, base - 0.28 * px_m, colour * 0.7)
    _rect(img, x_left, top_body, x_right, top_body + 0.06 * px_m, min(colour + 45, 250))
    glass = rng.uniform(30, 70) if rng.random() < 0.7 else rng.uniform(140, 190)
    if van:
        _poly(
            img,
            (
                (at(0.80), top_body + 0.15 * px_m),
                (at(0.97), top_body + 0.15 * px_m),
                (at(0.99), base - 1.2 * px_m),
                (at(0.80), base - 1.2 * px_m),
            ),
            glass,
        )
        _line(img, (at(0.78), top_body), (at(0.78), base - 0.3 * px_m), colour * 0.6, 1)
    else:
        roof = base - 1.45 * px_m
        cabin = ((at(0.20), top_body), (at(0.82), top_body), (at(0.68), roof), (at(0.30), roof))
        _poly(img, cabin, colour)
        inset = 0.07 * px_m
        _poly(
            img,
            (
                (at(0.24), top_body - inset),
                (at(0.78), top_body - inset),
                (at(0.66), roof + inset),
                (at(0.32), roof + inset),
            ),
            glass,
        )
        _line(img, (at(0.50), roof), (at(0.50), base - 0.3 * px_m), colour * 0.6, 1)
    r = 0.33 * px_m
    for f in (0.18, 0.82):
        _circle(img, (at(f), base - r), r, 22.0)
        _circle(img, (at(f), base - r), 0.45 * r, 115.0)
    y_light = base - 0.75 * px_m
    head = 250.0 if rng.random() < 0.6 else 210.0
    _rect(img, at(0.985) - 0.1 * px_m, y_light, at(0.985) + 0.1 * px_m, y_light + 0.12 * px_m, head)
    _rect(
        img,
        at(0.015) - 0.08 * px_m,
        y_light,
        at(0.015) + 0.08 * px_m,
        y_light + 0.15 * px_m,
        rng.uniform(70, 170),
    )


def _draw_walker(
    img: np.ndarray, x: float, base: float, height: float, t_s: float, rng: np.random.Generator
) -> None:
    """A walking figure of ``height`` px, feet on ``base``, legs and arms swinging."""
    swing = math.sin(2 * math.pi * 0.9 * t_s + rng.uniform(0, 2 * math.pi))
    coat, trousers = rng.uniform(30, 200), rng.uniform(25, 110)
    hip_y, shoulder_y = base - 0.48 * height, base - 0.82 * height
    limb = max(1.0, 0.075 * height)
    stride = 0.16 * height * swing
    _line(img, (x, hip_y), (x + stride, base), trousers, limb)
    _line(img, (x, hip_y), (x - stride, base), trousers * 0.85, limb)
    _poly(
        img,
        (
            (x - 0.12 * height, shoulder_y),
            (x + 0.12 * height, shoulder_y),
            (x + 0.1 * height, hip_y),
            (x - 0.1 * height, hip_y),
        ),
        coat,
    )
    _line(
        img,
        (x, shoulder_y + 0.03 * height),
        (x - 0.6 * stride, hip_y + 0.04 * height),
        coat * 0.8,
        limb * 0.8,
    )
    _circle(img, (x, shoulder_y - 0.08 * height), 0.07 * height, rng.uniform(120, 175))


# -- the demo camera ---------------------------------------------------------------------------

#: The demo's cycle, seconds: clear, rain, clear, then snow (even cycles) or heavy rain (odd).
_DEMO_PHASES_S = (20.0, 40.0, 20.0, 40.0)
_DEMO_RAMP_S = 2.0


def _demo_schedule(i: int, *, fps: float) -> tuple[float, float]:
    """(rain, snow) multipliers of the demo at frame ``i``, ramping over 2 s at the edges."""
    t = i / fps
    period = sum(_DEMO_PHASES_S)
    cycle, t = divmod(t, period)
    clear1, rain, clear2, last = _DEMO_PHASES_S

    def envelope(t0: float, duration: float) -> float:
        u = min(t - t0, t0 + duration - t) / _DEMO_RAMP_S
        return float(np.clip(u, 0.0, 1.0))

    if t < clear1 + rain:
        return envelope(clear1, rain), 0.0
    k = envelope(clear1 + rain + clear2, last)
    return (0.0, k) if int(cycle) % 2 == 0 else (1.8 * k, 0.0)


def demo_frames(
    width: int = 640, height: int = 360, fps: float = 25, *, seed: int = 0
) -> Iterator[tuple[np.ndarray, FrameTruth]]:
    """Endless (gray, truth) frames for the daemon's demo camera.

    A street with cars, pedestrians, light wind in the tree and a little sensor noise; the
    weather cycles every two minutes: clear (20 s), moderate rain (40 s), clear (20 s), then
    snow (40 s) on even cycles and heavy rain on odd ones. Counts and lengths scale with the
    frame size so that the rain looks the same at any resolution.
    """
    area = width * height / (640 * 360)
    rain = StreakParams(count=max(1, round(300 * area)), length_px=max(3.0, 11.0 * height / 540))
    snow = SnowParams(count=max(1, round(220 * area)))
    schedule = functools.partial(_demo_schedule, fps=fps)
    params = SceneParams(
        fps=fps,
        cars=3,
        pedestrians=3,
        foliage_sway_px=1.5,
        sensor_noise=1.5,
        rain=rain,
        snow=snow,
        schedule=schedule,
    )
    yield from Scene(width, height, seed=seed, params=params).frames()


# -- video files -------------------------------------------------------------------------------

_CODECS = ("libx264", "mpeg4", "mjpeg")


def _pick_codec(codec: str | None) -> str:
    for name in (codec,) if codec else _CODECS:
        try:
            av.codec.Codec(name, "w")
        except ValueError:  # av.codec.codec.UnknownCodecError: not in this build
            continue
        return name
    wanted = codec or " / ".join(_CODECS)
    raise ValueError(f"write_video: no {wanted} encoder in this PyAV build")


def write_video(
    path: str | Path,
    frames: Iterable[np.ndarray],
    fps: float = 25,
    *,
    codec: str | None = None,
    crf: int = 18,
) -> int:
    """Write uint8 frames to a video file with PyAV; return the number of frames written.

    Parameters
    ----------
    path : output file; the container follows its extension (.mp4, .mkv, .avi...)
    frames : iterable of (H, W) uint8 grey or (H, W, 3) uint8 BGR frames, all the same shape;
        H and W must be even (the encoders use 4:2:0 chroma)
    fps : frame rate, Hz
    codec : encoder name; None picks libx264 if this PyAV build has it, else mpeg4, else mjpeg
    crf : libx264 constant rate factor (0 lossless, 18 visually lossless); the other encoders
        run at 8 Mbit/s

    Raises
    ------
    ValueError : no frames, odd or changing size, not uint8, or no such encoder
    """
    it = iter(frames)
    first = next(it, None)
    _require(first is not None, "write_video", "no frames to write")
    first = np.asarray(first)
    shape = first.shape
    _require(
        first.ndim == 2 or (first.ndim == 3 and shape[2] == 3),
        "write_video",
        f"frames must be (H, W) gray or (H, W, 3) BGR, got {shape}",
    )
    h, w = shape[:2]
    _require(
        h % 2 == 0 and w % 2 == 0,
        "write_video",
        f"frame size {w}x{h} must be even for 4:2:0 video; crop or pad the frames",
    )
    fmt = "gray" if first.ndim == 2 else "bgr24"
    name = _pick_codec(codec)
    rate = Fraction(fps).limit_denominator(1001)
    n = 0
    with av.open(str(path), "w") as container:
        stream = container.add_stream(name, rate=rate)
        stream.width, stream.height = w, h
        stream.pix_fmt = "yuvj420p" if name == "mjpeg" else "yuv420p"
        if name == "libx264":
            stream.options = {"crf": str(int(crf)), "preset": "veryfast"}
        else:
            stream.bit_rate = 8_000_000
        for arr in itertools.chain((first,), it):
            arr = np.asarray(arr)
            _require(arr.shape == shape, "write_video", f"frame {n} is {arr.shape}, not {shape}")
            _require(arr.dtype == np.uint8, "write_video", f"frame {n} is {arr.dtype}, not uint8")
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(arr), format=fmt)
            container.mux(stream.encode(frame))
            n += 1
        container.mux(stream.encode(None))
    return n
