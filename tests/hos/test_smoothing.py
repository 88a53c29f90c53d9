import itertools
import math
from pathlib import Path

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


def _filterpy_reference(params: DecisionParams):
    """The 3x3 filter as the paper writes it, with filterpy's KalmanFilter."""
    import numpy as np
    from filterpy.kalman import KalmanFilter

    kf = KalmanFilter(dim_x=3, dim_z=3)
    kf.x = np.array([[0.0], [math.pi / 2], [math.radians(20.0)]])
    kf.F = np.eye(3)
    kf.H = np.eye(3)
    q, r = params.process_var, params.measurement_var
    kf.P = np.diag([0.5 * (q + math.sqrt(q * q + 4.0 * q * r)) - q, 1.0, 1.0])
    kf.Q = np.eye(3) * q
    kf.R = np.eye(3) * r
    return kf


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_scalar_filters_equal_filterpy_kalman_filter(seed):
    """The three scalar filters are filterpy's 3x3 filter (F = H = I), step by step."""
    import numpy as np

    from hos.angles import wrap_diff

    p = DecisionParams()
    rng = np.random.default_rng(seed)
    kf = _filterpy_reference(p)
    s = ParameterSmoother(p)
    h_pi = np.array([[1.0, 0.0, 0.0]])
    for _ in range(300):
        kf.predict()
        if rng.random() < 0.3:
            st = s.update(None)
            kf.update(np.array([[0.0]]), R=np.array([[p.miss_measurement_var]]), H=h_pi)
        else:
            z = (rng.uniform(0, 1), rng.uniform(0, math.pi), rng.uniform(0.01, 0.6))
            st = s.update(z)
            mu_near = kf.x[1, 0] + float(wrap_diff(z[1], kf.x[1, 0]))
            kf.update(np.array([[z[0]], [mu_near], [z[2]]]))
        kf.x[0, 0] = min(max(kf.x[0, 0], 0.0), 1.0)
        kf.x[1, 0] = float(np.mod(kf.x[1, 0], np.pi))
        kf.x[2, 0] = max(kf.x[2, 0], 1e-3)
        assert (st.pi, st.mu, st.sigma) == pytest.approx(tuple(kf.x[:, 0]), rel=1e-12, abs=1e-15)
        assert s.variance == pytest.approx(tuple(np.diag(kf.P)), rel=1e-12)
        assert np.count_nonzero(kf.P - np.diag(np.diag(kf.P))) == 0  # P stays diagonal


@pytest.mark.e2e
def test_importing_the_detector_does_not_import_filterpy():
    """filterpy imports scipy.stats (0.4 s of every start): the detector does not need it."""
    import subprocess
    import sys

    code = "import sys, hos, hos.pipeline; print('filterpy' in sys.modules)"
    root = str(Path(__file__).resolve().parents[2])
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=root
    )
    assert out.stdout.strip() == "False"


def test_a_noisier_measurement_moves_the_state_less():
    from hos.smoothing import ParameterSmoother

    a, b = ParameterSmoother(), ParameterSmoother()
    a.update((0.8, 1.5, 0.2))
    b.update((0.8, 1.5, 0.2), measurement_var=0.5)
    assert 0.0 < b.state.pi < a.state.pi
    c = ParameterSmoother()
    c.update((0.8, 1.5, 0.2), measurement_var=c.params.measurement_var)
    assert c.state == a.state  # the parameters' own variance by default


def test_a_frame_without_blobs_ends_rain_within_ten_frames():
    """Issue 10's rain -> clear latency: a miss with hardly a blob in sight (the pipeline passes
    ``empty_measurement_var``) ends a verdict at Pi 0.8 in 8 frames: 3 to fall under the
    threshold, then the 5-frame dwell; a failed fit of many blobs (the miss variance) takes 15."""
    p = DecisionParams()

    def frames_to_clear(var: float | None) -> int:
        s = ParameterSmoother(p)
        for _ in range(30):
            s.update((0.8, math.radians(85), math.radians(8)))
        frames = 0
        while s.update(None, measurement_var=var).rain:
            frames += 1
            assert frames < 100
        return frames + 1

    empty, failed = frames_to_clear(p.empty_measurement_var), frames_to_clear(None)
    assert empty <= 8 < 12 <= failed, (empty, failed)
