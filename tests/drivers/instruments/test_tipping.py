"""Tipping bucket: debouncing, interval maths, the text capture and the line-polling reader."""

from __future__ import annotations

import itertools
import random
import threading
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.errors import ConfigError
from drivers.instruments import tipping
from drivers.instruments.base import Frame, ParseError
from drivers.instruments.tipping import (
    Debouncer,
    TipCaptureFramer,
    TippingBucketReader,
    bin_tips,
    check_options,
    debounce,
    parse,
)

MS = 1_000_000
S = 1_000_000_000
T0 = 1_700_000_040 * S  # a whole minute since the epoch
OPTIONS = check_options({})


# --- options ---------------------------------------------------------------------------------


def test_defaults():
    assert OPTIONS["line"] == "cts"
    assert OPTIONS["debounce_s"] == 0.05
    assert OPTIONS["mm_per_tip"] == 0.2
    assert OPTIONS["report_interval_s"] == 60.0


@pytest.mark.parametrize(
    ("options", "key"),
    [
        ({"line": "rts"}, "options.line"),
        ({"mm_per_tip": 0}, "options.mm_per_tip"),
        ({"mm_per_tip": "0.2"}, "options.mm_per_tip"),
        ({"debounce_s": -1}, "options.debounce_s"),
        ({"report_interval_s": 0}, "options.report_interval_s"),
        ({"edge": "both"}, "options.edge"),
        ({"colour": 1}, "options.colour"),
    ],
)
def test_bad_options_name_the_key(options, key):
    with pytest.raises(ConfigError, match=f"^{key}:"):
        check_options(options)


# --- debouncing ------------------------------------------------------------------------------


def train(start_ms: int, states: list[int], step_ms: int = 2) -> list[tuple[int, bool]]:
    return [(T0 + (start_ms + i * step_ms) * MS, bool(s)) for i, s in enumerate(states)]


def test_bounce_train_on_closing_and_release_counts_once():
    events = train(0, [0]) + train(100, [1, 0, 1, 0, 1, 0, 1]) + train(250, [0, 1, 0, 1, 0])
    assert debounce(events, debounce_s=0.05) == [T0 + 100 * MS]


def test_two_tips_apart_count_twice():
    events = train(0, [0]) + train(100, [1, 0, 1]) + train(300, [0]) + train(400, [1, 0, 1])
    assert debounce(events, debounce_s=0.05) == [T0 + 100 * MS, T0 + 400 * MS]


def test_edge_exactly_after_the_debounce_time_counts():
    events = [(T0, False), (T0 + 10 * MS, True), (T0 + 20 * MS, False), (T0 + 70 * MS, True)]
    assert debounce(events, debounce_s=0.05) == [T0 + 10 * MS, T0 + 70 * MS]
    events[-1] = (T0 + 70 * MS - 1, True)
    assert debounce(events, debounce_s=0.05) == [T0 + 10 * MS]


def test_initial_state_is_never_an_edge_and_falling_edges_can_be_chosen():
    events = [(T0, True), (T0 + S, False), (T0 + 2 * S, True), (T0 + 3 * S, False)]
    assert debounce(events, debounce_s=0.05) == [T0 + 2 * S]
    assert debounce(events, debounce_s=0.05, edge="falling") == [T0 + S, T0 + 3 * S]


def test_repeated_samples_of_the_same_state_are_not_edges():
    debouncer = Debouncer(debounce_s=0.05)
    fed = [debouncer.feed(T0 + i * 10 * MS, s) for i, s in enumerate([0, 0, 1, 1, 1, 0, 0])]
    assert fed == [False, False, True, False, False, False, False]


# --- intervals -------------------------------------------------------------------------------


def test_tip_on_a_border_belongs_to_the_next_interval():
    tips = [T0, T0 + 60 * S - 1, T0 + 60 * S, T0 + 120 * S]
    out = bin_tips(tips, start_ns=T0, end_ns=T0 + 180 * S, interval_s=60.0)
    assert [(iv.start_ns, iv.end_ns, iv.tips) for iv in out] == [
        (T0, T0 + 60 * S, 2),
        (T0 + 60 * S, T0 + 120 * S, 1),
        (T0 + 120 * S, T0 + 180 * S, 1),
    ]


def test_first_interval_is_partial_and_empty_intervals_are_reported():
    start = T0 + 45 * S
    out = bin_tips([start + S], start_ns=start, end_ns=T0 + 180 * S, interval_s=60.0)
    assert [(iv.start_ns, iv.end_ns, iv.tips) for iv in out] == [
        (start, T0 + 60 * S, 1),
        (T0 + 60 * S, T0 + 120 * S, 0),
        (T0 + 120 * S, T0 + 180 * S, 0),
    ]
    reading = parse(tipping.summary_frame(out[0], 1), OPTIONS)
    assert reading.rain_rate_mm_h == pytest.approx(0.2 * 3600 / 15)  # over 15 s, not 60


