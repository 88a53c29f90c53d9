"""KNMI hourly and daily files, on real excerpts (tests/daemon/offline/data/PROVENANCE.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

from daemon.offline.reference import detect_format, load_reference
from drivers.errors import InputError
from tests.conftest import run_weatherd

DATA = Path(__file__).parent / "data"
UURGEG = DATA / "uurgeg_260_2000_excerpt.txt"
KNMY = DATA / "knmy_hourly_209_2017_excerpt.txt"


def _by_end(data):
    return {iv.end.strftime("%Y-%m-%d %H"): iv for iv in data.intervals}


def test_a_real_uurgeg_file_is_detected_and_read_in_tenths_of_a_mm():
    assert detect_format(UURGEG) == "knmi"
    data = load_reference(UURGEG)
    assert data.fmt == "knmi" and data.stats.malformed == 0
    assert len(data.intervals) == 18 and {iv.station for iv in data.intervals} == {"260"}
    got = _by_end(data)
    # 29 July 2000, De Bilt: a thunderstorm hour, RH = 217 (21.7 mm) in hour 16 UT
    storm = got["2000-07-29 16"]
    assert storm.precip_mm == pytest.approx(21.7)
    assert storm.start.isoformat() == "2000-07-29T15:00:00+00:00"  # "Uurvak 05: 04-05 UT"
    assert got["2000-07-29 15"].precip_mm == pytest.approx(0.8)
    assert got["2000-01-01 05"].precip_mm == pytest.approx(0.4)


def test_minus_one_is_a_trace_and_hour_24_ends_at_the_next_midnight():
    got = _by_end(load_reference(UURGEG))
    trace = got["2000-01-01 04"]
    assert trace.precip_mm == 0.0 and trace.quality == "trace"
    assert got["2000-01-01 01"].quality is None
    last = got["2001-01-01 00"]  # 20001231, HH = 24
    assert last.start.isoformat() == "2000-12-31T23:00:00+00:00"


def test_the_script_export_with_a_commented_legend_and_no_gauge_is_all_missing():
    data = load_reference(KNMY)
    assert data.fmt == "knmi"
    assert [iv.precip_mm for iv in data.intervals] == [None, None, None]
    assert data.stats.missing == 3 and data.intervals[0].station == "209"


def test_a_daily_file_covers_the_ut_day(tmp_path):
    path = tmp_path / "etmgeg_260.txt"
    path.write_text(
        "# SOURCE: ROYAL NETHERLANDS METEOROLOGICAL INSTITUTE (KNMI)\n"
        "# STN,YYYYMMDD,   DR,   RH\n"
        "  260,20240101,   35,   42\n"
        "  260,20240102,    0,   -1\n"
    )
    data = load_reference(path)
    assert [iv.precip_mm for iv in data.intervals] == [4.2, 0.0]
    assert data.intervals[0].start.isoformat() == "2024-01-01T00:00:00+00:00"
    assert data.intervals[0].end.isoformat() == "2024-01-02T00:00:00+00:00"


def test_bad_rows_are_skipped_and_a_file_without_rh_is_one_line(tmp_path):
    path = tmp_path / "uurgeg.txt"
    path.write_text(
        "# STN,YYYYMMDD,   HH,   RH\n  260,20240101,    1,    3\n  260,2024010,    2,    3\n"
        "  260,20240101,   25,    3\n  260,20240101,    4,  x\n  260,20240101\n"
    )
    data = load_reference(path, fmt="knmi")
    assert len(data.intervals) == 1 and data.stats.malformed == 4
    path.write_text("# STN,YYYYMMDD,   HH,   DD\n  260,20240101,    1,  200\n")
    with pytest.raises(InputError, match="no RH"):
        load_reference(path, fmt="knmi")


def test_the_command_reads_it_and_a_bad_file_exits_2(tmp_path):
    done = run_weatherd("reference", UURGEG, "--station", "260")
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("\n") == 18 and "knmi, 18 intervals" in done.stderr
    bad = tmp_path / "bad.txt"
    bad.write_text("# SOURCE: ROYAL NETHERLANDS METEOROLOGICAL INSTITUTE (KNMI)\nnothing\n")
    done = run_weatherd("reference", bad)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "KNMI header" in done.stderr
