"""Thies LNM telegram 4: the Leipzig capture, checksums, field counts, garbage, chunking."""

from __future__ import annotations

import random

import pytest

from drivers.errors import ConfigError
from drivers.instruments import thies
from drivers.instruments.base import Frame, ParseError

FIXTURE = "instruments/thies-lnm/2024041723-leipzig-lim.txt"

#: Columns 2...80 of a telegram 4 in moderate rain (index = manual column - 2).
HEAD = (
    "00;0747;2.50;14.05.24;10:31:00;61;61;RA   ;004.512;61;61;-RA  ;002.345;002.300;000.045;"
    "0012.34;05230;23.1;100;0.0;0;0;0;0;0;0;0;0;0;0;0;0;0;0;0;0;021;035;0152;04010;04567;"
    "240;0000;0000;012.5;240;0000;0000;0000;00123;00000.000;00001;00000.000;00000;"
    "00000.000;00002;00000.000;00000;00000.000;00003;00000.000;00120;00001.234;00000;"
    "00000.000;00000;00000.000;00000;00000.000;00000;00000.000;00000;00000.000;00000;"
    "00000.000;00000;00000.000;00000;00000.000"
)


def telegram(head: str = HEAD, *, spectrum: bool = True, cs: str | None = "auto", tail=";"):
    """STX telegram CR LF ETX, with the spectrum and a checksum computed over STX...';'."""
    body = "\x02" + head + ";"
    if spectrum:
        body += ";".join(["000"] * 440) + ";"
    data = body.encode("ascii")
    if cs == "auto":
        cs = thies.checksum(data)
    if cs is not None:
        data += cs.encode("ascii") + tail.encode("ascii")
    return data + b"\r\n\x03"


def frames_of(data: bytes, chunks: list[int] | None = None) -> tuple[list[Frame], int]:
    framer = thies.make_framer({})
    out: list[Frame] = []
    pos = 0
    for n in chunks or []:
        out += framer.feed(data[pos : pos + n])
        pos += n
    out += framer.feed(data[pos:]) + framer.flush()
    return out, framer.garbage_bytes


def test_leipzig_capture(shared_fixtures):
    data = (shared_fixtures / FIXTURE).read_bytes()
    frames, garbage = frames_of(data)
    assert garbage == 1  # the ETX of the telegram before the file starts
    readings = [thies.parse(f, {}) for f in frames]
    assert [r.to_json()["t"] for r in readings] == [
        "2024-04-17T23:00:50Z",
        "2024-04-17T23:01:50Z",
        "2024-04-17T23:02:50Z",
    ]
    r = readings[0]
    assert r.rain_rate_mm_h == 0.0 and r.rain_accum_mm == 87.76
    assert r.wawa == 0 and r.metar == ""
    assert r.visibility_m is None  # 99999: not reduced by precipitation
    assert r.status == "ok" and r.fault is False
    assert r.extra["serial_number"] == "0747" and r.extra["quality_pct"] == 100.0
    assert r.extra["reflectivity_dbz"] is None  # -9.9
    assert r.temperature_c is None  # the logger kept columns 2...23 only


def test_full_telegram_with_checksum():
    r = thies.parse(Frame(telegram()), {})
    assert r.to_json()["t"] == "2024-05-14T10:31:00Z"
    assert r.wawa == 61 and r.metar == "-RA"
    assert r.rain_rate_mm_h == pytest.approx(2.345)
    assert r.rain_accum_mm == pytest.approx(12.34)
    assert r.visibility_m == 5230.0
    assert r.temperature_c == pytest.approx(12.5)
    assert r.extra["rain_rate_solid_mm_h"] == pytest.approx(0.045)
    assert r.extra["ww"] == 61 and r.extra["metar_5min"] == "RA"
    assert r.extra["n_particles"] == 123
    assert r.status == "ok" and r.fault is False


@pytest.mark.parametrize("tail", [";", ""])
def test_checksum_after_the_last_field_with_or_without_separator(tail):
    assert thies.parse(Frame(telegram(tail=tail)), {}).wawa == 61


