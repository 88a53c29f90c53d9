"""What every instrument driver shares: the reading, the framer and parser interfaces, errors.

A driver is split in three, as weewx's serial drivers are:

- a **framer** cuts the byte stream into frames (one telegram, message or line). It is fed
  whatever the port returns, split or merged arbitrarily, and keeps what is incomplete for the
  next call; garbage between frames is dropped and counted. A framer also accepts a logger's
  lines with a timestamp prefix, and then gives the frame the logger's time;
- a **parser** is a pure function from one frame to one :class:`Reading`, raising
  :class:`ParseError` with a one-line reason for a frame it cannot read (bad checksum, wrong
  field count, wrong baud garbage). Missing values (``/``, ``-9.999``, ``99999``...) become
  ``None``; counters that wrap or reset never become a negative amount;
- a **reader** (``drivers.instruments.reader``) owns the serial port, polls when the
  instrument is polled, and reopens it with a bounded backoff when the cable is pulled.

Units are in the field names (SI-style): ``visibility_m``, ``rain_rate_mm_h``,
``rain_accum_mm``, ``temperature_c``. ``wawa`` is the instant WMO 4680 code.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import Any, Protocol

from drivers.errors import ConfigError, WeatherdError

__all__ = [
    "DriverSpec",
    "Frame",
    "Framer",
    "ParseError",
    "Parser",
    "Reading",
    "SerialDefaults",
    "iso_utc",
    "sensor_zone",
    "with_defaults",
]


class ParseError(WeatherdError):
    """A frame that cannot be read; the message is one line saying why."""


@dataclass(frozen=True)
class Frame:
    """One telegram, message or line cut from the stream.

    Attributes
    ----------
    data : bytes, the frame as received (framing characters included where the parser needs
        them, e.g. for a checksum)
    t_ns : int or None, UTC ns from a logger's timestamp prefix; None for a raw serial stream
        (the reader then stamps the receive time)
    line : int, 1-based line number in a file where the frame starts (0 when not from a file)
    fields : what each column of a row holds, when a header line in the file named the
        columns (the driver's value numbers; drivers give their own codes to a time column
        or one to skip); None for a telegram laid out as the driver's options say
    separator : the column separator of such a row (``;``, ``,``...)
    """

    data: bytes
    t_ns: int | None = None
    line: int = 0
    fields: tuple[int, ...] | None = None
    separator: str | None = None


class Framer(Protocol):
    """Cuts a byte stream into frames; stateful, one per stream."""

    #: Bytes dropped because they were not inside any frame (garbage, noise at power-up).
    garbage_bytes: int

    def feed(self, data: bytes) -> list[Frame]:
        """Frames completed by ``data`` (possibly none), in order."""
        ...

    def flush(self) -> list[Frame]:
        """At the end of a file: whatever complete frame is still held (possibly none)."""
        ...


#: parse(frame) -> Reading, pure; raises ParseError.
Parser = Callable[[Frame], "Reading"]


@dataclass(frozen=True)
class Reading:
    """One reading of one instrument, in SI-style units; None where missing or not measured.

    ``to_json`` gives the line of ``weatherd instruments decode`` (contract fields ``t``,
    ``driver``, ``visibility_m``, ``rain_rate_mm_h``, ``rain_accum_mm``, ``wawa``, ``metar``,
    ``status``, then the others).
    """

    driver: str
    t_ns: int | None = None
    #: Visibility (MOR), metres: the 1-minute value where an instrument gives several.
    visibility_m: float | None = None
    visibility_10min_m: float | None = None
    #: Precipitation intensity, mm/h, and the instrument's accumulation counter, mm (as the
    #: instrument reports it: it may wrap or be reset; see ``drivers.instruments.accum``).
    rain_rate_mm_h: float | None = None
    rain_accum_mm: float | None = None
    snow_accum_mm: float | None = None
    #: WMO 4680 present weather: instant, 15-minute and 1-hour codes.
    wawa: int | None = None
    wawa_15min: int | None = None
    wawa_1h: int | None = None
    #: WMO 4678 / METAR present-weather group, e.g. "-RA", "SN", "+TSRA"; "" for none.
    metar: str | None = None
    #: NWS present-weather code (Vaisala), e.g. "R-", "S", "L", "C" (clear).
    nws_code: str | None = None
    #: The instrument's own status, as text (e.g. "0", "ok", a hardware/alarm code).
    status: str | None = None
    #: True when the status says the measurement cannot be trusted (a hardware error, a
    #: blocked sensor...); None when unknown.
    fault: bool | None = None
    temperature_c: float | None = None
    #: Anything else the instrument says that users may want, already in SI-style units.
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "t": iso_utc(self.t_ns) if self.t_ns is not None else None,
            "driver": self.driver,
        }
        for f in fields(self):
            if f.name in ("driver", "t_ns", "extra"):
                continue
            out[f.name] = _clean(getattr(self, f.name))
        if self.t_ns is not None:
            out["t_ns"] = int(self.t_ns)
        out.update({k: _clean(v) for k, v in self.extra.items()})
        return out


def with_defaults(options: dict[str, Any], defaults: dict[str, Any], driver: str) -> dict[str, Any]:
    """``options`` over ``defaults``; an unknown key is a ConfigError naming it."""
    unknown = sorted(set(options) - set(defaults))
    if unknown:
        raise ConfigError(f"options.{unknown[0]}: unknown option for {driver}")
    return {**defaults, **options}


def sensor_zone(value: Any, key: str = "options.timezone") -> dt.tzinfo:
    """The time zone of a sensor's clock: a zone name (``"Europe/Berlin"``, ``"UTC"``) or a
    fixed offset from UTC in hours (``-6``, ``5.5``, ``"-06:00"``); ConfigError naming ``key``."""
    import re
    import zoneinfo

    if isinstance(value, int | float) and not isinstance(value, bool):
        hours = float(value)
    elif isinstance(value, str) and (m := re.fullmatch(r"([+-])(\d{1,2}):?(\d{2})?", value)):
        hours = (int(m[2]) + int(m[3] or 0) / 60) * (-1 if m[1] == "-" else 1)
    else:
        try:
            return zoneinfo.ZoneInfo(str(value))
        except (zoneinfo.ZoneInfoNotFoundError, ValueError) as exc:
            raise ConfigError(f"{key}: unknown time zone {value!r}") from exc
    if not -14 <= hours <= 14:
        raise ConfigError(f"{key}: an offset from UTC is within -14...+14 hours")
    return dt.timezone(dt.timedelta(hours=hours))


def _clean(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def iso_utc(t_ns: int) -> str:
    """UTC ns since the epoch as ISO-8601 with ``Z`` (second precision unless fractional)."""
    t = dt.datetime.fromtimestamp(t_ns // 1000 / 1e6, tz=dt.UTC)
    if t.microsecond:
        return t.strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    return t.strftime("%Y-%m-%dT%H:%M:%SZ")


@dataclass(frozen=True)
class SerialDefaults:
    """The instrument's factory serial settings (pyserial names)."""

    baudrate: int = 9600
    bytesize: int = 8
    parity: str = "N"  # "N", "E", "O"
    stopbits: float = 1


