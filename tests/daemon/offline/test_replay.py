"""``weatherd replay``: the daemon's MCAP topics, offline, with frame times from --start/--fps."""

from __future__ import annotations

import json
import subprocess
from collections import Counter
from pathlib import Path

import pytest
from mcap.reader import make_reader

from drivers.simulator import Scene, SceneParams, StreakParams, write_video
from tests.conftest import (
    run_weatherd,
)
from tests.daemon.transport.schemas import validate

START_NS = 1_729_080_000 * 10**9  # 2024-10-16T12:00:00Z
N = 120


@pytest.fixture(scope="module")
def clip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    scene = Scene(
        320,
        240,
        seed=3,
        params=SceneParams(
            rain=StreakParams(mu_deg=100.0, sigma_deg=6.0, count=150, length_px=9.0),
            sensor_noise=1.0,
        ),
    )
    path = tmp_path_factory.mktemp("clip") / "rain.mp4"
    write_video(path, (gray for gray, _ in scene.frames(0, N)), fps=25)
    return path


def weatherd(*args: object) -> subprocess.CompletedProcess[str]:
    return run_weatherd(*args)


def messages(path: Path) -> list[tuple[str, dict, int]]:
    with open(path, "rb") as f:
        return [
            (channel.topic, json.loads(msg.data), msg.log_time)
            for _, channel, msg in make_reader(f).iter_messages()
        ]


def test_replay_writes_the_daemon_topics_at_the_given_times(clip: Path, tmp_path: Path) -> None:
    out = tmp_path / "replay.mcap"
    proc = weatherd(
        "replay", clip, clip, "--out", out, "--start", "2024-10-16T12:00:00Z", "--fps", "5"
    )
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["frames"] == 2 * N and summary["videos"] == 2
    got = messages(out)
    topics = Counter(topic for topic, *_ in got)
    assert topics["/hos/replay/frame"] == 2 * N
    assert topics["/hos/replay/histogram"] == 2 * N
    assert topics["/hos/replay/thumbnail"] >= 2
    assert topics["/weather/state"] >= 30  # once a second of video time: 48 s at 5 fps
    frames = [(m, t) for topic, m, t in got if topic == "/hos/replay/frame"]
    for i, (m, t) in enumerate(frames):
        validate(m)
        assert m["t_ns"] == t == START_NS + i * 200_000_000  # the second clip follows the first
    assert frames[0][0]["t"] == "2024-10-16T12:00:00.000000Z"
    for topic, m, _ in got:
        if topic in ("/weather/state", "/hos/replay/summary", "/hos/replay/histogram"):
            validate(m)
    assert any(m["rain"] for m, _ in frames)


def test_replay_without_start_uses_the_file_time(clip: Path, tmp_path: Path) -> None:
    out = tmp_path / "r.mcap"
    mtime = clip.stat().st_mtime_ns
    assert weatherd("replay", clip, "--out", out).returncode == 0
    first = next(t for topic, _, t in messages(out) if topic == "/hos/replay/frame")
    assert first == mtime


@pytest.mark.parametrize(
    ("args", "names"),
    [
        (["replay", "missing.mp4", "--out", "x.mcap"], "missing.mp4"),
        (["replay", "CLIP", "--out", "x.mcap", "--start", "yesterday"], "--start"),
        (["replay", "CLIP", "--out", "x.mcap", "--fps", "0"], "--fps"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    clip: Path, tmp_path: Path, args: list[str], names: str
) -> None:
    args = [
        str(clip) if a == "CLIP" else str(tmp_path / a) if a.endswith("mcap") else a for a in args
    ]
    proc = weatherd(*args)
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and lines[0].startswith("weatherd: error: ") and names in lines[0]
