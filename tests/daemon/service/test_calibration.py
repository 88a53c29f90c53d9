"""Online calibration of R into mm/h: convergence on a known law, outliers, persistence."""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path

import numpy as np
import pytest

from daemon.service.calibration import CalibrationParams, OnlineCalibration, load_calibration_file
from drivers.errors import ConfigError
from tests.conftest import run_python

W = 60.0  # window, seconds
T0 = 1_700_000_000 * 10**9


def feed(
    cal: OnlineCalibration,
    rng: np.random.Generator,
    windows: int,
    *,
    a: float,
    b: float,
    outliers: int = 0,
    start: int = 0,
    noise: float = 0.2,
) -> int:
    """Feed ``windows`` rainy windows of rate = a R^b (log-normal noise); some outliers."""
    t = T0 + start * int(W * 1e9)
    cal.tick(t)
    bad = set(rng.choice(windows, size=outliers, replace=False).tolist()) if outliers else set()
    for k in range(windows):
        r = float(np.exp(rng.uniform(np.log(200), np.log(8000))))
        rate = a * r**b * float(np.exp(rng.normal(0, noise)))
        if k in bad:
            rate = 0.25 if rate > 2 else rate * 20  # a blocked gauge, a splash
        for i in range(6):
            ti = t + int(i * W / 6 * 1e9)
            cal.add_camera(t_ns=ti, r_mean=r, frames=250, judged=250, rain_frames=250)
            cal.add_gauge_rate(t_ns=ti, rate_mm_h=rate)
        t += int(W * 1e9)
        cal.tick(t)
    return t


@pytest.mark.parametrize(("a", "b"), [(0.003, 1.0), (0.02, 0.7), (1e-4, 1.3)])
def test_converges_on_a_known_power_law(a: float, b: float) -> None:
    rng = np.random.default_rng(7)
    cal = OnlineCalibration(CalibrationParams(window_s=W))
    assert cal.rate_mm_h(1000) is None  # not calibrated yet
    t = feed(cal, rng, 150, a=a, b=b)
    q = cal.quality(t)
    assert q["n"] >= 120 and q["ready"]  # windows under 0.2 mm/h are not measurements
    assert q["b"] == pytest.approx(b, abs=0.08)
    for r in (300, 1000, 5000):
        assert cal.rate_mm_h(r) == pytest.approx(a * r**b, rel=0.12)
    assert q["r2"] > 0.8


def test_outliers_are_rejected_and_counted() -> None:
    rng = np.random.default_rng(3)
    cal = OnlineCalibration(CalibrationParams(window_s=W))
    t = feed(cal, rng, 200, a=0.004, b=1.0, outliers=15)
    q = cal.quality(t)
    assert q["outliers"] >= 10
    assert cal.rate_mm_h(2000) == pytest.approx(8.0, rel=0.12)


def test_dry_or_unjudged_windows_are_not_measurements() -> None:
    cal = OnlineCalibration(CalibrationParams(window_s=W))
    t = T0
    cal.tick(t)
    for _ in range(10):
        # gauge dry while the camera sees rain; the camera unable to judge while it rains
        cal.add_camera(t_ns=t, r_mean=2000.0, frames=100, judged=100, rain_frames=100)
        cal.add_gauge_rate(t_ns=t, rate_mm_h=0.0)
        t += int(W * 1e9)
        assert not cal.tick(t)
        cal.add_camera(t_ns=t, r_mean=2000.0, frames=100, judged=10, rain_frames=10)
        cal.add_gauge_rate(t_ns=t, rate_mm_h=5.0)
        t += int(W * 1e9)
        assert not cal.tick(t)
    assert cal.n == 0


def test_tipping_bucket_amounts_become_a_rate() -> None:
    cal = OnlineCalibration(CalibrationParams(window_s=W, min_windows=1))
    cal.tick(T0)
    for i in range(6):  # 6 tips of 0.2 mm in a minute: 72 mm/h
        cal.add_gauge_amount(t_ns=T0 + i * 10**10, amount_mm=0.2)
        cal.add_camera(t_ns=T0 + i * 10**10, r_mean=3000.0, frames=250, judged=250, rain_frames=250)
    assert cal.tick(T0 + int(W * 1e9))
    assert cal.pairs[-1][1] == pytest.approx(72.0)


