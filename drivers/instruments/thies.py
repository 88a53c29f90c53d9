"""Thies Clima Laser Precipitation Monitor (LNM / LPM 5.4110.xx.x00), telegram 4 (``thies-lnm``).

Telegram 4 (Thies "Instruction for use" 021341, Clima Sensor US disdrometer telegram alike;
the column numbers are the manual's, counting STX as column 1)::

    <STX>00;0747;2.50;17.04.2024;23:00:50;00;00;NP   ;000.000;00;00;NP   ;000.000;...;<CR><LF><ETX>

    col  index  field
    2    0      device address (00...99)
    3-4  1-2    serial number, software version
    5-6  3-4    date dd.mm.yy(yy), time hh:mm:ss (the sensor's clock)
    7-10 5-8    5-minute SYNOP 4677 ww, SYNOP 4680 wawa, METAR 4678, intensity mm/h
    11   9      1-minute SYNOP 4677 ww
    12   10     1-minute SYNOP 4680 wawa
    13   11     1-minute METAR/SPECI 4678 (``NP`` = no precipitation)
    14   12     intensity, total precipitation, mm/h
    15-16 13-14 intensity, liquid and solid precipitation, mm/h
    17   15     precipitation amount since reset, mm (a counter)
    18   16     MOR visibility in precipitation, m (0...99999; 99999 = not reduced)
    19-21 17-19 radar reflectivity dBZ (-9.9 = none), measuring quality %, max hail diameter mm
    22-36 20-34 status: laser, static signal, laser temperature (analogue, digital), laser
                current (analogue, digital), sensor supply (0 = OK, 1 = error); heating of
                laser head, receiver, temperature sensor, heating supply, housing, heads,
                carriers, laser power control (0 = OK, 1 = warning)
    38-39 36-37 interior temperature, laser driver temperature, °C
    46   44     ambient temperature, °C
    51   49     number of particles
    81-520 79-518 22 × 20 spectrum (diameter × speed)
    521-524 519-522 optional external sensors (temperature, humidity, wind speed, direction)
    last        checksum, 2 hex digits, then CR LF ETX

Checksum (manual 021341/07/11, footnote 8 of telegram 4): the two's complement of the sum of
all characters, control characters included, without the checksum itself; its lowest byte as
two hex digits. The footnote lists ETX/CR/LF among the summed characters although they follow
the checksum, so both readings are accepted: the sum from STX up to the ``;`` before the
checksum, or with the trailing bytes of the frame (or CR LF ETX) added. Real sensors write
it a constant away from that rule (see :func:`checksum_offset`); option ``checksum``:
``auto`` (verify when present, the default and what the live reader does), ``require``,
``report`` (verify, never refuse: ``checksum_ok`` and ``checksum_offset`` in the reading),
``ignore``. A checksum is present when the field count
says so (520 or 524 values); loggers also store shortened telegrams (Leipzig's LIM keeps
columns 2-23, cloudnetpy's ``truncate_columns``): any prefix of 17 to 79 values is read, a
count between the prefix and the full telegram is a ParseError.

Missing or "nothing measured" values become None: visibility 99999, reflectivity -9.9. The
METAR group ``NP`` becomes ``""`` (no precipitation). ``status`` is ``"ok"`` or the names of
the status fields that are set; ``fault`` is True when one of the error fields (laser to
sensor supply) is set, the heating fields being warnings.

Polled mode: ``<id>TR<telegram, 5 digits><CR>`` (Thies command interpreter, e.g.
``00TR00004``); options ``device_id`` (0...99) and ``telegram`` (default 4). Files logged
with the ETX at the start of the next line (as Leipzig's) frame fine; the last telegram of
such a file has no ETX and is still read.
"""

from __future__ import annotations

import datetime as dt
import re
from typing import Any

from drivers.errors import ConfigError

from .base import (
    DriverSpec,
    Frame,
    ParseError,
    Reading,
    SerialDefaults,
    sensor_zone,
    with_defaults,
)
from .framing import (
    PREFIX_ISO,
    PREFIX_TOA5,
    PREFIX_YMDHMS,
    DelimitedOrLineFramer,
    first_prefix,
    regex_prefix,
    unix_prefix,
)

__all__ = [
    "DRIVER",
    "check_options",
    "checksum",
    "checksum_offset",
    "make_framer",
    "parse",
    "poll_command",
]

