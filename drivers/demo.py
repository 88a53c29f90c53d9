"""The demo camera: the synthetic street of :func:`drivers.simulator.demo_frames` as a live source.

It lets ``weatherd run`` work out of the box without a camera: rain and snow come and go on a
two-minute cycle. Frames are paced in real time at the demo's rate, or given as fast as they
are read (``realtime=False``, for tests and benchmarks).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import numpy as np

from drivers.simulator import FrameTruth, demo_frames

from .errors import SourceError
from .frames import LiveFrame, Pacer

__all__ = ["DemoSource"]


class DemoSource:
    """The built-in synthetic street, ``demo:`` (``demo:?seed=3`` for another street,
    ``demo:?start=15`` to begin 15 s into its two-minute cycle: rain 5 s later).

    Parameters
    ----------
    width, height : frame size, pixels
    fps : frame rate, Hz; frame i is at ``t_s = i / fps``
    seed : the street and its weather
    start_s : where in the street's cycle the first frame is, seconds (frame times still start
        at 0)
    realtime : pace frames at ``fps`` (else as fast as they are read)

    Attributes
    ----------
    truth : the :class:`~drivers.simulator.FrameTruth` of the last frame read (what fell, how much)
    """

    def __init__(
        self,
        *,
        width: int = 640,
        height: int = 360,
        fps: float = 25.0,
        seed: int = 0,
        start_s: float = 0.0,
        realtime: bool = True,
    ):
        options = "&".join(
            option
            for option, given in ((f"seed={seed}", seed), (f"start={start_s:g}", start_s))
            if given
        )
        self.name = f"demo:?{options}" if options else "demo:"
        self.width, self.height, self.fps, self.seed = int(width), int(height), float(fps), seed
        self.start_s = float(start_s)
        self.truth: FrameTruth | None = None
        self._realtime = realtime
        self._closed = threading.Event()
        self._pacer = Pacer(self._closed)
        self._frames: Iterator[tuple[np.ndarray, FrameTruth]] | None = None
        self._index = 0
        self._open_ns = 0

    def open(self) -> None:
        if self._closed.is_set():
            raise SourceError(f"{self.name}: closed")
        start = round(self.start_s * self.fps)
        self._frames = demo_frames(self.width, self.height, self.fps, seed=self.seed, start=start)
        self._open_ns = time.time_ns()

    def read(self) -> LiveFrame:
        if self._frames is None or self._closed.is_set():
            raise SourceError(f"{self.name}: " + ("not open" if self._frames is None else "closed"))
        gray, self.truth = next(self._frames)
        t_s = self._index / self.fps
        if self._realtime and not self._pacer.wait(t_s):
            raise SourceError(f"{self.name}: closed")
        frame = LiveFrame(self._index, t_s, self._open_ns + round(t_s * 1e9), gray)
        self._index += 1
        return frame

    def close(self) -> None:
        self._closed.set()
        self._frames = None
