"""Lambrecht rain[e] / rain[e]H3 weighing precipitation gauge (``lambrecht-raine``).

Three line formats are read (all ``;``-separated, one reading per line):

**Logger minute lines** (Lindenberg's data logger, cloudnetpy ``rain_e_h3.py``, 16 columns)::

    14.05.2023;00:00:39;0.000;0.406;0;9.56;11.50;0;0;0;60;2582;rain[e]H3;Lindenberg ;MF ;ACTRIS

    0 date dd.mm.yyyy   1 time hh:mm:ss      2 intensity mm/h    3 accumulation mm
    4 housing contact   5 top temperature °C 6 bottom temperature °C
    7 heater status (1 = on)  8 error code (bits, below)  9 system status
    10 talker interval s  11 operating hours  12 device type  13-15 user data 1-3

**The 22-column variant** (newer Lindenberg files): a logger UTC time ``yyyy-mm-dd
hh:mm:ss`` first, then the 16 columns above with a 4th user-data column, serial number,
hardware and firmware versions and ``external temperature*checksum``. The logger's UTC
time is used; the checksum is not verified there (which bytes it covers after the logger's
rewrite is unknown).

**Polled data telegrams 2 and 3** (rain[e]H3 manual, 13.2-13.3), answering
``<STX>USR2<CR><LF>`` / ``<STX>USR3<CR><LF>``::

    <STX>t2:yyyy.mm.dd;hh:mm:ss;intensity mm/h;total mm;stop(1)/run(0);T above;T below;
            heating;error code;outside T ("/" = none)*CS<CR><LF>
    <STX>t3:  ...the same to the error code;manufacturer;device type;(serial);firmware;
            outside T*CS<CR><LF>

with the manual's checksum (13.6): two's complement of the byte sum from STX to ``*``
inclusive, lowest byte as two hex digits; a wrong one is a ParseError.

Error code bits (manual 13.2): 0 maximum heating temperature exceeded, 1 heating,
2 interior temperature sensor, 3 funnel temperature sensor, 4 RTC initialisation, 5 external
temperature sensor, 6 poor supply voltage. ``status`` is ``"ok"`` or the names of the set
bits (and ``system=<n>`` / ``stopped`` when the system status is non-zero / measurement is
stopped); ``fault`` is True for any error bit or a stopped measurement. The system status
bits are not documented in what we could find: shown, not judged.

Times in the lines are the logger's or the gauge's local time: option ``timezone`` (IANA
name, default ``"UTC"``). ``time_source`` says whose: ``logger`` for the logger's lines
(the 22-column one also gives ``sensor_clock_offset_s``, the gauge's clock against the
logger's), ``sensor`` for the gauge's own t2/t3 telegrams. ``rain_accum_mm`` is the
gauge's total since system start (0...9999 mm); turn it into amounts with
:mod:`drivers.instruments.accum`. Factory serial settings of the talker protocol: 19200
baud, 8N1.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import re
import zoneinfo
from typing import Any

from drivers.errors import ConfigError

from .base import DriverSpec, Frame, ParseError, Reading, SerialDefaults, with_defaults
from .framing import LineFramer

__all__ = ["DRIVER", "check_options", "checksum", "make_framer", "parse", "poll_command"]

NAME = "lambrecht-raine"
DEFAULTS: dict[str, Any] = {"timezone": "UTC", "telegram": 3}

ERROR_BITS = (
    "heating_temperature_max",
    "heating",
    "interior_temperature_sensor",
    "funnel_temperature_sensor",
    "rtc_init",
    "external_temperature_sensor",
    "supply_voltage",
)

_DMY = re.compile(r"(\d{2})\.(\d{2})\.(\d{4})")
_YMD_DOT = re.compile(r"(\d{4})\.(\d{2})\.(\d{2})")
_YMD_HMS = re.compile(r"(\d{4})-(\d{2})-(\d{2})[ T](\d{2}):(\d{2}):(\d{2})")
_HMS = re.compile(r"(\d{2}):(\d{2}):(\d{2})")
_TEXT = re.compile(rb"[\x02\t\x20-\x7e\xa0-\xff]*")
_TELEGRAM = re.compile(rb"\x02?t(?P<n>[23]):(?P<body>[^*]*)\*(?P<cs>[0-9A-Fa-f]{2})\s*")


def check_options(options: dict[str, Any]) -> dict[str, Any]:
    """``options`` with defaults filled in; ConfigError naming the key when invalid."""
    out = with_defaults(options, DEFAULTS, NAME)
    try:
        zoneinfo.ZoneInfo(str(out["timezone"]))
    except (zoneinfo.ZoneInfoNotFoundError, ValueError) as exc:
        raise ConfigError(f"options.timezone: unknown time zone {out['timezone']!r}") from exc
    if out["telegram"] not in (2, 3) or isinstance(out["telegram"], bool):
        raise ConfigError("options.telegram: expected 2 or 3")
    return out


def make_framer(options: dict[str, Any]) -> LineFramer:
    """CR/LF lines."""
    return LineFramer()


def poll_command(options: dict[str, Any]) -> bytes:
    """``<STX>USR3<CR><LF>`` (or ``USR2``): ask for one data telegram."""
    return b"\x02USR%d\r\n" % check_options(options)["telegram"]


def checksum(data: bytes) -> str:
    """Two hex digits: lowest byte of the two's complement of the byte sum (manual 13.6)."""
    return f"{-sum(data) & 0xFF:02X}"


