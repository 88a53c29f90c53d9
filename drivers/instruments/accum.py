"""Per-interval precipitation amounts from an instrument's cumulative counter.

Gauges and disdrometers report a running total (``rain_accum_mm``) rather than the amount of
each interval. The counter is awkward: it wraps at the top of its range (a rain[e] counts
0…9999 mm, some loggers 0…99.99 mm), it is reset by a power cycle or an operator, readings go
missing and the link drops for hours. :func:`accum_delta` turns two successive counter values
into the amount between them and :class:`AccumulationTracker` keeps the previous value. The
rules, as in weewx's ``delta`` for rain counters, err on the side of "unknown":

- an increase is the amount (tiny negative float noise counts as 0);
- a decrease is a **wrap** only when the counter has a known range (``wrap_at_mm``), the
  wrapped amount is under half the range and, if ``max_rate_mm_h`` is set, no more than that
  rate allows over the elapsed time; the amount is then ``accum + wrap_at_mm - previous``;
- any other decrease is a **reset**: the amount of that interval is ``None`` (unknown) and the
  new value becomes the baseline. An amount is never negative;
- a gap longer than ``max_gap_s`` since the previous valid reading, or time going backwards,
  gives ``None`` and restarts from the new value; a missing value (``None``/NaN) gives
  ``None`` and keeps the previous baseline, so the next amount covers the missing interval too.
"""

from __future__ import annotations

import logging
import math

__all__ = ["AccumulationTracker", "accum_delta"]

log = logging.getLogger(__name__)

#: Decreases smaller than this (mm) are float noise, not resets.
TOLERANCE_MM = 1e-6


def accum_delta(
    previous_mm: float,
    accum_mm: float,
    *,
    wrap_at_mm: float | None = None,
    dt_s: float | None = None,
    max_rate_mm_h: float | None = None,
) -> float | None:
    """Amount between two readings of a cumulative counter, or None when unknowable.

    Parameters
    ----------
    previous_mm, accum_mm : float, mm, the counter at the previous and at this reading
    wrap_at_mm : float or None, mm, the value at which the counter rolls over to 0
        (None: the counter never wraps, every decrease is a reset)
    dt_s : float or None, s, time between the readings (used with ``max_rate_mm_h``)
    max_rate_mm_h : float or None, mm/h, the largest plausible mean rate over ``dt_s``; a
        wrap that would imply more is taken as a reset

    Returns
    -------
    float or None : mm, ≥ 0; None for a reset.
    """
    delta = accum_mm - previous_mm
    if delta >= -TOLERANCE_MM:
        return max(delta, 0.0)
    if wrap_at_mm is None:
        return None
    wrapped = accum_mm + wrap_at_mm - previous_mm
    if wrapped < 0.0 or wrapped >= wrap_at_mm / 2.0:
        return None
    if max_rate_mm_h is not None and dt_s is not None and wrapped > max_rate_mm_h * dt_s / 3600.0:
        return None
    return wrapped


class AccumulationTracker:
    """Amounts since the previous reading of one counter; a thin state over :func:`accum_delta`.

    Parameters
    ----------
    wrap_at_mm : float or None, mm, where the counter rolls over (None: it never wraps)
    max_gap_s : float or None, s, a longer silence gives None (default one hour: the counter
        may have wrapped or been reset unseen); None for no limit
    max_rate_mm_h : float or None, mm/h, plausibility bound for wraps (default 400 mm/h, above
        the world-record hourly rainfall); None to accept any wrap under half the range
    """

    def __init__(
        self,
        wrap_at_mm: float | None = None,
        *,
        max_gap_s: float | None = 3600.0,
        max_rate_mm_h: float | None = 400.0,
    ) -> None:
        if wrap_at_mm is not None and not wrap_at_mm > 0:
            raise ValueError(f"wrap_at_mm must be > 0, got {wrap_at_mm!r}")
        if max_gap_s is not None and not max_gap_s > 0:
            raise ValueError(f"max_gap_s must be > 0, got {max_gap_s!r}")
        self.wrap_at_mm = wrap_at_mm
        self.max_gap_s = max_gap_s
        self.max_rate_mm_h = max_rate_mm_h
        self._t_ns: int | None = None
        self._accum_mm: float | None = None
        #: How many resets (and gaps) were seen; for the health report.
        self.resets = 0

    def reset(self) -> None:
        """Forget the baseline: the next reading gives None."""
        self._t_ns = None
        self._accum_mm = None

    def update(self, t_ns: int, accum_mm: float | None) -> float | None:
        """The amount (mm, ≥ 0) since the previous reading, or None when unknown.

        Parameters
        ----------
        t_ns : int, UTC ns of this reading
        accum_mm : float or None, mm, the counter as the instrument reports it
        """
        if accum_mm is None or not math.isfinite(accum_mm):
            return None
        previous_t, previous = self._t_ns, self._accum_mm
        self._t_ns, self._accum_mm = t_ns, float(accum_mm)
        if previous_t is None or previous is None:
            return None
        dt_s = (t_ns - previous_t) / 1e9
        if dt_s <= 0:
            log.info("accumulation: time went back %.3f s; restarting from %.3f mm", dt_s, accum_mm)
            self.resets += 1
            return None
        if self.max_gap_s is not None and dt_s > self.max_gap_s:
            log.info("accumulation: %.0f s gap; restarting from %.3f mm", dt_s, accum_mm)
            self.resets += 1
            return None
        amount = accum_delta(
            previous,
            float(accum_mm),
            wrap_at_mm=self.wrap_at_mm,
            dt_s=dt_s,
            max_rate_mm_h=self.max_rate_mm_h,
        )
        if amount is None:
            log.info("accumulation: counter reset %.3f -> %.3f mm", previous, accum_mm)
            self.resets += 1
        return amount
