"""OTT Parsivel² laser disdrometer: the ``CS/PA`` answer and ``;``-separated user telegrams.

Measured-value numbers (OTT Parsivel² operating instructions, section 11.2) used here::

    01 rain intensity, mm/h (0000.000)         13 sensor serial number
    02 rain amount accumulated, mm (0000.00)   14/15 firmware IOP / DSP
    03 SYNOP wawa, WMO 4680                     16 sensor head heating current, A
    04 SYNOP ww, WMO 4677                       17 power supply voltage, V
    05 METAR/SPECI w'w', WMO 4678 ("  -RA")     18 sensor status: 0 ok, 1 dirty, 2 no
    06 NWS code ("  R-")                           measurement possible (3 laser damaged)
    07 radar reflectivity, dBZ (-9.999: dry)    19 date/time of measuring start
    08 MOR visibility in precipitation, m       20/21 sensor time (hh:mm:ss) / date (dd.mm.yyyy)
    09 sample interval, s                       22/23 station name / number
    10 signal amplitude of the laser strip      24 rain amount absolute, mm
    11 number of detected particles             25 error code
    12 temperature in the sensor housing, °C    26/27/28 temperatures PCB / right / left head
    30/31/32/33 16-bit intensity/amount/reflectivity; 34 kinetic energy, J/(m² h);
    35 snow intensity (volume equivalent), mm/h; 60 all particles; 90/91 32 values per
    diameter class; 93 the 32 x 32 raw spectrum.

Two shapes arrive on the wire:

- the answer to ``CS/PA`` (polled): ``TYP OP4A`` then one ``NN:value`` line per value, CR LF,
  closed by ``<ETX><CR><LF>`` (cloudnetpy's ``_read_typ_op4a``). :class:`ParsivelFramer`
  gathers the lines of one answer into one frame; it ends at a blank or ETX line, at the
  next ``TYP`` or at the end of the file;
- a user telegram (automatic), one line of values separated by ``;`` in the order of the
  configured format string (option ``fields``). The default is what the Lindenberg logger
  writes (cloudnetpy's tests: ``19, 1, 2, 3, 7, 8, 9, 10, 11, 12, 13, 14, 16, 17, 18, 22,
  24, 25, 90, 91, 93``), where the leading ``YYYYMMDDhhmmss`` is the logger's timestamp
  (taken as UTC) rather than the sensor's value 19, whose own format is
  ``dd.mm.yyyy hh:mm:ss``. In that logger the spectrum (93) is one ``/``-separated field.

Loggers add a third: a CSV whose header line names the columns (pyAtmosLogger-style
``datetime_utc;rain rate [mm/h];...``, OTT's export ``Date;Time;Intensity of precipitation
(mm/h);...``, Campbell TOA5 tables with their four header lines). :class:`ParsivelFramer`
recognises a header line (three known names at least) and gives each row under it the value
numbers of its columns (``Frame.fields``), so no ``fields`` option is needed; unknown columns
(the 32 x 32 spectrum spread over 1024 columns...) are skipped. A spectrum written
``<SPECTRUM>`` then its values then ``</SPECTRUM>`` (the raining rows) is one value.

Sentinels (``-9.999``) become None. The reading's time is the frame's (logger or receive
time; the stamps read are in ``_LOGGER_PREFIX``, or a header CSV's time column), else the
sensor clock (values 21 + 20, in option ``timezone``, UTC by default). ``temperature_c`` is
value 12, the temperature in the sensor housing, not the air temperature. ``fault`` is True when the
sensor status (18) or the error code (25) is 2 or more (no usable measurement).
Factory serial settings: 19200 baud, 8N1 (RS-485).
"""

from __future__ import annotations

import csv
import datetime as dt
import re
from collections.abc import Sequence
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
    LineFramer,
    first_prefix,
    is_blank,
    regex_prefix,
    unix_prefix,
)

__all__ = ["DEFAULT_FIELDS", "DRIVER", "ParsivelFramer", "check_options", "parse"]

