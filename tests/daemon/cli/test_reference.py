"""``weatherd reference FILE [--station ID]``: the contract JSON lines, as a subprocess."""

from __future__ import annotations

import gzip
import json
import subprocess
from pathlib import Path

from tests.conftest import (
    run_weatherd,
)


def reference(*args: object) -> subprocess.CompletedProcess[str]:
    return run_weatherd("reference", *args)


def test_hourly_file_with_station_filter(tmp_path: Path) -> None:
    path = tmp_path / "H_75_previous-2020-2022.csv.gz"
    rows = [
        "NUM_POSTE;NOM_USUEL;LAT;LON;ALTI;AAAAMMJJHH;RR1;QRR1",
        "75114001;PARIS-MONTSOURIS;48.82;2.34;75;2022061512;1.4;1",
        "75114001;PARIS-MONTSOURIS;48.82;2.34;75;2022061513;;",
        "75107005;PARIS-LUXEMBOURG;48.84;2.33;46;2022061512;0.8;1",
    ]
    with gzip.open(path, "wt") as f:
        f.write("\n".join(rows) + "\n")
    proc = reference(path, "--station", "75114001")
    assert proc.returncode == 0, proc.stderr
    lines = [json.loads(line) for line in proc.stdout.splitlines()]
    assert [{k: r[k] for k in ("start", "end", "precip_mm", "station")} for r in lines] == [
        {
            "start": "2022-06-15T11:00:00Z",
            "end": "2022-06-15T12:00:00Z",
            "precip_mm": 1.4,
            "station": "75114001",
        },
        {
            "start": "2022-06-15T12:00:00Z",
            "end": "2022-06-15T13:00:00Z",
            "precip_mm": None,
            "station": "75114001",
        },
    ]


def test_real_commande_sample(shared_fixtures: Path) -> None:
    proc = reference(shared_fixtures / "meteofrance" / "commande_horaires_sample.csv")
    assert proc.returncode == 0, proc.stderr
    for line in proc.stdout.splitlines():
        rec = json.loads(line)
        assert {"start", "end", "precip_mm", "station"} <= set(rec)
        assert rec["start"].endswith("Z") and rec["end"] > rec["start"]


def test_not_station_data_is_one_line_and_exit_2(tmp_path: Path) -> None:
    path = tmp_path / "notes.txt"
    path.write_text("hello\nworld\n")
    proc = reference(path)
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert proc.returncode == 2 and len(lines) == 1 and "notes.txt" in lines[0]
