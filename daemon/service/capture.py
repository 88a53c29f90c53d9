"""One capture thread per camera: read frames, keep only the newest, reconnect on failure.

The thread opens the camera's :class:`~drivers.frames.FrameSource` and puts every frame it reads
into a one-slot mailbox; the processing thread takes the newest with :meth:`CaptureThread.take`.
Capture never waits for processing: a frame still in the mailbox when the next one arrives is
overwritten and counted as dropped.

A source that fails (open or read raises :class:`~drivers.errors.SourceError`, or
:class:`~drivers.errors.InputError` for a file that has gone) is closed and opened again after a
bounded exponential backoff (0.5 s doubling to 30 s by default), reset once frames flow again.
:meth:`CaptureThread.take` returns None, never raises, at the end: check ``state``. A finite
source that ends (a file without ``loop``) leaves the thread in state ``ended``. A
:class:`~drivers.errors.ConfigError` (a spec that can never work) leaves it ``failed``. Any other
exception is retried like a :class:`~drivers.errors.SourceError` (nothing a camera does may kill
the daemon), logged with its traceback.

States: ``starting`` -> ``ok`` <-> ``reconnecting``; then ``ended``, ``failed`` or ``stopped``.
One log line per change of state (and per change of failure reason), never one per frame.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from typing import Any

from drivers.errors import ConfigError, WeatherdError
from drivers.frames import FrameSource, LiveFrame

__all__ = ["CaptureThread", "backoff_delays"]

log = logging.getLogger(__name__)

#: Window over which :meth:`CaptureThread.stats` measures the frame rate, seconds.
FPS_WINDOW_S = 5.0


def backoff_delays(initial_s: float = 0.5, max_s: float = 30.0) -> Iterator[float]:
    """Endless delays before successive reconnections, seconds: ``initial_s`` doubling up to
    ``max_s`` (0.5, 1, 2, 4, 8, 16, 30, 30...)."""
    delay = initial_s
    while True:
        yield min(delay, max_s)
        delay = min(delay * 2.0, max_s)


class CaptureThread:
    """Reads one camera in a thread; the newest frame waits in a one-slot mailbox.

    Parameters
    ----------
    camera_id : names the camera in logs
    opener : makes a fresh, unopened source; called for each (re)connection
    backoff_initial_s, backoff_max_s : reconnection delays, seconds (see :func:`backoff_delays`)

    Attributes
    ----------
    state : ``"starting"``, ``"ok"``, ``"reconnecting"``, ``"ended"``, ``"failed"`` or
        ``"stopped"``
    """

    def __init__(
        self,
        camera_id: str,
        opener: Callable[[], FrameSource],
        *,
        backoff_initial_s: float = 0.5,
        backoff_max_s: float = 30.0,
    ):
        if not 0 < backoff_initial_s <= backoff_max_s:
            raise ValueError("need 0 < backoff_initial_s <= backoff_max_s")
        self.camera_id = camera_id
        self.state = "starting"
        self._opener = opener
        self._backoff = (backoff_initial_s, backoff_max_s)
        self._stop = threading.Event()
        self._lock = threading.Lock()  # guards the source being read, for stop()
        self._mailbox = threading.Condition()
        self._slot: LiveFrame | None = None
        self._source: FrameSource | None = None
        self._source_name: str | None = None
        self._thread = threading.Thread(target=self._run, name=f"capture {camera_id}", daemon=True)
        self._received: deque[float] = deque()  # monotonic receipt times within FPS_WINDOW_S
        self._last_frame_mono: float | None = None
        self._last_error: str | None = None
        self._frames_captured = 0
        self._frames_dropped = 0
        self._frames_taken = 0
        self._reconnects = 0
        self._next_retry_s: float | None = None
        self._flowed = False  # the current session has delivered a frame

    # -- control ---------------------------------------------------------------------------
    def start(self) -> None:
        """Start reading in the background."""
        self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the thread: close the source (even mid-read) and wait up to ``timeout`` s."""
        self._stop.set()
        with self._lock:
            source = self._source
        if source is not None:
            source.close()
        if self._thread.is_alive():
            self._thread.join(timeout)
        if self._thread.is_alive():
            log.warning(
                "camera %s: capture thread still busy after %.1f s", self.camera_id, timeout
            )
        self._set_state("stopped")

    def take(self, timeout: float) -> LiveFrame | None:
        """The newest frame not yet taken, waiting up to ``timeout`` seconds; None if none came.

        It waits the whole ``timeout`` even once the source has ended (so that a caller's loop
        cannot spin): check :attr:`state` to tell an end from a pause.
        """
        with self._mailbox:
            self._mailbox.wait_for(lambda: self._slot is not None, timeout)
            frame, self._slot = self._slot, None
            if frame is not None:
                self._frames_taken += 1
            return frame

    def stats(self) -> dict[str, Any]:
        """Counters and health of this camera, for the status message.

        Returns
        -------
        dict with ``camera``, ``source`` (name, credentials masked), ``state``,
        ``frames_captured``, ``frames_taken``, ``frames_dropped`` (overwritten in the mailbox),
        ``reconnects`` (reconnection attempts), ``last_error`` (str or None),
        ``last_frame_age_s`` (float or None), ``fps`` (measured over the last ~5 s, Hz) and
        ``next_retry_s`` (the current backoff delay while reconnecting, else None).
        """
        now = time.monotonic()
        with self._mailbox:
            received = list(self._received)
            last = self._last_frame_mono
            counters = {
                "frames_captured": self._frames_captured,
                "frames_taken": self._frames_taken,
                "frames_dropped": self._frames_dropped,
            }
        recent = [t for t in received if now - t <= FPS_WINDOW_S]
        span_s = recent[-1] - recent[0] if recent else 0.0
        fps = (len(recent) - 1) / span_s if span_s > 0 else 0.0
        return {
            "camera": self.camera_id,
            "source": self._source_name,
            "state": self.state,
            **counters,
            "reconnects": self._reconnects,
            "last_error": self._last_error,
            "last_frame_age_s": None if last is None else now - last,
            "fps": fps,
            "next_retry_s": self._next_retry_s if self.state == "reconnecting" else None,
        }

    # -- the thread ------------------------------------------------------------------------
    def _run(self) -> None:
        delays = backoff_delays(*self._backoff)
        attempts = 0
        while not self._stop.is_set():
            if attempts:
                self._reconnects += 1
            attempts += 1
            self._flowed = False
            try:
                ended = self._session()
            except ConfigError as exc:
                self._last_error = str(exc)
                log.error("camera %s: cannot use the source: %s", self.camera_id, exc)
                self._set_state("failed")
                return
            except Exception as exc:
                if self._stop.is_set():
                    break
                if self._flowed:  # frames came before the failure: back to the shortest delay
                    delays = backoff_delays(*self._backoff)
                delay_s = next(delays)
                self._report_failure(exc, delay_s)
                if self._stop.wait(delay_s):
                    break
                continue
            if ended:
                log.info("camera %s: %s ended", self.camera_id, self._source_name)
                self._set_state("ended")
            return

    def _session(self) -> bool:
        """Open a fresh source and read it until it ends (True) or the thread stops (False);
        raises what the source raised."""
        source = self._opener()
        with self._lock:
            self._source, self._source_name = source, source.name
        try:
            if self._stop.is_set():  # stop() may have come before the source was known
                return False
            source.open()
            while not self._stop.is_set():
                frame = source.read()
                if frame is None:
                    return True
                self._deliver(frame)
                if not self._flowed:
                    self._flowed = True
                    self._on_flowing(frame)
            return False
        finally:
            with self._lock:
                self._source = None
            try:
                source.close()
            except Exception:
                log.exception("camera %s: error closing %s", self.camera_id, source.name)

    def _deliver(self, frame: LiveFrame) -> None:
        now = time.monotonic()
        with self._mailbox:
            if self._slot is not None:
                self._frames_dropped += 1
            self._slot = frame
            self._frames_captured += 1
            self._last_frame_mono = now
            self._received.append(now)
            while self._received and now - self._received[0] > FPS_WINDOW_S:
                self._received.popleft()
            self._mailbox.notify_all()

    def _on_flowing(self, frame: LiveFrame) -> None:
        height, width = frame.gray.shape[:2]
        log.info(
            "camera %s: receiving frames from %s (%dx%d)",
            self.camera_id,
            self._source_name,
            width,
            height,
        )
        self._set_state("ok")

    def _report_failure(self, exc: BaseException, delay_s: float) -> None:
        """Note a failed session; log it once per change of state or of reason."""
        reason = _describe(exc)
        unexpected = not isinstance(exc, WeatherdError)
        if self.state != "reconnecting" or reason != self._last_error or unexpected:
            log.warning(
                "camera %s: %s (%s); reconnecting in %.3g s",
                self.camera_id,
                "source lost" if self.state == "ok" else "source unavailable",
                reason,
                delay_s,
                exc_info=exc if unexpected else None,
            )
        else:
            log.debug("camera %s: still failing; next try in %.3g s", self.camera_id, delay_s)
        self._last_error = reason
        self._next_retry_s = delay_s
        self._set_state("reconnecting")

    def _set_state(self, state: str) -> None:
        if state != self.state:
            log.debug("camera %s: state %s -> %s", self.camera_id, self.state, state)
            self.state = state


def _describe(exc: BaseException) -> str:
    """One line for logs and status: the message of our errors, the type of others."""
    if isinstance(exc, WeatherdError):
        return str(exc)
    return f"{type(exc).__name__}: {exc}"
