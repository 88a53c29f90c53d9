"""The camera's own precipitation type in the daemon: camera messages, the site state, the fusion
rule (a sensor's type first, then the cameras'), the log line and ``weatherd watch``."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from daemon.config import ConfigError, detector_params
from daemon.service.app import _verdict_words
from daemon.service.fusion import CameraView, CameraWindow, InstrumentView, camera_type, fuse
from daemon.transport.messages import frame_message
from daemon.transport.watch import human_line
from hos.result import FrameResult, MixtureFit
from tests.daemon.transport.schemas import validate

T0 = 1_763_800_000_000_000_000  # 2025-11-22T08:26:40Z


def _result(frame: int, *, rain: bool, kind: str, state: str = "ok") -> FrameResult:
    return FrameResult(
        frame=frame,
        t_s=frame / 25,
        rain=rain,
        state=state,
        fit=MixtureFit(ok=True, pi=0.6, mu=math.radians(92), sigma=0.5, gof_d=0.05, gof_ok=True),
        pi_smoothed=0.55 if rain else 0.05,
        mu_smoothed=math.radians(92),
        sigma_smoothed=0.5,
        S=200.0,
        R=120.0,
        n_blobs=40,
        n_rain_blobs=30 if rain else 0,
        histogram=np.linspace(0, 1, 180),
        precipitation_type=kind,
    )


def _view(rain: bool, kind: str = "unknown", state: str = "ok") -> CameraView:
    return CameraView(rain, state, 0.5, 90.0, 28.0, 80.0, 25.0, 1.0, T0 - 10**8, 80.0, kind)


def _sensor(wawa: int, metar: str) -> InstrumentView:
    return InstrumentView(
        kind="present_weather",
        driver="vaisala-pwd",
        connected=True,
        t_ns=T0 - 10**10,
        precipitation=True,
        wawa=wawa,
        metar=metar,
    )


def test_frame_message_and_camera_summary_carry_the_camera_type() -> None:
    snow = _result(7, rain=True, kind="snow")
    msg = frame_message(snow, site="s1", camera="c", t_ns=T0)
    validate(msg)
    assert msg["precipitation_type"] == "snow"
    window = CameraWindow("c")
    window.add(snow, t_ns=T0, processing_s=0.01)
    summary = window.summary(site="s1", t_ns=T0, capture_state="running", window_s=1.0)
    validate(summary)
    assert summary["camera_precipitation_type"] == "snow"
    assert window.view().precipitation_type == "snow"
    # an empty window says nothing of the type
    empty = window.summary(site="s1", t_ns=T0 + 10**9, capture_state="running", window_s=1.0)
    validate(empty)
    assert empty["camera_precipitation_type"] == "unknown"


@pytest.mark.parametrize("kind", ["rain", "snow"])
def test_camera_only_type_reaches_the_state_wawa_and_metar(kind: str) -> None:
    state = fuse({"a": _view(True, kind)}, site="s1", t_ns=T0)
    validate(state)
    assert state["precipitation"] is True
    assert state["precipitation_type"] == state["camera_precipitation_type"] == kind
    assert state["cameras"]["a"]["camera_precipitation_type"] == kind
    wawa_tens = {"rain": 6, "snow": 7}[kind]
    assert state["wawa"] // 10 == wawa_tens
    assert state["metar"].lstrip("-+") == {"rain": "RA", "snow": "SN"}[kind]


def test_a_sensor_type_wins_over_the_camera_type() -> None:
    # the sensor says rain (wawa 61), the camera says snow: the sensor measures the drops
    sensor = _sensor(61, "-RA")
    state = fuse({"a": _view(True, "snow")}, site="s1", t_ns=T0, instruments={"pwd": sensor})
    validate(state)
    assert state["precipitation_type"] == "rain"
    assert state["camera_precipitation_type"] == "snow"  # the camera's own stays visible
    assert (state["wawa"], state["metar"]) == (61, "-RA")


def test_a_sensor_without_a_type_leaves_the_type_to_the_camera() -> None:
    # wawa 41: "precipitation, slight or moderate", type not known by the sensor
    sensor = _sensor(41, "-UP")
    state = fuse({"a": _view(True, "snow")}, site="s1", t_ns=T0, instruments={"pwd": sensor})
    validate(state)
    assert state["precipitation_type"] == "snow"
    assert (state["wawa"], state["metar"]) == (41, "-UP")  # the sensor's own codes are kept


def test_cameras_that_disagree_or_cannot_judge_give_no_type() -> None:
    both = {"a": _view(True, "rain"), "b": _view(True, "snow")}
    state = fuse(both, site="s1", t_ns=T0)
    validate(state)
    assert state["precipitation_type"] == state["camera_precipitation_type"] == "unknown"
    # a camera that sees no precipitation has no say; one that cannot judge is left out
    one = {"a": _view(True, "snow"), "b": _view(False), "c": _view(True, "rain", "dark")}
    state = fuse(one, site="s1", t_ns=T0)
    validate(state)
    assert state["precipitation_type"] == "snow"
    assert state["cameras"]["c"]["camera_precipitation_type"] is None
    dark = fuse({"a": _view(True, "rain", "dark")}, site="s1", t_ns=T0)
    validate(dark)
    assert dark["camera_precipitation_type"] is None and dark["precipitation_type"] is None
    dry = fuse({"a": _view(False)}, site="s1", t_ns=T0)
    validate(dry)
    assert (dry["precipitation_type"], dry["camera_precipitation_type"]) == (None, "unknown")


def test_camera_type_rule() -> None:
    assert camera_type({}) is None
    assert camera_type({"a": _view(True, "snow"), "b": _view(True, "unknown")}) == "snow"
    assert camera_type({"a": _view(False, "unknown")}) == "unknown"
    # a stale type on a camera that sees nothing now does not count
    stale = dataclasses.replace(_view(False), precipitation_type="rain")
    assert camera_type({"a": stale, "b": _view(True, "snow")}) == "snow"


def test_the_log_says_snow_not_rain() -> None:
    assert _verdict_words(_result(1, rain=True, kind="snow")) == "SNOW"
    assert _verdict_words(_result(1, rain=True, kind="rain")) == "RAIN"
    assert _verdict_words(_result(1, rain=True, kind="unknown")) == "PRECIPITATION (type unknown)"
    assert _verdict_words(_result(1, rain=False, kind="unknown")) == "no precipitation"


def test_watch_shows_the_type() -> None:
    state = fuse({"cam1": _view(True, "snow")}, site="s1", t_ns=T0)
    line = human_line({"key": "weather/s1/state", "payload": state})
    assert "precipitation yes (snow)" in line and "cam1 ok snow" in line


def test_the_config_sets_the_type_parameters_and_names_bad_keys() -> None:
    params = detector_params({"detector": {"precipitation_type": {"contrast_snow": 60}}})
    assert params.precipitation_type.contrast_snow == 60.0
    with pytest.raises(ConfigError, match=r"detector\.precipitation_type\.min_votes: must be an"):
        detector_params({"detector": {"precipitation_type": {"min_votes": "x"}}})
    with pytest.raises(ConfigError, match=r"detector\.precipitation_type\.colour: unknown"):
        detector_params({"detector": {"precipitation_type": {"colour": 1}}})
