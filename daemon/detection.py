"""Running the detector over a stream of frames, both cores busy.

``HosDetector.segment`` (exposure, background model, candidate pixels: mostly OpenCV, which
releases the GIL) of frame n+1 runs on a worker thread while ``HosDetector.analyse`` (blobs, HOS,
EM, decision) of frame n runs on the caller's thread. The two stages share no mutable state
(``hos.pipeline.Segmented`` is all that passes between them), each stage sees its frames in
order, and the results are exactly those of ``process`` called frame by frame
(tests/daemon/test_detection.py).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

from hos import FrameResult, HosDetector

__all__ = ["detect_frames"]


def detect_frames(
    detector: HosDetector,
    frames: Iterable[tuple[float, np.ndarray]],
    *,
    pipelined: bool = True,
) -> Iterator[FrameResult]:
    """Yield one :class:`FrameResult` per ``(t_s, gray)`` of ``frames``, in order.

    With ``pipelined`` the next frame's segmentation overlaps this frame's analysis; the
    worker thread is shut down when the generator is closed or exhausted.
    """
    if not pipelined:
        for t_s, gray in frames:
            yield detector.process(gray, t_s)
        return
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="hos-segment") as pool:
        pending: Future | None = None
        try:
            for t_s, gray in frames:
                nxt = pool.submit(detector.segment, gray, t_s)
                if pending is not None:
                    yield detector.analyse(pending.result())
                pending = nxt
            if pending is not None:
                yield detector.analyse(pending.result())
                pending = None
        finally:
            if pending is not None:
                pending.cancel()
