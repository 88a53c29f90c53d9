"""The scene-family benchmark's CI subset: its scoring on hand-made sequences, its generator's
truth, and a few small scenes through the detector (bench/eval_scenes.py; ``make eval`` runs
the whole benchmark)."""

from __future__ import annotations

import importlib.util
import math
import sys
from dataclasses import replace

import cv2
import numpy as np
import pytest

from drivers.simulator import families
from drivers.simulator.families import (
    CONDITIONS,
    SPLITS,
    case_frames,
    sample_case,
    sample_cases,
)
from drivers.simulator.scene import view_fits
from tests.conftest import REPO

_spec = importlib.util.spec_from_file_location("eval_scenes", REPO / "bench" / "eval_scenes.py")
ev = importlib.util.module_from_spec(_spec)
sys.modules["eval_scenes"] = ev  # its dataclasses look their module up
_spec.loader.exec_module(ev)


def test_false_onsets_count_rises() -> None:
    assert ev.false_onsets([]) == 0
    assert ev.false_onsets([True]) == 1
    assert ev.false_onsets([False, True, True, False, True, False]) == 2


def test_onsets_within_runs_of_scored_frames() -> None:
    """A run's first frame carries what came before it (a shower's verdict held past its end
    is no onset); a rise inside a run is one; a gap starts a new run."""
    t, f = True, False
    assert ev.onsets_within([], []) == 0
    assert ev.onsets_within([t, t, f], [t, t, t]) == 0
    assert ev.onsets_within([t, f, f, t, t], [t, t, t, t, t]) == 1
    assert ev.onsets_within([f, t, f, t], [t, t, t, t]) == 2
    # the rise falls on the first frame after a gap: carried, not counted
    assert ev.onsets_within([f, f, t, t], [t, f, t, t]) == 0
    assert ev.onsets_within([f, t, t, f, t], [t, t, f, t, t]) == 2


def test_latency() -> None:
    truth = [False] * 5 + [True] * 5 + [False] * 5
    verdict = [False] * 7 + [True] * 5 + [False] * 3
    assert ev.latency(verdict, truth, 5, to=True) == 2.0
    assert ev.latency(verdict, truth, 10, to=False) == 2.0
    assert ev.latency([False] * 15, truth, 5, to=True) is None  # never before the truth ends


def test_orientation_error_wraps() -> None:
    assert ev.wrapped_deg(math.radians(1), math.radians(179)) == pytest.approx(2.0)
    assert ev.wrapped_deg(math.radians(90), math.radians(80)) == pytest.approx(10.0)


def test_spearman() -> None:
    assert ev.spearman([1, 2, 3], [10, 20, 30]) == pytest.approx(1.0)
    assert ev.spearman([1, 2, 3], [3, 2, 1]) == pytest.approx(-1.0)
    assert math.isnan(ev.spearman([1], [1]))


def test_the_splits_differ_in_seeds_and_ranges() -> None:
    tuning = sample_cases("tuning", per_cell=2, frames=10)
    evaluation = sample_cases("evaluation", per_cell=2, frames=10)
    assert {c.seed for c in tuning}.isdisjoint({c.seed for c in evaluation})
    assert {(c.width, c.height) for c in tuning}.isdisjoint(
        {(c.width, c.height) for c in evaluation}
    )
    assert {c.condition for c in tuning} == set(CONDITIONS)
    assert sample_case("tuning", 3, condition="snow", camera="wind") == sample_case(
        "tuning", 3, condition="snow", camera="wind"
    )
    # cloud shade in some scenes of each split, from a stream of its own
    for cases in (tuning, evaluation):
        shaded = [c for c in cases if c.params.shade > 0]
        assert 0 < len(shaded) < len(cases)
        assert all(0.2 <= c.params.shade <= 0.55 for c in shaded)