NAME = "ott-parsivel"
#: The Lindenberg logger's telegram after its timestamp prefix.
DEFAULT_FIELDS: tuple[int, ...] = (
    *(1, 2, 3, 7, 8, 9, 10, 11, 12, 13, 14, 16, 17, 18, 22, 24, 25),
    *(90, 91, 93),
)
DEFAULTS: dict[str, Any] = {
    "fields": DEFAULT_FIELDS,
    "separator": ";",
    "logger_prefix": True,
    "timezone": "UTC",
}

#: value number -> (kind, Reading field or extra key). Kinds: f float, i int, s text.
_VALUES: dict[int, tuple[str, str]] = {
    1: ("f", "rain_rate_mm_h"),
    2: ("f", "rain_accum_mm"),
    3: ("i", "wawa"),
    4: ("i", "ww"),
    5: ("s", "metar"),
    6: ("s", "nws_code"),
    7: ("f", "radar_reflectivity_dbz"),
    8: ("f", "visibility_m"),
    9: ("i", "sample_interval_s"),
    10: ("i", "laser_amplitude"),
    11: ("i", "particles"),
    12: ("f", "temperature_c"),
    13: ("s", "serial_number"),
    14: ("s", "firmware_iop"),
    15: ("s", "firmware_dsp"),
    16: ("f", "heating_current_a"),
    17: ("f", "supply_voltage_v"),
    18: ("i", "status"),
    19: ("s", "measuring_start"),
    20: ("s", "sensor_time"),
    21: ("s", "sensor_date"),
    22: ("s", "station_name"),
    23: ("s", "station_number"),
    24: ("f", "rain_amount_absolute_mm"),
    25: ("i", "error_code"),
    26: ("f", "temperature_pcb_c"),
    27: ("f", "temperature_right_head_c"),
    28: ("f", "temperature_left_head_c"),
    30: ("f", "rain_rate_16bit_mm_h"),
    31: ("f", "rain_rate_16bit_1200_mm_h"),
    32: ("f", "rain_accum_16bit_mm"),
    33: ("f", "radar_reflectivity_16bit_dbz"),
    34: ("f", "kinetic_energy_j_m2_h"),
    35: ("f", "snow_intensity_mm_h"),
    60: ("i", "particles_all"),
}
_VECTORS = {90: 32, 91: 32, 93: 1024}  # values per field; kept out of the reading
_READING_FIELDS = {"rain_rate_mm_h", "rain_accum_mm", "wawa", "metar", "nws_code"}
_READING_FIELDS |= {"visibility_m", "temperature_c"}
_SENTINEL = -9.999
_KEY_LINE = re.compile(r"(\d{2}):(.*)")
#: The logger stamps a Parsivel capture may carry, alone on a line or before a telegram.
_ISO = regex_prefix(PREFIX_ISO)
_LOGGER_PREFIX = first_prefix(
    regex_prefix(PREFIX_YMDHMS), _ISO, regex_prefix(PREFIX_TOA5), unix_prefix
)

