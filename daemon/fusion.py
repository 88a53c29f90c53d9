"""From per-frame detector results to camera summaries and one weather state for the site.

Pure bookkeeping, no I/O: :class:`CameraWindow` gathers one camera's results between two
summaries (the processing thread adds, the publishing loop reads), and :func:`fuse` turns the
cameras' latest views into the fields of ``weather.state/1``.

The fusion rule for cameras (instruments join in the instrument issue):

- a camera *can judge* when its detector state is ``ok`` and its last result is younger than
  ``stale_s``; otherwise it is left out, and its state says why (``warming_up``, ``unstable``,
  ``dark``, ``scene_change``, or ``offline`` when no recent frame came);
- precipitation is true when any camera that can judge sees it, false when at least one can
  judge and none sees it, and null when none can judge (``reason`` says why). One camera seeing
  rain wins over another that does not: a camera misses rain in its dark or excluded parts far
  more often than it invents it (clear-weather false positives were 0 % in every tested case);
- the camera alone cannot tell rain from snow: ``precipitation_type`` is ``"unknown"`` when
  precipitation is seen, null otherwise;
- ``camera_R`` is the mean of R over the cameras that see precipitation, 0 when cameras judge
  and none sees it, null when none can judge. R is relative (paper eq. 31); it becomes mm/h only
  through a site calibration.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any

from hos.result import FrameResult

from .messages import stamp

__all__ = ["OFFLINE", "CameraView", "CameraWindow", "fuse"]

#: The camera state when its last result is too old (or it never gave one).
OFFLINE = "offline"


@dataclass(frozen=True)
class CameraView:
    """What fusion needs of one camera at one moment."""

    rain: bool
    state: str
    pi: float | None
    mu_deg: float | None
    sigma_deg: float | None
    R: float | None
    fps: float | None
    rain_fraction: float | None
    t_ns: int | None  # time of the latest result; None if there is none

    def can_judge(self, now_ns: int, stale_s: float) -> bool:
        return (
            self.state == "ok" and self.t_ns is not None and (now_ns - self.t_ns) <= stale_s * 1e9
        )

    def effective_state(self, now_ns: int, stale_s: float) -> str:
        if self.t_ns is None or (now_ns - self.t_ns) > stale_s * 1e9:
            return OFFLINE
        return self.state


class CameraWindow:
    """One camera's results between two summaries; thread-safe.

    ``add`` is called by the processing thread for every frame; ``summary`` by the publishing
    loop, which starts a new window.
    """

    def __init__(self, camera: str):
        self.camera = camera
        self._lock = threading.Lock()
        self._latest: dict[str, Any] | None = None
        self._latest_t_ns: int | None = None
        self._frames = 0
        self._rain_frames = 0
        self._r_sum = 0.0
        self._proc_s = 0.0
        self._window_start_ns: int | None = None
        self.frames_total = 0
        self.last_processing_ms: float | None = None
        self._fps: float | None = None
        self._rain_fraction: float | None = None

    def add(self, result: FrameResult, *, t_ns: int, processing_s: float) -> None:
        j = result.to_json()
        with self._lock:
            if self._window_start_ns is None:
                self._window_start_ns = t_ns
            self._latest = j
            self._latest_t_ns = t_ns
            self._frames += 1
            self.frames_total += 1
            self._rain_frames += bool(j["rain"])
            if j["R"] is not None:
                self._r_sum += j["R"]
            self._proc_s += processing_s
            self.last_processing_ms = processing_s * 1e3

    def summary(
        self, *, site: str, t_ns: int, capture_state: str, window_s: float
    ) -> dict[str, Any]:
        """``weather.camera/1`` over the window since the last call, which starts a new one."""
        with self._lock:
            latest = self._latest or {}
            n = self._frames
            fps = n / window_s if window_s > 0 else None
            self._fps = fps
            self._rain_fraction = self._rain_frames / n if n else None
            msg = stamp(
                "weather.camera",
                site=site,
                t_ns=t_ns,
                camera=self.camera,
                rain=bool(latest.get("rain", False)),
                state=latest.get("state", OFFLINE) if n else OFFLINE,
                capture_state=capture_state,
                frame=latest.get("frame"),
                **{
                    k: latest.get(k)
                    for k in (
                        "pi",
                        "mu_deg",
                        "sigma_deg",
                        "gof_d",
                        "gof_ok",
                        "pi_smoothed",
                        "mu_smoothed_deg",
                        "sigma_smoothed_deg",
                        "S",
                        "R",
                    )
                },
                R_mean=round(self._r_sum / n, 6) if n else None,
                rain_fraction=self._rain_fraction,
                n_blobs=latest.get("n_blobs"),
                n_rain_blobs=latest.get("n_rain_blobs"),
                frames=n,
                window_s=round(window_s, 3),
                fps=round(fps, 3) if fps is not None else None,
                processing_ms=round(self._proc_s / n * 1e3, 3) if n else None,
            )
            self._frames = self._rain_frames = 0
            self._r_sum = self._proc_s = 0.0
            self._window_start_ns = None
            return msg

    def view(self) -> CameraView:
        """The camera's latest result, for :func:`fuse`."""
        with self._lock:
            j = self._latest
            if j is None:
                return CameraView(False, OFFLINE, None, None, None, None, None, None, None)
            return CameraView(
                rain=bool(j["rain"]),
                state=j["state"],
                pi=j["pi_smoothed"],
                mu_deg=j["mu_smoothed_deg"],
                sigma_deg=j["sigma_smoothed_deg"],
                R=j["R"],
                fps=self._fps,
                rain_fraction=self._rain_fraction,
                t_ns=self._latest_t_ns,
            )


def fuse(
    cameras: dict[str, CameraView], *, site: str, t_ns: int, stale_s: float = 5.0
) -> dict[str, Any]:
    """``weather.state/1`` from the cameras' latest views (see the module's rule)."""
    judging = {k: v for k, v in cameras.items() if v.can_judge(t_ns, stale_s)}
    raining = [v for v in judging.values() if v.rain]
    reason = None
    if judging:
        precipitation: bool | None = bool(raining)
    else:
        precipitation = None
        reason = "no camera can judge" + (
            ": " + ", ".join(f"{k} {v.effective_state(t_ns, stale_s)}" for k, v in cameras.items())
            if cameras
            else ""
        )
    rs = [v.R for v in raining if v.R is not None and math.isfinite(v.R)]
    if precipitation is None:
        camera_r = None
    else:
        camera_r = round(sum(rs) / len(rs), 6) if rs else 0.0
    return stamp(
        "weather.state",
        site=site,
        t_ns=t_ns,
        precipitation=precipitation,
        precipitation_type="unknown" if precipitation else None,
        rain_rate_mm_h=None,
        rain_rate_source=None,
        intensity_class=None,
        wawa=None,
        metar=None,
        visibility_m=None,
        camera_R=camera_r,
        cameras={
            k: {
                "rain": v.rain if v.can_judge(t_ns, stale_s) else None,
                "state": v.effective_state(t_ns, stale_s),
                "pi": v.pi,
                "mu_deg": v.mu_deg,
                "sigma_deg": v.sigma_deg,
                "R": v.R,
                "fps": None if v.fps is None else round(v.fps, 3),
                "rain_fraction": v.rain_fraction,
            }
            for k, v in cameras.items()
        },
        calibration=None,
        sources=[f"camera/{k}" for k in judging],
        reason=reason,
    )
