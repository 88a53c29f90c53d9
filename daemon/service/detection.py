"""Running the detector over a stream of frames, both cores busy.

``HosDetector.segment`` (the exposure gain and the background model, MOG2: the floor of the
method, which OpenCV spreads over both cores with the GIL released) of the next frames runs on a
worker thread while ``HosDetector.analyse`` (camera motion, candidate pixels, blobs, HOS, EM,
decision: compiled kernels and numpy) of frame n runs on the caller's thread. The two stages
share no mutable state (``hos.pipeline.Segmented`` is all that passes between them), each stage
sees its frames in order, and the results are exactly those of ``process`` called frame by
frame (tests/daemon/test_detection.py).

The worker may run up to ``lookahead`` frames ahead of the analysis. One frame ahead is enough
in theory; in practice the two stages' costs vary from frame to frame (a car, a burst of rain)
and a stage that finds the other one late waits, leaving a core idle. A few frames of slack
absorb that.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

from hos import FrameResult, HosDetector
from hos.pipeline import Segmented

__all__ = ["LOOKAHEAD_FRAMES", "detect_frames"]

#: Frames that segmentation may run ahead of the analysis (measured: 1 leaves a core idle
#: about a tenth of the time; 3 and more are no faster than 2-3).
LOOKAHEAD_FRAMES = 3


def detect_frames(
    detector: HosDetector,
    frames: Iterable[tuple[float, np.ndarray]],
    *,
    pipelined: bool = True,
    lookahead: int = LOOKAHEAD_FRAMES,
) -> Iterator[FrameResult]:
    """Yield one :class:`FrameResult` per ``(t_s, gray)`` of ``frames``, in order.

    With ``pipelined`` the segmentation of the next ``lookahead`` frames (>= 1) overlaps this
    frame's analysis; the worker thread is shut down when the generator is closed or
    exhausted. Results are yielded as soon as they are ready: at most ``lookahead + 1`` frames
    are in flight.
    """
    if not pipelined:
        for t_s, gray in frames:
            yield detector.process(gray, t_s)
        return
    if lookahead < 1:
        raise ValueError(f"lookahead must be >= 1, got {lookahead}")
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="hos-segment") as pool:
        pending: deque[Future[Segmented]] = deque()
        try:
            for t_s, gray in frames:
                pending.append(pool.submit(detector.segment, gray, t_s))
                if len(pending) > lookahead:
                    yield detector.analyse(pending.popleft().result())
            while pending:
                yield detector.analyse(pending.popleft().result())
        finally:
            for future in pending:
                future.cancel()
