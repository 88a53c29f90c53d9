"""Any line-oriented ASCII instrument, read with a regular expression (``ascii-regex``).

For the instruments without a driver of their own. Configuration example::

    [instrument.options]
    pattern = '^(?P<time>\\S+ \\S+) R=(?P<rain>[-\\d.]+) V=(?P<vis>[\\d.]+|///)'
    fields = { rain = "rain_rate_mm_h", vis = "visibility_m:km" }
    time_format = "%Y-%m-%d %H:%M:%S"   # strptime; without it the time group is ISO-8601
    timezone = "Europe/Paris"           # for times without a zone; default "UTC"
    missing = ["///", "-9999"]          # values meaning "not measured" (also compared as numbers)
    line_ending = "auto"                # CR, LF or CRLF; or "crlf", "lf", "cr", or any string

Options:

- ``pattern``: a Python regular expression with named groups, searched in each line (anchor it
  with ``^``/``$`` to match whole lines). A line it does not match is a ParseError.
- ``fields``: group name -> ``"<reading field>[:<unit>]"``. Targets are the numeric and text
  fields of :class:`~drivers.instruments.base.Reading` (``visibility_m``, ``rain_rate_mm_h``,
  ``rain_accum_mm``, ``snow_accum_mm``, ``temperature_c``, ``wawa``..., ``metar``,
  ``nws_code``, ``status``, ``fault``) or ``extra.<name>`` for anything else. The unit says
  what the instrument sends and is converted to the field's unit (:data:`UNITS`): lengths
  ``m km ft mi nmi``, rates ``mm/h in/h mm/min``, amounts ``mm cm m in``, temperatures
  ``C F K``.
- ``time`` group (optional) with ``time_format`` and ``timezone``: the reading's time.
  Without it the frame's time is kept (a logger prefix, or the reader's receive time).
- ``missing``: values (text) that become None; an empty or absent group is always None.

Every invalid option is a ConfigError naming its key (``options.pattern: ...``).
"""

from __future__ import annotations

import datetime as dt
import functools
import math
import re
import zoneinfo
from dataclasses import dataclass, fields
from typing import Any

from drivers.errors import ConfigError

from .base import DriverSpec, Frame, ParseError, Reading, with_defaults
from .framing import LineFramer, is_blank

__all__ = ["DRIVER", "UNITS", "TerminatorFramer", "check_options", "make_framer", "parse"]

NAME = "ascii-regex"

DEFAULTS: dict[str, Any] = {
    "pattern": None,
    "fields": None,
    "time_format": None,
    "timezone": "UTC",
    "missing": [],
    "line_ending": "auto",
}

#: Unit family -> {unit: (scale, offset)}: value_in_field_unit = value * scale + offset.
UNITS: dict[str, dict[str, tuple[float, float]]] = {
    "length_m": {"m": (1.0, 0.0), "km": (1000.0, 0.0), "ft": (0.3048, 0.0),
                 "mi": (1609.344, 0.0), "nmi": (1852.0, 0.0)},
    "rate_mm_h": {"mm/h": (1.0, 0.0), "in/h": (25.4, 0.0), "mm/min": (60.0, 0.0)},
    "amount_mm": {"mm": (1.0, 0.0), "cm": (10.0, 0.0), "m": (1000.0, 0.0), "in": (25.4, 0.0)},
    "temperature_c": {"c": (1.0, 0.0), "f": (5.0 / 9.0, -160.0 / 9.0), "k": (1.0, -273.15)},
}  # fmt: skip

#: Reading field -> its kind: a unit family, "code" (WMO 0...99), "text" or "bool".
TARGETS: dict[str, str] = {
    "visibility_m": "length_m",
    "visibility_10min_m": "length_m",
    "rain_rate_mm_h": "rate_mm_h",
    "rain_accum_mm": "amount_mm",
    "snow_accum_mm": "amount_mm",
    "temperature_c": "temperature_c",
    "wawa": "code",
    "wawa_15min": "code",
    "wawa_1h": "code",
    "metar": "text",
    "nws_code": "text",
    "status": "text",
    "fault": "bool",
}
assert set(TARGETS) <= {f.name for f in fields(Reading)}

_LINE_ENDINGS = {"crlf": "\r\n", "lf": "\n", "cr": "\r"}
_TRUE = {"1", "true", "yes", "on", "fault", "error"}
_FALSE = {"0", "false", "no", "off", "ok", ""}


