"""The ASCII regex driver: options checking, unit conversion, missing values, times, framing."""

from __future__ import annotations

import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.errors import ConfigError
from drivers.instruments import ascii_regex
from drivers.instruments.base import Frame, ParseError

PATTERN = (
    r"^(?P<time>\d{4}-\d\d-\d\d \d\d:\d\d:\d\d) R=(?P<rain>\S+) A=(?P<acc>\S+) "
    r"V=(?P<vis>\S+) T=(?P<temp>\S+) W=(?P<wawa>\S+) P=(?P<pw>\S*) S=(?P<st>\S+)$"
)
OPTIONS = ascii_regex.check_options(
    {
        "pattern": PATTERN,
        "fields": {
            "rain": "rain_rate_mm_h:in/h",
            "acc": "rain_accum_mm:in",
            "vis": "visibility_m:mi",
            "temp": "temperature_c:F",
            "wawa": "wawa",
            "pw": "metar",
            "st": "fault",
        },
        "time_format": "%Y-%m-%d %H:%M:%S",
        "timezone": "America/New_York",
        "missing": ["///", "-9999"],
    }
)
LINE = b"2024-01-15 07:00:00 R=0.10 A=1.5 V=2 T=32 W=61 P=-RA S=0\r\n"


def test_parse_converts_units_and_time():
    r = ascii_regex.parse(Frame(LINE), OPTIONS)
    assert r.to_json()["t"] == "2024-01-15T12:00:00Z"  # EST = UTC-5
    assert r.rain_rate_mm_h == pytest.approx(2.54)
    assert r.rain_accum_mm == pytest.approx(38.1)
    assert r.visibility_m == pytest.approx(3218.688)
    assert r.temperature_c == pytest.approx(0.0)
    assert r.wawa == 61 and r.metar == "-RA" and r.fault is False
    assert r.driver == "ascii-regex"


@pytest.mark.parametrize(
    ("spec", "value", "expected"),
    [
        ("visibility_m:km", "1.5", 1500.0),
        ("visibility_m:ft", "1000", 304.8),
        ("visibility_m:nmi", "1", 1852.0),
        ("visibility_m", "750", 750.0),
        ("rain_rate_mm_h:mm/min", "0.5", 30.0),
        ("snow_accum_mm:cm", "2.5", 25.0),
        ("temperature_c:K", "273.15", 0.0),
        ("temperature_c:f", "212", 100.0),
    ],
)
def test_units(spec, value, expected):
    target = spec.split(":")[0]
    options = ascii_regex.check_options({"pattern": r"x=(?P<x>\S+)", "fields": {"x": spec}})
    r = ascii_regex.parse(Frame(f"x={value}".encode()), options)
    assert getattr(r, target) == pytest.approx(expected)


def test_missing_values_text_and_numbers():
    line = b"2024-01-15 07:00:00 R=/// A=-9999.0 V=-9999 T=32 W=61 P= S=1"
    r = ascii_regex.parse(Frame(line), OPTIONS)
    assert r.rain_rate_mm_h is None and r.rain_accum_mm is None and r.visibility_m is None
    assert r.metar is None  # an empty group
    assert r.fault is True


def test_extra_fields_and_no_time_group_keeps_the_frame_time():
    options = ascii_regex.check_options(
        {
            "pattern": r"Q=(?P<q>\d+) H=(?P<h>[\d.]+) ID=(?P<id>\w+)",
            "fields": {"q": "extra.quality_pct", "h": "extra.height_m:ft", "id": "status"},
        }
    )
    r = ascii_regex.parse(Frame(b"Q=87 H=100 ID=ok", t_ns=123), options)
    assert r.t_ns == 123 and r.status == "ok"
    assert r.extra == {"quality_pct": 87.0, "height_m": pytest.approx(30.48)}


def test_iso_time_without_format():
    options = ascii_regex.check_options(
        {"pattern": r"(?P<time>\S+) (?P<r>\S+)", "fields": {"r": "rain_rate_mm_h"}}
    )
    r = ascii_regex.parse(Frame(b"2024-01-15T07:00:00.25+01:00 3.5"), options)
    assert r.to_json()["t"] == "2024-01-15T06:00:00.250000Z"


