"""A full disk, for real: the daemon on a small tmpfs keeps running, its budget deletes the
oldest files before the disk fills, a disk filled by someone else drops and counts messages,
and when room returns recording resumes and the abandoned file is repaired."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from tests.conftest import REPO, tmpfs

pytestmark = pytest.mark.e2e

CONFIG = """
[site]
id = "fulldisk"
state_dir = "{state}"
[zenoh]
enabled = false
[recording]
dir = "{rec}"
rotate_mb = 0.1
budget_mb = 100
min_free_mb = {min_free_mb}
flush_interval_s = 0.2
[publish]
status_interval_s = 1.0
"""


@pytest.fixture
def small_disk(tmp_path: Path):
    """A 4 MiB tmpfs, unmounted afterwards (root can mount one on these machines)."""
    with tmpfs(tmp_path / "disk", "4m") as mount:
        yield mount


def _free(path: Path) -> int:
    st = os.statvfs(path)
    return st.f_bavail * st.f_frsize


def _fill(path: Path, filler: Path, leave: int) -> None:
    """Grow ``filler`` until ``path``'s filesystem has about ``leave`` bytes free."""
    size = filler.stat().st_size if filler.exists() else 0
    with open(filler, "ab") as f:
        f.write(b"\0" * max(0, _free(path) - leave))
    assert filler.stat().st_size >= size


def _wait_for(log: Path, text: str, timeout: float) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        content = log.read_text()
        if text in content:
            return content
        time.sleep(0.2)
    raise AssertionError(f"no {text!r} in the log within {timeout} s:\n{log.read_text()[-3000:]}")


class _Daemon:
    """``weatherd run`` recording to ``rec``, its log in ``log``."""

    def __init__(self, tmp_path: Path, rec: Path, *, min_free_mb: float):
        config = tmp_path / "weatherd.toml"
        config.write_text(CONFIG.format(state=tmp_path / "state", rec=rec, min_free_mb=min_free_mb))
        self.rec, self.log = rec, tmp_path / "run.log"
        with open(self.log, "w") as out:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "daemon.cli", "run", "--config", str(config)],
                cwd=REPO,
                env={**os.environ, "PYTHONPATH": str(REPO), "HOS_JIT": "0"},
                stdout=out,
                stderr=subprocess.STDOUT,
            )

    def wait_for(self, text: str, timeout: float) -> str:
        return _wait_for(self.log, text, timeout)

    def stop(self) -> str:
        """SIGTERM; the log, after checking the exit status and that every file is finished
        and readable."""
        self.proc.send_signal(signal.SIGTERM)
        status = self.proc.wait(timeout=30)
        text = self.log.read_text()
        assert status == 0, text[-3000:]
        assert "Traceback" not in text and "internal error" not in text
        assert list(self.rec.glob("*.mcap.part")) == []
        return text

    def statuses(self) -> list[dict]:
        out = []
        for path in sorted(self.rec.glob("*.mcap")):
            with open(path, "rb") as f:
                for _, channel, message in make_reader(f).iter_messages():
                    if channel.topic == "/status":
                        out.append(json.loads(message.data)["recorder"])
        return out


def test_the_budget_deletes_oldest_files_before_the_disk_is_full(small_disk, tmp_path):
    _fill(small_disk, small_disk / "someone-else", leave=450_000)
    daemon = _Daemon(tmp_path, small_disk / "rec", min_free_mb=0.35)
    try:
        daemon.wait_for("for the disk budget", timeout=40)
        time.sleep(3.0)
    finally:
        text = daemon.stop()
    assert "No space left" not in text and "recording stopped" not in text
    recorder = daemon.statuses()[-1]
    assert recorder["files_deleted"] >= 1 and recorder["dropped"] == 0


def test_a_disk_filled_by_others_drops_counts_and_recovers(small_disk, tmp_path):
    filler = small_disk / "someone-else"
    _fill(small_disk, filler, leave=200_000)
    daemon = _Daemon(tmp_path, small_disk / "rec", min_free_mb=0)
    try:
        daemon.wait_for("finished", timeout=40)  # a first file, finished before the disk fills
        time.sleep(1.5)  # the next file holds a second of flushed messages when the disk fills
        _fill(small_disk, filler, leave=0)
        daemon.wait_for("recording stopped", timeout=20)
        time.sleep(2.0)
        assert daemon.proc.poll() is None  # the daemon runs on, dropping and counting
        filler.unlink()  # room returns
        daemon.wait_for("recording resumed", timeout=20)
        daemon.wait_for("repaired", timeout=20)  # the file abandoned at the failure
        time.sleep(1.5)  # a status after the episode
    finally:
        daemon.stop()
    recorder = daemon.statuses()[-1]
    assert recorder["dropped"] > 0 and recorder["files_repaired"] >= 1
