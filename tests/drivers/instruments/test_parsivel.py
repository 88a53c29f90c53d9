"""OTT Parsivel²: the real CS/PA answer and logger telegrams, crafted telegrams, framing."""

from __future__ import annotations

import datetime as dt

import pytest

from drivers.errors import ConfigError
from drivers.instruments import parsivel
from drivers.instruments.base import Frame, ParseError
from drivers.instruments.decode import DecodeStats, decode_chunks, decode_file

SPEC = parsivel.DRIVER
FIELDS = {"fields": [1, 2, 3, 5, 8, 12, 18, 25]}
ANSWER = (
    b"TYP OP4A\r\n01:0002.356\r\n02:0005.48\r\n03:61\r\n05:  -RA\r\n07:-9.999\r\n08:08134\r\n"
    b"12:013\r\n18:0\r\n20:22:18:04\r\n21:25.10.2023\r\n90:00.000;01.000;\r\n\x03\r\n\x00"
)


def _ns(*args: int) -> int:
    return int(dt.datetime(*args, tzinfo=dt.UTC).timestamp()) * 1_000_000_000


def parse(data: bytes, options: dict | None = None):
    return parsivel.parse(Frame(data), SPEC.check_options(options or {}))


def test_cs_pa_answer_capture(shared_fixtures) -> None:
    path = shared_fixtures / "instruments" / "ott-parsivel2"
    stats = DecodeStats()
    [r] = list(decode_file(SPEC, path / "bucharest_0000000123_20231025221800.txt", stats=stats))
    assert (stats.frames, stats.bad, stats.garbage_bytes) == (1, [], 2)  # ETX line, NUL
    assert r.rain_rate_mm_h == pytest.approx(2.356)
    assert r.rain_accum_mm == pytest.approx(5.48)
    assert (r.wawa, r.metar, r.nws_code) == (61, "-RA", "R-")
    assert r.visibility_m == 8134
    assert r.temperature_c == 13
    assert (r.status, r.fault) == ("0", False)
    assert r.t_ns == _ns(2023, 10, 25, 22, 18, 4)  # the sensor clock: no other time
    assert r.extra["radar_reflectivity_dbz"] == pytest.approx(30.787)
    assert r.extra["ww"] == 62 and r.extra["particles"] == 21
    assert r.extra["serial_number"] == "413259"


def test_lindenberg_logger_telegrams(shared_fixtures) -> None:
    path = shared_fixtures / "instruments" / "ott-parsivel2" / "Lindenberg_Parsivel_20231204.log"
    stats = DecodeStats()
    readings = list(decode_file(SPEC, path, stats=stats))
    assert (stats.readings, stats.bad) == (3, [])
    assert [r.t_ns for r in readings] == [_ns(2023, 12, 4, 0, m, 47) for m in range(3)]
    r = readings[0]
    assert (r.rain_rate_mm_h, r.rain_accum_mm, r.wawa) == (0.0, 58.68, 0)
    assert r.visibility_m == 20000
    assert r.temperature_c == -10
    assert (r.status, r.fault) == ("0", False)
    assert r.extra["radar_reflectivity_dbz"] is None  # -9.999: dry
    assert r.extra["serial_number"] == "451221"
    assert r.extra["station_name"] == "LINDENBERG"
    assert r.extra["laser_amplitude"] == 21922
    assert r.metar is None  # not in this telegram


def test_custom_telegram_without_prefix() -> None:
    r = parse(b"0000.123;0001.23;51;  -DZ;15000;005;1;000;", FIELDS)
    assert r.t_ns is None
    assert (r.rain_rate_mm_h, r.rain_accum_mm, r.wawa, r.metar) == (0.123, 1.23, 51, "-DZ")
    assert (r.visibility_m, r.temperature_c, r.status, r.fault) == (15000, 5, "1", False)