def test_the_splits_draw_views_of_the_street_and_soft_lenses(monkeypatch) -> None:
    # the street magnified, aimed, rolled or mirrored, and a soft lens, in some scenes of each
    # split; the evaluation split's ranges are wider than the tuning split's
    for split, zoom, roll, blur in (("tuning", 1.3, 2.0, 1.0), ("evaluation", 1.6, 4.0, 1.5)):
        cases = sample_cases(split, per_cell=2, frames=10)
        viewed = [c for c in cases if c.params.view_zoom > 1.0]
        soft = [c for c in cases if c.params.lens_blur_px > 0]
        assert 0 < len(viewed) < len(cases) and 0 < len(soft) < len(cases)
        assert any(c.params.view_mirror for c in viewed)
        assert any(not c.params.view_mirror for c in viewed)
        for c in viewed:
            p = c.params
            assert 1.0 < p.view_zoom <= zoom + 0.02 and abs(p.view_roll_deg) <= roll
            assert view_fits(p.view_zoom, p.view_centre, p.view_roll_deg, c.width / c.height)
        assert all(0.3 <= c.params.lens_blur_px <= blur for c in soft)
    # drawn from a stream of their own: without them, every other draw of a scene is the same
    for split in SPLITS:
        drawn = sample_cases(split, per_cell=1, frames=10)
        ranges = {**families._RANGES[split], "view_chance": 0.0, "blur_chance": 0.0}
        monkeypatch.setitem(families._RANGES, split, ranges)
        plain = sample_cases(split, per_cell=1, frames=10)
        monkeypatch.undo()
        unviewed = {
            "view_zoom": 1.0,
            "view_centre": (0.5, 0.5),
            "view_roll_deg": 0.0,
            "view_mirror": False,
            "lens_blur_px": 0.0,
        }
        assert [replace(c, params=replace(c.params, **unviewed)) for c in drawn] == plain
        assert sample_cases(split, per_cell=1, frames=10, views=False) == plain


def test_truth_of_a_transition_and_a_re_aimed_camera() -> None:
    case = sample_case("tuning", 0, condition="transition", camera="static", frames=30)
    case = replace(case, width=160, height=120)
    truth = [f.precipitation for f in case_frames(case)]
    assert truth == [False] * 10 + [True] * 10 + [False] * 10
    reaim = sample_case("tuning", 1, condition="clear", camera="reaim", frames=120)
    reaim = replace(reaim, width=160, height=120)
    frames = list(case_frames(reaim))
    first, end = reaim.reaim
    assert [f.moving for f in frames] == [first <= i < end for i in range(120)]
    assert not any(f.precipitation for f in frames)
    # the image moves while the truth says so, and stays at its new aim afterwards
    assert np.abs(frames[end].gray.astype(int) - frames[first - 1].gray).mean() > 1.0


@pytest.mark.slow
def test_small_scenes_through_the_detector() -> None:
    """Loose bounds: the figures against the targets are `make eval`'s job."""
    clear = replace(
        sample_case("tuning", 0, condition="clear", camera="static", frames=200),
        width=320,
        height=240,
    )
    rain = replace(
        sample_case("tuning", 1, condition="moderate", camera="static", frames=200),
        width=320,
        height=240,
    )
    c, r = ev.score(clear), ev.score(rain)
    assert c.judged_clear > 50 and c.false_frames <= 0.2 * c.judged_clear
    assert r.wet > 50 and r.detected >= 0.5 * r.wet
    assert r.mu_errors and np.median(r.mu_errors) < 10
    # the camera's type: clear frames are never typed, rain frames typed rain, never snow
    assert set(c.types) <= {("clear", "rain"), ("clear", "snow"), ("clear", "unknown")}
    assert sum(c.types.values()) == c.judged_clear
    assert c.types[("clear", "unknown")] >= 0.8 * c.judged_clear
    assert r.types[("rain", "snow")] == 0 and r.types[("rain", "rain")] >= 0.5 * r.wet
    # the clear frames' margin: one smoothed Pi per frame judged clear, under the threshold
    # wherever no rain was said; a rain scene has no clear frame after the warm-up
    assert len(c.clear_pi) == c.judged_clear and not r.clear_pi
    assert all(0.0 <= p <= 1.0 for p in c.clear_pi)
    if c.false_frames == 0:
        assert max(c.clear_pi) < ev.PI_RAIN