@settings(max_examples=100, deadline=None, derandomize=True)
@given(
    offsets_ms=st.lists(st.integers(0, 600_000), max_size=50),
    interval_s=st.sampled_from([1.0, 10.0, 60.0, 300.0]),
)
def test_binning_keeps_every_tip_in_its_interval(offsets_ms, interval_s):
    tips = [T0 + o * MS for o in offsets_ms]
    out = bin_tips(tips, start_ns=T0, end_ns=T0 + 600_001 * MS, interval_s=interval_s)
    assert sum(iv.tips for iv in out) == len(tips)
    for a, b in itertools.pairwise(out):
        assert a.end_ns == b.start_ns
    for t in tips:
        (owner,) = [iv for iv in out if iv.start_ns <= t < iv.end_ns]
        assert owner.tips >= 1


# --- parse -----------------------------------------------------------------------------------


def test_parse_summary():
    frame = Frame(f"interval start_ns={T0} end_ns={T0 + 60 * S} tips=3 total=10".encode())
    r = parse(frame, OPTIONS)
    assert r.t_ns == T0 + 60 * S
    assert r.rain_rate_mm_h == pytest.approx(3 * 0.2 * 60)
    assert r.to_json()["rain_rate_mm_h"] == 36.0  # as the counts give it, no float noise
    assert r.rain_accum_mm == pytest.approx(2.0)
    assert r.extra == {"tips": 3, "interval_s": 60.0}
    assert r.status == "ok" and r.fault is False


def test_parse_disconnected_interval_has_no_rate():
    frame = Frame(
        f"interval start_ns={T0} end_ns={T0 + 60 * S} tips=1 total=1 status=disconnected".encode()
    )
    r = parse(frame, OPTIONS)
    assert r.rain_rate_mm_h is None and r.fault is True and r.rain_accum_mm == pytest.approx(0.2)


@pytest.mark.parametrize("data", [b"", b"garbage", b"2024-05-14T10:00:00Z tip", b"\xff\x00"])
def test_parse_rejects_anything_else(data):
    with pytest.raises(ParseError):
        parse(Frame(data), OPTIONS)


# --- text captures ---------------------------------------------------------------------------

CAPTURE = b"""# tipping bucket on CTS, bounce included
2023-11-14T22:14:05.000Z CTS 0
2023-11-14T22:14:10.000Z CTS 1
2023-11-14T22:14:10.004Z CTS 0
2023-11-14T22:14:10.008Z CTS 1
2023-11-14T22:14:10.300Z CTS 0
2023-11-14T22:14:30Z tip
2023-11-14T22:14:31Z DSR 1
not a line at all
2023-11-14T22:15:00Z tip
2023-11-14T22:16:20.5+00:00 tip
"""


def decode(data: bytes, options: dict, chunks: list[int] | None = None):
    framer = TipCaptureFramer(options)
    frames: list[Frame] = []
    pos = 0
    for n in chunks or [len(data)]:
        frames += framer.feed(data[pos : pos + n])
        pos += n
    frames += framer.feed(data[pos:]) + framer.flush()
    out = []
    for frame in frames:
        try:
            out.append(parse(frame, options))
        except ParseError as exc:
            out.append((frame.line, str(exc)))
    return out


def test_capture_decodes_to_interval_readings_and_reports_bad_lines():
    out = decode(CAPTURE, OPTIONS)
    bad = [x for x in out if isinstance(x, tuple)]
    readings = [x for x in out if not isinstance(x, tuple)]
    assert [line for line, _ in bad] == [9]
    # 22:14:05 -> 22:15:00 (partial, 2 tips), 22:15 -> 22:16 (1), 22:16 -> 22:17 (1)
    assert [r.extra["tips"] for r in readings] == [2, 1, 1]
    assert [r.rain_accum_mm for r in readings] == pytest.approx([0.4, 0.6, 0.8])
    assert readings[0].extra["interval_s"] == pytest.approx(55.0)
    assert readings[1].rain_rate_mm_h == pytest.approx(0.2 * 60)
    assert readings[-1].to_json()["t"] == "2023-11-14T22:17:00Z"


def test_capture_is_independent_of_chunking():
    rng = random.Random(7)
    whole = decode(CAPTURE, OPTIONS)
    for _ in range(20):
        chunks = [rng.randint(1, 17) for _ in range(60)]
        assert decode(CAPTURE, OPTIONS, chunks) == whole


