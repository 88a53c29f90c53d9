"""Issue 11's table for ``weatherd detect``, as real subprocesses: a full output device is a
full disk (exit 74, one line naming the file), random bytes are not a video (exit 2), and the
demo street is a source (issue 13). The configuration cases of the table are in
tests/daemon/service/test_config_agreement.py (check-config and run side by side)."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import REPO, run_weatherd, tmpfs

DEMO_TO_STDOUT = ("detect", "demo:", "--frames", "3", "--jsonl", "-")


def stderr_lines(proc: subprocess.CompletedProcess[str]) -> list[str]:
    return [line for line in proc.stderr.splitlines() if line.strip()]


@pytest.fixture(scope="module")
def dev_full() -> Path:
    path = Path("/dev/full")
    if not (path.exists() and stat.S_ISCHR(path.stat().st_mode)):
        pytest.skip("no /dev/full character device here")
    return path


@pytest.mark.parametrize("to", ["file", "stdout"])
def test_a_full_output_device_is_a_full_disk(dev_full: Path, to: str) -> None:
    if to == "file":
        proc = run_weatherd("detect", "demo:", "--frames", "3", "--jsonl", dev_full)
        name = str(dev_full)
    else:  # weatherd's stdout itself is /dev/full
        with open(dev_full, "w") as full:
            proc = subprocess.run(
                [sys.executable, "-m", "daemon.cli", *DEMO_TO_STDOUT],
                cwd=REPO,
                env={**os.environ, "PYTHONPATH": str(REPO)},
                stdout=full,
                stderr=subprocess.PIPE,
                text=True,
                timeout=120,
            )
        name = "standard output"
    assert proc.returncode == 74, proc.stderr
    assert stderr_lines(proc) == [f"weatherd: error: {name}: no space left on device"]


def test_an_overlay_cannot_be_written_to_a_device_and_the_device_survives(
    dev_full: Path,
) -> None:
    proc = run_weatherd("detect", "demo:", "--frames", "3", "--overlay", dev_full)
    assert proc.returncode == 2, proc.stderr
    assert len(stderr_lines(proc)) == 1 and str(dev_full) in proc.stderr
    assert stat.S_ISCHR(dev_full.stat().st_mode)  # it once unlinked /dev/full


def test_random_bytes_named_bin_are_not_a_video(tmp_path: Path) -> None:
    path = tmp_path / "random.bin"
    path.write_bytes(np.random.default_rng(7).bytes(1_000_000))
    proc = run_weatherd("detect", path)
    assert proc.returncode == 2, proc.stderr
    [line] = stderr_lines(proc)
    assert line.startswith(f"weatherd: error: {path}: not a video")


def test_detect_runs_on_the_demo_street(tmp_path: Path) -> None:
    out = tmp_path / "demo.jsonl"
    proc = run_weatherd("detect", "demo:?seed=2", "--frames", "30", "--jsonl", out)
    assert proc.returncode == 0, proc.stderr
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert [r["frame"] for r in lines] == list(range(30))
    assert lines[-1]["t_s"] == pytest.approx(29 / 25)


def test_the_demo_needs_a_bound_and_live_sources_are_refused() -> None:
    proc = run_weatherd("detect", "demo:")
    assert proc.returncode == 2
    assert stderr_lines(proc) == [
        "weatherd: error: the demo street (demo:) never ends: give --frames N or --seconds S"
    ]
    proc = run_weatherd("detect", "rtsp://user:secret@cam/stream")
    assert proc.returncode == 2 and "secret" not in proc.stderr
    assert "a live camera or stream" in proc.stderr


@pytest.fixture(scope="module")
def good_mcap(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tests.test_fuzz_inputs import _mcap_bytes

    folder = tmp_path_factory.mktemp("mcap")
    path = folder / "good.mcap"
    path.write_bytes(_mcap_bytes(folder))
    return path


def test_recover_never_replaces_a_directory_or_a_device(good_mcap: Path, tmp_path: Path) -> None:
    targets = [tmp_path]
    if os.geteuid() == 0:  # root may make a device node (what /dev/full is)
        device = tmp_path / "null-device"
        os.mknod(device, 0o600 | stat.S_IFCHR, os.makedev(1, 3))
        targets.append(device)
    for target in targets:
        proc = run_weatherd("recover", good_mcap, target)
        assert proc.returncode == 2, proc.stderr
        assert stderr_lines(proc) == [
            f"weatherd: error: {target}: not a regular file (give the name of the MCAP file "
            "to write)"
        ]
    assert tmp_path.is_dir()
    if len(targets) > 1:
        assert stat.S_ISCHR(targets[1].stat().st_mode)


def test_recover_into_a_missing_folder_is_a_clean_error(good_mcap: Path, tmp_path: Path) -> None:
    out = tmp_path / "no" / "such" / "out.mcap"
    proc = run_weatherd("recover", good_mcap, out)
    assert proc.returncode == 2, proc.stderr
    assert stderr_lines(proc) == [
        f"weatherd: error: {out}: cannot write (No such file or directory)"
    ]


@pytest.fixture
def tiny_disk(tmp_path: Path):
    """A 64-KiB tmpfs (root only; skipped where it cannot be mounted)."""
    with tmpfs(tmp_path / "tiny", "64k") as mount:
        yield mount


@pytest.mark.parametrize("output", ["--jsonl", "--overlay"])
def test_a_full_disk_under_an_output_is_named(tiny_disk: Path, output: str) -> None:
    target = tiny_disk / ("out.jsonl" if output == "--jsonl" else "out.mp4")
    proc = run_weatherd("detect", "demo:", "--seconds", "8", output, target)
    assert proc.returncode == 74, proc.stderr
    assert stderr_lines(proc) == [f"weatherd: error: {target}: no space left on device"]
