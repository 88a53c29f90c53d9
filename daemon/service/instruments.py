"""The daemon's instruments: one reader thread each, their readings published and recorded,
their latest state for fusion, and their rain rates for the online calibration of R.

Every frame an instrument sends is recorded raw on ``/instrument/<id>/raw`` (``instrument.raw/1``,
with the parse error when there is one), so nothing an instrument says is ever lost. Every
reading is published on ``weather/<site>/instrument/<id>`` and recorded on
``/instrument/<id>/reading`` (``instrument.reading/1``).

An instrument's presence verdict is:
- for a present-weather sensor, its WMO 4680 code (precipitation or not), else its intensity;
- for a gauge, whether its rate is above zero. The rate comes from the reading, or from the
  difference of its accumulation counter, which is safe against wraps and resets
  (:class:`drivers.instruments.accum.AccumulationTracker`).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from daemon.config import InstrumentConfig
from daemon.transport.messages import stamp
from drivers.errors import ConfigError
from drivers.instruments import DRIVERS, DriverSpec, Frame, Reading
from drivers.instruments.accum import AccumulationTracker

from .calibration import OnlineCalibration
from .fusion import InstrumentView, wawa_precipitation

__all__ = ["InstrumentHub", "driver_kind", "make_reader"]

log = logging.getLogger(__name__)

#: Drivers of instruments that see the drops themselves and know their type.
_PRESENT_WEATHER = frozenset({"vaisala-pwd", "ott-parsivel", "thies-lnm"})
#: Where the instruments' accumulation counters wrap (mm): the PWD's water sum 0...99.99, the
#: Parsivel's and the rain[e]'s four-digit counters.
_WRAP_AT_MM = {"vaisala-pwd": 100.0, "ott-parsivel": 10000.0, "lambrecht-raine": 10000.0}


def driver_kind(cfg: InstrumentConfig) -> str:
    """``present_weather`` or ``gauge``: the configured kind, else the driver's."""
    if cfg.kind is not None:
        return cfg.kind
    return "present_weather" if cfg.driver in _PRESENT_WEATHER else "gauge"


def driver_spec(cfg: InstrumentConfig, index: int) -> DriverSpec:
    spec = DRIVERS.get(cfg.driver)
    if spec is None:
        raise ConfigError(
            f"instrument[{index}].driver: unknown driver {cfg.driver!r}; "
            f"one of {', '.join(sorted(DRIVERS))}"
        )
    return spec


def make_reader(
    cfg: InstrumentConfig,
    spec: DriverSpec,
    on_frame: Callable[[Frame, Reading | None, str | None], None],
) -> Any:
    """The reader thread object of one instrument (not started).

    Raises
    ------
    ConfigError : options, mode or serial settings the driver refuses.
    """
    if cfg.driver == "tipping-bucket":
        from drivers.instruments.tipping import TippingBucketReader

        return TippingBucketReader(cfg.id, cfg.port, options=cfg.options, on_frame=on_frame)
    from drivers.instruments.reader import InstrumentReader

    return InstrumentReader(
        cfg.id,
        spec,
        cfg.port,
        serial=cfg.serial_settings(),
        mode=cfg.mode,
        poll_interval_s=cfg.poll_interval_s,
        options=cfg.options,
        on_frame=on_frame,
        idle_timeout_s=cfg.idle_timeout_s,
    )


@dataclass
class _Latest:
    reading: Reading | None = None
    received_ns: int | None = None
    rate_mm_h: float | None = None