def parse(frame: Frame, options: dict[str, Any] | None = None) -> Reading:
    """One line (logger minute line or polled telegram) -> Reading; ParseError if unreadable."""
    options = check_options(options or {})
    raw = frame.data.rstrip(b"\r\n")
    if _TEXT.fullmatch(raw) is None:
        raise ParseError("control or non-text bytes in the line (wrong baud rate or noise?)")
    m = _TELEGRAM.fullmatch(raw)
    if m is not None:
        return _telegram(raw, m, options)
    cols = [c.strip() for c in raw.decode("latin-1").split(";")]
    if len(cols) == 16:
        t_ns = _local_ns(_DMY, cols[0], cols[1], options["timezone"], day_first=True)
        extra = {"device_type": cols[12], "time_source": "logger"}
        return _reading(cols[2:12], t_ns, extra=extra)
    if len(cols) == 22:
        t_ns = _utc_ns(cols[0])
        extra = {"device_type": cols[13], "serial_number": cols[18], "firmware": cols[20]}
        extra["time_source"] = "logger"
        try:  # the gauge's own date and time follow the logger's
            gauge_ns = _local_ns(_DMY, cols[1], cols[2], options["timezone"], day_first=True)
            extra["sensor_clock_offset_s"] = round((gauge_ns - t_ns) / 1e9, 3)
        except ParseError:
            pass
        outside = cols[21].split("*")[0]
        extra["outside_temperature_c"] = _float(outside, "outside temperature")
        # the air's temperature, as the t3 telegram's reading carries it
        reading = _reading(cols[3:13], t_ns, extra=extra)
        return dataclasses.replace(reading, temperature_c=extra["outside_temperature_c"])
    raise ParseError(f"wrong field count {len(cols)} (expected 16 or 22, or a t2/t3 telegram)")


def _reading(c: list[str], t_ns: int, *, extra: dict[str, Any]) -> Reading:
    """From the ten columns intensity ... talker interval, in the logger line order."""
    error = _int(c[6], "error code")
    system = _int(c[7], "system status")
    status, fault = _status(error, system, stopped=False)
    return Reading(
        driver=NAME,
        t_ns=t_ns,
        rain_rate_mm_h=_nonnegative(_float(c[0], "intensity")),
        rain_accum_mm=_float(c[1], "accumulation"),
        status=status,
        fault=fault,
        extra={
            "housing_contact": _int(c[2], "housing contact"),
            "temperature_top_c": _float(c[3], "top temperature"),
            "temperature_bottom_c": _float(c[4], "bottom temperature"),
            "heating": _int(c[5], "heater status"),
            "error_code": error,
            "system_status": system,
            "interval_s": _float(c[8], "talker interval"),
            "operating_hours": _float(c[9], "operating hours"),
            **extra,
        },
    )