def test_semicolon_spectrum_and_zero_spectrum() -> None:
    options = {"fields": [1, 90, 91, 93]}
    vec = ";".join(["00.000"] * 32)
    full = f"0001.000;{vec};{vec};{';'.join(['000'] * 1024)};".encode()
    assert parse(full, options).rain_rate_mm_h == 1.0
    zero = f"0001.000;{vec};{vec};<SPECTRUM>ZERO</SPECTRUM>".encode()
    assert parse(zero, options).rain_rate_mm_h == 1.0
    with pytest.raises(ParseError, match="expected"):
        parse(full.replace(b"000;", b"", 1), options)


@pytest.mark.parametrize(
    ("status", "error", "fault"), [("0", "000", False), ("1", "001", False), ("2", "0", True)]
)
def test_status_and_error_code_fault(status: str, error: str, fault: bool) -> None:
    r = parse(f"0000.000;0000.00;00;;20000;010;{status};{error}".encode(), FIELDS)
    assert (r.status, r.fault) == (status, fault)
    assert parse(b"0.0;0.0;00;;20000;010;0;003", FIELDS).fault is True


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        (b"0000.000;0000.00;00;;20000;010;0", "expected 8 values, got 7"),
        (b"0000.000;0000.00;00;;20000;010;0;0;1;2", "expected 8 values, got 10"),
        (b"00x0.000;0000.00;00;;20000;010;0;0", "field 01"),
        (b"0000.000;0000.00;0.5;;20000;010;0;0", "field 03"),
        (b"0000.000;0000.00;00;;20000;010;0;0\xff\xfe", "non-ASCII"),
        (b"0000.000;0000.00;123;;20000;010;0;0", "WMO 4680"),
        (b"TYP OP4A\r\n\x03", "without measured values"),
    ],
)
def test_bad_telegrams_raise_parse_error(data: bytes, reason: str) -> None:
    with pytest.raises(ParseError, match=reason):
        parse(data, FIELDS)


def test_sentinels_and_negative_rates_become_none() -> None:
    r = parse(b"-9.999;-9.999;00;;20000;-9.999;0;0", FIELDS)
    assert r.rain_rate_mm_h is None and r.rain_accum_mm is None and r.temperature_c is None
    assert parse(b"-0.500;0;00;;20000;010;0;0", FIELDS).rain_rate_mm_h is None


def test_framer_groups_an_answer_and_keeps_telegrams_apart() -> None:
    telegram = b"20231204000047;0000.000;0058.68\r\n"
    stream = telegram + ANSWER + telegram + b"TYP OP4A\r\n01:0001.000\r\nTYP OP4A\r\n01:2\r\n"
    framer = parsivel.ParsivelFramer()
    frames = framer.feed(stream) + framer.flush()
    assert [f.data[:8] for f in frames] == [b"0000.000", b"TYP OP4A", b"0000.000"] + [
        b"TYP OP4A"
    ] * 2
    assert frames[1].line == 2 and frames[1].t_ns is None
    assert frames[1].data.count(b"\r\n") == 11
    assert frames[0].t_ns == _ns(2023, 12, 4, 0, 0, 47)
    assert framer.garbage_bytes == 2


@pytest.mark.parametrize("step", [1, 3, 17, 4096])
def test_answer_split_and_merged_reads(step: int) -> None:
    stream = ANSWER * 3
    chunks = [stream[i : i + step] for i in range(0, len(stream), step)]
    stats = DecodeStats()
    readings = list(decode_chunks(SPEC, chunks, stats=stats))
    assert len(readings) == 3 and stats.bad == []
    r = readings[0]
    assert (r.rain_rate_mm_h, r.wawa, r.metar, r.visibility_m) == (2.356, 61, "-RA", 8134)
    assert r.extra["radar_reflectivity_dbz"] is None
    assert r.t_ns == _ns(2023, 10, 25, 22, 18, 4)


def test_garbage_lines_are_counted_bad_and_valid_ones_kept() -> None:
    stream = b"\xff\xfe\x80garbage\r\n" + ANSWER + b"20231204000047;1;2\r\n"
    stats = DecodeStats()
    readings = list(decode_chunks(SPEC, [stream], stats=stats))
    assert len(readings) == 1
    assert [line for line, _ in stats.bad] == [1, 15]