#: Column codes of a header CSV besides value numbers: the logger's time, its record
#: number, a column the reading does not use.
TIME_COLUMN, RECORD_COLUMN, SKIP_COLUMN = -1, -2, 0
#: Column names that loggers write in a header line (pyAtmosLogger-style CSVs, Campbell TOA5
#: tables, OTT's ASDO export), lower case, without non-ASCII characters, -> value number.
_HEADER_NAMES: dict[str, int] = {
    name: num
    for num, names in {
        TIME_COLUMN: ("timestamp", "datetime_utc", "datetime [utc]", "datetime"),
        RECORD_COLUMN: ("record",),
        1: ("rain rate [mm/h]", "rainintensity", "rain_intensity",
            "intensity of precipitation (mm/h)", "intensity"),
        2: ("rain accum [mm]", "accprec", "precipitation since start (mm)",
            "accumulatedamount"),
        3: ("wawa", "weathercodewawa", "weather_code_wawa", "weather code synop wawa",
            "code4680"),
        4: ("wawa [ww]", "code4677"),
        5: ("wawa [metar]", "weather code metar/speci"),
        6: ("wawa [nws]", "weather code nws"),
        7: ("z [dbz]", "radarreflectivity", "radar_reflectivity", "radar reflectivity (dbz)"),
        8: ("mor visibility [m]", "morvisibility", "mor_visibility", "mor visibility (m)",
            "visibility"),
        9: ("sample interval [s]",),
        10: ("signal amplitude", "signalamplitude", "signal amplitude of laserband",
             "laseramplitude"),
        11: ("number of detected particles", "numberparticles", "number_particles",
             "numberofparticles"),
        12: ("temperature sensor [c]", "sensortemperature", "sensor_temperature",
             "temperature in sensor (c)", "temperature"),
        13: ("serial number",),
        14: ("iop firmware version",),
        15: ("dsp firmware version",),
        16: ("current heating system [a]", "heatingcurrent", "heating current (a)"),
        17: ("power supply voltage in the sensor [v]", "sensorvoltage", "sensor voltage (v)",
             "voltage"),
        18: ("sensor status", "sensorstatus", "optics status", "status"),
        20: ("sensor time [hh:mm:ss]", "time"),
        21: ("sensor date [dd.mm.yy]", "date"),
        22: ("station name",),
        23: ("station number",),
        24: ("rain amount absolute [mm]", "absoluteamount"),
        25: ("error code", "errorcode", "error"),
        26: ("temperature pcb [c]", "pbctemperature"),
        27: ("temperature right sensor head [c]", "righttemperature"),
        28: ("temperature left sensor head [c]", "lefttemperature"),
        34: ("kinetic energy [j m-2 h-1)]", "kineticenergy", "kinetic energy"),
        35: ("snow depth intensity (vol equiv.) [mm/h]", "snowintensity",
             "snow intensity (mm/h)"),
        60: ("number of particles",),
        93: ("spectrum",),
    }.items()
    for name in names
}  # fmt: skip
#: A line naming at least this many known columns is a header line.
_MIN_HEADER_NAMES = 3
_CONTROL = "".join(map(chr, range(33)))


def check_options(options: dict[str, Any]) -> dict[str, Any]:
    """``options`` with defaults; ConfigError naming the key when invalid.

    Keys: ``fields`` (the telegram's value numbers in order, default the Lindenberg
    logger's), ``separator`` (one character, ``;``), ``logger_prefix`` (bool: lines may
    start with a logger's timestamp), ``timezone`` (the sensor clock's zone, a name or hours
    from UTC such as ``-6``; default UTC).
    """
    out = with_defaults(options, DEFAULTS, NAME)
    fields = out["fields"]
    if isinstance(fields, str | bytes) or not isinstance(fields, Sequence) or not fields:
        raise ConfigError("options.fields: expected a non-empty list of value numbers")
    for num in fields:
        if isinstance(num, bool) or not isinstance(num, int):
            raise ConfigError(f"options.fields: {num!r} is not a value number")
        if num not in _VALUES and num not in _VECTORS:
            raise ConfigError(f"options.fields: value number {num} is not supported")
    out["fields"] = tuple(fields)
    sep = out["separator"]
    if not isinstance(sep, str) or len(sep) != 1 or sep in "\r\n/":
        raise ConfigError("options.separator: expected one character (not CR, LF or /)")
    if not isinstance(out["logger_prefix"], bool):
        raise ConfigError("options.logger_prefix: expected true or false")
    sensor_zone(out["timezone"])
    return out