def _telegram(raw: bytes, m: re.Match[bytes], options: dict[str, Any]) -> Reading:
    star = raw.index(b"*")
    expected = checksum(raw[: star + 1] if raw[:1] == b"\x02" else b"\x02" + raw[: star + 1])
    if m["cs"].decode().upper() != expected:
        got = m["cs"].decode()
        raise ParseError(f"checksum mismatch: telegram says {got}, computed {expected}")
    c = [x.strip() for x in m["body"].decode("latin-1").split(";")]
    n = int(m["n"])
    if (n == 2 and len(c) != 10) or (n == 3 and len(c) not in (13, 14)):
        raise ParseError(f"wrong field count {len(c)} for telegram t{n}")
    t_ns = _local_ns(_YMD_DOT, c[0], c[1], options["timezone"], day_first=False)
    stopped = _int(c[4], "start/stop") == 1
    error = _int(c[8], "error code")
    status, fault = _status(error, 0, stopped=stopped)
    extra: dict[str, Any] = {
        "temperature_top_c": _float(c[5], "temperature above"),
        "temperature_bottom_c": _float(c[6], "temperature below"),
        "heating": _int(c[7], "heating"),
        "error_code": error,
        "outside_temperature_c": _float(c[-1], "outside temperature"),
        "time_source": "sensor",
    }
    if n == 3:
        extra["device_type"] = c[10]
        extra["firmware"] = c[-2]
    return Reading(
        driver=NAME,
        t_ns=t_ns,
        rain_rate_mm_h=_nonnegative(_float(c[2], "intensity")),
        rain_accum_mm=_float(c[3], "total amount"),
        status=status,
        fault=fault,
        temperature_c=extra["outside_temperature_c"],
        extra=extra,
    )


def _status(error: int | None, system: int | None, *, stopped: bool) -> tuple[str, bool | None]:
    if error is None:
        return "unknown", None
    names = [name for bit, name in enumerate(ERROR_BITS) if error >> bit & 1]
    if error >> len(ERROR_BITS):
        names.append(f"error={error}")
    if system:
        names.append(f"system={system}")
    if stopped:
        names.append("stopped")
    return (",".join(names) or "ok"), bool(error) or stopped


def _local_ns(date_re: re.Pattern[str], date: str, time: str, zone: str, *, day_first: bool) -> int:
    d, t = date_re.fullmatch(date), _HMS.fullmatch(time)
    if d is None or t is None:
        raise ParseError(f"bad date/time {date[:12]!r} {time[:10]!r}")
    day, month, year = (d[1], d[2], d[3]) if day_first else (d[3], d[2], d[1])
    return _ns(int(year), int(month), int(day), int(t[1]), int(t[2]), int(t[3]), zone)


def _utc_ns(text: str) -> int:
    m = _YMD_HMS.fullmatch(text)
    if m is None:
        raise ParseError(f"bad logger time {text[:20]!r}")
    return _ns(*(int(g) for g in m.groups()), "UTC")


def _ns(year: int, month: int, day: int, hour: int, minute: int, second: int, zone: str) -> int:
    try:
        t = dt.datetime(year, month, day, hour, minute, second, tzinfo=zoneinfo.ZoneInfo(zone))
    except ValueError as exc:
        raise ParseError(f"impossible date/time {year}-{month}-{day} {hour}:{minute}") from exc
    return int(t.timestamp()) * 1_000_000_000


def _float(token: str, name: str) -> float | None:
    token = token.strip()
    if token in ("", "/", "-", "---"):
        return None
    try:
        return float(token)
    except ValueError:
        raise ParseError(f"{name}: not a number {token[:12]!r}") from None


def _int(token: str, name: str) -> int | None:
    value = _float(token, name)
    if value is None:
        return None
    if value != int(value):
        raise ParseError(f"{name}: not an integer {token[:12]!r}")
    return int(value)


def _nonnegative(value: float | None) -> float | None:
    return None if value is None or value < 0 else value


DRIVER = DriverSpec(
    name=NAME,
    make_framer=make_framer,
    parse=parse,
    serial=SerialDefaults(baudrate=19200, bytesize=8, parity="N", stopbits=1),
    modes=("automatic", "polled"),
    poll_command=poll_command,
    check_options=check_options,
    description="Lambrecht rain[e]/rain[e]H3 weighing gauge: logger minute lines, t2/t3",
)
