"""Site calibration of the camera's rain intensity R (paper eq. 31) into millimetres per hour.

The model is a power law, ``rate_mm_h = a * R ** b``. R counts and weighs the visible streaks
(eq. 31: S times Pi). Garg and Nayar's visibility model, paper eq. 1, makes the visibility of rain
grow with the square root of the drop density. Rain rate grows with the density and with the
drops' size and fall speed. So R is not proportional to the rate in general, and a power law
with a free exponent covers both.

The fit is linear in log space: ``ln rate = ln a + b ln R``. Two cases need no special code:
- b = 1 is the paper's linear reading of Fig. 15, and the prior centre;
- an offline calibration (``weatherd calibrate``, a ``[calibration]`` TOML table) becomes the
  prior with its confidence interval as its spread.

**Online estimator.** A Kalman filter on x = (ln a, b): filterpy's ``predict`` and ``update``
(Joseph form), written out below for this one filter (two states, one scalar measurement) and
proven equal to filterpy's in the tests. Importing filterpy imports ``scipy.stats``: 57 MiB of
the daemon's memory and 0.8 s of its start, for eight lines of algebra. Rainy windows are fed to
it one at a time:
- a random walk lets the calibration follow slow changes (a dirty lens, seasonal light) instead
  of freezing after the first week;
- the prior keeps b near 1 until the data span enough range of R to tell;
- outliers are rejected by gating the innovation: a window more than ``gate_sigma`` standard
  deviations from the prediction is counted and left out. That catches a blocked gauge, a splash
  on the lens, or snow on an unheated gauge.

**Windows.** The camera's R and the gauge's rate are aggregated over ``window_s`` (15 min by
default; a tipping bucket of 0.2 mm needs that long to say anything at a few mm/h). A window is a
measurement only when all of these hold:
- the gauge measured at least ``min_rate_mm_h``;
- the camera could judge most of the window (``min_judged``) and saw rain in most of it
  (``min_rain_fraction``);
- R > 0.

Dry windows say nothing about a and b. They matter for the presence scores, which are the offline
comparison's job.

**Quality.** Computed over the last ``history`` accepted windows, in mm/h:
- ``n``, the number of accepted windows;
- ``r2`` and ``rmse_mm_h``;
- the age of the last update.

The state is saved atomically (write, fsync, rename) after every update, so a restart or a power
cut keeps it.
"""

from __future__ import annotations

import json
import logging
import math
import os
import tempfile
import threading
import tomllib
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivers.errors import ConfigError

__all__ = ["CalibrationParams", "OnlineCalibration", "load_calibration_file"]

log = logging.getLogger(__name__)

_STATE_VERSION = 1
_NS_PER_DAY = 86_400 * 10**9


