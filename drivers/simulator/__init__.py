"""Synthetic rain and snow on a roadside scene, for tests, benchmarks and the demo camera.

The paper evaluates its rain-pixel classifier on synthetic streaks (section 8.4): streak
orientations drawn from a Gaussian, plus a share drawn from a uniform distribution ("noise"),
with a per-pixel ground truth from which a Dice coefficient is computed. The renderer draws such
streaks, draws snow flakes, and puts both on a procedural street scene with the distractors that
make a fixed camera hard to judge: cars, pedestrians, swaying foliage, auto-exposure steps,
sensor noise, JPEG artefacts, camera shake and night.

This package is a simulated camera, kept apart from the detector in ``hos/``: the frame source
of the demo camera (:mod:`drivers.demo`), and the scene generator of the tests and the
benchmark. Its ``__init__`` re-exports the public names of the modules that do the work, so
that ``from drivers.simulator import Scene`` is all a test or a benchmark needs. Read in order:

* :mod:`.precipitation` -- :class:`StreakParams`, :func:`render_streaks`: additive rain
  streaks and their ground truth; :class:`SnowParams`, :func:`render_snow`: opaque flakes,
  composited with ``max``; :func:`composite`: a layer over a background, without touching
  either;
* :mod:`.street` -- the painting of the street and of what crosses it (private helpers);
* :mod:`.scene` -- :class:`SceneParams`, :class:`Scene`: the street; ``Scene.frame(i)`` is a
  pure function of the seed and ``i``, so any frame can be rendered again, alone, in any order;
* :mod:`.demo` -- :func:`demo_params`: the demo street; :func:`demo_frames`: the endless
  clear -> rain -> clear -> snow sequence of the demo camera;
* :mod:`.video_writer` -- :func:`write_video`: frames to a video file with PyAV.

Orientation convention (project contract): image coordinates, x to the right, y downward,
theta measured from the x axis toward the y axis, in [0, pi). 90 degrees is a vertical streak,
45 degrees runs from top-left to bottom-right. A streak of orientation theta runs along
(cos theta, sin theta). Parameters take degrees (``*_deg``); arrays hold radians.
"""

from __future__ import annotations

from .demo import _demo_schedule as _demo_schedule
from .demo import demo_frames, demo_params
from .precipitation import (
    VISIBLE_C,
    SnowParams,
    StreakLayer,
    StreakParams,
    composite,
    render_falling_snow,
    render_snow,
    render_streaks,
)
from .scene import FrameTruth, Scene, SceneParams
from .scene import Schedule as Schedule
from .video_writer import write_video

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
    "demo_params",
    "render_falling_snow",
    "render_snow",
    "render_streaks",
    "write_video",
]
