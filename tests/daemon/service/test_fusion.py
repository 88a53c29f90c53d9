"""Camera summaries and the fused site state: the rule for disagreement, and the schemas."""

from __future__ import annotations

import json
import math

import jsonschema
import numpy as np
import pytest

from daemon.service.fusion import (
    OFFLINE,
    CameraView,
    CameraWindow,
    InstrumentView,
    fuse,
    wawa_precipitation,
    wawa_type,
)
from daemon.transport.messages import SCHEMAS, frame_message, histogram_message, iso_utc, schema_for
from hos.result import FrameResult, MixtureFit
from tests.conftest import REPO
from tests.daemon.transport.schemas import validate

T0 = 1_763_800_000_000_000_000  # 2025-11-22T08:26:40Z


def _result(frame: int, *, rain: bool, state: str = "ok", R: float = 100.0) -> FrameResult:
    return FrameResult(
        frame=frame,
        t_s=frame / 25,
        rain=rain,
        state=state,
        fit=MixtureFit(ok=True, pi=0.6, mu=math.radians(95), sigma=0.2, gof_d=0.1, gof_ok=True),
        pi_smoothed=0.55 if rain else 0.05,
        mu_smoothed=math.radians(94),
        sigma_smoothed=0.21,
        S=R / 0.6,
        R=R,
        n_blobs=40,
        n_rain_blobs=25 if rain else 0,
        histogram=np.linspace(0, 1, 180),
    )


def _view(rain: bool, state: str = "ok", *, age_s: float = 0.1, R: float = 50.0) -> CameraView:
    return CameraView(rain, state, 0.5, 90.0, 10.0, R, 25.0, 1.0, T0 - int(age_s * 1e9))


def test_every_schema_is_valid_json_schema_and_docs_point_at_them() -> None:
    for name in SCHEMAS:
        schema = schema_for(name)
        jsonschema.Draft202012Validator.check_schema(schema)
        assert schema["properties"]["schema"] == {"const": f"{name}/1"}
        on_disk = json.loads((REPO / "docs" / "schemas" / f"{name}.schema.json").read_text())
        assert on_disk == schema


def test_iso_time_is_utc_with_z() -> None:
    assert iso_utc(T0) == "2025-11-22T08:26:40.000000Z"
    assert iso_utc(T0 + 1_500_000) == "2025-11-22T08:26:40.001500Z"


@pytest.mark.parametrize(
    ("views", "expected"),
    [
        ({"a": _view(True), "b": _view(False)}, True),  # one camera seeing rain wins
        ({"a": _view(False), "b": _view(False)}, False),
        ({"a": _view(False), "b": _view(True, "dark")}, False),  # a dark camera does not count
        ({"a": _view(True, "warming_up")}, None),
        ({"a": _view(True, age_s=30.0)}, None),  # stale: offline
        ({}, None),
    ],
)
def test_fusion_rule(views: dict[str, CameraView], expected: bool | None) -> None:
    state = fuse(views, site="s1", t_ns=T0, stale_s=5.0)
    validate(state)
    assert state["precipitation"] is expected
    if expected is None:
        assert state["reason"].startswith("no source can judge")
        assert state["camera_R"] is None
        assert state["precipitation_type"] is None
    elif expected:
        assert state["precipitation_type"] == "unknown"
        assert state["camera_R"] == pytest.approx(50.0)
    else:
        assert state["camera_R"] == 0.0


def test_stale_camera_reports_offline() -> None:
    state = fuse({"a": _view(True, age_s=30.0)}, site="s1", t_ns=T0, stale_s=5.0)
    assert state["cameras"]["a"]["state"] == OFFLINE
    assert state["cameras"]["a"]["rain"] is None
    assert "a offline" in state["reason"]


def test_camera_window_summarises_and_restarts() -> None:
    window = CameraWindow("cam1")
    assert window.view().state == OFFLINE
    for i in range(10):
        window.add(
            _result(i, rain=i >= 6, R=10.0 * i), t_ns=T0 + i * 40_000_000, processing_s=0.002
        )
    summary = window.summary(site="s1", t_ns=T0 + 10**9, capture_state="ok", window_s=0.4)
    validate(summary)
    assert summary["frames"] == 10
    assert summary["fps"] == pytest.approx(25.0)
    assert summary["rain"] is True and summary["frame"] == 9
    assert summary["rain_fraction"] == pytest.approx(0.4)
    assert summary["R_mean"] == pytest.approx(45.0)
    assert summary["processing_ms"] == pytest.approx(2.0)
    empty = window.summary(site="s1", t_ns=T0 + 2 * 10**9, capture_state="reconnecting", window_s=1)
    validate(empty)
    assert empty["frames"] == 0 and empty["state"] == OFFLINE and empty["fps"] == 0.0
    view = window.view()
    assert view.rain and view.t_ns == T0 + 9 * 40_000_000


