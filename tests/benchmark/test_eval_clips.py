"""bench/eval_clips.py, the real-clip report of docs/method.md: on a clip written here (a
clear street, then rain), and on files it cannot read."""

from __future__ import annotations

import importlib.util
import sys

from drivers.simulator import Scene, SceneParams
from drivers.simulator.precipitation import StreakParams
from drivers.simulator.video_writer import write_video
from tests.conftest import REPO

_spec = importlib.util.spec_from_file_location("eval_clips", REPO / "bench" / "eval_clips.py")
clips = importlib.util.module_from_spec(_spec)
sys.modules["eval_clips"] = clips  # its dataclass looks its module up
_spec.loader.exec_module(clips)


def test_a_clip_that_turns_to_rain_is_reported_with_its_episode(tmp_path, capsys) -> None:
    rain = StreakParams(count=250, length_px=10.0, brightness=40.0, mu_deg=95)
    params = SceneParams(fps=25.0, cars=1, rain=rain, schedule=[0.0] * 120 + [1.0] * 80)
    scene = Scene(320, 240, seed=5, params=params)
    path = tmp_path / "street.avi"
    write_video(path, (scene.frame(i)[0] for i in range(200)), fps=25, codec="mjpeg")
    bad = tmp_path / "notes.txt"
    bad.write_text("not a video\n")

    r = clips.evaluate(path)
    assert r.frames == 200 and r.size == (320, 240) and r.fps == 25.0
    assert r.counted == 200 - clips.SETTLE and r.judged == r.counted
    assert 60 <= r.rain <= 80  # the rain's 80 frames, less the detector's latency
    assert r.episodes == 1 and r.longest == r.rain

    assert clips.main([str(path), str(bad), "--markdown"]) == 1  # one clip could not be read
    out, err = capsys.readouterr()
    assert out.startswith("| clip | size |") and "| street.avi | 320x240 | 25.0 | 200 |" in out
    assert "notes.txt: cannot be read as a video" in err
