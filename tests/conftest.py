"""Shared test helpers: where the real fixtures live (beside the checkout, never copied in)."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_FIXTURES = REPO.parent / "shared" / "fixtures"

# The suite runs one pytest-xdist worker per core (`make test`). OpenCV would give each worker
# its own pool of one thread per core too, and on CI's two cores four busy threads then take
# turns: the same tests took about 5 % more CPU time (tests/hos/test_acceptance.py, alternated
# runs). Each worker, and every weatherd it starts, uses one OpenCV thread; the environment
# variable is read by OpenCV when it is first imported.
if int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")) > 1:
    os.environ.setdefault("OPENCV_FOR_THREADS_NUM", "1")


@pytest.fixture
def shared_fixtures() -> Path:
    """``../shared/fixtures``; the test is skipped when the folder is absent."""
    if not SHARED_FIXTURES.is_dir():
        pytest.skip("../shared/fixtures is not beside this checkout")
    return SHARED_FIXTURES


def run_weatherd(*args: object, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """``weatherd ARGS...`` as a subprocess of this checkout, output captured as text."""
    return subprocess.run(
        [sys.executable, "-m", "daemon.cli", *map(str, args)],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def run_python(code: str, **env: str) -> str:
    """What ``python -c CODE`` prints, in a fresh interpreter of this checkout with ``env``
    added to the environment (for what a process imports or sets up at start)."""
    return subprocess.run(
        [sys.executable, "-c", code],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO), **env},
        capture_output=True,
        text=True,
        check=True,
    ).stdout


@contextlib.contextmanager
def tmpfs(mount: Path, size: str) -> Iterator[Path]:
    """A tmpfs of ``size`` (``64k``, ``4m``) mounted at ``mount`` (made if missing), unmounted
    afterwards; the test is skipped where it cannot be mounted (root is needed)."""
    mount.mkdir(exist_ok=True)
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mount)], capture_output=True
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode(errors='replace').strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)