def test_state_survives_a_restart(tmp_path: Path) -> None:
    path = tmp_path / "state" / "calibration.json"
    rng = np.random.default_rng(1)
    cal = OnlineCalibration(CalibrationParams(window_s=W), state_path=path)
    t = feed(cal, rng, 40, a=0.005, b=0.9)
    saved = json.loads(path.read_text())
    assert saved["n"] == 40
    again = OnlineCalibration(CalibrationParams(window_s=W), state_path=path)
    assert again.n == 40
    assert again.rate_mm_h(1500) == pytest.approx(cal.rate_mm_h(1500))
    assert again.quality(t)["rmse_mm_h"] == cal.quality(t)["rmse_mm_h"]
    assert not list(path.parent.glob(".calibration.json.*"))  # no temporary left behind


def test_a_corrupt_state_file_is_ignored(tmp_path: Path) -> None:
    path = tmp_path / "calibration.json"
    path.write_text("{not json")
    cal = OnlineCalibration(CalibrationParams(window_s=W), state_path=path)
    assert cal.n == 0 and not cal.ready


def test_an_offline_calibration_is_the_prior(tmp_path: Path) -> None:
    f = tmp_path / "calibration.toml"
    f.write_text('[calibration]\nmodel = "linear"\na = 0.004\nb = 1.0\na_ci = [0.0036, 0.0044]\n')
    cal = OnlineCalibration(CalibrationParams(window_s=W), prior=load_calibration_file(f))
    assert cal.ready
    assert cal.rate_mm_h(1000) == pytest.approx(4.0)
    assert cal.quality(T0)["source"] == "offline"
    bad = tmp_path / "bad.toml"
    bad.write_text('[calibration]\nmodel = "cubic"\na = 1\n')
    with pytest.raises(ConfigError, match="model"):
        load_calibration_file(bad)
    assert math.isfinite(cal.x[0])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kalman_steps_equal_filterpy(seed):
    """The written-out predict/update are filterpy's (Joseph form), over a run of windows."""
    from filterpy.kalman import predict, update

    from daemon.service.calibration import kf_predict, kf_update

    rng = np.random.default_rng(seed)
    x = ours_x = np.array([math.log(0.004), 1.0])
    P = ours_P = np.diag([4.0, 0.25])
    Q = np.diag([1e-4, 1e-5])
    for _ in range(50):
        H = np.array([[1.0, math.log(rng.uniform(50, 20_000))]])
        z, r = float(rng.normal(-2.0, 1.5)), float(rng.uniform(0.01, 0.5))
        x, P = predict(x, P, F=np.eye(2), Q=Q)
        x, P = update(x, P, z, r, H)
        ours_x, ours_P = kf_predict(ours_x, ours_P, Q)
        ours_x, ours_P = kf_update(ours_x, ours_P, z, r, H)
        np.testing.assert_allclose(ours_x, np.asarray(x).reshape(2), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(ours_P, P, rtol=1e-12, atol=1e-12)


def test_the_daemon_does_not_import_filterpy_or_scipy_stats():
    """57 MiB and 0.8 s of start-up: the service's modules must not pull them in."""
    code = (
        "import sys, daemon.service.app, daemon.service.calibration; "
        "print(sorted(m for m in ('filterpy', 'scipy.stats') if m in sys.modules))"
    )
    assert run_python(code, HOS_JIT="0").strip() == "[]"


def test_checking_the_configuration_does_not_restore_the_state(tmp_path: Path, caplog) -> None:
    """The online state is ``run``'s to restore, once, after its signal handlers are in place:
    ``check_paths`` (run by check-config and before run's start-up) neither reads nor logs
    it, while it still refuses a bad offline file."""
    from daemon.config import parse_config
    from daemon.service.app import check_paths

    state = tmp_path / "calibration.json"
    OnlineCalibration(CalibrationParams(window_s=W), state_path=state)._save()
    config = parse_config(
        {"site": {"id": "s", "state_dir": str(tmp_path)}, "zenoh": {"enabled": False}}
    )
    with caplog.at_level(logging.INFO, logger="daemon.service.calibration"):
        check_paths(config)
        assert not caplog.records
        OnlineCalibration(CalibrationParams(window_s=W), state_path=state)
    assert [r.getMessage().split(" from ")[0] for r in caplog.records] == ["calibration: restored"]
    bad = tmp_path / "bad.toml"
    bad.write_text('[calibration]\nmodel = "cubic"\na = 1\n')
    with pytest.raises(ConfigError, match="model"):
        check_paths(parse_config({"zenoh": {"enabled": False}, "calibration": {"file": str(bad)}}))
