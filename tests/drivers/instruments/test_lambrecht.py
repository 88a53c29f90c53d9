"""Lambrecht rain[e]: Lindenberg logger lines, the 22-column variant, t2/t3 telegrams."""

from __future__ import annotations

import random

import pytest

from drivers.errors import ConfigError
from drivers.instruments import lambrecht
from drivers.instruments.base import Frame, ParseError

FIXTURE = "instruments/lambrecht-raine/Lindenberg_RainE_20230514.txt"
LINE = (
    b"14.05.2023;00:05:39;1.250;0.512;0;9.25;11.31;1;0;0;60;2582;rain[e]H3;"
    b"Lindenberg      ;MF              ;ACTRIS       \r\n"
)


def t3(body: bytes = b"2024.05.14;10:00:00;1.234;12.345;0;5.00;6.00;1;0;LAMBRECHT meteo;"
       b"rain[e]H3;1.23;-1.50") -> bytes:  # fmt: skip
    data = b"\x02t3:" + body + b"*"
    return data + lambrecht.checksum(data).encode() + b"\r\n"


def readings_of(data: bytes, chunks: list[int] | None = None, options: dict | None = None):
    framer = lambrecht.make_framer({})
    frames: list[Frame] = []
    pos = 0
    for n in chunks or []:
        frames += framer.feed(data[pos : pos + n])
        pos += n
    frames += framer.feed(data[pos:]) + framer.flush()
    out = []
    for frame in frames:
        try:
            out.append(lambrecht.parse(frame, options))
        except ParseError as exc:
            out.append((frame.line, str(exc)))
    return out


def test_lindenberg_capture(shared_fixtures):
    readings = readings_of((shared_fixtures / FIXTURE).read_bytes())
    assert len(readings) == 18
    first, last = readings[0], readings[-1]
    assert first.to_json()["t"] == "2023-05-14T00:00:39Z"
    assert last.to_json()["t"] == "2023-05-14T00:17:39Z"
    assert first.rain_rate_mm_h == 0.0 and first.rain_accum_mm == 0.406
    assert first.extra["temperature_top_c"] == 9.56
    assert first.extra["temperature_bottom_c"] == 11.50
    assert first.extra["operating_hours"] == 2582
    assert first.extra["interval_s"] == 60
    assert first.extra["device_type"] == "rain[e]H3"
    assert first.status == "ok" and first.fault is False
    assert last.extra["temperature_top_c"] == 8.94


def test_timezone_option():
    utc = lambrecht.parse(Frame(LINE))
    berlin = lambrecht.parse(Frame(LINE), {"timezone": "Europe/Berlin"})
    assert utc.t_ns - berlin.t_ns == 2 * 3600 * 10**9  # CEST = UTC+2 in May
    assert utc.rain_rate_mm_h == 1.25 and utc.extra["heating"] == 1


def test_error_code_bits_and_system_status():
    line = LINE.replace(b";1;0;0;60;", b";1;6;4;60;")
    r = lambrecht.parse(Frame(line))
    assert r.status == "heating,interior_temperature_sensor,system=4"
    assert r.fault is True and r.extra["error_code"] == 6
    ok_but_system = lambrecht.parse(Frame(LINE.replace(b";1;0;0;60;", b";1;0;2;60;")))
    assert ok_but_system.status == "system=2" and ok_but_system.fault is False


def test_22_column_variant_uses_the_logger_utc_time():
    line = (
        b"2023-05-14 00:01:00;14.05.2023;02:00:39;0.120;3.500;0;9.50;11.44;0;0;0;60;2582;"
        b"rain[e]H3;a;b;c;d;12345;1.0;2.3;12.50*AB\r\n"
    )
    r = lambrecht.parse(Frame(line))
    assert r.to_json()["t"] == "2023-05-14T00:01:00Z"
    assert r.rain_accum_mm == 3.5 and r.rain_rate_mm_h == 0.12
    assert r.extra["serial_number"] == "12345"
    assert r.extra["outside_temperature_c"] == 12.5
    assert r.temperature_c == 12.5  # the reading's own temperature, as for a t3 telegram
    # the gauge's clock, 2 h ahead (CEST): the logger's dates the reading, both said
    assert r.extra["time_source"] == "logger"
    assert r.extra["sensor_clock_offset_s"] == 2 * 3600 - 21
    local = lambrecht.parse(Frame(line), {"timezone": "Europe/Berlin"})
    assert local.extra["sensor_clock_offset_s"] == -21


