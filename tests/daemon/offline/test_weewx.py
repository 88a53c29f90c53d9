"""A weewx archive (Davis Vantage and other home stations): the SQLite database and its CSV
export. The rows of most tests are BUILT from weewx's schema documentation (its example rows:
dateTime 1413937800, usUnits 1, interval 5); one test reads a real archive found in a public
repository without a licence, so kept out of git in $WEATHERD_DATA/refs (skipped when
absent); see data/PROVENANCE.md."""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path

import pytest

from daemon.offline.reference import detect_format, load_reference
from drivers.errors import InputError
from tests.conftest import run_weatherd

# dateTime (end of the interval, epoch s), usUnits, interval (min), rain (in usUnits' unit)
ROWS = [
    (1413937800, 1, 5, 0.0),  # 2014-10-22T00:30:00Z, US: inches
    (1413938100, 1, 5, 0.01),  # one Vantage bucket tip: 0.01 in = 0.254 mm
    (1413938400, 1, 5, None),
    (1413938700, 17, 5, 0.2),  # METRICWX: mm
    (1413939000, 16, 5, 0.02),  # METRIC: cm
]


def _database(tmp_path: Path, rows=ROWS) -> Path:
    path = tmp_path / "weewx.sdb"
    with sqlite3.connect(path) as db:
        db.execute(
            "CREATE TABLE archive (dateTime INTEGER NOT NULL UNIQUE PRIMARY KEY, "
            "usUnits INTEGER NOT NULL, interval INTEGER NOT NULL, barometer REAL, "
            "outTemp REAL, rain REAL, rainRate REAL)"
        )
        db.executemany(
            "INSERT INTO archive (dateTime, usUnits, interval, barometer, rain) "
            "VALUES (?, ?, ?, 29.938, ?)",
            rows,
        )
    return path


def _csv(tmp_path: Path) -> Path:
    lines = ["dateTime,usUnits,interval,barometer,outTemp,rain,rainRate"]
    for stamp, units, minutes, rain in ROWS:
        lines.append(f"{stamp},{units},{minutes},29.938,56.0,{'' if rain is None else rain},0")
    path = tmp_path / "archive.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


EXPECTED = [0.0, 0.254, None, 0.2, 0.2]
REAL = Path(os.environ.get("WEATHERD_DATA", "/work/data")) / "refs" / "wd8cxb_weewx.sdb"


def test_the_sqlite_archive_in_every_unit_system(tmp_path):
    path = _database(tmp_path)
    assert detect_format(path) == "weewx"
    data = load_reference(path, station="home-vantage")
    assert [iv.precip_mm for iv in data.intervals] == EXPECTED
    first = data.intervals[0]
    assert first.end.isoformat() == "2014-10-22T00:30:00+00:00"
    assert first.start.isoformat() == "2014-10-22T00:25:00+00:00"
    assert first.station == "home-vantage" and data.stats.missing == 1


def test_the_csv_export_reads_the_same(tmp_path):
    path = _csv(tmp_path)
    assert detect_format(path) == "weewx"
    assert [iv.precip_mm for iv in load_reference(path).intervals] == EXPECTED


def test_unknown_units_and_bad_intervals_are_malformed_rows(tmp_path):
    rows = [*ROWS, (1413939300, 3, 5, 0.1), (1413939600, 1, 0, 0.1)]
    data = load_reference(_database(tmp_path, rows))
    assert len(data.intervals) == 5 and data.stats.malformed == 2


def test_a_database_without_the_archive_table_and_a_damaged_one_exit_2(tmp_path):
    other = tmp_path / "other.sdb"
    with sqlite3.connect(other) as db:
        db.execute("CREATE TABLE t (x)")
    with pytest.raises(InputError, match=r"archive\.dateTime"):
        load_reference(other)
    damaged = tmp_path / "damaged.sdb"
    damaged.write_bytes(_database(tmp_path).read_bytes()[:200])
    done = run_weatherd("reference", damaged)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


def test_the_command(tmp_path):
    done = run_weatherd("reference", _database(tmp_path), "--station", "vp2")
    assert done.returncode == 0, done.stderr
    assert "weewx, 5 intervals" in done.stderr and '"station":"vp2"' in done.stdout


@pytest.mark.skipif(not REAL.is_file(), reason=f"{REAL} absent (not redistributable)")
def test_a_real_archive_five_minute_us_units():
    assert detect_format(REAL) == "weewx"
    data = load_reference(REAL)
    ivs = data.intervals
    assert len(ivs) == 5839 and data.stats.malformed == 0
    assert {(iv.end - iv.start).total_seconds() for iv in ivs} == {300.0}
    wet = [iv for iv in ivs if iv.precip_mm]
    assert len(wet) == 141
    # 0.01 in tips stored with float noise (0.009999999989800034) come out as 0.254 mm
    assert wet[0].precip_mm == 0.254 and wet[0].end.isoformat() == "2015-06-21T18:35:00+00:00"
    assert sum(iv.precip_mm for iv in wet) == pytest.approx(3.06 * 25.4, abs=0.01)