NAME = "thies-lnm"
STX, ETX = b"\x02", b"\x03"

DEFAULTS: dict[str, Any] = {
    "device_id": 0,
    "telegram": 4,
    "checksum": "auto",
    "clock": "auto",
    "timezone": "UTC",
    "n_fields": None,
}

#: Index of the first status field and the names of the status fields, in order; the first
#: seven are errors (the measurement cannot be trusted), the others warnings.
STATUS_FROM = 20
STATUS_NAMES = (
    "laser_off",
    "static_signal",
    "laser_temperature_analogue",
    "laser_temperature_digital",
    "laser_current_analogue",
    "laser_current_digital",
    "sensor_supply",
    "heating_laser_head",
    "heating_receiver_head",
    "temperature_sensor",
    "heating_supply",
    "heating_housing",
    "heating_heads",
    "heating_carriers",
    "laser_power_control",
)
N_ERRORS = 7
MIN_FIELDS = 17  # up to the visibility
PREFIX_MAX = 79  # everything before the spectrum
FULL_COUNTS = {519: False, 520: True, 523: False, 524: True}  # count -> has a checksum

#: ``checksum``: verify when present, require one, verify and say it in the reading
#: (``checksum_ok``, ``checksum_offset``) without refusing it, or do not verify.
CHECKSUM_MODES = ("auto", "require", "report", "ignore")

_DATE = re.compile(r"(\d{2})\.(\d{2})\.(\d{2}|\d{4})")
_TIME = re.compile(r"(\d{2}):(\d{2}):(\d{2})")
_HEX2 = re.compile(r"[0-9A-Fa-f]{2}")
_TEXT = re.compile(rb"[\x02\x03\r\n\x20-\x7e]*")


def check_options(options: dict[str, Any]) -> dict[str, Any]:
    """``options`` with defaults filled in; ConfigError naming the key when invalid."""
    out = with_defaults(options, DEFAULTS, NAME)
    for key, low, high in (("device_id", 0, 99), ("telegram", 1, 99)):
        value = out[key]
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise ConfigError(f"options.{key}: expected an integer in {low}...{high}")
    if out["checksum"] not in CHECKSUM_MODES:
        raise ConfigError('options.checksum: expected "auto", "require", "report" or "ignore"')
    if out["clock"] not in ("auto", "instrument", "receiver"):
        raise ConfigError('options.clock: expected "auto", "instrument" or "receiver"')
    sensor_zone(out["timezone"])
    n = out["n_fields"]
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < MIN_FIELDS):
        raise ConfigError(f"options.n_fields: expected an integer >= {MIN_FIELDS}")
    return out


#: Logger stamps before a telegram on its line: ``2024-10-03 00:00:41;``, ISO 8601,
#: ``YYYYMMDDhhmmss;``, Unix seconds, a Campbell TOA5 row ``"2024-04-14 00:01:00",552609,"``.
_LOGGER_PREFIX = first_prefix(
    regex_prefix(PREFIX_TOA5),
    regex_prefix(PREFIX_YMDHMS),
    regex_prefix(PREFIX_ISO),
    unix_prefix,
)


def _is_header(line: bytes) -> bool:
    """A header line of a logger's file (column names, TOA5 metadata), not a telegram: it
    has columns but does not start with the device address's digits."""
    columns = line.count(b";") + line.count(b",")
    return columns >= 2 and not line.lstrip(b" \x02")[:1].isdigit()


def make_framer(options: dict[str, Any]) -> DelimitedOrLineFramer:
    """STX…ETX telegrams (a last one cut before its ETX is still handed out), or one telegram
    a line where a logger stripped STX and ETX (with or without its stamp before it, under
    header lines or not): the capture's first bytes tell which."""
    return DelimitedOrLineFramer(
        STX,
        ETX,
        marker=b";",
        min_markers=MIN_FIELDS,
        flush_partial=True,
        line_prefix=_LOGGER_PREFIX,
        is_header=_is_header,
    )


def poll_command(options: dict[str, Any]) -> bytes:
    """``<id>TR<telegram><CR>``, e.g. ``b"00TR00004\\r"``."""
    options = check_options(options)
    return f"{options['device_id']:02d}TR{options['telegram']:05d}\r".encode("ascii")


def checksum(data: bytes) -> str:
    """Two hex digits: the lowest byte of the two's complement of the byte sum of ``data``."""
    return f"{-sum(data) & 0xFF:02X}"


