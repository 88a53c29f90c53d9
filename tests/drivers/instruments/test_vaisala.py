"""Vaisala PWD/FD12P message 2 and 7: the real FD12P capture, raw frames, edge cases."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.errors import ConfigError, InputError
from drivers.instruments import vaisala
from drivers.instruments.base import Frame, ParseError
from drivers.instruments.decode import DecodeStats, decode_chunks, decode_file

SPEC = vaisala.DRIVER
BODY = b" 00  9163  9298   L   52   52   40  0.18  50.30  112"


def raw(body: bytes = BODY, unit: bytes = b" 1") -> bytes:
    return b"\x01PW " + unit + b"\x02" + body + b"\x03\r\n"


def parse(data: bytes):
    return vaisala.parse(Frame(data), SPEC.check_options({}))


def test_fd12p_logger_capture(shared_fixtures) -> None:
    path = shared_fixtures / "instruments" / "vaisala-fd12p" / "PW040406.DAT"
    stats = DecodeStats()
    readings = list(decode_file(SPEC, path, stats=stats))
    assert (stats.frames, stats.readings, stats.bad) == (3, 3, [])
    first = readings[0]
    assert first.t_ns == int(dt.datetime(2004, 4, 6, 5, 51, 21, tzinfo=dt.UTC).timestamp() * 1e9)
    assert first.visibility_m == 9163
    assert first.visibility_10min_m == 9298
    assert first.nws_code == "L"
    assert (first.wawa, first.wawa_15min, first.wawa_1h) == (52, 52, 40)
    assert first.rain_rate_mm_h == pytest.approx(0.18)
    assert first.rain_accum_mm == pytest.approx(50.30)
    assert first.snow_accum_mm == 112
    assert (first.status, first.fault) == ("00", False)
    assert first.extra["unit_id"] == "1"
    assert [r.rain_accum_mm for r in readings] == pytest.approx([50.30, 50.31, 50.31])
    assert readings[0].to_json()["t"] == "2004-04-06T05:51:21Z"


def test_raw_frame_around_the_same_body() -> None:
    r = parse(raw()[:-2])
    assert r.t_ns is None
    assert (r.visibility_m, r.wawa, r.rain_rate_mm_h, r.rain_accum_mm) == (9163, 52, 0.18, 50.30)
    assert r.extra["message"] == 2
    logger = parse(b"FD   100   9163   9298   L   52   52   40   0.18   50.30   112   ")
    assert logger == r
    separate = parse(b"PW 1 00 9163 9298 L 52 52 40 0.18 50.30 112")
    assert separate == r


def test_message_7_adds_temperature_and_luminance() -> None:
    r = parse(raw(b"00  6839  7505   R-   61   61   61  0.33  12.16     0  23.4  12345", b"AB"))
    assert r.temperature_c == pytest.approx(23.4)
    assert r.extra["background_luminance_cd_m2"] == 12345
    assert r.extra["message"] == 7 and r.extra["unit_id"] == "AB"
    assert (r.nws_code, r.wawa, r.snow_accum_mm) == ("R-", 61, 0)


def test_slashes_are_missing_values() -> None:
    r = parse(raw(b"00 ///// /////  /// // // //  ////  /////  ///"))
    assert r.visibility_m is None and r.visibility_10min_m is None
    assert r.nws_code is None and r.wawa is None and r.wawa_15min is None and r.wawa_1h is None
    assert r.rain_rate_mm_h is None and r.rain_accum_mm is None and r.snow_accum_mm is None


@pytest.mark.parametrize(
    ("status", "fault", "hardware", "alarm"),
    [
        ("00", False, "ok", 0),
        ("01", True, "hardware error", 0),
        ("02", False, "hardware warning", 0),
        ("13", True, "backscatter alarm", 1),
        ("04", False, "backscatter warning", 0),
        ("30", False, "ok", 3),
    ],
)
def test_status_digits(status: str, fault: bool, hardware: str, alarm: int) -> None:
    r = parse(raw(status.encode() + BODY[3:]))
    assert (r.status, r.fault) == (status, fault)
    assert r.extra["hardware_status"] == hardware
    assert r.extra["visibility_alarm"] == alarm


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        (raw(BODY.rsplit(b" ", 1)[0])[:-2], "got 9"),
        (raw(BODY.replace(b"9163", b"91x3"))[:-2], "not a number"),
        (raw(BODY.replace(b"  52   52", b" 152   52", 1))[:-2], "WMO 4680"),
        (raw(BODY.replace(b" 00 ", b" x0 "))[:-2], "two digits"),
        (raw(BODY.replace(b" L ", b" 7 "))[:-2], "NWS"),
        (b"\x01PW  1\x02" + BODY, "without ETX"),
        (b"\x01PW  1" + BODY, "without STX"),
        (b"\x01XX  1\x02" + BODY + b"\x03", "header"),
        (b"\x01PW  1\x02\xff\xfe" + BODY + b"\x03", "non-ASCII"),
        (b"hello world", "not a PWD"),
    ],
)
def test_bad_frames_raise_parse_error(data: bytes, reason: str) -> None:
    with pytest.raises(ParseError, match=reason):
        parse(data)


def test_water_sum_wrap_is_reported_as_is_and_no_rate_is_negative() -> None:
    sums = [b"99.98", b"99.99", b"0.01", b"0.03"]
    stream = b"".join(raw(BODY.replace(b"50.30", s)) for s in sums)
    stream += raw(BODY.replace(b" 0.18", b"-0.05"))
    readings = list(decode_chunks(SPEC, [stream]))
    assert [r.rain_accum_mm for r in readings] == pytest.approx([99.98, 99.99, 0.01, 0.03, 50.30])
    assert [r.rain_rate_mm_h for r in readings] == pytest.approx([0.18] * 4 + [None])


def test_power_up_garbage_and_wrong_baud_noise() -> None:
    rng = np.random.default_rng(7)
    noise = bytes(rng.integers(0x80, 0x100, 500, dtype=np.uint8))
    stream = b"\x00\xff\x13" + raw() + noise + b"\r\n" + noise[:40] + raw() + raw()
    stats = DecodeStats()
    readings = list(decode_chunks(SPEC, [stream], stats=stats))
    assert len(readings) == 3
    assert stats.readings == 3
    assert stats.garbage_bytes >= 3 + 40


@pytest.mark.parametrize("step", [1, 2, 3, 7, 64])
def test_split_and_merged_reads(step: int) -> None:
    stream = raw() + raw(BODY.replace(b"50.30", b"50.31")) + b"\r\n" + raw()
    chunks = [stream[i : i + step] for i in range(0, len(stream), step)]
    assert list(decode_chunks(SPEC, chunks)) == list(decode_chunks(SPEC, [stream]))
    assert len(list(decode_chunks(SPEC, chunks))) == 3


@settings(max_examples=100, deadline=None, derandomize=True)
@given(noise=st.binary(max_size=60), cut=st.integers(0, 200))
def test_noise_before_a_frame_on_the_same_line_is_dropped(noise: bytes, cut: int) -> None:
    noise = noise.replace(b"\r", b"").replace(b"\n", b"")
    stream = noise + raw()
    readings = list(decode_chunks(SPEC, [stream[:cut], stream[cut:]]))
    assert readings == [parse(raw()[:-2])]


def test_poll_command_and_options() -> None:
    assert vaisala.poll_command({}) == b"\r\x05PW 1 2\r"
    assert vaisala.poll_command({"unit_id": "A", "message": 7}) == b"\r\x05PW A 7\r"
    assert vaisala.poll_command({"device": "FD"}) == b"\r\x05FD 1 2\r"
    for bad, key in [
        ({"baud": 1}, "options.baud"),
        ({"unit_id": "ABC"}, "options.unit_id"),
        ({"message": 3}, "options.message"),
        ({"device": "XX"}, "options.device"),
    ]:
        with pytest.raises(ConfigError, match=key):
            vaisala.check_options(bad)
    assert (SPEC.serial.baudrate, SPEC.serial.bytesize, SPEC.serial.parity) == (9600, 7, "E")
    assert set(SPEC.modes) == {"automatic", "polled"}


def test_decode_file_errors_and_chunk_sizes(tmp_path) -> None:
    with pytest.raises(InputError, match=r"missing\.dat"):
        decode_file(SPEC, tmp_path / "missing.dat")
    path = tmp_path / "capture.bin"
    path.write_bytes(b"\xff" * 10 + raw() + b"garbage\r\n" + raw() * 3)
    small, large = DecodeStats(), DecodeStats()
    readings = list(decode_file(SPEC, path, stats=small, chunk_bytes=5))
    assert readings == list(decode_file(SPEC, path, stats=large))
    assert len(readings) == 4
    assert small == large
    assert small.bad == [(2, "not a PWD/FD12P message (no SOH, no PW/FD header)")]
    assert small.garbage_bytes == 10