def test_capture_events_out_of_order_are_bad_lines():
    data = b"2023-11-14T22:14:30Z tip\n2023-11-14T22:14:20Z tip\n"
    out = decode(data, OPTIONS)
    assert isinstance(out[0], tuple) and out[0][0] == 2
    assert out[1].extra["tips"] == 1


# --- the live reader with a fake port ---------------------------------------------------------


class FakeClock:
    """UTC ns advancing 10 ms per call: one poll of the reader = 10 ms of fake time."""

    def __init__(self, t_ns: int = T0) -> None:
        self.t_ns = t_ns - 10 * MS
        self.lock = threading.Lock()

    def __call__(self) -> int:
        with self.lock:
            self.t_ns += 10 * MS
            return self.t_ns


class FakePort:
    """A port whose CTS follows a script, one state per read; fails after ``fail_after`` reads."""

    def __init__(self, states: list[int], fail_after: int | None = None) -> None:
        self.states = list(states)
        self.reads = 0
        self.fail_after = fail_after
        self.closed = False

    @property
    def cts(self) -> bool:
        if self.fail_after is not None and self.reads >= self.fail_after:
            raise OSError(5, "Input/output error")
        state = self.states[min(self.reads, len(self.states) - 1)]
        self.reads += 1
        return bool(state)

    def close(self) -> None:
        self.closed = True


def run_reader(opener, n_readings: int, **options):
    got: list = []
    reader = TippingBucketReader(
        "gauge",
        opener,
        options={"report_interval_s": 1.0, "poll_hz": 1e6, **options},
        on_frame=lambda frame, reading, error: got.append((frame, reading, error)),
        clock_ns=FakeClock(),
        backoff_initial_s=0.001,
        backoff_max_s=0.004,
    )
    reader.start()
    try:
        deadline = time.monotonic() + 20.0  # hang guard only, not a speed assertion
        while len(got) < n_readings and time.monotonic() < deadline:
            time.sleep(0.002)
    finally:
        reader.stop()
    assert len(got) >= n_readings
    return got, reader


def test_reader_counts_debounced_tips_per_interval():
    # 10 ms per sample: low, a 3-sample bounce train, low again, a clean second tip.
    states = [0] * 20 + [1, 0, 1] + [1] * 10 + [0] * 30 + [1] * 5 + [0] * 300
    port = FakePort(states)
    got, reader = run_reader(lambda: port, 2)
    frame, first, error = got[0]
    assert error is None
    assert first.extra["tips"] == 2
    assert first.rain_accum_mm == pytest.approx(0.4)
    assert first.rain_rate_mm_h == pytest.approx(0.4 * 3600)
    assert first.t_ns == T0 + S and frame.t_ns == T0 + S
    assert parse(frame, check_options({})) == first  # the raw frame decodes again
    second = got[1][1]
    assert second.extra["tips"] == 0 and second.rain_accum_mm == pytest.approx(0.4)
    stats = reader.stats()
    assert stats["tips"] == 2 and stats["readings"] >= 2 and stats["state"] == "stopped"
    assert port.closed


def test_reader_reconnects_with_backoff_and_flags_the_gap():
    ports = [FakePort([0] * 10 + [1] + [0] * 50, fail_after=50), None, None, FakePort([0])]

    def opener():
        port = ports.pop(0) if len(ports) > 1 else ports[0]
        if port is None:
            raise OSError(2, "No such file or directory")
        return port

    got, reader = run_reader(opener, 3)
    first = got[0][1]
    assert first.extra["tips"] == 1
    assert first.fault is True and first.status == "disconnected"
    assert first.rain_rate_mm_h is None
    assert first.rain_accum_mm == pytest.approx(0.2)
    stats = reader.stats()
    assert stats["reconnects"] == 1
    assert "No such file" in stats["last_error"]
    assert any(r.status == "ok" for _, r, _ in got[1:])


def test_reader_reads_the_configured_line():
    class DsrPort(FakePort):
        @property
        def dsr(self) -> bool:
            return FakePort.cts.fget(self)

        @property
        def cts(self) -> bool:  # must not be read
            raise AssertionError("read CTS instead of DSR")

    port = DsrPort([0] * 5 + [1] + [0] * 200)
    got, _ = run_reader(lambda: port, 1, line="dsr")
    assert got[0][1].extra["tips"] == 1


def test_driver_spec():
    assert tipping.DRIVER.name == "tipping-bucket"
    framer = tipping.DRIVER.make_framer(check_options({}))
    assert framer.feed(b"") == []