def test_the_clear_frames_margin_pools_the_scenes() -> None:
    a = ev.CaseResult("a", "clear", "static", 0.0, 25.0, judged_clear=100)
    a.clear_pi = [0.0] * 98 + [0.2, 0.3]
    b = ev.CaseResult("b", "clear", "wind", 0.0, 25.0, judged_clear=100)
    b.clear_pi = [0.1] * 100
    _, totals = ev.table([a, b])
    p99 = totals[f"smoothed Pi on clear frames, 99th percentile (rain at {ev.PI_RAIN:g})"]
    assert p99 == pytest.approx(np.percentile(a.clear_pi + b.clear_pi, 99))
    assert 0.1 < p99 < 0.3 and totals["smoothed Pi on clear frames, highest"] == 0.3
    text = ev.render("tuning", [a, b], 1.0, markdown=False)
    assert "- smoothed Pi on clear frames, highest: 0.30" in text


def test_the_type_confusion_matrix_adds_the_scenes_up() -> None:
    a = ev.CaseResult("a", "snow", "static", 1.0, 25.0)
    a.types.update({("snow", "snow"): 30, ("snow", "unknown"): 10, ("clear", "unknown"): 5})
    b = ev.CaseResult("b", "light", "wind", 1.0, 25.0)
    b.types.update({("rain", "rain"): 45, ("rain", "snow"): 5, ("clear", "rain"): 5})
    rows = ev.confusion([a, b])
    assert rows[0] == ["clear (10)", "5 (50.0 %)", "0 (0.0 %)", "5 (50.0 %)"]
    assert rows[1] == ["rain (50)", "45 (90.0 %)", "5 (10.0 %)", "0 (0.0 %)"]
    assert rows[2] == ["snow (40)", "0 (0.0 %)", "30 (75.0 %)", "10 (25.0 %)"]
    assert ev.confusion([])[0] == ["clear (0)", "-", "-", "-"]
    text = ev.render("tuning", [a, b], 1.0, markdown=True)
    assert (
        "| truth (frames) | rain | snow | unknown |" in text and "| rain (50) | 45 (90.0 %)" in text
    )


def test_h264_scenes_come_back_compressed_frame_for_frame() -> None:
    tuning = sample_cases("tuning", per_cell=3, frames=10)
    evaluation = sample_cases("evaluation", per_cell=3, frames=10)
    assert {c.h264_crf for c in tuning} >= {None, 23, 28}
    assert {c.h264_crf for c in evaluation} >= {None, 26, 32}
    assert all(c.params.jpeg_quality is None for c in tuning + evaluation if c.h264_crf)
    assert any(c.width == 1920 for c in evaluation) and all(c.width < 1920 for c in tuning)
    assert any(c.width == 1600 for c in tuning)  # the tuning split's large frame
    case = replace(next(c for c in tuning if c.h264_crf), width=161, height=121, frames=12)
    plain = list(case_frames(replace(case, h264_crf=None)))
    coded = list(case_frames(case))
    assert len(coded) == 12 and all(f.gray.shape == (121, 161) for f in coded)
    diff = [np.abs(a.gray.astype(int) - b.gray).mean() for a, b in zip(plain, coded, strict=True)]
    assert all(0.05 < d < 8.0 for d in diff), diff  # compressed, and still the same frame


def test_truth_of_a_knocked_camera() -> None:
    case = sample_case("tuning", 2, condition="moderate", camera="knock", frames=80)
    case = replace(case, width=160, height=120, reaim=(40, 43))
    assert case.roll_deg != 0 and 1.0 <= abs(case.roll_deg) <= 4.0
    frames = list(case_frames(case))
    assert [f.moving for f in frames] == [40 <= i < 43 for i in range(80)]
    before, after = frames[39], frames[43]
    # the drawn orientation turns with the view: back by the roll once the knock is over
    assert after.mu == pytest.approx(before.mu - math.radians(case.roll_deg))
    assert frames[41].mu == pytest.approx(before.mu - math.radians(case.roll_deg) * 2 / 3)


