"""bench/eval_clips.py, the real-clip report of docs/method.md: on a clip written here (a
clear street, then rain), and on files it cannot read."""

from __future__ import annotations

import importlib.util
import inspect
import sys

import numpy as np
import pytest

from drivers.simulator import Scene, SceneParams
from drivers.simulator.precipitation import StreakParams
from drivers.simulator.video_writer import write_video
from tests.conftest import REPO

_spec = importlib.util.spec_from_file_location("eval_clips", REPO / "bench" / "eval_clips.py")
clips = importlib.util.module_from_spec(_spec)
sys.modules["eval_clips"] = clips  # its dataclass looks its module up
_spec.loader.exec_module(clips)


@pytest.fixture
def remembered(monkeypatch) -> dict:
    """``clips.evaluate`` made to remember its result for a clip and a set of arguments, for the
    test's own calls and those of ``clips.main``: main given the arguments of an evaluation the
    test made already prints that evaluation's result rather than running the detector over
    the clip again (the same frames, decoded, drawn from a seeded generator and judged by a
    fresh detector: the same result). Arguments that main passes otherwise than the test (a
    flag not passed on, say) are evaluated anew. The results, by their arguments."""
    real, signature = clips.evaluate, inspect.signature(clips.evaluate)
    done: dict = {}

    def evaluate(*args, **kwargs):
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()
        key = tuple(bound.arguments.items())
        if key not in done:
            done[key] = real(*args, **kwargs)
        return done[key]

    monkeypatch.setattr(clips, "evaluate", evaluate)
    return done


def _street(tmp_path, *, seed: int):
    """A 200-frame MJPEG street at 320x240, 25 fps: clear for 120 frames, then rain."""
    rain = StreakParams(count=250, length_px=10.0, brightness=40.0, mu_deg=95)
    params = SceneParams(fps=25.0, cars=1, rain=rain, schedule=[0.0] * 120 + [1.0] * 80)
    scene = Scene(320, 240, seed=seed, params=params)
    path = tmp_path / "street.avi"
    write_video(path, (scene.frame(i)[0] for i in range(200)), fps=25, codec="mjpeg")
    return path


def test_a_clip_that_turns_to_rain_is_reported_with_its_episode(
    tmp_path, capsys, remembered
) -> None:
    path = _street(tmp_path, seed=5)
    bad = tmp_path / "notes.txt"
    bad.write_text("not a video\n")

    r = clips.evaluate(path)
    assert r.frames == 200 and r.size == (320, 240) and r.fps == 25.0
    assert r.counted == 200 - clips.SETTLE and r.judged == r.counted
    assert 60 <= r.rain <= 80  # the rain's 80 frames, less the detector's latency
    assert r.episodes == 1 and r.longest == r.rain
    # every frame said rain has a type, and streaks drawn anew every frame are never snow
    assert sum(r.types.values()) == r.rain and r.types["snow"] == 0 and r.types["rain"] > 0
    # one smoothed Pi per judged frame: over the threshold in the rain
    assert len(r.pi_smoothed) == r.judged and max(r.pi_smoothed) > 0.35

    assert clips.main([str(path), str(bad), "--markdown"]) == 1  # one clip could not be read
    out, err = capsys.readouterr()
    assert out.startswith("| clip | size |") and "| street.avi | 320x240 | 25.0 | 200 |" in out
    assert "| longest | typed | Pi~ p99 | Pi~ max |" in out
    assert f"| rain {r.types['rain']}" in out
    assert "notes.txt: cannot be read as a video" in err


def test_a_second_pass_counts_the_whole_clip_and_its_parts(tmp_path, capsys, remembered) -> None:
    path = _street(tmp_path, seed=6)

    once = clips.evaluate(path, part_s=2.0)
    # the warm-up is not counted: the first part holds frames 90-99 only
    assert once.counted == 200 - clips.SETTLE
    assert sum(j for j, _ in once.parts.values()) == once.judged
    assert set(once.parts) == {1, 2, 3} and once.parts[1] == [10, 0]

    twice = clips.evaluate(path, passes=2, part_s=2.0)
    assert twice.counted == 200 and twice.judged == 200  # the whole clip, nothing to warm up
    assert set(twice.parts) == {0, 1, 2, 3}
    judged, said = twice.parts[0]  # the loop comes back to clear weather, and the rain ends
    assert judged == 50 and said < 50
    # rain from frame 120 (the third part's 21st frame), said within the latency
    assert twice.parts[1] == [50, 0] and 20 <= twice.parts[2][1] <= 30 and twice.parts[3][1] == 50
    assert twice.rain == sum(s for _, s in twice.parts.values()) and twice.episodes == 2

    assert clips.main([str(path), "--passes", "2", "--parts", "2"]) == 0
    out, _ = capsys.readouterr()
    assert "street.avi, rain % of the judged frames of each 2 s: 0-2 s " in out
    assert ", 6-8 s 100" in out

    with pytest.raises(ValueError, match="passes"):
        clips.evaluate(path, passes=0)