def test_frame_and_histogram_messages_validate() -> None:
    result = _result(3, rain=True)
    frame = frame_message(result, site="s1", camera="cam1", t_ns=T0)
    validate(frame)
    assert {k: frame[k] for k in result.to_json()} == result.to_json()
    hist = histogram_message(result, site="s1", camera="cam1", t_ns=T0)
    validate(hist)
    assert len(hist["histogram"]) == 180 and hist["bin_width_deg"] == 1.0
    assert hist["mu_deg"] == pytest.approx(95.0)


def test_a_failed_fit_gives_nulls() -> None:
    result = _result(0, rain=False, state="warming_up")
    result.fit = MixtureFit(ok=False, reason="too few blobs")
    validate(frame_message(result, site="s1", camera="c", t_ns=T0))
    hist = histogram_message(result, site="s1", camera="c", t_ns=T0)
    validate(hist)
    assert hist["pi"] is None and hist["mu_deg"] is None


def _inst(kind: str = "gauge", *, age_s: float = 10.0, **kw) -> InstrumentView:
    base = {"driver": "vaisala-pwd" if kind == "present_weather" else "tipping-bucket"}
    return InstrumentView(kind=kind, connected=True, t_ns=T0 - int(age_s * 1e9), **(base | kw))


def test_a_present_weather_sensor_gives_type_rate_wawa_and_visibility() -> None:
    pwd = _inst(
        "present_weather",
        precipitation=True,
        rain_rate_mm_h=0.6,
        wawa=71,
        metar="-SN",
        visibility_m=2400.0,
    )
    state = fuse({"a": _view(True)}, site="s1", t_ns=T0, instruments={"pwd": pwd})
    validate(state)
    assert state["precipitation"] is True
    assert state["precipitation_type"] == "snow"
    assert state["rain_rate_mm_h"] == pytest.approx(0.6)
    assert state["rain_rate_source"] == "sensor"
    assert state["intensity_class"] == "light"
    assert (state["wawa"], state["metar"], state["visibility_m"]) == (71, "-SN", 2400.0)
    assert state["sources"] == ["camera/a", "instrument/pwd"]


def test_a_dark_camera_and_a_gauge() -> None:
    gauge = _inst(precipitation=True, rain_rate_mm_h=12.0)
    state = fuse({"a": _view(False, "dark")}, site="s1", t_ns=T0, instruments={"g": gauge})
    validate(state)
    assert state["precipitation"] is True
    assert (state["rain_rate_source"], state["intensity_class"]) == ("gauge", "heavy")
    assert state["precipitation_type"] == "unknown"
    assert state["wawa"] == 42 and state["metar"] == "+UP"


def test_a_faulty_or_stale_instrument_is_left_out() -> None:
    blocked = _inst(precipitation=False, rain_rate_mm_h=0.0, fault=True, status="blocked")
    stale = _inst(precipitation=False, rain_rate_mm_h=0.0, age_s=3600)
    state = fuse(
        {"a": _view(True)},
        site="s1",
        t_ns=T0,
        instruments={"g1": blocked, "g2": stale},
        camera_rate=lambda r: None if r is None else 0.002 * r,
    )
    validate(state)
    assert state["precipitation"] is True
    assert state["rain_rate_source"] == "camera"
    assert state["rain_rate_mm_h"] == pytest.approx(0.1)
    assert state["instruments"]["g1"]["state"].startswith("fault")
    assert state["instruments"]["g2"]["state"] == "stale"


def test_the_sensor_overrules_a_camera_alone() -> None:
    pwd = _inst("present_weather", precipitation=False, rain_rate_mm_h=0.0, wawa=0)
    state = fuse({"a": _view(True)}, site="s1", t_ns=T0, instruments={"pwd": pwd})
    validate(state)
    assert state["precipitation"] is False
    assert state["disagreement"]
    assert state["rain_rate_mm_h"] == 0.0 and state["wawa"] == 0