@dataclass(frozen=True)
class _Field:
    group: str
    target: str  # a Reading field, or "extra.<name>"
    kind: str  # a unit family, "code", "text", "bool" or "number" (extra without unit)
    scale: float = 1.0
    offset: float = 0.0


def check_options(options: dict[str, Any]) -> dict[str, Any]:
    """``options`` with defaults filled in; ConfigError naming the key when one is wrong."""
    out = with_defaults(options, DEFAULTS, NAME)
    if out["time_format"] is not None and not isinstance(out["time_format"], str):
        raise ConfigError("options.time_format: expected a strptime format string")
    missing = out["missing"]
    if not isinstance(missing, list | tuple) or not all(isinstance(x, str) for x in missing):
        raise ConfigError('options.missing: expected a list of strings, e.g. ["///", "-9999"]')
    out["missing"] = list(missing)
    ending = out["line_ending"]
    if not isinstance(ending, str) or not ending:
        raise ConfigError('options.line_ending: expected "auto", "crlf", "lf", "cr" or a string')
    _compiled(out)
    return out


@dataclass(frozen=True)
class _Compiled:
    regex: re.Pattern[str]
    fields: tuple[_Field, ...]
    zone: zoneinfo.ZoneInfo
    missing_text: frozenset[str]
    missing_numbers: frozenset[float]


def _compiled(options: dict[str, Any]) -> _Compiled:
    fields_ = options.get("fields")
    key = (
        options.get("pattern"),
        tuple(fields_.items()) if isinstance(fields_, dict) else fields_,
        options.get("time_format"),
        options.get("timezone", "UTC"),
        tuple(options.get("missing", ())),
    )
    try:
        return _compile_cached(key)
    except TypeError as exc:  # an unhashable value where a string was expected
        raise ConfigError(f"options: expected strings, tables of strings: {exc}") from exc


@functools.lru_cache(maxsize=64)
def _compile_cached(key: tuple[Any, ...]) -> _Compiled:
    pattern, field_items, time_format, timezone, missing = key
    regex = _compile(pattern)
    specs = _fields(dict(field_items) if isinstance(field_items, tuple) else field_items, regex)
    if time_format is not None and "time" not in regex.groupindex:
        raise ConfigError("options.time_format: options.pattern has no group named 'time'")
    try:
        zone = zoneinfo.ZoneInfo(str(timezone))
    except (zoneinfo.ZoneInfoNotFoundError, ValueError) as exc:
        raise ConfigError(f"options.timezone: unknown time zone {timezone!r}") from exc
    text, numbers = _missing_sets(missing)
    return _Compiled(regex, specs, zone, text, numbers)


def _compile(pattern: Any) -> re.Pattern[str]:
    if not isinstance(pattern, str) or not pattern:
        raise ConfigError("options.pattern: expected a regular expression (a string)")
    try:
        regex = re.compile(pattern)
    except re.error as exc:
        raise ConfigError(f"options.pattern: invalid regular expression: {exc}") from exc
    if not regex.groupindex:
        raise ConfigError("options.pattern: has no named group (?P<name>...)")
    return regex


def _fields(mapping: Any, regex: re.Pattern[str]) -> tuple[_Field, ...]:
    if not isinstance(mapping, dict) or not mapping:
        raise ConfigError('options.fields: expected a table, e.g. { rain = "rain_rate_mm_h" }')
    out, seen = [], set()
    for group, spec in mapping.items():
        key = f"options.fields.{group}"
        if group not in regex.groupindex:
            raise ConfigError(f"{key}: options.pattern has no group named {group!r}")
        if not isinstance(spec, str) or not spec:
            raise ConfigError(f'{key}: expected "<field>" or "<field>:<unit>"')
        target, _, unit = spec.partition(":")
        target, unit = target.strip(), unit.strip().lower()
        if target in seen:
            raise ConfigError(f"{key}: {target} is already set by another group")
        seen.add(target)
        if target.startswith("extra."):
            if not target[6:].isidentifier():
                raise ConfigError(f"{key}: bad extra name {target!r}")
            kind = next((fam for fam, units in UNITS.items() if unit in units), None)
            if unit and kind is None:
                raise ConfigError(f"{key}: unknown unit {unit!r}")
            kind = kind or "number"
        elif target in TARGETS:
            kind = TARGETS[target]
        else:
            raise ConfigError(f"{key}: unknown reading field {target!r} (or use extra.<name>)")
        scale, offset = 1.0, 0.0
        if unit:
            if kind not in UNITS or unit not in UNITS[kind]:
                known = ", ".join(UNITS.get(kind, {})) or "none"
                raise ConfigError(f"{key}: unit {unit!r} does not convert to {target} ({known})")
            scale, offset = UNITS[kind][unit]
        out.append(_Field(group, target, kind, scale, offset))
    return tuple(out)


