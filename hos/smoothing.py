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

With F = H = I and diagonal Q, R and initial P, the covariance stays diagonal for ever (a miss,
H = [1, 0, 0], keeps it diagonal too): the filter is three independent scalar filters. They are
written out below as filterpy's ``predict`` and ``update`` (Joseph form) do it, operation for
operation, in plain floats: a 3x3 :class:`filterpy.kalman.KalmanFilter` costs more per frame
than the rest of the decision, and importing filterpy imports ``scipy.stats`` (0.4 s of every
start). ``tests/hos/test_smoothing.py`` proves the two equal, step by step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .params import DecisionParams

__all__ = ["Dwell", "ParameterSmoother", "SmoothedState", "kalman_predict", "kalman_update"]

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class SmoothedState:
    pi: float
    mu: float
    sigma: float
    rain: bool


def kalman_predict(x: float, p: float, q: float) -> tuple[float, float]:
    """Scalar Kalman prediction with F = 1: ``x = F x``, ``P = F P F' + Q``.

    Parameters
    ----------
    x, p : state and its variance
    q : process noise variance
    """
    return x, p + q


def kalman_update(x: float, p: float, z: float, r: float) -> tuple[float, float]:
    """Scalar Kalman update with H = 1, covariance in Joseph form (as filterpy writes it).

    Parameters
    ----------
    x, p : prior state and variance
    z : measurement
    r : measurement noise variance

    Returns
    -------
    (x, p), the posterior.
    """
    y = z - x  # residual
    s = p + r  # system uncertainty
    k = p * (1.0 / s)  # Kalman gain, P H' S^-1
    x = x + k * y
    i_kh = 1.0 - k
    return x, i_kh * p * i_kh + k * r * k  # (I - KH) P (I - KH)' + K R K'


class Dwell:
    """A verdict that changes only once its test has disagreed with it for ``on_frames``
    consecutive frames (to become true) or ``off_frames`` (to become false)."""

    def __init__(self, on_frames: int, off_frames: int) -> None:
        self.on_frames = on_frames
        self.off_frames = off_frames
        self.reset()

    def reset(self) -> None:
        self.value = False
        self._pending = 0  # consecutive frames whose test disagrees with the verdict

    def update(self, wants: bool) -> bool:
        """Add one frame's test; return the verdict."""
        if wants == self.value:
            self._pending = 0
        else:
            self._pending += 1
            if self._pending >= (self.off_frames if self.value else self.on_frames):
                self.value, self._pending = wants, 0
        return self.value


class ParameterSmoother:
    """Kalman filter of x = (Pi, mu, sigma), F = H = I, and the decision with hysteresis."""

    def __init__(self, params: DecisionParams | None = None) -> None:
        self.params = params or DecisionParams()
        self.reset()

    def reset(self) -> None:
        p = self.params
        self._x = [0.0, math.pi / 2, math.radians(20.0)]
        # Start at the steady-state variance of a filter updated every frame (the root of
        # P^2 - Q P - Q R = 0): one early measurement then moves Pi no more than a late one.
        q, r = p.process_var, p.measurement_var
        steady = 0.5 * (q + math.sqrt(q * q + 4.0 * q * r)) - q
        self._p = [steady, 1.0, 1.0]
        self._verdict = Dwell(p.dwell_on_frames, p.dwell_off_frames)

    @property
    def state(self) -> SmoothedState:
        x = self._x
        return SmoothedState(x[0], x[1], x[2], self._verdict.value)

    @property
    def variance(self) -> tuple[float, float, float]:
        """Diagonal of the state covariance P (Pi, mu, sigma)."""
        return self._p[0], self._p[1], self._p[2]

    def update(
        self,
        measurement: tuple[float, float, float] | None,
        *,
        measurement_var: float | None = None,
    ) -> SmoothedState:
        """Predict, then update with a fitted (Pi, mu, sigma), or with a miss when None.

        ``measurement_var`` overrides the parameters' measurement variance for this frame (a fit
        from few blobs is a noisier measurement), or the miss variance for a miss (a frame with
        hardly any blob is surer evidence of no rain than a fit that failed)."""
        p = self.params
        r = measurement_var
        if r is None:
            r = p.measurement_var if measurement is not None else p.miss_measurement_var
        x, var = self._x, self._p
        for i in range(3):
            x[i], var[i] = kalman_predict(x[i], var[i], p.process_var)
        if measurement is None:  # Pi alone, measured 0 with the miss variance
            x[0], var[0] = kalman_update(x[0], var[0], 0.0, r)
        else:
            pi, mu, sigma = measurement
            mu_near = x[1] + _wrap(mu - x[1])
            x[0], var[0] = kalman_update(x[0], var[0], float(pi), r)
            x[1], var[1] = kalman_update(x[1], var[1], mu_near, r)
            x[2], var[2] = kalman_update(x[2], var[2], float(sigma), r)
        x[0] = min(max(x[0], 0.0), 1.0)
        x[1] = x[1] % math.pi
        x[2] = max(x[2], 1e-3)
        return self._decide()

    def hold(self) -> SmoothedState:
        """A frame that carries no evidence either way (camera moving, warming up)."""
        return self._decide()

    def _decide(self) -> SmoothedState:
        """Threshold with hysteresis; a new verdict must hold for ``dwell_on/off_frames``."""
        p = self.params
        pi = self._x[0]
        rain = self._verdict.value
        self._verdict.update(pi >= p.pi_rain - p.hysteresis if rain else pi > p.pi_rain)
        return self.state


def _wrap(d: float) -> float:
    """An orientation difference wrapped into [-pi/2, pi/2), as :func:`hos.angles.wrap_diff`."""
    return (d + math.pi / 2) % math.pi - math.pi / 2
