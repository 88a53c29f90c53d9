"""Research-station CSVs as they come: other column names, comments, day-first dates, NaN,
trailing separators, running totals."""

from __future__ import annotations

from pathlib import Path

import pytest

from daemon.offline.reference import load_reference
from drivers.errors import InputError
from tests.conftest import run_weatherd

STATION = """# station Tharandt, tipping bucket 0.1 mm
# times: end of the 10-minute interval, CET
Datum;Niederschlag_mm;Temp;
14.05.2023 10:10;0,1;12,3;
14.05.2023 10:20;NaN;12,2;
14.05.2023 10:30;0,4;12,0;
# a maintenance note
14.05.2023 10:40;0,0;11,9;
"""


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "station.csv"
    path.write_text(text)
    return path


def test_named_columns_comments_day_first_dates_nan_and_trailing_separators(tmp_path):
    data = load_reference(
        _write(tmp_path, STATION),
        time_column="Datum",
        amount_column="Niederschlag_mm",
        tz="Etc/GMT-1",
    )
    assert [iv.precip_mm for iv in data.intervals] == [0.1, None, 0.4, 0.0]
    assert data.intervals[0].end.isoformat() == "2023-05-14T09:10:00+00:00"
    assert data.intervals[0].start.isoformat() == "2023-05-14T09:00:00+00:00"
    assert data.stats.malformed == 0


def test_when_no_column_matches_the_error_lists_the_file_s_columns(tmp_path):
    with pytest.raises(InputError) as err:
        load_reference(_write(tmp_path, STATION), fmt="csv")
    assert "the file has: datum, niederschlag_mm, temp" in str(err.value)
    assert "--time-column" in str(err.value)


def test_a_running_total_becomes_amounts_and_survives_a_reset(tmp_path):
    text = "time,counter_mm\n" + "".join(
        f"2024-06-15T12:{m:02d}:00Z,{v}\n"
        for m, v in [(0, 10.0), (10, 10.2), (20, 11.0), (30, 0.3), (40, 0.3)]
    )
    data = load_reference(_write(tmp_path, text), amount_column="counter_mm", cumulative=True)
    assert [iv.precip_mm for iv in data.intervals] == [None, 0.2, 0.8, 0.3, 0.0]


def test_the_command_takes_the_column_options(tmp_path):
    done = run_weatherd(
        "reference",
        _write(tmp_path, STATION),
        "--time-column",
        "Datum",
        "--amount-column",
        "Niederschlag_mm",
    )
    assert done.returncode == 0, done.stderr
    assert len(done.stdout.splitlines()) == 4