class ParsivelFramer:
    """Lines, with the lines of one ``CS/PA`` answer gathered into one frame.

    A telegram line is a frame of its own (its logger timestamp, if any, in ``t_ns``). An
    answer starts with a ``TYP`` line and ends at a blank or ETX line, the next ``TYP``, a
    line that is not ``NN:value``, or :meth:`flush`; its frame is the lines joined by CR LF.
    """

    def __init__(self, *, logger_prefix: bool = True, max_line_bytes: int = 65536) -> None:
        self._lines = LineFramer(
            prefix=_LOGGER_PREFIX if logger_prefix else None,
            max_line_bytes=max_line_bytes,
            keep_blank=True,
            lstrip=_CONTROL.encode("ascii"),
        )
        self._block: list[Frame] = []
        self._blank_bytes = 0
        self._stamp: int | None = None  # a logger's stamp alone on a line: the next telegram's
        self._header: tuple[tuple[int, ...], str] | None = None  # a header line's columns
        self._skip = 0  # TOA5: the units and processing lines after the header
        self._toa5 = False

    @property
    def garbage_bytes(self) -> int:
        return self._lines.garbage_bytes + self._blank_bytes

    def feed(self, data: bytes) -> list[Frame]:
        return self._gather(self._lines.feed(data))

    def flush(self) -> list[Frame]:
        frames = self._gather(self._lines.flush())
        self._close_block(frames)
        return frames

    def _gather(self, lines: list[Frame]) -> list[Frame]:
        frames: list[Frame] = []
        for line in lines:
            text = line.data
            if self._skip and line.t_ns is None:
                self._skip -= 1  # header lines are neither frames nor garbage
                continue
            if line.t_ns is None and not self._block and self._header_line(text):
                continue
            if self._header is not None and not is_blank(text):
                frames.append(self._row(line))
                continue
            if is_blank(text):
                self._blank_bytes += len(line.data)
                self._close_block(frames)
                if line.t_ns is not None:  # ``[2024-01-14 00:00:00`` alone on its line
                    self._stamp = line.t_ns
            elif text.startswith(b"TYP") or (
                not self._block
                and self._stamp is not None
                and _KEY_LINE.match(text.decode("latin-1"))
            ):  # an answer, with or without its TYP line after a logger's stamp
                self._close_block(frames)
                self._block.append(self._stamped(line))
            elif self._block and _KEY_LINE.match(text.decode("latin-1")):
                self._block.append(line)
            else:
                self._close_block(frames)
                frames.append(self._stamped(line))
        return frames

    def _header_line(self, text: bytes) -> bool:
        """True when ``text`` is a TOA5 file's first line or a header line naming columns
        (then the rows that follow are read by their names)."""
        if text.startswith(b'"TOA5"'):
            self._toa5 = True
            return True
        line = text.decode("latin-1")
        sep = max(";,\t", key=line.count)
        names = [_header_name(name) for name in line.split(sep)]
        codes = [_HEADER_NAMES.get(name, SKIP_COLUMN) for name in names]
        if sum(code != SKIP_COLUMN for code in codes) < _MIN_HEADER_NAMES:
            return False
        if any(_KEY_LINE.fullmatch(name) or _NUMBER.fullmatch(name) for name in names):
            return False  # values, not names
        self._header = (tuple(codes), sep)
        self._skip = 2 if self._toa5 else 0
        return True

    def _row(self, line: Frame) -> Frame:
        """A row under a header line: its columns, less those the logger's stamp took."""
        assert self._header is not None
        codes, sep = self._header
        if line.t_ns is not None:
            while codes and codes[0] in (TIME_COLUMN, RECORD_COLUMN):
                codes = codes[1:]
        return Frame(line.data, line.t_ns, line.line, fields=codes, separator=sep)

    def _stamped(self, line: Frame) -> Frame:
        """``line`` with the pending logger stamp, when it has no time of its own."""
        stamp, self._stamp = self._stamp, None
        if line.t_ns is None and stamp is not None:
            return Frame(line.data, stamp, line.line)
        return line

    def _close_block(self, frames: list[Frame]) -> None:
        if self._block:
            first = self._block[0]
            data = b"\r\n".join(f.data for f in self._block)
            frames.append(Frame(data, first.t_ns, first.line))
            self._block = []