class InstrumentHub:
    """Every configured instrument; thread-safe. ``emit(suffix, topic, message)`` publishes
    and ``record(topic, schema_name, message)`` records (the daemon passes its own)."""

    def __init__(
        self,
        configs: list[InstrumentConfig],
        *,
        site: str,
        emit: Callable[[str | None, str, dict[str, Any]], None],
        calibration: OnlineCalibration | None = None,
    ):
        self.site = site
        self._emit = emit
        self.calibration = calibration
        self._lock = threading.Lock()
        self._configs = {c.id: c for c in configs}
        self._latest = {c.id: _Latest() for c in configs}
        self._trackers = {
            c.id: AccumulationTracker(wrap_at_mm=_WRAP_AT_MM.get(c.driver)) for c in configs
        }
        self._readers: dict[str, Any] = {}
        for i, cfg in enumerate(configs):
            spec = driver_spec(cfg, i)
            try:
                self._readers[cfg.id] = make_reader(cfg, spec, self._callback(cfg))
            except ConfigError as exc:
                raise ConfigError(f"instrument[{i}].{exc}") from None

    def start(self) -> None:
        for cfg in self._configs.values():
            log.info("instrument %s: %s on %s (%s)", cfg.id, cfg.driver, cfg.port, cfg.mode)
            self._readers[cfg.id].start()

    def stop(self) -> None:
        for reader in self._readers.values():
            reader.stop()

    # -- the reader threads' side ----------------------------------------------------------
    def _callback(
        self, cfg: InstrumentConfig
    ) -> Callable[[Frame, Reading | None, str | None], None]:
        def on_frame(frame: Frame, reading: Reading | None, error: str | None) -> None:
            self._on_frame(cfg, frame, reading, error)

        return on_frame

    def _on_frame(
        self, cfg: InstrumentConfig, frame: Frame, reading: Reading | None, error: str | None
    ) -> None:
        now = time.time_ns()
        t_ns = frame.t_ns or now
        self._emit(
            None,
            f"/instrument/{cfg.id}/raw",
            stamp(
                "instrument.raw",
                site=self.site,
                t_ns=t_ns,
                instrument=cfg.id,
                driver=cfg.driver,
                data=frame.data.decode("latin-1"),
                error=error,
            ),
        )
        if reading is None:
            return
        r_t = reading.t_ns or t_ns
        rate = reading.rain_rate_mm_h
        with self._lock:
            amount = (
                self._trackers[cfg.id].update(r_t, reading.rain_accum_mm)
                if reading.rain_accum_mm is not None
                else None
            )
            latest = self._latest[cfg.id]
            if rate is None and amount is not None and latest.reading is not None:
                prev_t = latest.reading.t_ns or latest.received_ns
                if prev_t is not None and r_t > prev_t:
                    rate = amount / ((r_t - prev_t) / 3.6e12)
            latest.reading, latest.received_ns, latest.rate_mm_h = reading, now, rate
        fields = {k: v for k, v in reading.to_json().items() if k not in ("t", "t_ns")}
        message = stamp(
            "instrument.reading",
            site=self.site,
            t_ns=r_t,
            instrument=cfg.id,
            **fields,
            received_ns=now,
        )
        self._emit(f"instrument/{cfg.id}", f"/instrument/{cfg.id}/reading", message)
        if self.calibration is not None and rate is not None and not reading.fault:
            self.calibration.add_gauge_rate(t_ns=now, rate_mm_h=rate)

    # -- the main loop's side --------------------------------------------------------------
    def views(self) -> dict[str, InstrumentView]:
        out = {}
        with self._lock:
            for iid, latest in self._latest.items():
                cfg = self._configs[iid]
                reader_state = self._readers[iid].stats().get("state")
                reading = latest.reading
                kind = driver_kind(cfg)
                rate = latest.rate_mm_h
                if reading is None:
                    precipitation = None
                elif kind == "present_weather" and reading.wawa is not None:
                    precipitation = wawa_precipitation(reading.wawa)
                else:
                    precipitation = None if rate is None else rate > 0
                out[iid] = InstrumentView(
                    kind=kind,
                    driver=cfg.driver,
                    connected=reader_state == "ok",
                    t_ns=latest.received_ns,
                    rain_rate_mm_h=None if rate is None or not math.isfinite(rate) else rate,
                    precipitation=precipitation,
                    wawa=None if reading is None else reading.wawa,
                    metar=None if reading is None else reading.metar,
                    visibility_m=None if reading is None else reading.visibility_m,
                    fault=None if reading is None else reading.fault,
                    status=None if reading is None else reading.status,
                    stale_s=self.stale_s(iid),
                )
        return out

    def stale_s(self, iid: str) -> float:
        cfg = self._configs[iid]
        if cfg.stale_s is not None:
            return cfg.stale_s
        return max(180.0, 3 * cfg.poll_interval_s)

    def stats(self) -> dict[str, Any]:
        return {iid: _json_safe(r.stats()) for iid, r in self._readers.items()}


def _json_safe(stats: dict[str, Any]) -> dict[str, Any]:
    out = {}
    for k, v in stats.items():
        if isinstance(v, float):
            out[k] = round(v, 3) if math.isfinite(v) else None
        elif isinstance(v, str | int | bool) or v is None:
            out[k] = v
        else:
            out[k] = str(v)
    return out
