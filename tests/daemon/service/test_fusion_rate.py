"""The rate and the R fields of the site state (issue 13): 0.0 is dry, null is unknown and
says why, and the per-camera R_smoothed is what camera_R averages."""

from __future__ import annotations

import pytest

from daemon.service.fusion import CameraView, fuse
from tests.daemon.service.test_fusion import T0, _inst, _view
from tests.daemon.transport.schemas import validate


def calibrated(r):
    return None if r is None else 0.003 * r


def uncalibrated(r):  # the daemon's calibration before it is ready
    return None


@pytest.mark.parametrize("camera_rate", [None, uncalibrated, calibrated])
def test_dry_is_zero_whatever_the_calibration(camera_rate):
    state = fuse({"a": _view(False)}, site="s1", t_ns=T0, camera_rate=camera_rate)
    validate(state)
    assert state["precipitation"] is False
    assert state["rain_rate_mm_h"] == 0.0
    assert state["rain_rate_source"] == "camera"
    assert state["rain_rate_reason"] is None


@pytest.mark.parametrize(
    ("camera_rate", "why"),
    [(None, "has no calibration"), (uncalibrated, "calibration is not ready")],
)
def test_rain_without_a_rate_is_null_and_says_why(camera_rate, why):
    state = fuse({"a": _view(True)}, site="s1", t_ns=T0, camera_rate=camera_rate)
    validate(state)
    assert state["precipitation"] is True
    assert state["rain_rate_mm_h"] is None and state["rain_rate_source"] is None
    assert why in state["rain_rate_reason"]


def test_nobody_judges_is_null():
    state = fuse({"a": _view(True, "dark")}, site="s1", t_ns=T0, camera_rate=calibrated)
    validate(state)
    assert state["rain_rate_mm_h"] is None
    assert state["rain_rate_reason"] == "no source can judge whether it rains"


def test_dry_judged_by_a_gauge_alone():
    gauge = _inst(precipitation=False, rain_rate_mm_h=None)
    state = fuse({"a": _view(True, "dark")}, site="s1", t_ns=T0, instruments={"g": gauge})
    validate(state)
    assert (state["rain_rate_mm_h"], state["rain_rate_source"]) == (0.0, "gauge")


def test_camera_r_is_the_mean_of_the_smoothed_r_of_the_raining_cameras():
    def view(rain, r_last, r_smoothed):
        v = _view(rain, R=r_last)
        return CameraView(**{**v.__dict__, "r_mean": r_smoothed})

    cams = {"a": view(True, 900.0, 400.0), "b": view(True, 100.0, 200.0), "c": view(False, 5, 1)}
    state = fuse(cams, site="s1", t_ns=T0, camera_rate=calibrated)
    validate(state)
    assert state["cameras"]["a"]["R"] == 900.0
    assert state["cameras"]["a"]["R_smoothed"] == 400.0
    assert state["camera_R"] == pytest.approx(300.0)  # (400 + 200) / 2; c sees no rain
    assert state["rain_rate_mm_h"] == pytest.approx(0.9)
