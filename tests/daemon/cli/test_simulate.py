"""``weatherd simulate``, run as a real subprocess: a video the other commands read, the truth
file, the weathers, and one-line errors."""

from __future__ import annotations

import csv
import json

import pytest

from daemon.cli.simulate import schedule
from drivers.errors import InputError
from drivers.video import open_video
from tests.conftest import run_weatherd


def test_writes_a_video_and_its_truth(tmp_path):
    out, truth = tmp_path / "street.mp4", tmp_path / "truth.csv"
    done = run_weatherd(
        "simulate", out, "--seconds", "2", "--fps", "10", "--width", "160", "--height", "96",
        "--weather", "rain", "--intensity", "0,2", "--truth", truth, "--seed", "3",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert summary["frames"] == 20 and summary["out"] == str(out)
    with open_video(out) as video:
        assert (video.width, video.height) == (160, 96)
        frames = list(video)
    assert len(frames) == 20
    rows = list(csv.DictReader(truth.open()))
    assert [r["frame"] for r in rows] == [str(i) for i in range(20)]
    # two equal steps: clear for the first second, twice the rain for the second
    assert {r["kind"] for r in rows[:10]} == {"clear"}
    assert {r["rain_intensity"] for r in rows[10:]} == {"2"}
    assert all(int(r["particles"]) > 0 for r in rows[10:])


def test_same_seed_same_video(tmp_path):
    args = ["--seconds", "0.4", "--fps", "10", "--width", "96", "--height", "64", "--seed", "5"]
    for name in ("a.mp4", "b.mp4"):
        assert run_weatherd("simulate", tmp_path / name, *args).returncode == 0
    with open_video(tmp_path / "a.mp4") as a, open_video(tmp_path / "b.mp4") as b:
        assert all((fa.gray == fb.gray).all() for fa, fb in zip(a, b, strict=True))


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--width", "63"], "--width/--height"),
        (["--seconds", "0"], "--seconds: must be > 0"),
        (["--intensity", "a,b"], "expected numbers separated by commas"),
        (["--weather", "cycle", "--intensity", "2"], "cannot be used with --weather cycle"),
    ],
)
def test_bad_options_are_one_line_errors(tmp_path, args, expected):
    done = run_weatherd("simulate", tmp_path / "x.mp4", *args)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and expected in done.stderr
    assert not (tmp_path / "x.mp4").exists()


def test_unwritable_output_is_a_one_line_error(tmp_path):
    done = run_weatherd("simulate", tmp_path / "no" / "x.mp4", "--seconds", "0.2")
    assert done.returncode == 2 and "no such directory" in done.stderr


def test_schedule_steps():
    assert schedule("cycle", [1.0], frames=5) is None
    assert schedule("snow", [1.0, 3.0], frames=4) == [(0, 1), (0, 1), (0, 3), (0, 3)]
    assert schedule("clear", [1.0], frames=2) == [(0, 0), (0, 0)]
    with pytest.raises(InputError):
        schedule("rain", [-1.0], frames=2)
