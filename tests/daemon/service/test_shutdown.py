"""A clean exit every time: the real daemon started and stopped again and again.

Each run is a real ``weatherd run`` on the demo camera, with Zenoh listening on loopback; some
with a subscriber process attached, some with a present-weather sensor on a pseudo-terminal
speaking the real protocol, some on the compiled kernels and some on the numpy path; stopped
by SIGTERM or SIGINT after a different time. Every run must exit with status 0, say so in its
log, and never print a fatal error: under systemd, anything else is a failure, a restart and a
core dump at every planned stop.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import REPO
from tests.zenoh_tools import SubscriberProcess, free_port, port_open

from .test_e2e_instruments import SimulatedPwd

pytestmark = pytest.mark.e2e

SITE = "stopstart"

#: (seconds running, signal, subscriber attached, instrument attached, compiled kernels)
RUNS = [
    (0.0, signal.SIGTERM, False, False, True),  # stopped as soon as it listens
    (1.0, signal.SIGINT, True, False, True),
    (2.5, signal.SIGTERM, True, True, False),
    (4.0, signal.SIGINT, False, True, True),
    (1.5, signal.SIGTERM, True, False, False),
    (6.0, signal.SIGTERM, True, True, True),
    (3.0, signal.SIGINT, True, True, False),
    (0.5, signal.SIGINT, False, False, False),
]


def _config(tmp: Path, port: int, instrument: bool) -> Path:
    path = tmp / "weatherd.toml"
    text = (
        f'[site]\nid = "{SITE}"\nstate_dir = "{tmp / "state"}"\n'
        f'[zenoh]\nlisten = ["tcp/127.0.0.1:{port}"]\n'
        f'[recording]\ndir = "{tmp / "rec"}"\nflush_interval_s = 0.25\n'
        "[publish]\nstate_interval_s = 0.5\nstatus_interval_s = 1.0\n"
    )
    if instrument:
        text += (
            f'[[instrument]]\nid = "pwd"\ndriver = "vaisala-pwd"\nport = "{tmp / "pwd"}"\n'
            'mode = "automatic"\n'
        )
    path.write_text(text)
    return path


@pytest.mark.parametrize(("seconds", "sig", "subscriber", "instrument", "jit"), RUNS)
def test_every_stop_is_clean(tmp_path, seconds, sig, subscriber, instrument, jit):
    port = free_port()
    config = _config(tmp_path, port, instrument)
    sensor = SimulatedPwd(tmp_path / "pwd", "1", polled=False) if instrument else None
    log = tmp_path / "run.log"
    sub = None
    with open(log, "wb") as err:
        proc = subprocess.Popen(
            [sys.executable, "-m", "daemon.cli", "run", "--config", str(config)],
            cwd=REPO,
            env={**os.environ, "PYTHONPATH": str(REPO), "HOS_JIT": "1" if jit else "0"},
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=err,
        )
    try:
        deadline = time.monotonic() + 30
        while not port_open(port):
            assert proc.poll() is None, log.read_text()
            assert time.monotonic() < deadline, "the daemon does not listen"
            time.sleep(0.05)
        if subscriber:
            sub = SubscriberProcess(f"tcp/127.0.0.1:{port}", f"weather/{SITE}/**").start()
        time.sleep(seconds)
        proc.send_signal(sig)
        status = proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if sub is not None:
            sub.stop()
        if sensor is not None:
            sensor.pull()
    text = log.read_text(errors="replace")
    assert status == 0, text[-3000:]
    assert "Fatal Python error" not in text and "FATAL" not in text, text[-3000:]
    assert "threads still running at exit" not in text, text[-3000:]
    assert f"{signal.Signals(sig).name} received; exited cleanly" in text
    assert list((tmp_path / "rec").glob("*.mcap.part")) == []  # the recording was finished
