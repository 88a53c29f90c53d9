"""Kalman smoothing of the mixture's parameters (Pi, mu, sigma) and the decision (section 5).

The paper filters the three parameters with a static evolution model (F = I) and updates the
filter only on frames whose fit passed the goodness-of-fit test; rain is declared when the
filtered Pi exceeds Pi_rain. Process noise variance 0.01, measurement noise variance 0.1.

Departure (the weakness the paper notes itself): with updates only on good fits, a state that
is never updated in clear weather keeps its last value forever. Here a frame *without* a valid
fit is a measurement too: it says "no streak population here", so it updates Pi alone with a
measurement of 0 and a larger variance (``miss_measurement_var``). In rain most frames fit and
the few misses barely move Pi; when the rain stops, misses pull Pi down within a few dozen
frames. mu is periodic: the measured mu is unwrapped next to the state before each update and
the state is wrapped back into [0, pi) after.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from filterpy.kalman import KalmanFilter

from .angles import wrap_diff
from .params import DecisionParams

__all__ = ["ParameterSmoother", "SmoothedState"]

_H_PI = np.array([[1.0, 0.0, 0.0]])


@dataclass(frozen=True)
class SmoothedState:
    pi: float
    mu: float
    sigma: float
    rain: bool


class ParameterSmoother:
    """A thin class over filterpy's KalmanFilter: state x = (Pi, mu, sigma), F = H = I."""

    def __init__(self, params: DecisionParams | None = None) -> None:
        self.params = params or DecisionParams()
        self.reset()

    def reset(self) -> None:
        p = self.params
        kf = KalmanFilter(dim_x=3, dim_z=3)
        kf.x = np.array([[0.0], [math.pi / 2], [math.radians(20.0)]])
        kf.F = np.eye(3)
        kf.H = np.eye(3)
        # Start at the steady-state variance of a filter updated every frame (the root of
        # P^2 - Q P - Q R = 0): one early measurement then moves Pi no more than a late one.
        q, r = p.process_var, p.measurement_var
        steady = 0.5 * (q + math.sqrt(q * q + 4.0 * q * r)) - q
        kf.P = np.diag([steady, 1.0, 1.0])
        kf.Q = np.eye(3) * p.process_var
        kf.R = np.eye(3) * p.measurement_var
        self._kf = kf
        self._rain = False
        self._pending = 0  # consecutive frames whose threshold test disagrees with the verdict

    @property
    def state(self) -> SmoothedState:
        x = self._kf.x[:, 0]
        return SmoothedState(float(x[0]), float(x[1]), float(x[2]), self._rain)

    def update(self, measurement: tuple[float, float, float] | None) -> SmoothedState:
        """Predict, then update with a fitted (Pi, mu, sigma), or with a miss when None."""
        kf = self._kf
        kf.predict()
        if measurement is None:
            kf.update(np.array([[0.0]]), R=np.array([[self.params.miss_measurement_var]]), H=_H_PI)
        else:
            pi, mu, sigma = measurement
            mu_near = kf.x[1, 0] + float(wrap_diff(mu, kf.x[1, 0]))
            kf.update(np.array([[pi], [mu_near], [sigma]]))
        kf.x[0, 0] = min(max(kf.x[0, 0], 0.0), 1.0)
        kf.x[1, 0] = float(np.mod(kf.x[1, 0], np.pi))
        kf.x[2, 0] = max(kf.x[2, 0], 1e-3)
        return self._decide()

    def hold(self) -> SmoothedState:
        """A frame that carries no evidence either way (camera moving, warming up)."""
        return self._decide()

    def _decide(self) -> SmoothedState:
        """Threshold with hysteresis; a new verdict must hold for ``dwell_on/off_frames``."""
        p = self.params
        pi = self._kf.x[0, 0]
        wants = pi >= p.pi_rain - p.hysteresis if self._rain else pi > p.pi_rain
        if wants == self._rain:
            self._pending = 0
        else:
            self._pending += 1
            dwell = p.dwell_off_frames if self._rain else p.dwell_on_frames
            if self._pending >= dwell:
                self._rain, self._pending = wants, 0
        return self.state
