"""Framers: lines and delimited telegrams, split and merged reads, garbage, prefixes."""

from __future__ import annotations

import datetime as dt
import itertools

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from drivers.instruments.base import Frame
from drivers.instruments.framing import (
    PREFIX_DMY_HMS,
    PREFIX_YMDHMS,
    DelimitedFramer,
    LineFramer,
    is_blank,
    regex_prefix,
)

SETTINGS = settings(
    max_examples=150, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)


def _ns(*args: int) -> int:
    return int(dt.datetime(*args, tzinfo=dt.UTC).timestamp()) * 1_000_000_000


def _run(framer, chunks: list[bytes]) -> list[Frame]:
    frames: list[Frame] = []
    for chunk in chunks:
        frames += framer.feed(chunk)
    return frames + framer.flush()


def _split(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts})
    bounds = [0, *points, len(data)]
    return [data[a:b] for a, b in itertools.pairwise(bounds)]


# -- LineFramer -----------------------------------------------------------------------------
def test_line_framer_cr_lf_crlf_and_line_numbers() -> None:
    framer = LineFramer()
    frames = _run(framer, [b"one\r\ntwo\nthree\rfour"])
    assert [f.data for f in frames] == [b"one", b"two", b"three", b"four"]
    assert [f.line for f in frames] == [1, 2, 3, 4]
    assert all(f.t_ns is None for f in frames)


def test_line_framer_crlf_split_between_reads_counts_one_line() -> None:
    framer = LineFramer()
    assert [f.data for f in framer.feed(b"a\r")] == [b"a"]
    frames = framer.feed(b"\nb\r\n")
    assert [(f.data, f.line) for f in frames] == [(b"b", 2)]


def test_line_framer_blank_lines_are_garbage_unless_kept() -> None:
    framer = LineFramer()
    frames = _run(framer, [b"a\r\n\r\n \x03\x00\r\nb\r\n"])
    assert [f.data for f in frames] == [b"a", b"b"]
    assert framer.garbage_bytes == 3
    kept = _run(LineFramer(keep_blank=True), [b"a\r\n\r\nb"])
    assert [f.data for f in kept] == [b"a", b"", b"b"]
    assert is_blank(b" \x02\x03") and not is_blank(b" x ")


def test_line_framer_flush_gives_the_unterminated_last_line() -> None:
    framer = LineFramer()
    assert framer.feed(b"partial") == []
    assert [f.data for f in framer.flush()] == [b"partial"]
    assert framer.flush() == []


def test_line_framer_drops_over_long_lines_and_recovers() -> None:
    framer = LineFramer(max_line_bytes=10)
    frames = _run(framer, [b"x" * 7, b"y" * 7, b"z" * 5 + b"\r\nok\r\n"])
    assert [f.data for f in frames] == [b"ok"]
    assert framer.garbage_bytes == 19
    assert framer.dropped_lines == 1
    assert frames[0].line == 2


def test_line_framer_sync_byte_drops_leading_noise() -> None:
    framer = LineFramer(sync=b"\x01")
    frames = _run(framer, [b"\xff\xfe\x00\x01PW  1\x02body\x03\r\n"])
    assert [f.data for f in frames] == [b"\x01PW  1\x02body\x03"]
    assert framer.garbage_bytes == 3


def test_line_framer_lstrip_counts_garbage_before_the_prefix() -> None:
    framer = LineFramer(prefix=PREFIX_YMDHMS, lstrip=b"\x00\x03")
    frames = _run(framer, [b"\x03\r\n\x0020231204000047;x\r\n"])
    assert [(f.data, f.line, f.t_ns) for f in frames] == [(b"x", 2, _ns(2023, 12, 4, 0, 0, 47))]
    assert framer.garbage_bytes == 2


def test_prefix_ymdhms_gives_utc_time_and_strips_it() -> None:
    framer = LineFramer(prefix=PREFIX_YMDHMS)
    frames = _run(framer, [b"20231204000047;0000.000;0058.68\r\n0000.000;1\r\n"])
    assert frames[0].t_ns == _ns(2023, 12, 4, 0, 0, 47)
    assert frames[0].data == b"0000.000;0058.68"
    assert frames[1].t_ns is None and frames[1].data == b"0000.000;1"