def test_checksum_over_the_whole_frame_is_accepted_too():
    data = telegram(cs=None)[:-3]  # STX ... last spectrum value;
    whole = data + b"00;\r\n\x03"
    cs = thies.checksum(data + b";\r\n\x03")
    assert thies.parse(Frame(data + cs.encode() + b";\r\n\x03"), {}).wawa == 61
    with pytest.raises(ParseError, match="checksum"):
        thies.parse(Frame(whole.replace(b"00;\r\n", b"ZZ;\r\n")), {})


def test_bad_checksum_is_a_parse_error():
    good = telegram()
    bad = good.replace(b"002.345", b"002.346")
    with pytest.raises(ParseError, match="checksum mismatch"):
        thies.parse(Frame(bad), {})
    assert thies.parse(Frame(bad), {"checksum": "ignore"}).rain_rate_mm_h == pytest.approx(2.346)


def test_checksum_arithmetic_of_the_manual_example():
    # "Summe dezimal 64800 -> Zweierkomplement F02E0 -> E0"
    data = b"\xff" * 254 + bytes([64800 - 254 * 255])
    assert sum(data) == 64800
    assert thies.checksum(data) == "E0"


def test_required_checksum_missing():
    with pytest.raises(ParseError, match="no checksum"):
        thies.parse(Frame(telegram(spectrum=False, cs=None)), {"checksum": "require"})


def test_status_fields():
    laser_off = HEAD.replace(";0.0;0;0;0;0;", ";0.0;1;0;0;0;", 1)
    r = thies.parse(Frame(telegram(laser_off)), {})
    assert r.status == "laser_off" and r.fault is True
    fields = HEAD.split(";")
    fields[31] = "1"  # heating of the housing: a warning
    r = thies.parse(Frame(telegram(";".join(fields))), {})
    assert r.status == "heating_housing" and r.fault is False


@pytest.mark.parametrize("n", [5, 16, 80, 300, 518, 530])
def test_wrong_field_counts(n):
    values = (HEAD.split(";") + ["000"] * 600)[:n]
    with pytest.raises(ParseError, match="field count"):
        thies.parse(Frame(("\x02" + ";".join(values) + ";\r\n\x03").encode()), {})


def test_exact_field_count_option():
    short = telegram(HEAD, spectrum=False, cs=None)
    assert thies.parse(Frame(short), {"n_fields": 79}).wawa == 61
    with pytest.raises(ParseError, match="n_fields"):
        thies.parse(Frame(short), {"n_fields": 22})


@pytest.mark.parametrize(
    "data",
    [
        b"\x02\x9f\xe3\x80;\xfe\xff\x00\x03",  # wrong baud rate
        b"\x02" + b"XX;0747;2.50;14.05.24;10:31:00" + b";00" * 20 + b"\x03",  # bad address
        b"\x02" + HEAD.replace("14.05.24", "31.02.24").encode() + b";\r\n\x03",  # 31 February
        b"\x02" + HEAD.replace("10:31:00", "1031").encode() + b";\r\n\x03",
        b"\x02" + HEAD.replace("002.345", "2.3x5").encode() + b";\r\n\x03",
    ],
)
def test_garbage_is_a_parse_error(data):
    with pytest.raises(ParseError):
        thies.parse(Frame(data), {})


def test_missing_values_become_none():
    fields = HEAD.split(";")
    fields[12] = "/////"
    r = thies.parse(Frame(telegram(";".join(fields), spectrum=False, cs=None)), {})
    assert r.rain_rate_mm_h is None


def test_stream_with_power_up_garbage_split_and_merged_reads():
    rng = random.Random(4680)
    noise = bytes(rng.randrange(256) for _ in range(300)).replace(b"\x02", b"\x01")
    stream = noise + telegram() + telegram(HEAD.replace("10:31:00", "10:32:00")) + b"\x03\x7f"
    whole, garbage = frames_of(stream)
    assert len(whole) == 2 and garbage >= 300
    for _ in range(30):
        chunks = [rng.randint(1, 200) for _ in range(40)]
        assert frames_of(stream, chunks)[0] == whole
    times = [thies.parse(f, {}).to_json()["t"] for f in whole]
    assert times == ["2024-05-14T10:31:00Z", "2024-05-14T10:32:00Z"]