def make_framer(options: dict[str, Any]) -> ParsivelFramer:
    return ParsivelFramer(logger_prefix=bool(options.get("logger_prefix", True)))


def poll_command(options: dict[str, Any]) -> bytes:
    """``CS/PA`` + CR LF: ask for all measured values."""
    return b"CS/PA\r\n"


def parse(frame: Frame, options: dict[str, Any] | None = None) -> Reading:
    """A ``CS/PA`` answer or one user telegram to a :class:`Reading`.

    Raises
    ------
    ParseError : wrong number of values for the configured ``fields``, a value that is not
        a number where one is expected, non-ASCII bytes, an answer without values.
    """
    o = check_options(options or {})
    try:
        text = frame.data.decode("ascii")
    except UnicodeDecodeError:
        raise ParseError("non-ASCII bytes (noise, or a wrong baud rate)") from None
    head = text.lstrip(_CONTROL)
    t_ns = frame.t_ns
    if frame.fields is not None:  # a row under a header line: its columns are named
        sep = frame.separator or ";"
        (tokens,) = csv.reader([text.strip(_CONTROL)], delimiter=sep)  # "a,b" is one column
        raw = _telegram_values(sep.join(t.replace(sep, " ") for t in tokens), frame.fields, sep)
        if t_ns is None and TIME_COLUMN in raw:
            t_ns, _ = _ISO(raw[TIME_COLUMN].strip().encode("ascii") + b";")
            if t_ns is None:
                raise ParseError(f"time column: {raw[TIME_COLUMN][:25]!r} is not a date")
    elif head.startswith("TYP") or ("\n" in head and _KEY_LINE.match(head)):
        raw = _answer_values(text)  # with its TYP line, or without (a logger's layout)
    else:
        raw = _telegram_values(text, o["fields"], o["separator"])
    return _reading(raw, t_ns, o["timezone"])


def _header_name(name: str) -> str:
    """A column name as :data:`_HEADER_NAMES` spells it."""
    ascii_only = name.encode("ascii", "ignore").decode("ascii")
    return " ".join(ascii_only.strip().strip('"').lower().split())


_NUMBER = re.compile(r"[-+]?\d+([.,]\d*)?")


def _answer_values(text: str) -> dict[int, str]:
    raw: dict[int, str] = {}
    for line in text.splitlines():
        m = _KEY_LINE.match(line.strip(_CONTROL))
        if m is not None:
            raw[int(m.group(1))] = m.group(2)
    if not any(num in raw for num in _VALUES):
        raise ParseError("CS/PA answer without measured values")
    return raw


def _telegram_values(text: str, fields: Sequence[int], sep: str) -> dict[int, str]:
    tokens = text.strip(_CONTROL).split(sep)
    if tokens and tokens[-1].strip() == "":
        tokens.pop()  # the separator that ends a telegram
    need = sum(_VECTORS.get(num, 1) for num in fields)
    raw: dict[int, str] = {}
    i = 0
    for num in fields:
        if i >= len(tokens):
            raise ParseError(
                f"expected {need} values, got {len(tokens)} "
                f"(the telegram of {len(fields)} fields: options.fields or a header line)"
            )
        width = _width(num, tokens, i)
        raw[num] = sep.join(tokens[i : i + width])
        i += width
    if i != len(tokens):
        raise ParseError(f"expected {i} values, got {len(tokens)}")
    return raw


def _width(num: int, tokens: list[str], i: int) -> int:
    """Tokens taken by value ``num`` starting at ``tokens[i]``.

    The spectrum (93) is one ``/``-separated field, or ``<SPECTRUM>ZERO</SPECTRUM>``, or
    ``<SPECTRUM>`` then its values (empty for 0) up to the token ending ``</SPECTRUM>``: the
    rows where it rains.
    """
    first = tokens[i]
    if num == 93 and first.startswith("<SPECTRUM>"):
        for j in range(i, len(tokens)):
            if tokens[j].rstrip().endswith("</SPECTRUM>"):
                return j - i + 1
        raise ParseError("<SPECTRUM> without </SPECTRUM>: the telegram is cut")
    if num == 93 and "/" in first:
        return 1
    return _VECTORS.get(num, 1)


