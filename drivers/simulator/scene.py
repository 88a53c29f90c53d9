"""A procedural roadside camera: :class:`SceneParams`, :class:`Scene` and :class:`FrameTruth`.

``Scene.frame(i)`` paints the street of :mod:`.street`, moves its distractors (cars,
pedestrians, swaying foliage, auto-exposure steps, sensor noise, JPEG artefacts, camera shake,
night), lays the precipitation of :mod:`.precipitation` over it and says what it drew. It is
a pure function of the seed and ``i``, so any frame can be rendered again, alone, in any order.
"""

from __future__ import annotations

import itertools
import math
import numbers
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace

import cv2
import numpy as np

from ._common import _require
from .precipitation import (
    VISIBLE_C,
    SnowParams,
    StreakLayer,
    StreakParams,
    render_falling_snow,
    render_snow,
    render_streaks,
)
from .street import (
    _SCALE_FAR,
    _SCALE_NEAR,
    _SCALE_PAVEMENT,
    _Y_PAVEMENT,
    _Y_ROAD,
    _draw_vehicle,
    _draw_walker,
    _draw_wet_road,
    _paint_background,
)

__all__ = ["FrameTruth", "Scene", "SceneParams", "Schedule"]

#: Precipitation multiplier(s) per frame index: a callable, or a sequence indexed by frame.
Schedule = Callable[[int], float | tuple[float, float]] | Sequence[float | tuple[float, float]]


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
    shake_px : camera shake: the street is translated by a smooth random motion (about
        3 Hz) plus a per-frame jitter, of typical amplitude ``shake_px`` px; 0: still. The
        precipitation, drawn at random sub-pixel places, is not resampled with it
    darkness : global dimming, 0 (day) to 1 (black): the scene is multiplied by 1 - darkness
    shade : cloud shade: the share of light a passing cloud's shadow takes away, 0 (none) to
        1; its shadows drift across the view at ``shade_speed_px_s`` px/s (to the right),
        cover about ``shade_cover`` of it, and their edges are soft over about
        ``shade_edge`` of a shadow's size (0: sharp). The whole view is multiplied, the
        precipitation with it
    wet_road : how wet the road is while it rains (and for 10 s after), 0 (dry) to 1: vehicles
        throw spray behind their wheels and their lights are mirrored in the road as vertical
        bright streaks under them (``street._draw_wet_road``); 0: never
    wet_always : the road is wet (``wet_road``) even in clear weather, as after rain
    view_zoom, view_centre, view_roll_deg, view_mirror : the camera's view of the street:
        magnified ``view_zoom`` times (>= 1: a longer lens, a camera nearer or higher) about
        the point ``view_centre`` of the street (fractions of its width and height; moved up
        or down, the horizon goes the other way: the camera's tilt), turned by
        ``view_roll_deg`` (counter-clockwise as shown) and mirrored left to right. The
        precipitation is drawn in the frame as it is (its orientation is its own). The view
        must stay on the street: :func:`view_fits` says whether it does
    lens_blur_px : a soft camera: the whole view, precipitation included, is blurred by a
        Gaussian of this standard deviation (px) after the light and before the sensor noise
        and the codec (the street is drawn with a blur of 0.7 px already); 0: none
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
    shade: float = 0.0
    shade_speed_px_s: float = 40.0
    shade_cover: float = 0.4
    shade_edge: float = 0.3
    wet_road: float = 0.0
    wet_always: bool = False
    view_zoom: float = 1.0
    view_centre: tuple[float, float] = (0.5, 0.5)
    view_roll_deg: float = 0.0
    view_mirror: bool = False
    lens_blur_px: float = 0.0
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
        _require(0 <= self.shade < 1, "SceneParams.shade", "must be in [0, 1)")
        _require(0 < self.shade_cover < 1, "SceneParams.shade_cover", "must be in (0, 1)")
        _require(0 <= self.shade_edge <= 1, "SceneParams.shade_edge", "must be in [0, 1]")
        _require(0 <= self.wet_road <= 1, "SceneParams.wet_road", "must be in [0, 1]")
        _require(1 <= self.view_zoom <= 4, "SceneParams.view_zoom", "must be in [1, 4]")
        _require(abs(self.view_roll_deg) <= 20, "SceneParams.view_roll_deg", "must be in [-20, 20]")
        _require(0 <= self.lens_blur_px <= 10, "SceneParams.lens_blur_px", "must be in [0, 10]")

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
    gain : global gain applied to the scene (exposure times 1 - darkness; cloud shade, which
        varies over the view, is not in it)
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
_SPRAY = 11
_CLOUD = 12
#: A road stays wet this long after the rain, s (it dries over hours; the benchmark's scenes
#: last seconds, so a clear scene on a wet road says so with ``SceneParams.wet_always``).
_WET_AFTER_S = 10.0


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
        p = self.params
        _require(
            view_fits(p.view_zoom, p.view_centre, p.view_roll_deg, self.width / self.height),
            "SceneParams.view_centre",
            "the view must stay on the street (scene.view_centre_range gives where it may be)",
        )
        self._view = view_matrix(p, self.width, self.height)
        self._gain_starts = [1.0]  # gain at the start of each exposure slot, grown on demand
        self._noise_bank: np.ndarray | None = None
        self._shade = self._shade_canvas() if self.params.shade > 0 else None

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W)."""
        return self.height, self.width

    @property
    def background(self) -> np.ndarray:
        """(H, W) uint8: the empty street, foliage at rest, gain 1, no noise (through the
        lens's blur, ``SceneParams.lens_blur_px``)."""
        still = self._foliage.over(self._static) if self._sway else self._static
        if self._view is not None:
            still = cv2.warpAffine(
                still, self._view, (self.width, self.height), flags=cv2.INTER_LINEAR
            )
        if self.params.lens_blur_px > 0:
            still = cv2.GaussianBlur(still, (0, 0), float(self.params.lens_blur_px))
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

        # The camera shake moves the street (resampled: a fraction of a pixel spreads its edges
        # as the sensor would), not the precipitation: a drop falls at a random place in front
        # of the camera, drawn already at its sub-pixel place (antialiased), so moving its layer
        # by a fraction of a pixel would blur every streak a second time, by up to half its
        # contrast on half the frames, which no camera does.
        dx, dy = self._shake(i)
        if p.shake_px > 0 or self._view is not None:
            m = np.float32([[1, 0, 0], [0, 1, 0]]) if self._view is None else self._view.copy()
            m[:, 2] += (dx, dy)  # the shake moves the view
            img = cv2.warpAffine(
                img,
                m,
                (self.width, self.height),
                flags=cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_REFLECT,
            )

        rain_k, snow_k = self._intensity(i)
        gain = self._gain(i) * (1.0 - p.darkness)
        g = np.float32(gain) if self._shade is None else self._shade_at(i) * np.float32(gain)
        lit = gain == 1.0 and self._shade is None
        clear = img if lit else np.clip(img * g, 0, 255)  # the street is within [0, 255]
        layers: list[StreakLayer] = []
        wet = img
        if rain_k > 0 and p.rain is not None:
            rng = np.random.default_rng([self.seed, _RAIN, i])
            count = int(rng.poisson(p.rain.count * rain_k))
            layers.append(render_streaks(shape, replace(p.rain, count=count), rng))
            wet = wet + layers[-1].layer
        if snow_k > 0 and p.snow is not None:
            rng = np.random.default_rng([self.seed, _SNOW, i])
            snow = replace(p.snow, count=int(rng.poisson(p.snow.count * snow_k)))
            if p.snow.fall_px > 0:  # the scene's flakes, where they have fallen to by now
                flakes = np.random.default_rng([self.seed, _SNOW])
                pool = 2 * p.snow.count + 64
                layers.append(render_falling_snow(shape, snow, flakes, i, pool=pool))
            else:
                layers.append(render_snow(shape, snow, rng))
            wet = np.maximum(wet, layers[-1].layer)
        if not layers:
            out = clear
        else:
            out = np.minimum(wet, 255) if lit else np.clip(wet * g, 0, 255)
        if p.lens_blur_px > 0:
            # the optics blur whatever comes through them, the drops too; the truth of what is
            # visible compares the blurred view with and without them
            blur = float(p.lens_blur_px)
            clear = cv2.GaussianBlur(np.asarray(clear, np.float32), (0, 0), blur)
            out = (
                clear if not layers else cv2.GaussianBlur(np.asarray(out, np.float32), (0, 0), blur)
            )

        # Ground truth per pixel: 0 none, 1 Gaussian population, 2 uniform population.
        if layers:
            visible = (out - clear) >= VISIBLE_C
            streak = visible & np.logical_or.reduce([lay.mask for lay in layers])
            gauss = visible & np.logical_or.reduce([lay.rain_mask for lay in layers])
            labels = 2 * streak.view(np.uint8) - gauss.view(np.uint8)  # rain_mask within mask
        else:
            labels = np.zeros(shape, np.uint8)

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

    def _shade_canvas(self) -> np.ndarray:
        """(H, P) float32 light of the cloud shade over a strip P wide that repeats, 1 in the
        sun and ``1 - shade`` under a cloud."""
        p = self.params
        rng = np.random.default_rng([self.seed, _CLOUD])
        cell = max(self.width // 4, 8)  # a cloud's shadow is about a quarter of the view
        gh, gw = -(-self.height // cell) + 1, 4 * (-(-self.width // cell))
        knots = rng.random((gh, gw)).astype(np.float32)
        pad = 2
        wrapped = np.pad(knots, ((pad, pad), (pad, pad)), mode="wrap")
        size = ((gw + 2 * pad) * cell, (gh + 2 * pad) * cell)
        field = cv2.resize(wrapped, size, interpolation=cv2.INTER_CUBIC)
        field = field[pad * cell : pad * cell + self.height, pad * cell : (pad + gw) * cell]
        # shade where the field is above its (1 - cover) quantile; a soft step of the given width
        level = float(np.quantile(field, 1.0 - p.shade_cover))
        spread = max(p.shade_edge * float(field.std()), 1e-3)
        shaded = np.clip((field - level) / spread + 0.5, 0.0, 1.0)
        return (1.0 - p.shade * shaded).astype(np.float32)

    def _shade_at(self, i: int) -> np.ndarray:
        """(H, W) float32 light of the cloud shade in frame ``i``."""
        canvas = self._shade
        period = canvas.shape[1]
        off = round(i * self.params.shade_speed_px_s / self.params.fps) % period
        cols = (np.arange(self.width) - off) % period
        return canvas[:, cols]

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

    def _wetness(self, i: int) -> float:
        """How wet the road is at frame ``i``: ``wet_road`` while it rains, for
        ``_WET_AFTER_S`` after, or always with ``wet_always``; else 0."""
        p = self.params
        if p.wet_road <= 0 or (p.rain is None and not p.wet_always):
            return 0.0
        if p.wet_always:
            return p.wet_road
        back = math.ceil(_WET_AFTER_S * p.fps)
        step = max(1, back // 20)
        rained = any(self._intensity(j)[0] > 0 for j in range(max(0, i - back), i + 1, step))
        return p.wet_road if rained or self._intensity(i)[0] > 0 else 0.0

    def _draw_cars(self, img: np.ndarray, i: int) -> None:
        p, h, w = self.params, self.height, self.width
        wet = self._wetness(i)
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
            if wet > 0:
                spray = np.random.default_rng([self.seed, _SPRAY, k, i])
                _draw_wet_road(img, x_left, base, px_m, length, direction, wet, spray)

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


def _view_extent(zoom: float, roll_deg: float, aspect: float) -> tuple[float, float]:
    """Half the extent, as fractions of the street's width and height, of the part of the
    street a view magnified ``zoom`` times and turned by ``roll_deg`` shows (a frame of
    ``aspect`` width / height)."""
    c, s = abs(math.cos(math.radians(roll_deg))), abs(math.sin(math.radians(roll_deg)))
    return (c + s / aspect) / (2 * zoom), (c + s * aspect) / (2 * zoom)


def least_zoom(roll_deg: float, aspect: float) -> float:
    """The least zoom that keeps a view rolled by ``roll_deg`` on the street, for a frame
    of ``aspect`` (width / height)."""
    a = math.radians(abs(roll_deg))
    return max(math.cos(a) + math.sin(a) * k for k in (aspect, 1.0 / aspect))


def view_fits(zoom: float, centre: tuple[float, float], roll_deg: float, aspect: float) -> bool:
    """Whether a view (``SceneParams.view_*``) of a frame of ``aspect`` (width / height)
    shows only the street: no border beyond it."""
    span = view_centre_range(zoom, roll_deg, (aspect,))
    eps = 1e-9
    return span is not None and all(
        lo - eps <= c <= hi + eps for c, (lo, hi) in zip(centre, span, strict=True)
    )


def view_centre_range(
    zoom: float, roll_deg: float, aspects: tuple[float, ...] = (4 / 3, 16 / 9)
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The ranges ((x lo, x hi), (y lo, y hi)) of ``view_centre`` that keep a view on the
    street at every frame aspect of ``aspects``; None when there are none."""
    ex = max(_view_extent(zoom, roll_deg, a)[0] for a in aspects)
    ey = max(_view_extent(zoom, roll_deg, a)[1] for a in aspects)
    if ex > 0.5 or ey > 0.5:
        return None
    return (ex, 1 - ex), (ey, 1 - ey)


def fit_view(p: SceneParams, aspect: float) -> SceneParams:
    """``p`` with its view brought onto the street for a frame of ``aspect`` (width / height):
    the least zoom its roll needs there, and its centre moved (the least) into range; ``p``
    itself when its view fits already (a scene drawn for one frame size, drawn at another)."""
    if view_fits(p.view_zoom, p.view_centre, p.view_roll_deg, aspect):
        return p
    zoom = max(p.view_zoom, least_zoom(p.view_roll_deg, aspect))
    (x0, x1), (y0, y1) = view_centre_range(zoom, p.view_roll_deg, (aspect,))
    centre = (min(max(p.view_centre[0], x0), x1), min(max(p.view_centre[1], y0), y1))
    return replace(p, view_zoom=zoom, view_centre=centre)


def view_matrix(p: SceneParams, width: int, height: int) -> np.ndarray | None:
    """(2, 3) float32 affine map from the street to the frame for ``p``'s view; None for the
    street as drawn (no zoom, roll or mirror, centred)."""
    if (
        p.view_zoom == 1.0
        and p.view_roll_deg == 0.0
        and not p.view_mirror
        and tuple(p.view_centre) == (0.5, 0.5)
    ):
        return None
    a = math.radians(p.view_roll_deg)
    # counter-clockwise as shown (y down), magnified; after the mirror (x -> -x)
    rot = p.view_zoom * np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]])
    lin = rot @ np.diag([-1.0 if p.view_mirror else 1.0, 1.0])
    # the street's point view_centre lands at the frame's centre
    c = np.array([p.view_centre[0] * (width - 1), p.view_centre[1] * (height - 1)])
    m = np.empty((2, 3), np.float32)
    m[:, :2] = lin
    m[:, 2] = np.array([(width - 1) / 2.0, (height - 1) / 2.0]) - lin @ c
    return m