def test_calibrated_camera_rate_when_no_instrument() -> None:
    state = fuse(
        {"a": _view(True, R=2000.0)},
        site="s1",
        t_ns=T0,
        camera_rate=lambda r: None if r is None else 0.003 * r,
    )
    validate(state)
    assert state["rain_rate_mm_h"] == pytest.approx(6.0)
    assert state["rain_rate_source"] == "camera"
    assert state["intensity_class"] == "moderate"
    assert (state["wawa"], state["metar"]) == (41, "UP")


#: Every WMO 4680 code, as the table states it: the type of precipitation falling now, or None.
WMO_4680 = {
    **dict.fromkeys(range(0, 40), None),  # no precipitation now (20-29: in the past hour)
    40: "unknown", 41: "unknown", 42: "unknown",  # precipitation (slight/moderate, heavy)
    43: "rain", 44: "rain",  # liquid precipitation
    45: "snow", 46: "snow",  # solid precipitation
    47: "rain", 48: "rain",  # freezing precipitation
    49: None,  # not used
    **dict.fromkeys(range(50, 57), "drizzle"),  # drizzle, freezing drizzle
    57: "mixed", 58: "mixed",  # drizzle and rain
    59: None,
    **dict.fromkeys(range(60, 67), "rain"),  # rain, freezing rain
    67: "mixed", 68: "mixed",  # rain or drizzle and snow
    69: None,
    70: "snow", 71: "snow", 72: "snow", 73: "snow",
    74: "ice_pellets", 75: "ice_pellets", 76: "ice_pellets",
    77: "snow", 78: "snow",  # snow grains, ice crystals
    79: None,
    80: "unknown",  # showers or intermittent precipitation
    81: "rain", 82: "rain", 83: "rain", 84: "rain",  # rain showers
    85: "snow", 86: "snow", 87: "snow",  # snow showers
    88: "hail",  # not used by WMO; OTT Parsivel: soft hail (graupel)
    89: "hail",
    90: None, 91: None,  # thunderstorm; with no precipitation
    92: "mixed", 93: "hail",  # thunderstorm with showers; with hail
    94: None,  # heavy thunderstorm with no precipitation
    95: "mixed", 96: "hail",
    97: None, 98: None, 99: None,  # not used; tornado
}  # fmt: skip


def test_the_table_covers_every_code():
    assert sorted(WMO_4680) == list(range(100))


@pytest.mark.parametrize(("wawa", "kind"), sorted(WMO_4680.items()))
def test_wawa_types(wawa: int, kind: str | None) -> None:
    assert wawa_type(wawa) == kind
    assert wawa_precipitation(wawa) is (kind is not None)


def _feed(persistence, verdicts, dt_s=0.1):
    """The persistent verdict after each instantaneous one, ``dt_s`` apart."""
    return [persistence(v, round(i * dt_s * 1e9)) for i, v in enumerate(verdicts)]


def test_a_short_blip_never_makes_the_site_wet():
    from daemon.service.fusion import Persistence

    out = _feed(Persistence(onset_s=10, end_s=60), [False] * 50 + [True] * 5 + [False] * 50)
    assert not any(out)  # a 0.5-s false verdict (the demo's clear-weather blips)


def test_precipitation_starts_after_onset_and_survives_short_gaps():
    from daemon.service.fusion import Persistence

    rain = [True] * 150 + [False] * 20 + [True] * 300  # 15 s, a 2-s gap, 30 s
    out = _feed(Persistence(onset_s=10, end_s=60), [False] * 10 + rain + [False] * 700)
    first = out.index(True)
    assert first == 10 + 100  # 10 s after the rain was first seen
    assert all(out[first : 10 + len(rain)])  # the 2-s gap does not end it
    last = len(out) - 1 - out[::-1].index(True)
    assert last - (10 + len(rain)) == 600 - 1  # it ends 60 s after the last rain seen


def test_unknown_at_once_and_judging_again_starts_dry():
    from daemon.service.fusion import Persistence

    p = Persistence(onset_s=1, end_s=1)
    out = _feed(p, [True] * 20 + [None] * 3 + [True] * 5)
    assert out[19] is True and out[20:23] == [None] * 3
    assert out[23:] == [False] * 5  # seen again for 0.5 s only: not yet


def test_fuse_follows_the_persistent_verdict_and_keeps_the_instant_one():
    from daemon.service.fusion import Persistence

    p = Persistence(onset_s=10, end_s=60)
    state = fuse({"c": _view(True)}, site="s", t_ns=T0, persistence=p)
    assert state["precipitation"] is False and state["precipitation_instant"] is True
    assert state["rain_rate_mm_h"] == 0.0 and state["precipitation_type"] is None
    validate(state)
