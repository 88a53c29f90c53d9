"""The stress sets (bench/stress_scenes.py): the scenes they draw, and one short run."""

from __future__ import annotations

import importlib.util
import sys

import pytest

from drivers.simulator.families import sample_case
from drivers.simulator.scene import Scene
from tests.conftest import REPO

_spec = importlib.util.spec_from_file_location("stress_scenes", REPO / "bench" / "stress_scenes.py")
st = importlib.util.module_from_spec(_spec)
sys.modules["stress_scenes"] = st
_spec.loader.exec_module(st)


@pytest.mark.parametrize(
    ("name", "condition", "size", "speed"),
    [
        ("shade-720p10", "transition", (1280, 720), 160.0),
        ("drizzle-shade", "drizzle", (640, 360), 80.0),
        ("snow-shade", "snow", (640, 360), 80.0),
    ],
)
def test_a_stress_case_is_the_tuning_scene_under_the_sets_settings(
    name: str, condition: str, size: tuple[int, int], speed: float
) -> None:
    case = st.stress_case(name, 103)
    base = sample_case("tuning", 103, condition=condition, camera="static", frames=st.FRAMES)
    assert case.name == f"{base.name}-{name}"
    assert (case.width, case.height, case.fps, case.h264_crf) == (*size, 10.0, None)
    p = case.params
    assert (p.fps, p.jpeg_quality, p.shade, p.shade_edge, p.shade_cover) == (
        10.0,
        60,
        0.45,
        0.2,
        0.5,
    )
    assert p.shade_speed_px_s == pytest.approx(speed)
    # the rest of the scene is the tuning generator's: its layout, seed and precipitation
    assert case.seed == base.seed and case.rain_frames == base.rain_frames
    assert p.rain == base.params.rain and p.snow == base.params.snow
    if name == "shade-720p10":
        assert (p.cars, p.wet_road) == (6, 0.99)
    else:
        assert (p.cars, p.wet_road) == (base.params.cars, base.params.wet_road)


@pytest.mark.parametrize("name", ["soft-720", "soft-drizzle-720", "soft-snow-270"])
def test_a_soft_camera_is_the_windy_tuning_scene_large_through_a_soft_lens(name: str) -> None:
    condition, width, height, blur = st.SOFT[name]
    case = st.stress_case(name, 104)
    base = sample_case("tuning", 104, condition=condition, camera="wind", frames=st.FRAMES)
    assert case.name == f"{base.name}-{name}"
    assert (case.width, case.height, case.params.lens_blur_px) == (width, height, blur)
    # its own frame rate, codec, shake and view
    assert (case.fps, case.h264_crf, case.params.jpeg_quality) == (
        base.fps,
        base.h264_crf,
        base.params.jpeg_quality,
    )
    assert case.params.shake_px == base.params.shake_px > 0
    if base.params.rain is not None:  # as many streaks a pixel as the generator draws
        area = width * height / (base.width * base.height)
        assert case.params.rain.count == pytest.approx(base.params.rain.count * area, rel=0.01)
        assert case.params.rain.mu_deg == base.params.rain.mu_deg
    if base.params.snow is not None:  # as many flakes a pixel
        area = width * height / (base.width * base.height)
        assert case.params.snow.count == pytest.approx(base.params.snow.count * area, rel=0.01)
        assert case.params.snow.mu_deg == base.params.snow.mu_deg


@pytest.mark.parametrize("name", ["wind-1080", "drizzle-wind-720"])
def test_a_large_set_is_the_windy_tuning_scene_at_that_size_with_its_own_lens(name: str) -> None:
    condition, width, height = st.LARGE[name]
    case = st.stress_case(name, 105)
    base = sample_case("tuning", 105, condition=condition, camera="wind", frames=st.FRAMES)
    assert case.name == f"{base.name}-{name}"
    assert (case.width, case.height) == (width, height)
    # its own lens, frame rate, codec, shake and shade (the drift scaled with the width)
    assert case.params.lens_blur_px == base.params.lens_blur_px
    assert (case.fps, case.h264_crf, case.params.jpeg_quality) == (
        base.fps,
        base.h264_crf,
        base.params.jpeg_quality,
    )
    assert case.params.shake_px == base.params.shake_px > 0
    assert case.params.shade == base.params.shade
    assert case.params.shade_speed_px_s == pytest.approx(
        base.params.shade_speed_px_s * width / base.width
    )
    if base.params.rain is not None:  # as many streaks a pixel, as long as the generator's
        area = width * height / (base.width * base.height)
        assert case.params.rain.count == pytest.approx(base.params.rain.count * area, rel=0.01)
        assert case.params.rain.length_px == base.params.rain.length_px


def test_every_set_draws_its_scenes_whatever_view_they_had() -> None:
    # a scene's view is drawn for its own frame size; a set draws it at another
    for name in [*st.SETS, *st.SOFT, *st.LARGE]:
        for index in range(100, 112):
            case = st.stress_case(name, index, frames=2)
            Scene(case.width, case.height, seed=case.seed, params=case.params)


def test_an_unknown_set_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown stress set 'fog'"):
        st.stress_case("fog", 100)
    with pytest.raises(SystemExit):
        st.main(["fog"])


def test_a_short_run_prints_each_scene_and_the_totals(capsys) -> None:
    assert st.main(["snow-shade", "--scenes", "100:101", "--frames", "100", "--jobs", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("tuning-100-snow-static-snow-shade ")
    assert out[-1].startswith("snow-shade: 1 scenes, false 0/0 clear frames, 0 false onsets")