def test_timezone_and_receiver_clock():
    frame = Frame(telegram(), t_ns=1_715_682_000_000_000_000)  # 2024-05-14T10:20:00Z
    local = thies.parse(frame, {"timezone": "Europe/Berlin", "clock": "instrument"})
    assert local.to_json()["t"] == "2024-05-14T08:31:00Z"
    assert thies.parse(Frame(telegram()), {"timezone": -6}).to_json()["t"] == (
        "2024-05-14T16:31:00Z"
    )
    assert thies.parse(frame, {"clock": "receiver"}).t_ns == frame.t_ns
    auto = thies.parse(frame, {"timezone": "Europe/Berlin"}).to_json()
    assert auto["t"] == "2024-05-14T10:20:00Z" and auto["time_source"] == "logger"
    assert auto["sensor_clock_offset_s"] == -(60 + 49) * 60


def test_poll_command():
    assert thies.poll_command({}) == b"00TR00004\r"
    assert thies.poll_command({"device_id": 7, "telegram": 5}) == b"07TR00005\r"
    assert thies.DRIVER.poll_command is thies.poll_command
    assert "polled" in thies.DRIVER.modes


@pytest.mark.parametrize(
    ("options", "key"),
    [
        ({"device_id": 100}, "options.device_id"),
        ({"telegram": "4"}, "options.telegram"),
        ({"checksum": "maybe"}, "options.checksum"),
        ({"timezone": "Mars/Olympus"}, "options.timezone"),
        ({"n_fields": 3}, "options.n_fields"),
        ({"baud": 9600}, "options.baud"),
    ],
)
def test_bad_options_name_the_key(options, key):
    with pytest.raises(ConfigError, match=f"^{key}:"):
        thies.check_options(options)


@pytest.mark.parametrize("eol", [b"\r\n", b"\n"])
def test_one_telegram_a_line_without_stx_and_etx(eol):
    """A logger that strips the control characters writes one telegram a line."""
    framed = [telegram(), telegram(HEAD.replace("10:31:00", "10:32:00"))]
    lines = b"".join(t.strip(b"\x02\x03\r\n") + eol for t in framed)
    whole, garbage = frames_of(lines)
    assert len(whole) == 2 and garbage == 0
    rng = random.Random(7)
    for _ in range(20):
        chunks = [rng.randint(1, 300) for _ in range(30)]
        assert frames_of(lines, chunks)[0] == whole
    for line, stx in zip(whole, framed, strict=True):  # the same readings, checksums included
        ours, theirs = thies.parse(line, {}).to_json(), thies.parse(Frame(stx), {}).to_json()
        assert {k: v for k, v in ours.items() if k != "raw"} == {
            k: v for k, v in theirs.items() if k != "raw"
        }


def test_power_up_noise_with_semicolons_does_not_look_like_a_telegram():
    stream = b"x;y;\r\n\x7f;;\n" + telegram()
    whole, _ = frames_of(stream)
    assert len(whole) == 1 and whole[0].data.startswith(b"\x02")


def test_leipzig_capture_with_stx_and_etx_stripped(shared_fixtures, tmp_path):
    from drivers.instruments import DRIVERS
    from drivers.instruments.decode import DecodeStats, decode_file

    original = shared_fixtures / "instruments" / "thies-lnm" / "2024041723-leipzig-lim.txt"
    stripped = tmp_path / "lines.txt"
    stripped.write_bytes(original.read_bytes().replace(b"\x02", b"").replace(b"\x03", b""))
    got = {}
    for path in (original, stripped):
        stats = DecodeStats()
        readings = list(decode_file(DRIVERS["thies-lnm"], path, stats=stats))
        got[path.name] = ([r.to_json()["t"] for r in readings], len(stats.bad))
    assert got["lines.txt"] == got[original.name] and got["lines.txt"][0]