@pytest.mark.parametrize("roll", [-4.0, 3.0])
def test_a_roll_turns_orientations_as_the_truth_says(roll: float) -> None:
    """The sign convention of ``case_frames``: OpenCV's rotation (counter-clockwise as shown)
    turns a streak's orientation (from x toward y, clockwise as shown) back by the roll."""
    import cv2

    from hos.moments import blob_moments

    img = np.zeros((201, 201), np.uint8)
    theta = math.radians(70.0)
    dx, dy = 60 * math.cos(theta), 60 * math.sin(theta)
    cv2.line(img, (round(100 - dx), round(100 - dy)), (round(100 + dx), round(100 + dy)), 255, 3)
    m = cv2.getRotationMatrix2D((100.0, 100.0), roll, 1.0)

    def orientation(image: np.ndarray) -> float:
        ys, xs = np.nonzero(image > 127)
        return float(blob_moments(xs, ys, np.ones(xs.size, np.intp), 2).theta[1])

    drawn = orientation(img)  # 70 degrees, as rasterised
    got = orientation(cv2.warpAffine(img, m, (201, 201)))
    assert ev.wrapped_deg(got, drawn - math.radians(roll)) < 0.2
    assert ev.wrapped_deg(got, drawn + math.radians(roll)) > 5.0


def test_visible_streaks_are_counted_against_a_dry_twin_of_the_same_scene() -> None:
    """The twin draws everything but the streaks: the same street, traffic, noise and
    codec; what differs is the rain, and only where the streaks are bright enough."""
    case = sample_case("tuning", 1, condition="moderate", camera="wind", frames=4)
    params = replace(case.params, jpeg_quality=None, sensor_noise=0.0)
    case = replace(case, h264_crf=None, params=params)
    dry = ev._dry_twin(case)
    assert ev._dry_twin(dry) is not None and dry.params.rain.count == 0
    assert (
        ev._dry_twin(sample_case("tuning", 0, condition="clear", camera="static", frames=6)) is None
    )
    for wet, twin in zip(case_frames(case), case_frames(dry), strict=True):
        assert wet.precipitation and wet.streaks.any()
        # away from the streaks the two renders are the same image, but for the faint parts
        # of streaks (under 3 grey levels, not in the mask) and the shake's interpolation
        near = cv2.dilate(wet.streaks.view(np.uint8), np.ones((3, 3), np.uint8)).view(bool)
        far = np.abs(wet.gray.astype(int) - twin.gray)[~near]
        assert far.max() <= 3 and np.mean(far > 0) < 0.2
        n = ev.visible_streaks(wet.gray, twin.gray, wet.streaks)
        assert 20 <= n <= 2 * case.params.rain.count, n
        # the streaks are faint: a margin far above their brightness leaves none
        assert ev.visible_streaks(wet.gray, twin.gray, wet.streaks, c=250) == 0
        assert ev.visible_streaks(twin.gray, twin.gray, wet.streaks) == 0
    noisy = replace(case, params=replace(case.params, sensor_noise=4.0))
    assert ev.visible_margin(noisy) == pytest.approx(12.0)  # 3 sigma of the sensor noise
    assert ev.visible_margin(case) == pytest.approx(3.0)  # eq. 8's c


def test_overrides_are_literals_or_bare_words() -> None:
    """``--set``: Python literals, and a bare word as a string; an unknown value is refused by
    the parameters' own checks."""
    p = ev.detector_params(
        ("robustness.stabilise=False", "decision.min_blobs=10", "robustness.motion_gradient=mean")
    )
    assert p.robustness.stabilise is False and p.decision.min_blobs == 10
    assert p.robustness.motion_gradient == "mean"
    assert (
        ev.detector_params(('robustness.motion_gradient="reference"',)).robustness.motion_gradient
        == "reference"
    )
    with pytest.raises(ValueError, match="motion_gradient"):
        ev.detector_params(("robustness.motion_gradient=sideways",))
    # TOML's spelling of a switch is a switch, not a (truthy) word; a word is no switch
    assert ev.detector_params(("robustness.shade_relevel=false",)).robustness.shade_relevel is False
    assert ev.detector_params(("robustness.stabilise=TRUE",)).robustness.stabilise is True
    with pytest.raises(ValueError, match="shade_relevel"):
        ev.detector_params(("robustness.shade_relevel=off",))
    with pytest.raises(ValueError, match="min_blobs"):
        ev.detector_params(("decision.min_blobs=many",))