def _reading(raw: dict[int, str], t_ns: int | None, zone: Any = "UTC") -> Reading:
    values: dict[str, Any] = {}
    for num, text in raw.items():
        if num not in _VALUES:
            continue
        kind, key = _VALUES[num]
        values[key] = _convert(kind, text.strip(), num)
    for fallback, key in ((30, "rain_rate_mm_h"), (31, "rain_rate_mm_h"), (32, "rain_accum_mm")):
        if values.get(key) is None and fallback in raw:
            values[key] = values.get(_VALUES[fallback][1])
    rate = values.get("rain_rate_mm_h")
    if rate is not None and rate < 0:
        values["rain_rate_mm_h"] = None
    status = values.pop("status", None)
    error = values.get("error_code")
    codes = [c for c in (status, error) if c is not None]
    sensor_ns = _sensor_clock(values.get("sensor_date"), values.get("sensor_time"), zone)
    # The most trustworthy clock: the logger's (or the receiver's, live), else the sensor's.
    values["time_source"] = "sensor" if t_ns is None else "logger"
    if t_ns is None:
        t_ns = sensor_ns
    elif sensor_ns is not None:
        values["sensor_clock_offset_s"] = round((sensor_ns - t_ns) / 1e9, 3)
    own = {k: values.pop(k) for k in list(values) if k in _READING_FIELDS}
    if own.get("metar") == "NP":  # OTT's "no precipitation": "" as every driver says it
        own["metar"] = ""
    wawa = own.get("wawa")
    if wawa is not None and not 0 <= wawa <= 99:
        raise ParseError(f"field 03 (wawa): {wawa} is not a WMO 4680 code")
    return Reading(
        driver=NAME,
        t_ns=t_ns,
        status=None if status is None else str(status),
        fault=max(codes) >= 2 if codes else None,
        extra=values,
        **own,
    )


def _convert(kind: str, text: str, num: int) -> Any:
    if kind == "s":
        return text
    if text == "":
        return None
    try:
        value = float(text.replace(",", "."))
    except ValueError:
        raise ParseError(f"field {num:02d}: {text!r} is not a number") from None
    if value == _SENTINEL:
        return None
    if kind == "i":
        if not value.is_integer():
            raise ParseError(f"field {num:02d}: {text!r} is not an integer")
        return int(value)
    return value


#: The sensor's date (value 21) as sensors and loggers write it.
_DATE_FORMATS = ("%d.%m.%Y", "%d.%m.%y", "%Y/%m/%d", "%Y-%m-%d", "%d/%m/%Y")


def _sensor_clock(date: str | None, time: str | None, zone: Any = "UTC") -> int | None:
    """Values 21 + 20 in the sensor's zone, as UTC ns; None when absent or unreadable."""
    if not date or not time:
        return None
    for fmt in _DATE_FORMATS:
        try:
            t = dt.datetime.strptime(f"{date.strip()} {time.strip()}", f"{fmt} %H:%M:%S")
        except ValueError:
            continue
        return int(t.replace(tzinfo=sensor_zone(zone)).timestamp()) * 1_000_000_000
    return None


DRIVER = DriverSpec(
    name=NAME,
    make_framer=make_framer,
    parse=parse,
    serial=SerialDefaults(baudrate=19200, bytesize=8, parity="N", stopbits=1),
    modes=("automatic", "polled"),
    poll_command=poll_command,
    check_options=check_options,
    description="OTT Parsivel2: CS/PA answers (NN:value lines) or ';'-separated user "
    "telegrams in the order of options.fields, with or without a logger's stamp before "
    "them, or a CSV whose header line names the columns",
)