@pytest.mark.parametrize(
    ("line", "match"),
    [
        (b"hello", "does not match"),
        (LINE.replace(b"R=0.10", b"R=abc"), "rain: not a number"),
        (LINE.replace(b"W=61", b"W=100"), "WMO code"),
        (LINE.replace(b"S=0", b"S=maybe"), "st: not a number"),
        (LINE.replace(b"2024-01-15", b"2024-02-30"), "time"),
    ],
)
def test_bad_lines_are_parse_errors(line, match):
    with pytest.raises(ParseError, match=match):
        ascii_regex.parse(Frame(line), OPTIONS)


GOOD = {"pattern": r"(?P<r>\S+)", "fields": {"r": "rain_rate_mm_h"}}


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"pattern": None}, "options.pattern"),
        ({"pattern": "(unclosed"}, "options.pattern"),
        ({"pattern": r"(\S+)"}, "options.pattern"),
        ({"fields": {}}, "options.fields"),
        ({"fields": {"nope": "rain_rate_mm_h"}}, "options.fields.nope"),
        ({"fields": {"r": "rainfall"}}, "options.fields.r"),
        ({"fields": {"r": "rain_rate_mm_h:km"}}, "options.fields.r"),
        ({"fields": {"r": "extra.x:parsec"}}, "options.fields.r"),
        ({"fields": {"r": ["rain_rate_mm_h"]}}, "options"),
        ({"time_format": "%H"}, "options.time_format"),
        ({"timezone": "Atlantis/Capital"}, "options.timezone"),
        ({"missing": "///"}, "options.missing"),
        ({"line_ending": ""}, "options.line_ending"),
        ({"delimiter": ";"}, "options.delimiter"),
    ],
)
def test_bad_options_name_the_key(change, key):
    with pytest.raises(ConfigError, match=f"^{key}[:.]"):
        ascii_regex.check_options({**GOOD, **change})


def test_same_target_twice_is_an_error():
    options = {"pattern": r"(?P<a>\S+) (?P<b>\S+)", "fields": {"a": "wawa", "b": "wawa"}}
    with pytest.raises(ConfigError, match=r"^options\.fields\.b:"):
        ascii_regex.check_options(options)


def frames(options: dict, data: bytes, chunks: list[int]) -> list[Frame]:
    framer = ascii_regex.make_framer(options)
    out: list[Frame] = []
    pos = 0
    for n in chunks:
        out += framer.feed(data[pos : pos + n])
        pos += n
    return out + framer.feed(data[pos:]) + framer.flush()


@pytest.mark.parametrize("ending", ["auto", "crlf", "lf", "#"])
def test_line_endings_and_chunking(ending):
    sep = {"auto": "\r\n", "crlf": "\r\n", "lf": "\n", "#": "#"}[ending]
    options = ascii_regex.check_options({**GOOD, "line_ending": ending})
    data = sep.join(["1.5", "2.5", "", "3.5"]).encode() + sep.encode() + b"4.5"
    rng = random.Random(1)
    whole = [ascii_regex.parse(f, options).rain_rate_mm_h for f in frames(options, data, [])]
    assert whole == [1.5, 2.5, 3.5, 4.5]
    for _ in range(10):
        chunks = [rng.randint(1, 4) for _ in range(10)]
        got = [ascii_regex.parse(f, options).rain_rate_mm_h for f in frames(options, data, chunks)]
        assert got == whole


@settings(max_examples=100, deadline=None, derandomize=True)
@given(st.binary(max_size=200))
def test_arbitrary_bytes_never_crash(data):
    options = ascii_regex.check_options(
        {"pattern": r"R=(?P<r>\S+)", "fields": {"r": "rain_rate_mm_h:in/h"}, "line_ending": "lf"}
    )
    for frame in frames(options, data, []):
        try:
            r = ascii_regex.parse(frame, options)
        except ParseError:
            continue
        assert r.rain_rate_mm_h is None or isinstance(r.rain_rate_mm_h, float)