def test_conditions_select_the_same_scenes_as_the_full_run() -> None:
    cases = sample_cases("tuning", per_cell=2, frames=50)
    faint = ev.select_conditions(cases, "drizzle, light")
    assert {c.condition for c in faint} == {"drizzle", "light"}
    assert [c.name for c in faint] == [c.name for c in cases if c.condition in ("drizzle", "light")]
    assert ev.select_conditions(cases, None) == cases
    for bad in ("rain", "drizzle,hail", ","):
        with pytest.raises(ValueError, match="choose from clear"):
            ev.select_conditions(cases, bad)
    with pytest.raises(SystemExit):
        ev.main(["--conditions", "hail"])


def test_a_scenes_view_is_named() -> None:
    case = sample_case("tuning", 9, condition="drizzle", camera="static", frames=50)
    plain = replace(case.params, view_zoom=1.0, view_centre=(0.5, 0.5), view_roll_deg=0.0)
    assert ev.view_name(replace(case, params=replace(plain, view_mirror=False))) == ""
    assert ev.view_name(replace(case, params=replace(plain, view_mirror=True))) == "mirrored"
    rolled = replace(plain, view_zoom=1.2, view_roll_deg=-1.5, view_centre=(0.45, 0.5))
    assert ev.view_name(replace(case, params=rolled)) == "x1.20 roll -1.5"


def test_the_scenes_table_says_where_a_rows_misses_are() -> None:
    case = sample_case("tuning", 9, condition="drizzle", camera="static", frames=50)
    jpeg = replace(case, h264_crf=None, params=replace(case.params, jpeg_quality=60))
    assert ev.codec_name(jpeg) == "JPEG 60"
    assert ev.codec_name(replace(jpeg, h264_crf=26)) == "H.264 CRF 26"
    assert ev.codec_name(replace(jpeg, params=replace(jpeg.params, jpeg_quality=None))) == "none"
    a = ev.CaseResult("a", "drizzle", "static", 1.0, 20.0, (1280, 720), "H.264 CRF 26", 0.52)
    a.view, a.lens = "x1.32 roll -2.1 mirrored", 0.8
    a.wet, a.detected, a.judged_still = 285, 16, 285
    a.types.update({("rain", "unknown"): 269, ("rain", "rain"): 16})
    b = ev.CaseResult("b", "clear", "wind", 0.0, 10.0, (320, 240), "none", 0.0)
    b.judged_clear = b.judged_still = 200
    b.types.update({("clear", "unknown"): 200})
    rows = ev.scene_rows([a, b])
    assert rows[0] == [
        "a",
        "1280x720",
        "20",
        "H.264 CRF 26",
        "0.52",
        "x1.32 roll -2.1 mirrored",
        "0.8",
        "-",
        "16/285",
        "0/285",
        "rain: rain 16, rain: unknown 269",
    ]
    assert rows[1][4:9] == ["-", "-", "-", "0/200", "-"]
    assert "scenes:" not in ev.render("tuning", [a, b], 1.0, markdown=False)
    text = ev.render("tuning", [a, b], 1.0, markdown=True, scenes=True)
    assert (
        "| a | 1280x720 | 20 | H.264 CRF 26 | 0.52 | x1.32 roll -2.1 mirrored | 0.8 | - |" in text
    )


def test_first_draws_other_scenes_of_the_same_split() -> None:
    # --first N: scenes not yet looked at, numbered on from N, each the scene of its index
    cases = sample_cases("evaluation", per_cell=1, frames=10)
    later = sample_cases("evaluation", per_cell=1, frames=10, first=1000)
    assert [c.name.split("-", 2)[2] for c in later] == [c.name.split("-", 2)[2] for c in cases]
    assert later[0].name == "evaluation-1000-clear-static"
    assert {c.seed for c in later}.isdisjoint({c.seed for c in cases})
    assert later[3] == sample_case(
        "evaluation", 1003, condition=later[3].condition, camera=later[3].camera, frames=10
    )
    with pytest.raises(ValueError, match="first"):
        sample_cases("evaluation", first=-1)
    with pytest.raises(SystemExit):
        ev.main(["--first", "-1"])