def parse(frame: Frame, options: dict[str, Any] | None = None) -> Reading:
    """One telegram 4 (whole or a logger's prefix of it) -> Reading; ParseError if unreadable."""
    options = check_options(options or {})
    raw = frame.data
    if raw[:1] == b'"':  # a telegram a logger stored as a quoted string (TOA5)
        raw = raw.strip(b'"\r\n')
    if _TEXT.fullmatch(raw) is None:
        raise ParseError("non-ASCII bytes in the telegram (wrong baud rate or noise?)")
    body = raw[raw.index(STX) + 1 :] if STX in raw else raw
    values = body.decode("ascii").strip('\x03\r\n"').split(";")
    if values and values[-1].strip() == "":
        values.pop()
    n = len(values)
    has_checksum = FULL_COUNTS.get(n, False)
    if options["n_fields"] is not None:
        if n != options["n_fields"]:
            raise ParseError(f"wrong field count {n} (options.n_fields = {options['n_fields']})")
    elif n not in FULL_COUNTS and not MIN_FIELDS <= n <= PREFIX_MAX:
        raise ParseError(f"wrong field count {n} for telegram 4")
    mode = options["checksum"]
    report: dict[str, Any] = {}
    if has_checksum:
        offset = None if mode == "ignore" else checksum_offset(raw, values[-1].strip())
        if offset is not None and mode != "report":
            manual = checksum(_summed(raw, values[-1].strip()))
            raise ParseError(
                f"checksum mismatch: telegram says {values[-1].strip()}, computed {manual} "
                "(two's complement of the byte sum from STX to the ';' before it)"
            )
        if mode == "report":
            report = {"checksum_ok": offset is None}
            if offset is not None:
                report["checksum_offset"] = f"{offset:02X}"
        values = values[:-1]
    elif mode == "require":
        raise ParseError("no checksum in the telegram")
    elif mode == "report":
        report = {"checksum_ok": None}
    reading = _reading(values, frame, options)
    if report:
        reading.extra.update(report)
    return reading


def _summed(raw: bytes, cs: str) -> bytes:
    """The bytes the manual's checksum covers: STX up to the ``;`` before the checksum."""
    at = raw.rfind(b";" + cs.encode("ascii")) + 1
    before = raw[:at]
    return before[before.index(STX) :] if STX in before else STX + before


def checksum_offset(raw: bytes, cs: str) -> int | None:
    """None when the telegram's checksum ``cs`` matches, else how far it is from the
    manual's rule: ``(cs - computed) mod 256``.

    The manual's rule is summed from STX to the ``;`` before the checksum (STX added back
    where a logger stripped it); the sum with the trailing CR LF ETX, which the manual's
    footnote also lists, is accepted too. Every real capture found so far (five files of four
    sensors, firmware 2.52 to 2.70, cloudnetpy's tests) carries a checksum a constant away
    from this rule (0xAB for 520 values, 0xA5 with the four external-sensor values): the
    same offset on every telegram of a file is a convention, not corruption
    (``drivers.instruments.decode`` says so once).
    """
    if _HEX2.fullmatch(cs) is None:
        raise ParseError(f"bad checksum field {cs[:8]!r}")
    summed = _summed(raw, cs)
    at = raw.rfind(b";" + cs.encode("ascii")) + 1
    after = raw[at + 2 :]
    candidates = {checksum(summed), checksum(summed + after), checksum(summed + b"\r\n\x03")}
    if cs.upper() in candidates:
        return None
    return (int(cs, 16) - int(checksum(summed), 16)) & 0xFF


