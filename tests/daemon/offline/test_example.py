"""The worked example of docs/offline.md: the gauge derived from the simulator's truth is a
reference that ``weatherd reference`` reads, with the amounts the truth implies."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.conftest import REPO, run_weatherd

GAUGE = REPO / "docs" / "example" / "gauge_from_truth.py"


def test_gauge_from_the_simulators_truth(tmp_path):
    truth = tmp_path / "truth.csv"
    done = run_weatherd(
        "simulate", tmp_path / "s.mp4", "--seconds", "2", "--fps", "10", "--width", "96",
        "--height", "64", "--weather", "rain", "--intensity", "0,1.5", "--truth", truth,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    gauge = subprocess.run(
        [sys.executable, GAUGE, truth, "--start", "2026-03-01T12:00:00Z", "--interval", "1",
         "--mm-h", "3600", "--noise", "0"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    csv_path = tmp_path / "gauge.csv"
    csv_path.write_text(gauge.stdout)
    read = run_weatherd("reference", csv_path)
    assert read.returncode == 0, read.stderr
    rows = [json.loads(line) for line in read.stdout.splitlines()]
    assert [(r["start"], r["end"]) for r in rows] == [
        ("2026-03-01T12:00:00Z", "2026-03-01T12:00:01Z"),
        ("2026-03-01T12:00:01Z", "2026-03-01T12:00:02Z"),
    ]
    # 3600 mm/h at intensity 1 is 1 mm per second: 0 then 1.5 mm
    assert [r["precip_mm"] for r in rows] == pytest.approx([0.0, 1.5])
    assert {r["station"] for r in rows} == {"example-gauge"}