def test_prefix_dmy_hms_fd12p_logger_line() -> None:
    line = b"06.04.2004   05:51:21   FD   100   9163   9298   L   52"
    t_ns, rest = regex_prefix(PREFIX_DMY_HMS)(line)
    assert t_ns == _ns(2004, 4, 6, 5, 51, 21)
    assert rest == b"FD   100   9163   9298   L   52"


def test_prefix_impossible_date_leaves_the_line_whole() -> None:
    line = b"20231304000047;1;2"
    assert regex_prefix(PREFIX_YMDHMS)(line) == (None, line)


def test_prefix_callable_fraction_and_keep() -> None:
    pattern = (
        r"(?P<year>\d{4})-(?P<month>\d\d)-(?P<day>\d\d)T(?P<hour>\d\d):(?P<minute>\d\d)"
        r":(?P<second>\d\d)\.(?P<fraction>\d+) "
    )
    parse = regex_prefix(pattern, strip=False)
    t_ns, rest = parse(b"2024-01-02T03:04:05.25 data")
    assert t_ns == _ns(2024, 1, 2, 3, 4, 5) + 250_000_000
    assert rest == b"2024-01-02T03:04:05.25 data"
    framer = LineFramer(prefix=lambda line: (7, line.upper()))
    assert _run(framer, [b"ab\n"]) == [Frame(b"AB", 7, 1)]


#: Streams rich in what matters to a line framer: terminators, sync, prefixes, long runs.
_LINE_STREAMS = st.lists(
    st.one_of(
        st.sampled_from([b"\r", b"\n", b"\r\n", b"\0", b"\x01PW", b"20231204000047;", b"x" * 45]),
        st.binary(max_size=8),
    ),
    max_size=40,
).map(b"".join)


@SETTINGS
@given(data=_LINE_STREAMS, cuts=st.lists(st.integers(0, 10_000), max_size=12))
@example(data=b"a\r\nb\r\n", cuts=[2])
def test_line_framer_any_split_gives_the_same_frames(data: bytes, cuts: list[int]) -> None:
    options = {"max_line_bytes": 40, "sync": b"\x01", "prefix": PREFIX_YMDHMS, "lstrip": b"\0"}
    whole = LineFramer(**options)
    split = LineFramer(**options)
    assert _run(split, _split(data, cuts)) == _run(whole, [data])
    assert split.garbage_bytes == whole.garbage_bytes


_TEXT = st.binary(min_size=1, max_size=30)
_VALID = st.from_regex(rb"\A[A-Z0-9;.]{1,20}\Z")


@SETTINGS
@given(
    valid=st.lists(_VALID, min_size=1, max_size=8),
    garbage=st.lists(st.one_of(_TEXT, st.binary(min_size=50, max_size=80)), max_size=8),
    ends=st.lists(st.sampled_from([b"\r\n", b"\n", b"\r"]), min_size=16, max_size=16),
    cuts=st.lists(st.integers(0, 600), max_size=10),
)
def test_line_framer_garbage_lines_never_lose_a_valid_line(
    valid: list[bytes], garbage: list[bytes], ends: list[bytes], cuts: list[int]
) -> None:
    garbage = [g.replace(b"\r", b"").replace(b"\n", b"") or b"?" for g in garbage]
    stream = b""
    for i, line in enumerate(valid):
        if i < len(garbage):
            stream += garbage[i] + ends[i]
        stream += line + ends[8 + i]
    frames = _run(LineFramer(max_line_bytes=40), _split(stream, cuts))
    got = iter(f.data for f in frames)
    assert all(any(line == g for g in got) for line in valid)  # an ordered subsequence


# -- DelimitedFramer ------------------------------------------------------------------------
def test_delimited_framer_frames_and_garbage() -> None:
    framer = DelimitedFramer()
    frames = _run(framer, [b"noise\x02one\x03\r\n\x02two\x03"])
    assert [f.data for f in frames] == [b"\x02one\x03", b"\x02two\x03"]
    assert framer.garbage_bytes == len(b"noise") + 2