def _reading(v: list[str], frame: Frame, options: dict[str, Any]) -> Reading:
    if not v[0].strip().isdigit():
        raise ParseError(f"bad device address {v[0][:8]!r}")
    t_ns, clocks = _clock(v, frame, options)
    status_values = [_int(x, "status") for x in v[STATUS_FROM : STATUS_FROM + len(STATUS_NAMES)]]
    status, fault = _status(status_values)
    extra: dict[str, Any] = {
        "device_address": v[0].strip(),
        "serial_number": v[1].strip(),
        "ww": _code(v[9], "ww"),
        "ww_5min": _code(v[5], "ww 5min"),
        "wawa_5min": _code(v[6], "wawa 5min"),
        "metar_5min": _metar(v[7]),
        "rain_rate_5min_mm_h": _float(v[8], "intensity 5min"),
        "rain_rate_liquid_mm_h": _float(v[13], "liquid intensity"),
        "rain_rate_solid_mm_h": _float(v[14], "solid intensity"),
        **clocks,
    }
    optional = (
        (17, "reflectivity_dbz"),
        (18, "quality_pct"),
        (19, "hail_diameter_mm"),
        (36, "interior_temperature_c"),
        (49, "n_particles"),
    )
    for i, key in optional:
        if i < len(v):
            extra[key] = _float(v[i], key)
    if extra.get("reflectivity_dbz") == -9.9:
        extra["reflectivity_dbz"] = None
    visibility = _float(v[16], "visibility")
    return Reading(
        driver=NAME,
        t_ns=t_ns,
        visibility_m=None if visibility is None or visibility >= 99999 else visibility,
        rain_rate_mm_h=_float(v[12], "intensity"),
        rain_accum_mm=_float(v[15], "amount"),
        wawa=_code(v[10], "wawa"),
        metar=_metar(v[11]),
        status=status,
        fault=fault,
        temperature_c=_float(v[44], "ambient temperature") if len(v) > 44 else None,
        extra=extra,
    )


def _status(values: list[int | None]) -> tuple[str | None, bool | None]:
    if not values:
        return None, None
    names = [STATUS_NAMES[i] for i, x in enumerate(values) if x]
    fault = any(values[:N_ERRORS])
    return (",".join(names) if names else "ok"), fault


def _clock(v: list[str], frame: Frame, options: dict[str, Any]) -> tuple[int | None, dict]:
    """The reading's time and what says which clock gave it.

    ``clock = "auto"``: the logger's stamp (or, live, the receive time) when the frame has
    one, else the sensor's clock; ``"instrument"``: the sensor's; ``"receiver"``: the frame's.
    A sensor date that cannot be read is a ParseError only when nothing else dates the reading.
    """
    mode, logger_ns = options["clock"], frame.t_ns
    if mode == "receiver":
        return logger_ns, {"time_source": "logger" if logger_ns is not None else None}
    if mode == "instrument" or logger_ns is None:
        return _time_ns(v[3], v[4], options["timezone"]), {"time_source": "sensor"}
    try:
        sensor_ns = _time_ns(v[3], v[4], options["timezone"])
    except ParseError:
        return logger_ns, {"time_source": "logger"}
    offset = round((sensor_ns - logger_ns) / 1e9, 3)
    return logger_ns, {"time_source": "logger", "sensor_clock_offset_s": offset}


def _time_ns(date: str, time: str, zone: str | float) -> int:
    d, t = _DATE.fullmatch(date.strip()), _TIME.fullmatch(time.strip())
    if d is None or t is None:
        raise ParseError(f"bad date/time {date[:12]!r} {time[:10]!r}")
    year = int(d[3]) + (2000 if len(d[3]) == 2 else 0)
    try:
        local = dt.datetime(
            year, int(d[2]), int(d[1]), int(t[1]), int(t[2]), int(t[3]),
            tzinfo=sensor_zone(zone),
        )  # fmt: skip
    except ValueError as exc:
        raise ParseError(f"impossible date/time {date} {time}") from exc
    return int(local.timestamp()) * 1_000_000_000


def _float(token: str, name: str) -> float | None:
    token = token.strip()
    if token in ("", "/", "//", "///", "////", "/////"):
        return None
    try:
        return float(token)
    except ValueError:
        raise ParseError(f"{name}: not a number {token[:12]!r}") from None


def _int(token: str, name: str) -> int | None:
    value = _float(token, name)
    return None if value is None else int(value)


def _code(token: str, name: str) -> int | None:
    value = _int(token, name)
    return value if value is not None and 0 <= value <= 99 else None


def _metar(token: str) -> str:
    text = token.strip()
    return "" if text in ("NP", "") else text


DRIVER = DriverSpec(
    name=NAME,
    make_framer=make_framer,
    parse=parse,
    serial=SerialDefaults(baudrate=9600, bytesize=8, parity="N", stopbits=1),
    modes=("automatic", "polled"),
    poll_command=poll_command,
    check_options=check_options,
    reports_checksum=True,
    description="Thies Clima LNM/LPM laser disdrometer telegram 4: ';'-separated values "
    "from the device address (17 to 79 of them, or 519/520/523/524 with the spectrum), "
    "within STX…ETX or one a line, with or without a logger's stamp before them",
)