@dataclass(frozen=True)
class DriverSpec:
    """One driver: how to frame, parse and poll an instrument.

    ``options`` everywhere is the ``[instrument.options]`` table of the configuration, already
    checked by ``check_options`` (which raises ``ConfigError`` naming the key, e.g.
    ``options.mm_per_tip: must be > 0``, and returns the options with defaults filled in).
    """

    name: str
    make_framer: Callable[[dict[str, Any]], Framer]
    parse: Callable[[Frame, dict[str, Any]], Reading]
    serial: SerialDefaults = SerialDefaults()
    #: Modes the instrument supports: "automatic" (it sends by itself), "polled" (we ask).
    modes: tuple[str, ...] = ("automatic",)
    #: The bytes that ask the instrument for one message, in polled mode.
    poll_command: Callable[[dict[str, Any]], bytes] | None = None
    check_options: Callable[[dict[str, Any]], dict[str, Any]] = dict
    #: The driver's option ``checksum`` takes "report" (each reading says whether its
    #: checksum matched, ``checksum_ok``, and by how much it is off, ``checksum_offset``)
    #: and "ignore": ``weatherd instruments decode --checksum`` drives it.
    reports_checksum: bool = False
    #: One line for ``weatherd instruments decode --help`` and the docs.
    description: str = ""
