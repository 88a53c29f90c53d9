"""``check-config`` and ``run`` agree: what one refuses, the other refuses with exit status 2
and the same lines; what one accepts, the other starts with (issue 11).

``check-config`` runs in this process (its cost is pydantic and the imports), ``run`` as the
real daemon: a refused file must stop it with the same lines, an accepted one must get past
start-up (its "site ..." line) without Zenoh retrying, then stop cleanly on SIGTERM.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from daemon import cli
from tests.conftest import REPO
from tests.zenoh_tools import free_port

pytestmark = pytest.mark.e2e

#: Off unless a case needs it: most cases are about something else.
NO_ZENOH = "[zenoh]\nenabled = false\n"

#: (name, TOML, the problems named, one line each). Independent problems share a file: each
#: case costs a daemon start.
REFUSED = [
    ("nested", "a = " + "[" * 3000 + "]" * 3000 + "\n", ["nested too deeply"]),
    (
        "non-finite",
        "[recording]\nrotate_s = inf\n[publish]\nstate_interval_s = nan\n"
        '[[instrument]]\nid = "g"\ndriver = "tipping-bucket"\nport = "/dev/null"\n'
        "options = { mm_per_tip = nan }\n",
        [
            "instrument[0].options.mm_per_tip: must be a finite number, got nan",
            "recording.rotate_s: Input should be a finite number",
            "publish.state_interval_s: Input should be a finite number",
        ],
    ),
    (
        "tiny-intervals",
        NO_ZENOH + "[recording]\nrotate_mb = 1e-9\nflush_interval_s = 1e-9\n",
        ["recording.rotate_mb: ", "recording.flush_interval_s: "],
    ),
    (
        "endpoints",
        '[zenoh]\nlisten = ["tcp/127.0.0.1:99999"]\nconnect = ["tcp/127.0.0.1", "tcp/[::1]:0"]\n',
        [
            "zenoh.connect[0]: 'tcp/127.0.0.1': expected HOST:PORT",
            "zenoh.connect[1]: 'tcp/[::1]:0': port must be 1 to 65535",
            "zenoh.listen[0]: 'tcp/127.0.0.1:99999': port must be 0 (any free port) to 65535",
        ],
    ),
    (
        "zenoh-file",
        '[zenoh]\nconfig_file = "{zfile}"\n',
        [
            "zenoh.config_file: {zfile}: connect/endpoints: 'tcp/x': expected HOST:PORT",
            "zenoh.config_file: {zfile}: listen/endpoints: 'tcp/127.0.0.1:99999': port must",
        ],
    ),
    (
        "huge-camera",
        NO_ZENOH + '[[camera]]\nid = "c"\nsource = "demo:"\nwidth = 8192\nheight = 8192\n',
        ["camera[0]: width x height = 8192x8192 = 67108864 pixels, more than max_pixels"],
    ),
    (
        "paths",
        NO_ZENOH + '[[camera]]\nid = "c"\nsource = "demo:"\nroi = "/no/mask.png"\n'
        '[calibration]\nfile = "/no/calibration.toml"\n[recording]\ndir = "{file}/rec"\n'
        '[site]\nstate_dir = "{file}/state"\n',
        [
            "roi: /no/mask.png",
            "calibration.file: ",
            "recording.dir: cannot create",
            "site.state_dir: cannot create",
        ],
    ),
]

#: A Zenoh configuration file whose endpoints Zenoh would refuse only when the session opens.
ZENOH_FILE = '{ listen: { endpoints: ["tcp/127.0.0.1:99999"] }, connect: { endpoints: ["tcp/x"] } }'

#: Accepted at the edges of every bound at once, Zenoh listening: run must start with it.
ACCEPTED = (
    '[zenoh]\nlisten = ["tcp/127.0.0.1:{port}"]\n'
    '[recording]\ndir = "{rec}"\nrotate_s = 1\nrotate_mb = 0.1\nbudget_mb = 0.1\n'
    "flush_interval_s = 0.1\nfsync_interval_s = 0.1\nthumbnail_interval_s = 1\n"
    "[publish]\nstate_interval_s = 0.1\ncamera_interval_s = 0.1\nstatus_interval_s = 0.1\n"
    '[[camera]]\nid = "c"\nsource = "demo:"\nwidth = 1920\nheight = 1080\nfps = 5\n'
)


def check_config(capsys: pytest.CaptureFixture[str], path: Path) -> tuple[int, list[str]]:
    capsys.readouterr()
    status = cli.main(["check-config", str(path)])
    captured = capsys.readouterr()
    return status, captured.err.splitlines()


def errors_of(lines: list[str]) -> list[str]:
    return [line for line in lines if line.startswith("weatherd: error: ")]


def start_run(path: Path, log: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "daemon.cli", "run", "--config", str(path)],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=log.open("wb"),
    )


@pytest.mark.parametrize(("name", "text", "named"), REFUSED, ids=[c[0] for c in REFUSED])
def test_refused_by_both_with_the_same_lines(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, name: str, text: str, named: list[str]
) -> None:
    zfile = tmp_path / "zenoh.json5"
    zfile.write_text(ZENOH_FILE)
    path = tmp_path / f"{name}.toml"
    path.write_text(text.replace("{file}", str(REPO / "README.md")).replace("{zfile}", str(zfile)))
    named = [what.replace("{zfile}", str(zfile)) for what in named]
    status, lines = check_config(capsys, path)
    assert status == 2, lines
    lines = errors_of(lines)  # warnings may come before (a state file that cannot be read)
    assert len(lines) == len(named), lines
    for line, what in zip(lines, named, strict=True):
        assert line.startswith(f"weatherd: error: {path}: "), line
        assert what in line, line
        assert "internal error" not in line
    log = tmp_path / "run.log"
    proc = start_run(path, log)
    assert proc.wait(60) == 2, log.read_text()
    assert errors_of(log.read_text().splitlines()) == lines


def test_accepted_by_both_and_run_starts(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    path = tmp_path / "edges.toml"
    path.write_text(ACCEPTED.format(rec=tmp_path / "rec", port=free_port()))
    status, lines = check_config(capsys, path)
    assert status == 0, lines
    log = tmp_path / "run.log"
    proc = start_run(path, log)
    try:
        deadline = time.monotonic() + 60
        while "camera(s), Zenoh" not in log.read_text():
            assert proc.poll() is None, log.read_text()
            assert time.monotonic() < deadline, log.read_text()
            time.sleep(0.1)
        time.sleep(1.0)  # the first frames, a Zenoh session opening in the background
        assert proc.poll() is None, log.read_text()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(30) == 0, log.read_text()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    text = log.read_text()
    assert "zenoh open failed" not in text
    assert "ERROR" not in text and "Traceback" not in text, text
