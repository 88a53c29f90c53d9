"""The demo camera's street: endless frames cycling clear -> rain -> clear -> snow."""

from __future__ import annotations

import functools
from collections.abc import Iterator

import numpy as np

from .precipitation import SnowParams, StreakParams
from .scene import FrameTruth, Scene, SceneParams, Schedule

__all__ = ["demo_frames", "demo_params"]

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


def demo_params(
    width: int = 640, height: int = 360, fps: float = 25, *, schedule: Schedule | None = None
) -> SceneParams:
    """The demo street's :class:`SceneParams` for this frame size: cars, pedestrians, light
    wind in the tree, a little sensor noise, and moderate rain or snow (falling flakes) at
    multiplier 1.

    ``schedule`` (see :class:`SceneParams`) says when it rains or snows; None: the demo's
    cycle. Counts and lengths scale with the frame size so that the rain looks the same at any
    resolution.
    """
    area = width * height / (640 * 360)
    rain = StreakParams(count=max(1, round(300 * area)), length_px=max(3.0, 11.0 * height / 540))
    # flakes that persist and fall, 3 px a frame at 480 rows, as snow does (the fall rule,
    # hos/fall.py, sees them as well as the HOS)
    snow = SnowParams(count=max(1, round(220 * area)), fall_px=3.0 * height / 480)
    if schedule is None:
        schedule = functools.partial(_demo_schedule, fps=fps)
    return SceneParams(
        fps=fps,
        cars=3,
        pedestrians=3,
        foliage_sway_px=1.5,
        sensor_noise=1.5,
        rain=rain,
        snow=snow,
        schedule=schedule,
    )


def demo_frames(
    width: int = 640, height: int = 360, fps: float = 25, *, seed: int = 0, start: int = 0
) -> Iterator[tuple[np.ndarray, FrameTruth]]:
    """Endless (gray, truth) frames for the daemon's demo camera, from frame ``start`` on.

    The street of :func:`demo_params`; the weather cycles every two minutes: clear (20 s),
    moderate rain (40 s), clear (20 s), then snow (40 s) on even cycles and heavy rain on odd
    ones. Frame ``i`` is the same whatever ``start`` is.
    """
    params = demo_params(width, height, fps)
    yield from Scene(width, height, seed=seed, params=params).frames(start)