def kf_predict(x: np.ndarray, P: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """filterpy's ``predict`` with F = I (a random walk): x unchanged, P + Q."""
    return x, P + Q


def kf_update(
    x: np.ndarray, P: np.ndarray, z: float, r: float, H: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """filterpy's ``update`` for one scalar measurement ``z`` of variance ``r`` through the
    (1, n) row ``H``: the gain, the state, and the covariance in Joseph form."""
    S = (H @ P @ H.T).item() + r  # innovation variance
    K = (P @ H.T) / S  # (n, 1) gain
    x = x + K[:, 0] * (z - (H @ x).item())
    I_KH = np.eye(len(x)) - K @ H
    return x, I_KH @ P @ I_KH.T + r * (K @ K.T)


@dataclass(frozen=True)
class CalibrationParams:
    """Settings of the online calibration (the ``[calibration]`` table)."""

    window_s: float = 900.0
    #: Accepted windows before camera-only mm/h is published (an offline prior counts as ready).
    min_windows: int = 4
    min_rate_mm_h: float = 0.2
    min_judged: float = 0.5
    min_rain_fraction: float = 0.5
    #: Spread of one window's ln(rate) about the model: gauge sampling and camera noise.
    measurement_sigma_ln: float = 0.35
    #: Random-walk drift per day of ln a and of b.
    drift_ln_a_per_day: float = 0.05
    drift_b_per_day: float = 0.01
    gate_sigma: float = 3.0
    #: Windows accepted before the outlier gate closes: the first ones teach the model what
    #: an outlier is (a prior far from the site's truth would otherwise reject good data).
    gate_after: int = 10
    history: int = 500
    #: The uninformed prior: rate = exp(ln_a) * R ** b.
    prior_ln_a: float = math.log(2e-3)
    prior_ln_a_sigma: float = 3.0
    prior_b: float = 1.0
    prior_b_sigma: float = 0.4


class OnlineCalibration:
    """Online fit of ``rate_mm_h = a * R ** b``; thread-safe, persisted in ``state_path``.

    Feed it with :meth:`add_camera` (each camera summary) and :meth:`add_gauge_rate` or
    :meth:`add_gauge_amount` (each instrument reading), and call :meth:`tick` regularly; it closes
    a window every ``window_s`` and updates the fit when the window is a measurement.
    """

    def __init__(
        self,
        params: CalibrationParams | None = None,
        *,
        state_path: str | os.PathLike[str] | None = None,
        prior: dict[str, Any] | None = None,
    ):
        self.params = p = params or CalibrationParams()
        self.state_path = Path(state_path) if state_path is not None else None
        self._lock = threading.Lock()
        self.source = "prior"
        x0 = np.array([p.prior_ln_a, p.prior_b])
        P0 = np.diag([p.prior_ln_a_sigma**2, p.prior_b_sigma**2])
        if prior is not None:
            x0, P0 = _prior_from_file(prior, p)
            self.source = "offline"
        self.x, self.P = x0, P0
        self.n = 0
        self.outliers = 0
        self.updated_ns: int | None = None
        self.pairs: deque[tuple[float, float, int]] = deque(maxlen=p.history)
        self._window_start: int | None = None
        self._reset_window()
        if self.state_path is not None:
            self._load()

    # -- feeding -------------------------------------------------------------------------------
    def add_camera(
        self, *, t_ns: int, r_mean: float | None, frames: int, judged: int, rain_frames: int
    ) -> None:
        """One camera summary: ``frames`` processed, ``judged`` of them in state ok,
        ``rain_frames`` with rain, and the mean R over the judged ones."""
        with self._lock:
            self._open(t_ns)
            self._frames += frames
            self._judged += judged
            self._rain += rain_frames
            if r_mean is not None and judged > 0 and math.isfinite(r_mean):
                self._r_sum += r_mean * judged

    def add_gauge_rate(self, *, t_ns: int, rate_mm_h: float) -> None:
        """One instantaneous or interval rain rate from an instrument (mm/h, >= 0)."""
        if rate_mm_h is None or not math.isfinite(rate_mm_h) or rate_mm_h < 0:
            return
        with self._lock:
            self._open(t_ns)
            self._rates.append(rate_mm_h)

    def add_gauge_amount(self, *, t_ns: int, amount_mm: float) -> None:
        """An amount fallen since the previous reading (mm, >= 0; a tipping bucket's tips)."""
        if amount_mm is None or not math.isfinite(amount_mm) or amount_mm < 0:
            return
        with self._lock:
            self._open(t_ns)
            self._amount += amount_mm
            self._has_amount = True

    def tick(self, now_ns: int) -> bool:
        """Close the window if it is due; True if the fit was updated."""
        with self._lock:
            if self._window_start is None:
                return False
            length_ns = now_ns - self._window_start
            if length_ns < self.params.window_s * 1e9:
                return False
            window = self._close(length_ns)
            self._window_start = now_ns
            if window is None:
                return False
            r, rate = window
            updated = self._update(r, rate, now_ns)
        if updated:
            self._save()
        return updated

    # -- reading -------------------------------------------------------------------------------
    @property
    def ready(self) -> bool:
        return self.source == "offline" or self.n >= self.params.min_windows

    def rate_mm_h(self, r: float | None) -> float | None:
        """Camera-only rain rate for intensity ``r``; None when not calibrated or r unusable."""
        with self._lock:
            if not self.ready or r is None or not math.isfinite(r) or r <= 0:
                return None
            return float(math.exp(self.x[0]) * r ** self.x[1])

    def quality(self, now_ns: int) -> dict[str, Any]:
        """The calibration in use, for ``weather.state``: model, parameters, n, R², age."""
        with self._lock:
            a, b = float(math.exp(self.x[0])), float(self.x[1])
            r2, rmse = self._scores(a, b)
            sd = np.sqrt(np.diag(self.P))
            return {
                "model": "power",
                "a": _sig(a),
                "b": _sig(b),
                "ln_a_sd": _sig(float(sd[0])),
                "b_sd": _sig(float(sd[1])),
                "n": self.n,
                "outliers": self.outliers,
                "r2": None if r2 is None else round(r2, 4),
                "rmse_mm_h": None if rmse is None else round(rmse, 4),
                "age_s": None
                if self.updated_ns is None
                else round((now_ns - self.updated_ns) / 1e9, 1),
                "source": self.source if self.n == 0 else "online",
                "ready": self.ready,
                "window_s": self.params.window_s,
            }

    # -- internals -----------------------------------------------------------------------------
    def _reset_window(self) -> None:
        self._frames = self._judged = self._rain = 0
        self._r_sum = 0.0
        self._rates: list[float] = []
        self._amount = 0.0
        self._has_amount = False

    def _open(self, t_ns: int) -> None:
        if self._window_start is None:
            self._window_start = t_ns

    def _close(self, length_ns: int) -> tuple[float, float] | None:
        p = self.params
        frames, judged, rain, r_sum = self._frames, self._judged, self._rain, self._r_sum
        if self._has_amount:
            rate: float | None = self._amount / (length_ns / 3.6e12)
        elif self._rates:
            rate = float(np.mean(self._rates))
        else:
            rate = None
        self._reset_window()
        if rate is None or frames == 0 or judged == 0:
            return None
        if judged / frames < p.min_judged or rain / judged < p.min_rain_fraction:
            return None
        if rate < p.min_rate_mm_h:
            log.debug("calibration window: camera sees rain, gauge %.2f mm/h: skipped", rate)
            return None
        r = r_sum / judged
        if r <= 0:
            return None
        return r, rate

    def _update(self, r: float, rate: float, now_ns: int) -> bool:
        p = self.params
        dt_days = p.window_s * 1e9 / _NS_PER_DAY
        Q = np.diag([p.drift_ln_a_per_day**2, p.drift_b_per_day**2]) * dt_days
        x, P = kf_predict(self.x, self.P, Q)
        H = np.array([[1.0, math.log(r)]])
        z = math.log(rate)
        S = (H @ P @ H.T).item() + p.measurement_sigma_ln**2
        innovation = z - (H @ x).item()
        if self.n >= p.gate_after and innovation**2 > p.gate_sigma**2 * S:
            self.x, self.P = x, P  # time still passed
            self.outliers += 1
            log.info(
                "calibration: window rejected as an outlier (R=%.0f, gauge %.2f mm/h, "
                "model %.2f mm/h)",
                r,
                rate,
                math.exp((H @ x).item()),
            )
            return False
        x, P = kf_update(x, P, z, p.measurement_sigma_ln**2, H)
        self.x, self.P = np.asarray(x, dtype=float).reshape(2), np.asarray(P, dtype=float)
        self.n += 1
        self.updated_ns = now_ns
        self.pairs.append((r, rate, now_ns))
        if self.n == p.min_windows and self.source != "offline":
            log.info(
                "calibration: camera-only mm/h available (a=%.3g, b=%.3f after %d windows)",
                math.exp(self.x[0]),
                self.x[1],
                self.n,
            )
        return True

    def _scores(self, a: float, b: float) -> tuple[float | None, float | None]:
        if len(self.pairs) < 2:
            return None, None
        r = np.array([q[0] for q in self.pairs])
        y = np.array([q[1] for q in self.pairs])
        pred = a * r**b
        rmse = float(np.sqrt(np.mean((pred - y) ** 2)))
        ss_tot = float(np.sum((y - y.mean()) ** 2))
        r2 = 1.0 - float(np.sum((pred - y) ** 2)) / ss_tot if ss_tot > 0 else None
        return r2, rmse

    def _state(self) -> dict[str, Any]:
        return {
            "version": _STATE_VERSION,
            "x": self.x.tolist(),
            "P": self.P.tolist(),
            "n": self.n,
            "outliers": self.outliers,
            "updated_ns": self.updated_ns,
            "source": self.source,
            "pairs": [list(q) for q in self.pairs],
        }

    def _save(self) -> None:
        if self.state_path is None:
            return
        with self._lock:
            state = self._state()
        try:
            atomic_write_json(self.state_path, state)
        except OSError as exc:
            log.warning("calibration: cannot save %s (%s)", self.state_path, exc)

    def _load(self) -> None:
        path = self.state_path
        assert path is not None
        try:
            state = json.loads(path.read_text())
            if state.get("version") != _STATE_VERSION:
                raise ValueError(f"version {state.get('version')}")
            x = np.array(state["x"], dtype=float).reshape(2)
            P = np.array(state["P"], dtype=float).reshape(2, 2)
            if not (np.all(np.isfinite(x)) and np.all(np.isfinite(P))):
                raise ValueError("not finite")
        except FileNotFoundError:
            return
        except (OSError, ValueError, KeyError, TypeError) as exc:
            log.warning("calibration: ignoring unreadable state %s (%s)", path, exc)
            return
        self.x, self.P = x, P
        self.n = int(state.get("n", 0))
        self.outliers = int(state.get("outliers", 0))
        self.updated_ns = state.get("updated_ns")
        self.source = state.get("source", self.source)
        self.pairs.extend(tuple(q) for q in state.get("pairs", []))  # type: ignore[misc]
        log.info(
            "calibration: restored from %s (a=%.3g, b=%.3f, n=%d)",
            path,
            math.exp(self.x[0]),
            self.x[1],
            self.n,
        )


def atomic_write_json(path: Path, data: object) -> None:
    """Write ``data`` as JSON to ``path`` so that a crash leaves the old or the new file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(data, f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


def load_calibration_file(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The ``[calibration]`` table of a file written by ``weatherd calibrate``.

    Raises
    ------
    ConfigError : unreadable, or without a valid model.
    """
    try:
        with open(path, "rb") as f:
            table = tomllib.load(f).get("calibration")
    except OSError as exc:
        raise ConfigError(f"calibration.file: cannot read {path} ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"calibration.file: {path}: not valid TOML ({exc})") from None
    if not isinstance(table, dict):
        raise ConfigError(f"calibration.file: {path}: no [calibration] table")
    model = table.get("model")
    a, b = table.get("a"), table.get("b", 1.0)
    if model not in ("linear", "power"):
        raise ConfigError(f"calibration.file: {path}: model must be 'linear' or 'power'")
    if not (isinstance(a, int | float) and a > 0 and isinstance(b, int | float) and b > 0):
        raise ConfigError(f"calibration.file: {path}: a and b must be positive numbers")
    return table


def _prior_from_file(table: dict[str, Any], p: CalibrationParams) -> tuple[np.ndarray, np.ndarray]:
    a = float(table["a"])
    b = float(table.get("b", 1.0)) if table["model"] == "power" else 1.0
    sd_ln_a, sd_b = 0.3, 0.1
    ci = table.get("a_ci")
    if isinstance(ci, list) and len(ci) == 2 and 0 < ci[0] < ci[1]:
        sd_ln_a = max((math.log(ci[1]) - math.log(ci[0])) / 3.92, 0.05)
    ci_b = table.get("b_ci")
    if isinstance(ci_b, list) and len(ci_b) == 2 and ci_b[0] < ci_b[1]:
        sd_b = max((ci_b[1] - ci_b[0]) / 3.92, 0.02)
    if table["model"] == "linear":
        sd_b = 0.05
    return np.array([math.log(a), b]), np.diag([sd_ln_a**2, sd_b**2])


def _sig(x: float) -> float:
    return float(f"{x:.5g}")
