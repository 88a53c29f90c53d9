"""Progress bars of the offline commands (issue 13): on a terminal, in frames, with a total and
an ETA when the total is known; nothing at all when stderr is a pipe."""

from __future__ import annotations

import fcntl
import os
import pty
import struct
import subprocess
import sys
import termios

from tests.conftest import REPO, run_weatherd

SMALL = ["--fps", "10", "--width", "96", "--height", "64"]


def on_a_terminal(*args: object) -> tuple[int, str]:
    """``weatherd ARGS`` with stderr on a pseudo-terminal: (exit status, what stderr showed)."""
    master, slave = pty.openpty()
    # a terminal of 30 x 100: tqdm draws nothing on one of size 0, as a bare pty is
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    proc = subprocess.Popen(
        [sys.executable, "-m", "daemon.cli", *map(str, args)],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        stdout=subprocess.DEVNULL,
        stderr=slave,
    )
    os.close(slave)
    shown = bytearray()
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # the child closed its end
            break
        if not chunk:
            break
        shown += chunk
    os.close(master)
    return proc.wait(timeout=120), shown.decode("utf-8", "replace")


def test_simulate_and_detect_show_frames_on_a_terminal_only(tmp_path):
    clip = tmp_path / "clip.mp4"
    status, shown = on_a_terminal("simulate", clip, "--seconds", "3", *SMALL)
    assert status == 0
    assert "/30" in shown and "frame" in shown  # a total, so tqdm shows n/30 and an ETA
    status, shown = on_a_terminal("detect", clip)
    assert status == 0 and "clip.mp4" in shown and "frame" in shown
    piped = run_weatherd("detect", clip)
    assert piped.returncode == 0
    assert "\r" not in piped.stderr and piped.stderr.count("\n") == 1  # the summary line only
