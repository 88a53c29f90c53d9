"""From per-frame detector results to camera summaries and one weather state for the site.

Pure bookkeeping, no I/O: :class:`CameraWindow` gathers one camera's results between two
summaries (the processing thread adds, the publishing loop reads), and :func:`fuse` turns the
cameras' latest views into the fields of ``weather.state/1``.

The fusion rule, cameras first, then instruments (see :func:`fuse_site`):

- a camera *can judge* when its detector state is ``ok`` and its last result is younger than
  ``stale_s``; otherwise it is left out, and its state says why (``warming_up``, ``unstable``,
  ``dark``, ``scene_change``, or ``offline`` when no recent frame came);
- precipitation is true when any camera that can judge sees it, false when at least one can
  judge and none sees it, and null when none can judge (``reason`` says why). One camera seeing
  rain wins over another that does not: a camera misses rain in its dark or excluded parts far
  more often than it invents it (clear-weather false positives were 0 % in every tested case);
- the type: a present-weather sensor's, when one gives a type; else the cameras' own
  (``camera_precipitation_type``, rain or snow from the streaks' shape, ``hos/ptype.py``), when
  the cameras that see precipitation agree on one; else ``"unknown"`` when precipitation is
  seen, null otherwise;
- R (paper eq. 31, R = S·Π: the summed half-lengths of the streaks, px, times the share of
  rain) comes in three averages, all in the same relative unit, which only a site calibration
  turns into mm/h: ``R`` is the last frame's (per camera, in the state and in
  ``weather.camera``); ``R_mean`` (``weather.camera``) the mean over the judged frames of the
  summary window (1 s); ``R_smoothed`` (per camera, in the state) the exponentially weighted
  mean over judged frames with a time constant of :data:`R_TAU_S`; ``camera_R`` is the mean of
  ``R_smoothed`` over the cameras that see precipitation, 0 when cameras judge and none sees
  it, null when none can judge — the value the calibration converts.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from daemon.transport.messages import stamp
from hos.result import FrameResult

__all__ = [
    "OFFLINE",
    "CameraView",
    "CameraWindow",
    "InstrumentView",
    "camera_type",
    "fuse",
    "intensity_class",
    "metar_group",
    "wawa_precipitation",
    "wawa_type",
]

#: The camera state when its last result is too old (or it never gave one).
OFFLINE = "offline"
#: Time constant (s) of the running mean of R behind ``camera_R`` and camera-only mm/h.
R_TAU_S = 60.0


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
    #: R averaged over the judged frames of the last minute or so (``R_TAU_S``): what the
    #: calibration turns into mm/h, comparable with an instrument's 1-minute intensity.
    r_mean: float | None = None
    #: The camera's own type, rain, snow or unknown (``hos/ptype.py``), voted over its
    #: recent frames; unknown whenever it sees no precipitation.
    precipitation_type: str = "unknown"

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

    def __init__(self, camera: str, *, tau_s: float = R_TAU_S):
        self.camera = camera
        self.tau_s = tau_s
        self._lock = threading.Lock()
        self._latest: dict[str, Any] | None = None
        self._latest_t_ns: int | None = None
        self._frames = 0
        self._judged = 0
        self._rain_frames = 0
        self._r_sum = 0.0
        self._proc_s = 0.0
        self._window_start_ns: int | None = None
        self.frames_total = 0
        self.last_processing_ms: float | None = None
        self._fps: float | None = None
        self._rain_fraction: float | None = None
        self._r_ema = 0.0  # bias-corrected by the weight below (no pull towards 0 at start)
        self._r_ema_weight = 0.0
        self._r_ema_t: int | None = None

    def add(self, result: FrameResult, *, t_ns: int, processing_s: float) -> None:
        j = result.to_json()
        with self._lock:
            if self._window_start_ns is None:
                self._window_start_ns = t_ns
            self._latest = j
            self._latest_t_ns = t_ns
            self._frames += 1
            self.frames_total += 1
            if j["state"] == "ok":  # R counts only where the camera can judge
                self._judged += 1
                self._rain_frames += bool(j["rain"])
                if j["R"] is not None:
                    self._r_sum += j["R"]
                    self._update_ema(j["R"], t_ns)
            self._proc_s += processing_s
            self.last_processing_ms = processing_s * 1e3

    def summary(
        self, *, site: str, t_ns: int, capture_state: str, window_s: float
    ) -> dict[str, Any]:
        """``weather.camera/1`` over the window since the last call, which starts a new one."""
        with self._lock:
            latest = self._latest or {}
            n, judged = self._frames, self._judged
            fps = n / window_s if window_s > 0 else None
            self._fps = fps
            self._rain_fraction = self._rain_frames / judged if judged else None
            msg = stamp(
                "weather.camera",
                site=site,
                t_ns=t_ns,
                camera=self.camera,
                rain=bool(latest.get("rain", False)),
                camera_precipitation_type=latest.get("precipitation_type", "unknown")
                if n
                else "unknown",
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
                R_mean=round(self._r_sum / judged, 6) if judged else None,
                rain_fraction=self._rain_fraction,
                frames_judged=judged,
                rain_frames=self._rain_frames,
                n_blobs=latest.get("n_blobs"),
                n_rain_blobs=latest.get("n_rain_blobs"),
                frames=n,
                window_s=round(window_s, 3),
                fps=round(fps, 3) if fps is not None else None,
                processing_ms=round(self._proc_s / n * 1e3, 3) if n else None,
            )
            self._frames = self._judged = self._rain_frames = 0
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
                r_mean=self._r_ema / self._r_ema_weight if self._r_ema_weight > 0 else None,
                precipitation_type=j.get("precipitation_type", "unknown"),
            )

    def _update_ema(self, r: float, t_ns: int) -> None:
        """Exponentially weighted mean of R over time (constant ``tau_s``), each frame weighted
        by the time it stands for; bias-corrected, so it is the mean of what there is at
        start."""
        dt = 0.04 if self._r_ema_t is None else max(0.0, (t_ns - self._r_ema_t) / 1e9)
        decay = math.exp(-dt / self.tau_s)
        self._r_ema = self._r_ema * decay + (1.0 - decay) * r
        self._r_ema_weight = self._r_ema_weight * decay + (1.0 - decay)
        self._r_ema_t = t_ns


@dataclass(frozen=True)
class InstrumentView:
    """What fusion needs of one instrument: its latest reading and whether to trust it."""

    kind: str  # "present_weather" (knows the type) or "gauge" (an amount or a rate only)
    driver: str
    connected: bool
    t_ns: int | None  # time of the latest reading
    rain_rate_mm_h: float | None = None
    precipitation: bool | None = None  # the instrument's own presence verdict
    wawa: int | None = None
    metar: str | None = None
    visibility_m: float | None = None
    fault: bool | None = None
    status: str | None = None
    #: A reading older than this (s) cannot judge.
    stale_s: float = 180.0

    def usable(self, now_ns: int) -> bool:
        return (
            self.connected
            and not self.fault
            and self.t_ns is not None
            and (now_ns - self.t_ns) <= self.stale_s * 1e9
        )

    def why_not(self, now_ns: int) -> str:
        if not self.connected:
            return "disconnected"
        if self.fault:
            return f"fault (status {self.status})"
        if self.t_ns is None:
            return "no reading yet"
        return "stale"


# WMO code table 4680 (present weather from an automatic station), the parts fusion needs.
#: The precipitation type of each WMO 4680 (``wawa``, automatic station) code that reports
#: precipitation at the time of observation; every other code is no precipitation now: 00-39
#: (no weather, haze, mist, lightning, squalls, fog, and 20-29, precipitation or fog during the
#: past hour but not now), 49, 59, 69 and 79 (not used), 90 (a thunderstorm: of itself no
#: precipitation), 91 and 94 (thunderstorm with no precipitation), 97-99. Each code is tested
#: against this list in tests/daemon/service/test_fusion.py.
_WAWA_TYPES: tuple[tuple[range, str], ...] = (
    (range(40, 43), "unknown"),  # precipitation; slight or moderate; heavy
    (range(43, 45), "rain"),  # liquid precipitation, slight or moderate / heavy
    (range(45, 47), "snow"),  # solid precipitation, slight or moderate / heavy
    (range(47, 49), "rain"),  # freezing precipitation (liquid, freezing on impact)
    (range(50, 57), "drizzle"),  # drizzle, freezing drizzle
    (range(57, 59), "mixed"),  # drizzle and rain
    (range(60, 67), "rain"),  # rain, freezing rain
    (range(67, 69), "mixed"),  # rain (or drizzle) and snow
    (range(70, 74), "snow"),
    (range(74, 77), "ice_pellets"),
    (range(77, 79), "snow"),  # snow grains, ice crystals
    (range(80, 81), "unknown"),  # showers or intermittent precipitation
    (range(81, 85), "rain"),  # rain showers, slight to violent
    (range(85, 88), "snow"),  # snow showers
    # 88 is "not used" in the WMO table, but OTT's Parsivel reports soft hail (graupel) with
    # it (42 mm/h of graupel in a real capture): ice falling is precipitation, here "hail".
    (range(88, 90), "hail"),  # 89: hail
    (range(92, 93), "mixed"),  # thunderstorm, slight or moderate, with rain and/or snow showers
    (range(93, 94), "hail"),  # thunderstorm, slight or moderate, with hail
    (range(95, 96), "mixed"),  # thunderstorm, heavy, with rain and/or snow showers
    (range(96, 97), "hail"),  # thunderstorm, heavy, with hail
)


def wawa_type(wawa: int | None) -> str | None:
    """The precipitation type of a WMO 4680 code; None when the code is no precipitation."""
    if wawa is None:
        return None
    for codes, kind in _WAWA_TYPES:
        if wawa in codes:
            return kind
    return None


def wawa_precipitation(wawa: int | None) -> bool | None:
    """Whether a WMO 4680 code reports precipitation now (None for no code)."""
    return None if wawa is None else wawa_type(wawa) is not None


def intensity_class(rate_mm_h: float | None) -> str | None:
    """WMO rain intensity: light < 2.5 mm/h, moderate < 10, heavy < 50, violent above."""
    if rate_mm_h is None or rate_mm_h <= 0:
        return None
    if rate_mm_h < 2.5:
        return "light"
    if rate_mm_h < 10:
        return "moderate"
    if rate_mm_h < 50:
        return "heavy"
    return "violent"


_METAR_CODES = {
    "rain": "RA",
    "drizzle": "DZ",
    "snow": "SN",
    "hail": "GR",
    "ice_pellets": "PL",
    "mixed": "RASN",
    "unknown": "UP",
}


def metar_group(kind: str | None, intensity: str | None) -> str | None:
    """A METAR present-weather group (``-RA``, ``SN``, ``+UP``) from a type and a class."""
    if kind is None:
        return None
    prefix = {"light": "-", "heavy": "+", "violent": "+"}.get(intensity or "", "")
    return prefix + _METAR_CODES.get(kind, "UP")


def _wawa_from(kind: str, intensity: str | None) -> int:
    """A WMO 4680 code for precipitation of ``kind`` seen by the fusion (no sensor gave one)."""
    heavy = intensity in ("heavy", "violent")
    if kind == "rain":
        return {"light": 61, "moderate": 62}.get(intensity or "", 63 if heavy else 60)
    if kind == "snow":
        return {"light": 71, "moderate": 72}.get(intensity or "", 73 if heavy else 70)
    if kind == "drizzle":
        return {"light": 51, "moderate": 52}.get(intensity or "", 53 if heavy else 50)
    if intensity is None:
        return 40
    return 42 if heavy else 41


def camera_type(judging: dict[str, CameraView]) -> str | None:
    """``camera_precipitation_type`` of the site: the type the judging cameras that see
    precipitation agree on (``rain`` or ``snow``); ``unknown`` when none of them types it, they
    disagree, or none sees precipitation; null when no camera can judge."""
    if not judging:
        return None
    kinds = {v.precipitation_type for v in judging.values() if v.rain} - {"unknown"}
    return kinds.pop() if len(kinds) == 1 else "unknown"


def _instrument_source(usable: dict[str, InstrumentView], votes: dict[str, Any]) -> str:
    """``rain_rate_source`` of a 0 mm/h that only instruments judged (no camera could)."""
    kinds = {usable[k].kind for k in votes}
    return "sensor" if "present_weather" in kinds else "gauge"


def _rate_reason(precipitation: bool | None, camera_rate: Callable | None) -> str:
    """Why ``rain_rate_mm_h`` is null: unknown is not dry (dry is 0.0)."""
    if precipitation is None:
        return "no source can judge whether it rains"
    if camera_rate is None:
        return "no usable gauge or sensor gives a rate, and the camera has no calibration"
    return (
        "no usable gauge or sensor gives a rate, and the camera's calibration is not ready "
        "(weatherd calibrate, or the online calibration still learning)"
    )


class Persistence:
    """The site's precipitation does not flicker: it starts once it has been seen for
    ``onset_s`` and stops once none has been seen for ``end_s`` (present-weather practice: a
    sensor reports over a window, never a 0.4-s shower). Unknown (no source can judge) is said
    at once; judging again starts from "no precipitation", the onset counted from then.

    One per site, fed each tick with the instantaneous verdict of :func:`fuse`'s sources.
    """

    def __init__(self, *, onset_s: float = 10.0, end_s: float = 60.0):
        self.onset_ns, self.end_ns = round(onset_s * 1e9), round(end_s * 1e9)
        self.state: bool | None = None
        self._since: int | None = None  # when the instantaneous verdict last differed

    def __call__(self, seen: bool | None, t_ns: int) -> bool | None:
        if seen is None:
            self.state, self._since = None, None
            return None
        if self.state is None:
            self.state = False
        if seen == self.state:
            self._since = None
            return self.state
        if self._since is None:
            self._since = t_ns
        if t_ns - self._since >= (self.onset_ns if seen else self.end_ns):
            self.state, self._since = seen, None
        return self.state


def fuse(
    cameras: dict[str, CameraView],
    *,
    site: str,
    t_ns: int,
    stale_s: float = 5.0,
    instruments: dict[str, InstrumentView] | None = None,
    camera_rate: Callable[[float | None], float | None] | None = None,
    calibration: dict[str, Any] | None = None,
    persistence: Persistence | None = None,
) -> dict[str, Any]:
    """``weather.state/1`` from the cameras' and instruments' latest views.

    With ``persistence`` (the daemon's), ``precipitation`` and everything derived from it
    follow the persistent verdict, and ``precipitation_instant`` is the verdict of this tick.

    The rule, in order (docs/daemon.md, "Fusion"):

    1. Sources that cannot judge are left out, with a reason: a camera not ``ok`` or stale; an
       instrument disconnected, reporting a fault in its status, or silent for longer than
       its ``stale_s``.
    2. **Presence**: true if any usable source sees precipitation, false if at least one can
       judge and none does, null if none can. A camera at night (``dark``) or a blocked gauge
       (``fault``) thus never vetoes the others. One exception: a camera sees rain, a usable
       *present-weather sensor* says none, and no other source agrees with the camera: the
       sensor wins (it measures the drops themselves), and ``disagreement`` records it.
    3. **Type** from a usable present-weather sensor's WMO 4680 code when it gives a type (a
       code of unknown type, 40-42 or 80, does not); otherwise the cameras'
       ``camera_precipitation_type`` when they agree on rain or snow; otherwise ``unknown``.
    4. **Rate** from a usable instrument (``rain_rate_source`` ``sensor`` or ``gauge``);
       otherwise from the camera's R through the site calibration (``camera``) when it is
       ready; otherwise null, and ``rain_rate_reason`` says why. When precipitation is false
       the rate is 0.0 whatever the calibration (a judged "dry" is a known rate; null always
       means unknown), its source the one that judged.
    5. ``wawa`` and ``metar`` from the sensor when it gives them, else derived from the type
       and the intensity class (e.g. 41 / ``-UP`` for camera-only light precipitation).
    6. ``visibility_m`` from a usable present-weather sensor.
    """
    instruments = instruments or {}
    judging = {k: v for k, v in cameras.items() if v.can_judge(t_ns, stale_s)}
    usable = {k: v for k, v in instruments.items() if v.usable(t_ns)}
    sensors = {k: v for k, v in usable.items() if v.kind == "present_weather"}
    cam_votes = {k: v.rain for k, v in judging.items()}
    inst_votes = {k: v.precipitation for k, v in usable.items() if v.precipitation is not None}
    reasons = [
        f"camera {k} {v.effective_state(t_ns, stale_s)}"
        for k, v in cameras.items()
        if k not in judging
    ]
    reasons += [
        f"instrument {k} {v.why_not(t_ns)}" for k, v in instruments.items() if k not in usable
    ]
    disagreement = None
    if not cam_votes and not inst_votes:
        precipitation: bool | None = None
    else:
        precipitation = any(cam_votes.values()) or any(inst_votes.values())
        sensor_says_no = any(inst_votes.get(k) is False for k in sensors)
        others_yes = any(v for k, v in inst_votes.items() if k not in sensors)
        if (
            any(cam_votes.values())
            and sensor_says_no
            and not others_yes
            and not any(inst_votes.get(k) for k in sensors)
        ):
            precipitation = False
            disagreement = "cameras see precipitation, the present-weather sensor does not"
        elif not any(cam_votes.values()) and any(inst_votes.values()) and cam_votes:
            disagreement = "instruments report precipitation the cameras do not see"

    instant = precipitation
    if persistence is not None:
        precipitation = persistence(instant, t_ns)

    # Type: the sensor's when it gives one, else the cameras' own (rain or snow), else unknown.
    cam_kind = camera_type(judging)
    kind: str | None = None
    wawa: int | None = None
    metar: str | None = None
    for v in sensors.values():
        if v.wawa is not None:
            wawa, metar = v.wawa, v.metar
            kind = wawa_type(v.wawa)
            break
    if precipitation and kind in (None, "unknown") and cam_kind in ("rain", "snow"):
        kind = cam_kind
    if precipitation and kind is None:
        kind = "unknown"
    if not precipitation:
        kind = None

    # Rate: an instrument, else the calibrated camera.
    rate: float | None = None
    source: str | None = None
    for v in sorted(usable.values(), key=lambda v: v.kind != "present_weather"):
        if v.rain_rate_mm_h is not None:
            rate = float(v.rain_rate_mm_h)
            source = "sensor" if v.kind == "present_weather" else "gauge"
            break
    rs = [
        r
        for r in (v.r_mean if v.r_mean is not None else v.R for v in judging.values() if v.rain)
        if r is not None and math.isfinite(r)
    ]
    camera_r = None if not judging else (round(sum(rs) / len(rs), 6) if rs else 0.0)
    if rate is None and camera_rate is not None and judging:
        if camera_r:
            rate = camera_rate(camera_r)
        elif precipitation is False:
            rate = 0.0
        if rate is not None:
            source = "camera"
    if precipitation is False:  # a judged "no precipitation" is a known rate: 0 mm/h
        rate = 0.0
        source = source or ("camera" if cam_votes else _instrument_source(usable, inst_votes))
    intensity = intensity_class(rate) if precipitation else None
    if precipitation and wawa is None:
        wawa = _wawa_from(kind or "unknown", intensity)
    elif precipitation is False and wawa is None:
        wawa = 0
    if metar is None or (precipitation and not metar):
        metar = metar_group(kind, intensity) if precipitation else None
    visibility = next(
        (v.visibility_m for v in sensors.values() if v.visibility_m is not None), None
    )
    if visibility is None:
        visibility = next(
            (v.visibility_m for v in usable.values() if v.visibility_m is not None), None
        )
    return stamp(
        "weather.state",
        site=site,
        t_ns=t_ns,
        precipitation=precipitation,
        precipitation_instant=instant,
        precipitation_type=kind,
        camera_precipitation_type=cam_kind,
        rain_rate_mm_h=None if rate is None else round(rate, 4),
        rain_rate_source=source if rate is not None else None,
        rain_rate_reason=None if rate is not None else _rate_reason(precipitation, camera_rate),
        intensity_class=intensity,
        wawa=wawa,
        metar=metar or None,
        visibility_m=visibility,
        camera_R=camera_r if precipitation is not None or judging else None,
        cameras={
            k: {
                "rain": v.rain if v.can_judge(t_ns, stale_s) else None,
                "state": v.effective_state(t_ns, stale_s),
                "pi": v.pi,
                "mu_deg": v.mu_deg,
                "sigma_deg": v.sigma_deg,
                "R": v.R,
                "R_smoothed": None if v.r_mean is None else round(v.r_mean, 6),
                "fps": None if v.fps is None else round(v.fps, 3),
                "rain_fraction": v.rain_fraction,
                "camera_precipitation_type": v.precipitation_type
                if v.can_judge(t_ns, stale_s)
                else None,
            }
            for k, v in cameras.items()
        },
        instruments={
            k: {
                "driver": v.driver,
                "usable": k in usable,
                "state": "ok" if k in usable else v.why_not(t_ns),
                "precipitation": v.precipitation,
                "rain_rate_mm_h": v.rain_rate_mm_h,
                "wawa": v.wawa,
                "visibility_m": v.visibility_m,
                "age_s": None if v.t_ns is None else round((t_ns - v.t_ns) / 1e9, 1),
            }
            for k, v in instruments.items()
        },
        calibration=calibration,
        sources=[f"camera/{k}" for k in judging] + [f"instrument/{k}" for k in usable],
        disagreement=disagreement,
        reason=None
        if precipitation is not None
        else "no source can judge" + (": " + ", ".join(reasons) if reasons else ""),
    )