def test_options_and_poll_command() -> None:
    assert parsivel.poll_command({}) == b"CS/PA\r\n"
    assert SPEC.check_options({})["fields"] == parsivel.DEFAULT_FIELDS
    for bad, key in [
        ({"speed": 1}, "options.speed"),
        ({"fields": []}, "options.fields"),
        ({"fields": [61]}, "options.fields"),
        ({"fields": "1,2"}, "options.fields"),
        ({"separator": ";;"}, "options.separator"),
        ({"logger_prefix": "yes"}, "options.logger_prefix"),
    ]:
        with pytest.raises(ConfigError, match=key):
            parsivel.check_options(bad)
    assert (SPEC.serial.baudrate, SPEC.serial.bytesize, SPEC.serial.parity) == (19200, 8, "N")


#: A CS/PA answer whose sensor clock (fields 20/21) reads 00:30:27 on 14.01.2024.
STAMPED = (
    b"01:0000.123\r\n02:0012.34\r\n03:88\r\n04:53\r\n05:-RA\r\n07:-9.999\r\n11:00042\r\n"
    b"12:021\r\n20:00:30:27\r\n21:14.01.2024\r\n"
)


def _decode(data: bytes) -> list[dict]:
    return [r.to_json() for r in decode_chunks(parsivel.DRIVER, [data], stats=DecodeStats())]


@pytest.mark.parametrize("typ", [b"", b"TYP OP4A\r\n"])
@pytest.mark.parametrize(
    "stamp",
    [
        b"[2024-01-14 00:00:00",
        b"2024-01-14 00:00:00",
        b"2024-01-14T00:00:00Z",
        b"2024/01/14 00:00:00",
    ],
)
def test_a_logger_stamp_on_its_own_line_dates_the_answer(stamp, typ):
    """The logger's clock, not the sensor's 30 min 27 s ahead, and the output says which."""
    readings = _decode((stamp + b"\r\n" + typ + STAMPED + b"\r\n") * 2)
    assert len(readings) == 2
    for r in readings:
        assert r["t"] == "2024-01-14T00:00:00Z"
        assert r["time_source"] == "logger"
        assert r["sensor_clock_offset_s"] == 30 * 60 + 27


def test_without_a_logger_the_sensor_clock_is_said():
    (reading,) = _decode(b"TYP OP4A\r\n" + STAMPED)
    assert reading["t"] == "2024-01-14T00:30:27Z" and reading["time_source"] == "sensor"


@pytest.mark.parametrize(
    ("prefix", "t"),
    [
        (b"20231204000047;", "2023-12-04T00:00:47Z"),
        (b"2023-12-04 00:00:47;", "2023-12-04T00:00:47Z"),
        (b"2023-12-04T00:00:47.250Z;", "2023-12-04T00:00:47.250000Z"),
        (b"[2023/12/04 00:00:47] ", "2023-12-04T00:00:47Z"),
    ],
)
def test_logger_prefixes_before_a_telegram(shared_fixtures, prefix, t):
    log = shared_fixtures / "instruments" / "ott-parsivel2" / "Lindenberg_Parsivel_20231204.log"
    first = log.read_bytes().splitlines()[0]
    assert first.startswith(b"20231204000047;")
    (reading,) = _decode(prefix + first[len(b"20231204000047;") :] + b"\r\n")
    (original,) = _decode(first + b"\r\n")
    assert reading["t"].replace(".250000", "") == original["t"] == "2023-12-04T00:00:47Z"
    assert reading["t"] == t and reading["time_source"] == "logger"
    assert reading["rain_rate_mm_h"] == original["rain_rate_mm_h"]


def test_no_precipitation_is_an_empty_metar_group():
    (reading,) = _decode(b"TYP OP4A\r\n" + STAMPED.replace(b"05:-RA", b"05:NP"))
    assert reading["metar"] == ""