def _clear_street(tmp_path, *, seed: int):
    """A 200-frame MJPEG street at 320x240, 25 fps, clear throughout."""
    scene = Scene(320, 240, seed=seed, params=SceneParams(fps=25.0, cars=1))
    path = tmp_path / "clear.avi"
    write_video(path, (scene.frame(i)[0] for i in range(200)), fps=25, codec="mjpeg")
    return path


def test_rain_drawn_over_a_clear_clip_is_told_apart_from_before_it(
    tmp_path, capsys, remembered
) -> None:
    """``--draw``: the benchmark's light rain drawn from 4.8 s (frame 120) on. Before it
    no frame is said rain, from a second after it began (frame 145) nearly all are; the same
    clip without it says rain on no frame, so the drawn rain is what is seen."""
    path = _clear_street(tmp_path, seed=7)
    dry = clips.evaluate(path)
    assert dry.rain == 0 and max(dry.pi_smoothed) < 0.35  # the dry clip's margin

    r = clips.evaluate(path, draw="light", draw_from_s=4.8)
    assert r.before_drawn == [30, 0]  # frames 90-119, judged, none said rain
    judged, said = r.with_drawn
    assert judged == 55 and said >= 0.9 * judged
    assert r.rain >= said
    assert r.drawn_types["rain"] >= 0.9 * judged and r.drawn_types["snow"] == 0

    assert clips.main([str(path), "--draw", "light", "--draw-from", "4.8"]) == 0
    out, _ = capsys.readouterr()
    assert "clear.avi, light drawn from 4.8 s: said rain before it on 0.0 % (0 of 30)" in out

    with pytest.raises(ValueError, match="must be one of"):
        clips.evaluate(path, draw="hail")


@pytest.mark.parametrize("name", ["motorway_clear_320x240.avi", "road_surface_clear_640x360.avi"])
def test_rain_drawn_over_real_clear_clips_is_seen(shared_fixtures, name) -> None:
    """Synthetic rain over a real background (docs/figures.md, "Rain drawn over real clear
    clips"): the benchmark's light rain from 8 s on. No rain before it, rain on nine judged
    frames in ten or more from a second after it began (98 and 100 % when measured)."""
    r = clips.evaluate(shared_fixtures / "video" / name, draw="light", draw_from_s=8.0)
    assert r.before_drawn[0] > 100 and r.before_drawn[1] == 0
    judged, said = r.with_drawn
    assert judged > 100 and said >= 0.9 * judged


@pytest.fixture(scope="module")
def clear_for_snow(tmp_path_factory):
    """The clear street both kinds of snow are drawn over, written once for both."""
    return _clear_street(tmp_path_factory.mktemp("snow"), seed=8)


@pytest.mark.parametrize("kind", ["snow", "falling-snow"])
def test_snow_drawn_over_a_clear_clip_is_seen_and_typed_snow(clear_for_snow, kind) -> None:
    """``--draw snow`` and ``falling-snow``: the benchmark's snow over a written clear street
    from 4.8 s on is precipitation on nearly every judged frame from a second after it began,
    and the camera types it snow, never rain."""
    r = clips.evaluate(clear_for_snow, draw=kind, draw_from_s=4.8)
    assert r.before_drawn[1] == 0
    judged, said = r.with_drawn
    assert judged == 55 and said >= 0.9 * judged
    assert r.drawn_types["rain"] == 0 and r.drawn_types["snow"] >= 0.8 * judged


def test_upscale_enlarges_every_frame_to_the_rows_asked(tmp_path, capsys, remembered) -> None:
    """``--upscale ROWS``: a soft camera's picture, the width in proportion and even."""
    assert clips.upscaled_size((320, 240), 720) == (960, 720)
    assert clips.upscaled_size((640, 360), 1080) == (1920, 1080)
    assert clips.upscaled_size((321, 240), 480) == (642, 480)
    gray = (np.arange(240 * 320) % 251).astype(np.uint8).reshape(240, 320)
    big = clips.upscale(gray, 480)
    assert big.shape == (480, 640) and big.dtype == np.uint8
    # Lanczos keeps a flat picture flat and a smooth one close to its twice-sampled self
    ramp = np.tile(np.linspace(20, 220, 320, dtype=np.float32), (240, 1)).astype(np.uint8)
    assert np.abs(clips.upscale(ramp, 480)[::2, 40:-40:2].astype(int) - ramp[:, 20:-20]).max() <= 2

    path = _street(tmp_path, seed=7)
    r = clips.evaluate(path, max_frames=120, upscale_rows=480)
    assert r.size == (640, 480) and r.frames == 120
    assert clips.main([str(path), "--upscale", "480", "--max-frames", "120"]) == 0
    assert "640x480" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        clips.main([str(path), "--upscale", "-1"])