def _missing_sets(values: list[str] | tuple[str, ...]) -> tuple[frozenset[str], frozenset[float]]:
    numbers = set()
    for value in values:
        try:
            numbers.add(float(value))
        except ValueError:
            pass
    return frozenset(v.strip() for v in values), frozenset(numbers)


def make_framer(options: dict[str, Any]) -> LineFramer | TerminatorFramer:
    """CR/LF lines (``line_ending = "auto"``), or lines ended by the given string."""
    ending = options.get("line_ending", "auto")
    if ending == "auto":
        return LineFramer()
    return TerminatorFramer(_LINE_ENDINGS.get(ending, ending).encode("latin-1"))


class TerminatorFramer:
    """Frames ended by one fixed byte string (blank frames and over-long ones are garbage)."""

    def __init__(self, terminator: bytes, *, max_frame_bytes: int = 16384) -> None:
        if not terminator:
            raise ValueError("terminator must not be empty")
        self._end = terminator
        self._max = max_frame_bytes
        self._buf = b""
        self._line = 1
        self.garbage_bytes = 0

    def feed(self, data: bytes) -> list[Frame]:
        self._buf += data
        *pieces, self._buf = self._buf.split(self._end)
        out = [f for f in map(self._frame, pieces) if f is not None]
        if len(self._buf) > self._max:
            self.garbage_bytes += len(self._buf)
            self._buf = b""
        return out

    def flush(self) -> list[Frame]:
        piece, self._buf = self._buf, b""
        frame = self._frame(piece) if piece else None
        return [] if frame is None else [frame]

    def _frame(self, piece: bytes) -> Frame | None:
        line = self._line
        self._line += piece.count(b"\n") + 1
        if is_blank(piece) or len(piece) > self._max:
            self.garbage_bytes += len(piece)
            return None
        return Frame(piece, None, line)


def parse(frame: Frame, options: dict[str, Any]) -> Reading:
    """One line -> Reading through ``options.pattern``; ParseError when it does not match."""
    c = _compiled(options)
    regex = c.regex
    text = frame.data.decode("latin-1").strip("\r\n")
    m = regex.search(text)
    if m is None:
        raise ParseError(f"line does not match options.pattern: {text[:60]!r}")
    values: dict[str, Any] = {}
    extra: dict[str, Any] = {}
    for spec in c.fields:
        value = _convert(m[spec.group], spec, c.missing_text, c.missing_numbers)
        if spec.target.startswith("extra."):
            extra[spec.target[6:]] = value
        else:
            values[spec.target] = value
    t_ns = frame.t_ns
    if "time" in regex.groupindex and m["time"] is not None:
        t_ns = _time_ns(m["time"], options.get("time_format"), c.zone)
    return Reading(driver=NAME, t_ns=t_ns, extra=extra, **values)


def _convert(
    raw: str | None, spec: _Field, missing_text: frozenset[str], missing_numbers: frozenset[float]
) -> Any:
    text = (raw or "").strip()
    if not text or text in missing_text:
        return None
    if spec.kind == "text":
        return text
    if spec.kind == "bool":
        if text.lower() in _TRUE | _FALSE:
            return text.lower() in _TRUE
    try:
        number = float(text)
    except ValueError:
        raise ParseError(f"{spec.group}: not a number {text[:16]!r}") from None
    if number in missing_numbers or not math.isfinite(number):
        return None
    if spec.kind == "bool":
        return number != 0
    if spec.kind == "code":
        if number != int(number) or not 0 <= number <= 99:
            raise ParseError(f"{spec.group}: not a WMO code (0...99) {text[:16]!r}")
        return int(number)
    return number * spec.scale + spec.offset


def _time_ns(text: str, time_format: str | None, zone: zoneinfo.ZoneInfo) -> int:
    try:
        if time_format is None:
            t = dt.datetime.fromisoformat(text.strip())
        else:
            t = dt.datetime.strptime(text.strip(), time_format)
    except ValueError:
        raise ParseError(f"time: cannot read {text[:30]!r}") from None
    if t.tzinfo is None:
        t = t.replace(tzinfo=zone)
    delta = t - dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
    return (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1000


DRIVER = DriverSpec(
    name=NAME,
    make_framer=make_framer,
    parse=parse,
    check_options=check_options,
    description="any line-oriented ASCII instrument, via a regular expression with named groups",
)