def test_delimited_framer_tolerates_etx_first_and_resyncs_on_stx() -> None:
    framer = DelimitedFramer()
    frames = _run(framer, [b"\x03\x02cut off\x02whole\x03\x03"])
    assert [f.data for f in frames] == [b"\x02whole\x03"]
    assert framer.dropped_frames == 1
    assert framer.garbage_bytes == 1 + len(b"\x02cut off") + 1


def test_delimited_framer_line_numbers_and_flush_partial() -> None:
    stream = b"\x03\x02a;\n\x03\x02b;\n\x03\x02c;\n"
    strict = DelimitedFramer()
    frames = _run(strict, [stream])
    assert [(f.data, f.line) for f in frames] == [(b"\x02a;\n\x03", 1), (b"\x02b;\n\x03", 2)]
    assert strict.garbage_bytes == 1 + 4
    lenient = _run(DelimitedFramer(flush_partial=True), [stream])
    assert [(f.data, f.line) for f in lenient][-1] == (b"\x02c;\n", 3)


def test_delimited_framer_drops_over_long_telegrams() -> None:
    framer = DelimitedFramer(max_frame_bytes=8)
    frames = _run(framer, [b"\x02" + b"x" * 20, b"\x03\x02ok\x03"])
    assert [f.data for f in frames] == [b"\x02ok\x03"]
    assert framer.dropped_frames == 1


def test_delimited_framer_multibyte_delimiters_split_anywhere() -> None:
    stream = b"zz<<a>>z<<b>><"
    for cut in range(len(stream) + 1):
        frames = _run(DelimitedFramer(b"<<", b">>"), [stream[:cut], stream[cut:]])
        assert [f.data for f in frames] == [b"<<a>>", b"<<b>>"]


#: Streams rich in STX, ETX and runs longer than the framers' limit in the tests (30 bytes).
_DELIMITED_STREAMS = st.lists(
    st.one_of(st.sampled_from([b"\x02", b"\x03", b"y" * 20]), st.binary(max_size=8)),
    max_size=40,
).map(b"".join)


@SETTINGS
@given(
    data=_DELIMITED_STREAMS,
    cuts=st.lists(st.integers(0, 10_000), max_size=12),
)
@example(data=b"\x02" + b"y" * 40 + b"\x03", cuts=[35])
def test_delimited_framer_any_split_gives_the_same_frames(data: bytes, cuts: list[int]) -> None:
    whole = DelimitedFramer(max_frame_bytes=30, flush_partial=True)
    split = DelimitedFramer(max_frame_bytes=30, flush_partial=True)
    assert _run(split, _split(data, cuts)) == _run(whole, [data])
    assert split.garbage_bytes == whole.garbage_bytes
    assert split.dropped_frames == whole.dropped_frames


_BODY = st.binary(max_size=20).filter(lambda b: b"\x02" not in b and b"\x03" not in b)


@SETTINGS
@given(
    bodies=st.lists(_BODY, min_size=1, max_size=6),
    garbage=st.lists(st.binary(max_size=25), min_size=7, max_size=7),
    no=st.sampled_from([b"\x02", b"\x03"]),
    cuts=st.lists(st.integers(0, 400), max_size=10),
)
def test_delimited_framer_garbage_between_frames_never_loses_a_frame(
    bodies: list[bytes], garbage: list[bytes], no: bytes, cuts: list[int]
) -> None:
    """Garbage without end bytes, or without start bytes, between frames loses none."""
    garbage = [g.replace(no, b"") for g in garbage]
    valid = [b"\x02" + body + b"\x03" for body in bodies]
    stream = b"".join(g + v for g, v in zip(garbage, valid, strict=False)) + garbage[-1]
    frames = _run(DelimitedFramer(), _split(stream, cuts))
    got = iter(f.data for f in frames)
    assert all(any(v == g for g in got) for v in valid)


def test_delimited_framer_rejects_bad_delimiters() -> None:
    with pytest.raises(ValueError):
        DelimitedFramer(b"\x02", b"\x02")
    with pytest.raises(ValueError):
        LineFramer(max_line_bytes=0)