def test_t3_telegram_with_checksum():
    r = lambrecht.parse(Frame(t3()))
    assert r.to_json()["t"] == "2024-05-14T10:00:00Z"
    assert r.rain_rate_mm_h == 1.234 and r.rain_accum_mm == 12.345
    assert r.temperature_c == -1.5 and r.extra["heating"] == 1
    assert r.status == "ok" and r.fault is False
    assert r.extra["time_source"] == "sensor"


def test_t2_telegram_stopped_and_missing_outside_temperature():
    data = b"\x02t2:2024.05.14;10:00:00;0.000;12.345;1;5.00;6.00;0;16;/*"
    frame = Frame(data + lambrecht.checksum(data).encode() + b"\r\n")
    r = lambrecht.parse(frame)
    assert r.temperature_c is None
    assert r.status == "rtc_init,stopped" and r.fault is True


def test_checksum_of_the_manual_example():
    assert lambrecht.checksum(b"\x021234567890*") == "C7"


def test_bad_checksum():
    bad = t3().replace(b"12.345", b"12.346")
    with pytest.raises(ParseError, match="checksum mismatch"):
        lambrecht.parse(Frame(bad))


@pytest.mark.parametrize(
    ("line", "match"),
    [
        (b"14.05.2023;00:05:39;1.250;0.512;0", "field count"),
        (LINE.replace(b";1.250;", b";1,250;"), "not a number"),
        (LINE.replace(b"14.05.2023", b"32.05.2023"), "impossible date"),
        (LINE.replace(b"00:05:39", b"0:5:39"), "bad date"),
        (b"\x80\x9f\xfe\x01\x00\xfe;;;\x7f", "non-text"),
        (t3(b"2024.05.14;10:00:00;1.0;2.0;0;5;6;1;0;X;Y;1.23;-1.50;extra;more"), "field count"),
    ],
)
def test_bad_lines(line, match):
    with pytest.raises(ParseError, match=match):
        lambrecht.parse(Frame(line))


def test_negative_intensity_is_none():
    assert lambrecht.parse(Frame(LINE.replace(b";1.250;", b";-0.010;"))).rain_rate_mm_h is None


def test_split_and_merged_reads_with_power_up_garbage():
    rng = random.Random(15184)
    # Noise glued to the first line spoils that line only: it is reported, not fatal.
    stream = b"\x00\xff\x13garbage" + LINE + LINE.replace(b"00:05:39", b"00:06:39") + t3()
    whole = readings_of(stream)
    assert isinstance(whole[0], tuple) and whole[0][0] == 1
    assert [r.to_json()["t"] for r in whole[1:]] == [
        "2023-05-14T00:06:39Z",
        "2024-05-14T10:00:00Z",
    ]
    for _ in range(30):
        chunks = [rng.randint(1, 40) for _ in range(30)]
        assert readings_of(stream, chunks) == whole


def test_poll_command_and_spec():
    assert lambrecht.poll_command({}) == b"\x02USR3\r\n"
    assert lambrecht.poll_command({"telegram": 2}) == b"\x02USR2\r\n"
    assert lambrecht.DRIVER.serial.baudrate == 19200


@pytest.mark.parametrize(
    ("options", "key"),
    [
        ({"timezone": "Nowhere/City"}, "options.timezone"),
        ({"telegram": 4}, "options.telegram"),
        ({"tz": "UTC"}, "options.tz"),
    ],
)
def test_bad_options_name_the_key(options, key):
    with pytest.raises(ConfigError, match=f"^{key}:"):
        lambrecht.check_options(options)
