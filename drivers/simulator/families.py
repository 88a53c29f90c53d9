"""Families of fixed-camera scenes for the benchmark (``make eval``): each a random draw of
everything the simulated street can vary, under one weather condition and one camera motion,
with per-frame truth.

Two splits draw from different seeds *and* different ranges: ``tuning`` (the scenes a
parameter may be set on) and ``evaluation`` (never used to set one): other resolutions, frame
rates, compression qualities, more traffic, darker scenes, stronger wind. The street's layout
comes from its seed (buildings, trees, poles and signs differ from seed to seed).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace

import cv2
import numpy as np

from .precipitation import SnowParams, StreakParams
from .scene import Scene, SceneParams

__all__ = ["CONDITIONS", "SPLITS", "SceneCase", "case_frames", "sample_case", "sample_cases"]

#: Weather conditions: clear, rain from drizzle-like to heavy, snow, and clear -> rain -> clear.
CONDITIONS = ("clear", "drizzle", "light", "moderate", "heavy", "snow", "transition")
#: The camera: fixed, shaken by the wind (sub-pixel), or re-aimed once (panned for 2 s).
CAMERAS = ("static", "wind", "reaim")
SPLITS = ("tuning", "evaluation")

_RANGES = {
    "tuning": {
        "sizes": [(320, 240), (640, 360)],
        "fps": [15.0, 25.0],
        "jpeg": [None, 90, 70],
        "cars": (0, 4),
        "pedestrians": (0, 4),
        "foliage": (0.0, 2.0),
        "noise": (0.0, 3.0),
        "darkness": (0.0, 0.5),
        "wind": (0.1, 1.0),
        "seed0": 10_000,
    },
    "evaluation": {
        "sizes": [(480, 270), (800, 450), (1280, 720)],
        "fps": [10.0, 20.0, 30.0],
        "jpeg": [85, 75, 60],
        "cars": (2, 6),
        "pedestrians": (0, 6),
        "foliage": (0.5, 3.0),
        "noise": (1.0, 4.0),
        "darkness": (0.0, 0.6),
        "wind": (0.2, 0.5),
        "seed0": 50_000,
    },
}

_RAIN = {
    "drizzle": StreakParams(count=200, length_px=5.0, brightness=14.0, sigma_deg=12.0),
    "light": StreakParams(count=90, brightness=25.0),
    "moderate": StreakParams(count=350, brightness=40.0),
    "heavy": StreakParams(count=1200, brightness=45.0, length_px=16.0),
}


@dataclass(frozen=True)
class SceneCase:
    """One benchmark scene: what to render and how long.

    ``reaim`` is the (first, last + 1) frames during which the camera is panned by ``pan_px``
    per frame (then it stays at its new aim); None for a camera that is never moved.
    ``density`` is the precipitation's streak count for a 640x360 frame (0 when clear), for the
    rank test of R; the count drawn scales with the frame's area.
    """

    name: str
    split: str
    seed: int
    width: int
    height: int
    fps: float
    condition: str
    camera: str
    frames: int
    params: SceneParams
    density: float
    reaim: tuple[int, int] | None = None
    pan_px: tuple[float, float] = (0.0, 0.0)
    #: frames of the transition's rain phase, [start, end)
    rain_frames: tuple[int, int] | None = None


def sample_case(
    split: str, index: int, *, condition: str, camera: str, frames: int = 300
) -> SceneCase:
    """Scene ``index`` of ``split`` under ``condition`` with ``camera``: the same arguments
    always give the same scene."""
    if split not in _RANGES:
        raise ValueError(f"split must be one of {SPLITS}, got {split!r}")
    if condition not in CONDITIONS or camera not in CAMERAS:
        raise ValueError(f"unknown condition {condition!r} or camera {camera!r}")
    r = _RANGES[split]
    seed = int(r["seed0"]) + index
    rng = np.random.default_rng([seed, CONDITIONS.index(condition), CAMERAS.index(camera)])
    width, height = r["sizes"][rng.integers(len(r["sizes"]))]
    fps = float(r["fps"][rng.integers(len(r["fps"]))])
    jpeg = r["jpeg"][rng.integers(len(r["jpeg"]))]

    def uniform(key: str) -> float:
        lo, hi = r[key]
        return float(rng.uniform(lo, hi))

    params = SceneParams(
        fps=fps,
        cars=int(rng.integers(r["cars"][0], r["cars"][1] + 1)),
        pedestrians=int(rng.integers(r["pedestrians"][0], r["pedestrians"][1] + 1)),
        foliage_sway_px=uniform("foliage"),
        exposure_steps=bool(rng.random() < 0.5),
        sensor_noise=uniform("noise"),
        jpeg_quality=None if jpeg is None else int(jpeg),
        shake_px=uniform("wind") if camera == "wind" else 0.0,
        darkness=uniform("darkness"),
    )
    density = 0.0
    rain_frames = None
    mu = float(rng.uniform(70.0, 110.0))
    # The conditions' streak counts are for 640x360: the same rain over another frame size
    # draws as many streaks per pixel.
    area = width * height / (640 * 360)
    if condition in _RAIN or condition == "transition":
        streaks = _RAIN.get(condition, _RAIN["moderate"])
        streaks = replace(streaks, mu_deg=mu, count=max(1, round(streaks.count * area)))
        density = float(streaks.count) / area
        schedule = None
        if condition == "transition":
            third = frames // 3
            rain_frames = (third, 2 * third)
            schedule = [0.0] * third + [1.0] * third + [0.0]
        params = replace(params, rain=streaks, schedule=schedule)
    elif condition == "snow":
        flakes = SnowParams()
        params = replace(params, snow=replace(flakes, count=max(1, round(flakes.count * area))))
        density = float(flakes.count)
    reaim = None
    pan = (0.0, 0.0)
    if camera == "reaim":
        start = int(frames * 0.55)
        reaim = (start, start + round(2.0 * fps))
        angle = float(rng.uniform(0, 2 * np.pi))
        speed = float(rng.uniform(1.0, 3.0))  # px a frame
        pan = (speed * np.cos(angle), speed * np.sin(angle))
    name = f"{split}-{index:03d}-{condition}-{camera}"
    return SceneCase(
        name=name,
        split=split,
        seed=seed,
        width=int(width),
        height=int(height),
        fps=fps,
        condition=condition,
        camera=camera,
        frames=frames,
        params=params,
        density=density,
        reaim=reaim,
        pan_px=pan,
        rain_frames=rain_frames,
    )


def sample_cases(split: str, *, per_cell: int = 1, frames: int = 300) -> list[SceneCase]:
    """Every condition with a static and a wind-shaken camera, and clear weather with a
    re-aimed one, ``per_cell`` scenes each."""
    cases = []
    index = 0
    for condition in CONDITIONS:
        cameras = ("static", "wind", "reaim") if condition == "clear" else ("static", "wind")
        for camera in cameras:
            for _ in range(per_cell):
                cases.append(
                    sample_case(split, index, condition=condition, camera=camera, frames=frames)
                )
                index += 1
    return cases


@dataclass(frozen=True)
class CaseFrame:
    """A rendered frame and its truth."""

    gray: np.ndarray
    precipitation: bool  # drawn in this frame
    moving: bool  # the camera is being moved
    mu: float  # radians, the drawn orientation (NaN when clear)


def case_frames(case: SceneCase) -> Iterator[CaseFrame]:
    """The frames of ``case`` with their truth."""
    scene = Scene(case.width, case.height, seed=case.seed, params=case.params)
    offset = np.zeros(2)
    for i in range(case.frames):
        gray, truth = scene.frame(i)
        moving = case.reaim is not None and case.reaim[0] <= i < case.reaim[1]
        if moving:
            offset += case.pan_px
        if offset.any():
            m = np.float32([[1, 0, offset[0]], [0, 1, offset[1]]])
            gray = cv2.warpAffine(gray, m, (case.width, case.height), borderMode=cv2.BORDER_REFLECT)
        yield CaseFrame(gray, bool(truth.precipitation), moving, float(truth.mu))
