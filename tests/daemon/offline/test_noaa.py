"""NOAA Global Hourly (ISD) CSV on a real excerpt, and the LCD CSV on rows built from its
documentation (no public LCD file was found; tests/daemon/offline/data/PROVENANCE.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

from daemon.offline.reference import detect_format, load_reference
from drivers.errors import InputError
from tests.conftest import run_weatherd

DATA = Path(__file__).parent / "data"
ISD = DATA / "noaa_global_hourly_94733_2019_excerpt.csv"

ISD_HEAD = '"STATION","DATE","SOURCE","REPORT_TYPE","CALL_SIGN","QUALITY_CONTROL","AA1","AA2"\n'
# Built from the ISD format document: a METAR station's hourly groups, a special report
# (FM-16) in between, a trace, a missing depth and a suspect quality code.
ISD_METAR = ISD_HEAD + (
    '"72503014732","2024-06-15T10:51:00","7","FM-15","KLGA ","V020","01,0000,9,5",""\n'
    '"72503014732","2024-06-15T11:20:00","7","FM-16","KLGA ","V020","01,0013,9,5",""\n'
    '"72503014732","2024-06-15T11:51:00","7","FM-15","KLGA ","V020","01,0025,9,5",'
    '"06,0031,9,5"\n'
    '"72503014732","2024-06-15T12:51:00","7","FM-15","KLGA ","V020","01,0000,2,5",""\n'
    '"72503014732","2024-06-15T13:51:00","7","FM-15","KLGA ","V020","01,9999,9,9",""\n'
    '"72503014732","2024-06-15T14:51:00","7","FM-15","KLGA ","V020","01,0102,9,2",""\n'
)
LCD = (
    '"STATION","DATE","REPORT_TYPE","SOURCE","HourlyDryBulbTemperature","HourlyPrecipitation"\n'
    '"72503014732","2024-06-15T05:51:00","FM-15","7","70","0.00"\n'
    '"72503014732","2024-06-15T06:20:00","FM-16","7","70","0.03"\n'
    '"72503014732","2024-06-15T06:51:00","FM-15","7","69","0.10"\n'
    '"72503014732","2024-06-15T07:51:00","FM-15","7","69","T"\n'
    '"72503014732","2024-06-15T08:51:00","FM-15","7","68","0.02s"\n'
    '"72503014732","2024-06-15T09:51:00","FM-15","7","68","M"\n'
)


def _write(tmp_path: Path, text: str, name: str = "noaa.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_real_global_hourly_rows_give_the_shortest_period_by_default():
    assert detect_format(ISD) == "noaa-isd"
    data = load_reference(ISD)
    # 6-hour groups ending 04 UTC (the 04:00 SYNOPs); the 24-hour ones are left out
    assert [(iv.start.hour, iv.end.hour) for iv in data.intervals] == [(22, 4), (22, 4)]
    assert [iv.precip_mm for iv in data.intervals] == [0.0, 0.0]
    assert {iv.quality for iv in data.intervals} == {"1"}


def test_the_24_hour_groups_when_asked_and_the_rain_the_synop_also_says():
    data = load_reference(ISD, interval_s=86400)
    assert [iv.precip_mm for iv in data.intervals] == [0.0, 0.0, 0.4]
    wet = data.intervals[-1]  # AA1 24,0004 at 2019-01-05T22:00, REM "69944": 0.4 mm in 24 h
    assert wet.start.isoformat() == "2019-01-04T22:00:00+00:00"
    assert wet.end.isoformat() == "2019-01-05T22:00:00+00:00"
    with pytest.raises(InputError, match="no 3600 s precipitation groups"):
        load_reference(ISD, interval_s=3600)


def test_metar_hours_specials_trace_missing_and_quality(tmp_path):
    data = load_reference(_write(tmp_path, ISD_METAR))
    assert data.fmt == "noaa-isd"
    got = [(iv.end.hour, iv.precip_mm, iv.quality) for iv in data.intervals]
    assert got == [
        (10, 0.0, "5"),
        (11, 2.5, "5"),  # the FM-16 special's 1.3 mm is part of this hour, not another
        (12, 0.0, "trace"),
        (13, None, "9"),
        (14, 10.2, "2"),  # suspect, kept: users filter on quality
    ]
    assert data.intervals[1].start.isoformat() == "2024-06-15T10:51:00+00:00"


def test_lcd_hours_in_local_standard_time_and_inches(tmp_path):
    path = _write(tmp_path, LCD, "LCD_USW00014732_2024.csv")
    assert detect_format(path) == "noaa-lcd"
    data = load_reference(path, tz="Etc/GMT+5")  # EST, UTC-5, all year
    got = [(iv.end.isoformat(), iv.precip_mm, iv.quality) for iv in data.intervals]
    assert got == [
        ("2024-06-15T10:51:00+00:00", 0.0, None),
        ("2024-06-15T11:51:00+00:00", 2.54, None),
        ("2024-06-15T12:51:00+00:00", 0.0, "trace"),
        ("2024-06-15T13:51:00+00:00", 0.508, "suspect"),
        ("2024-06-15T14:51:00+00:00", None, None),
    ]


@pytest.mark.parametrize("tz", ["UTC", "America/New_York"])
def test_lcd_needs_a_standard_time_offset(tmp_path, tz):
    with pytest.raises(InputError, match=r"(?i)standard time"):
        load_reference(_write(tmp_path, LCD), tz=tz)


def test_bad_groups_are_skipped_and_the_command_exits_2_on_a_bad_file(tmp_path):
    text = ISD_HEAD + (
        '"1","2024-06-15T10:51:00","7","FM-15","X","V020","01,0010,9,5",""\n'
        '"1","2024-06-15T11:51:00","7","FM-15","X","V020","99,0010,9,5",""\n'
        '"1","2024-06-15T12:51:00","7","FM-15","X","V020","01,xx,9,5",""\n'
        '"1","yesterday","7","FM-15","X","V020","01,0010,9,5",""\n'
        '"1","2024-06-15T14:51:00","7"\n'
    )
    data = load_reference(_write(tmp_path, text))
    assert len(data.intervals) == 1 and data.stats.malformed == 4
    done = run_weatherd("reference", _write(tmp_path, LCD))
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "--tz" in done.stderr
