"""The command line starts light: every ``weatherd`` command builds its parser from all the
subcommands' modules, so those import the detector, OpenCV, PyAV and numba only when a
handler needs them. ``weatherd get``, ``watch``, ``instruments`` and ``--help`` then start in
about a fifth of the time (0.15 s against 1.05 s to import ``daemon.cli`` on the 2-core test
machine), and so does every test that runs ``weatherd`` as a subprocess for such a command."""

from __future__ import annotations

import json
import subprocess
import sys

from tests.conftest import REPO

HEAVY = ("cv2", "av", "numba", "numpy", "hos", "pydantic", "zenoh", "daemon.config")


def test_the_parser_imports_nothing_heavy() -> None:
    code = (
        "import json, sys; import daemon.cli; "
        "daemon.cli._parser(); "
        f"print(json.dumps(sorted(m for m in {HEAVY!r} if m in sys.modules)))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True
    )
    assert json.loads(done.stdout) == []


def test_a_command_that_detects_still_finds_its_modules() -> None:
    """The handlers import what the parser no longer does: the demo street, three frames."""
    done = subprocess.run(
        [sys.executable, "-m", "daemon.cli", "detect", "demo:", "--frames", "3", "--jsonl", "-"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert [json.loads(line)["frame"] for line in done.stdout.splitlines()] == [0, 1, 2]
