import itertools
import math

import pytest

from hos.params import DecisionParams
from hos.smoothing import ParameterSmoother


def test_rain_then_misses_decays_instead_of_freezing():
    s = ParameterSmoother()
    for _ in range(30):
        st = s.update((0.8, math.radians(85), math.radians(8)))
    assert st.rain and st.pi == pytest.approx(0.8, abs=0.05)
    frames = 0
    while s.update(None).rain:
        frames += 1
        assert frames < 100
    assert frames <= 25  # paper's rain -> clear latency ~25 frames


def test_paper_mode_freezes_without_the_decay():
    # With an enormous miss variance a miss carries no information: the paper's behaviour.
    s = ParameterSmoother(DecisionParams(miss_measurement_var=1e12))
    for _ in range(30):
        s.update((0.8, 1.5, 0.1))
    for _ in range(200):
        st = s.update(None)
    assert st.rain


def test_mu_is_smoothed_across_the_seam():
    s = ParameterSmoother()
    for i in range(40):
        deg = 179.0 if i % 2 else 1.0  # one orientation, seen on both sides of 0 = 180
        st = s.update((0.7, math.radians(deg), math.radians(5)))
    d = min(math.degrees(st.mu), 180 - math.degrees(st.mu))
    assert d < 2.0  # a naive mean would sit at 90 degrees


def test_hysteresis_holds_the_verdict_near_the_threshold():
    p = DecisionParams()
    s = ParameterSmoother(p)
    for _ in range(40):
        s.update((0.6, 1.5, 0.1))
    for _ in range(40):
        st = s.update((p.pi_rain - 0.02, 1.5, 0.1))
    assert st.rain  # between off and on thresholds: keeps raining
    for _ in range(40):
        st = s.update((0.1, 1.5, 0.1))
    assert not st.rain


def test_tapering_rain_does_not_flicker_the_verdict():
    p = DecisionParams()
    s = ParameterSmoother(p)
    for _ in range(40):
        s.update((0.8, 1.5, 0.1))
    verdicts = []
    for i in range(60):  # rain fading: fits come and go around the threshold
        st = s.update((0.5, 1.5, 0.1)) if i % 3 == 0 else s.update(None)
        verdicts.append(st.rain)
    changes = sum(a != b for a, b in itertools.pairwise(verdicts))
    assert changes <= 1


def test_a_one_frame_blip_is_not_rain():
    s = ParameterSmoother()
    for _ in range(20):
        s.update(None)
    st = s.update((1.0, 1.5, 0.1))
    st = s.update(None)
    assert not st.rain
