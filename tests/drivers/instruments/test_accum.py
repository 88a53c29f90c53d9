"""Counter -> per-interval amounts: wraps, resets, gaps, and a Hypothesis sum property."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.instruments.accum import AccumulationTracker, accum_delta

S = 1_000_000_000  # ns per second
T0 = 1_700_000_000 * S


def feed(tracker: AccumulationTracker, values: list[float | None], dt_s: float = 60.0):
    return [tracker.update(T0 + round(i * dt_s * S), v) for i, v in enumerate(values)]


def test_increase_gives_the_difference_and_first_reading_is_unknown():
    out = feed(AccumulationTracker(), [1.0, 1.2, 1.2, 1.7])
    assert out[0] is None
    assert out[1:] == pytest.approx([0.2, 0.0, 0.5])


def test_wrap_gives_the_positive_amount():
    out = feed(AccumulationTracker(wrap_at_mm=100.0), [99.9, 99.99, 0.12, 0.5])
    assert out[1:] == pytest.approx([0.09, 0.13, 0.38])


def test_drop_without_wrap_range_is_a_reset():
    tracker = AccumulationTracker()
    out = feed(tracker, [5.0, 5.4, 0.0, 0.3])
    assert out[2] is None
    assert out[3] == pytest.approx(0.3)
    assert tracker.resets == 1


def test_large_drop_with_wrap_range_is_a_reset_not_a_wrap():
    # 60 -> 2 would be a 42 mm "wrap" (> half the range): a reset.
    out = feed(AccumulationTracker(wrap_at_mm=100.0), [60.0, 2.0, 2.5])
    assert out[1] is None
    assert out[2] == pytest.approx(0.5)


def test_power_cycle_to_zero_is_a_reset_by_the_rate_bound():
    # 87.76 -> 0 with a 100 mm range: 12.24 mm in one minute is beyond 400 mm/h.
    out = feed(AccumulationTracker(wrap_at_mm=100.0), [87.76, 0.0])
    assert out[1] is None
    # Without the rate bound only the half-range rule is left and the wrap is accepted.
    out = feed(AccumulationTracker(wrap_at_mm=100.0, max_rate_mm_h=None), [87.76, 0.0])
    assert out[1] == pytest.approx(12.24)


def test_gap_longer_than_max_gap_gives_none_and_restarts():
    tracker = AccumulationTracker(max_gap_s=600.0)
    assert tracker.update(T0, 1.0) is None
    assert tracker.update(T0 + 601 * S, 3.0) is None
    assert tracker.update(T0 + 661 * S, 3.5) == pytest.approx(0.5)


def test_time_going_back_gives_none():
    tracker = AccumulationTracker()
    tracker.update(T0, 1.0)
    assert tracker.update(T0 - S, 1.5) is None
    assert tracker.update(T0 + 60 * S, 2.0) == pytest.approx(0.5)


def test_missing_value_keeps_the_baseline():
    out = feed(AccumulationTracker(), [1.0, None, math.nan, 1.6])
    assert out[1] is None and out[2] is None
    assert out[3] == pytest.approx(0.6)


def test_float_noise_is_zero_not_a_reset():
    assert accum_delta(5.0, 5.0 - 1e-9) == 0.0


@pytest.mark.parametrize("kwargs", [{"wrap_at_mm": 0.0}, {"max_gap_s": -1.0}])
def test_bad_arguments(kwargs):
    with pytest.raises(ValueError):
        AccumulationTracker(**kwargs)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    wrap=st.sampled_from([10.0, 99.99, 100.0, 9999.0]),
    start=st.floats(0.0, 1.0),
    steps=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=60),
)
def test_monotone_series_with_wraps_sums_to_the_true_total(wrap, start, steps):
    # True increments of at most 1 mm per minute (under the 400 mm/h bound), counter wraps.
    tracker = AccumulationTracker(wrap_at_mm=wrap)
    total = start * wrap
    tracker.update(T0, math.fmod(total, wrap))
    got = 0.0
    for i, step in enumerate(steps, start=1):
        total += step
        amount = tracker.update(T0 + i * 60 * S, math.fmod(total, wrap))
        assert amount is not None and amount >= 0.0
        got += amount
    assert got == pytest.approx(sum(steps), abs=1e-6)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    values=st.lists(st.one_of(st.none(), st.floats(-10.0, 200.0)), min_size=1, max_size=40),
    wrap=st.one_of(st.none(), st.just(100.0)),
)
def test_never_negative(values, wrap):
    tracker = AccumulationTracker(wrap_at_mm=wrap)
    for amount in feed(tracker, values):
        assert amount is None or amount >= 0.0
