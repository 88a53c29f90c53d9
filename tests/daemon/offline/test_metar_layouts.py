"""METAR as it really comes: NWS collectives, reports over several lines, corrections, AO1
stations, and a day the given month lacks."""

from __future__ import annotations

from pathlib import Path

from daemon.offline.reference import load_reference

COLLECTIVE = (
    b"\x01\r\r\n123\r\r\nSAUS70 KWBC 161200\r\r\nMETAR\r\r\n"
    b"KJFK 161151Z 24012KT 10SM -RA BKN020 12/10 A2992 RMK AO2\r\r\n     SLP132=\r\r\n"
    b"KLGA 161151Z 24010KT 10SM FEW020 12/10\r\r\n     A2992 RMK AO2=\r\r\n\x03"
)


def _load(tmp_path: Path, data: bytes, **options):
    path = tmp_path / "reports.txt"
    path.write_bytes(data)
    return load_reference(path, **options)


def _by_station(data):
    return {iv.station: iv for iv in data.intervals}


def test_an_nws_collective_is_read_whole(tmp_path):
    for fmt in ("metar", None):  # forced, and recognised
        data = _load(tmp_path, COLLECTIVE, fmt=fmt, month="2024-10")
        got = _by_station(data)
        assert set(got) == {"KJFK", "KLGA"} and data.stats.malformed == 0
        assert got["KJFK"].precip_mm == 1.0 and got["KLGA"].precip_mm == 0.0
        assert got["KJFK"].start.isoformat() == "2024-10-16T11:51:00+00:00"


def test_the_weather_group_on_a_report_s_second_line_counts(tmp_path):
    data = _load(
        tmp_path, b"KJFK 161151Z 24012KT 10SM\n   -RA BKN020 12/10 A2992=\n", month="2024-10"
    )
    assert [iv.precip_mm for iv in data.intervals] == [1.0]


def test_a_correction_replaces_the_report_it_corrects(tmp_path):
    data = _load(
        tmp_path,
        b"202410161151 METAR KJFK 161151Z 24012KT 10SM FEW020 12/10 A2992=\n"
        b"202410161158 METAR COR KJFK 161151Z 24012KT 5SM -RA BKN020 12/10 A2992=\n",
    )
    assert [iv.precip_mm for iv in data.intervals] == [1.0]


def test_an_ao1_station_without_weather_says_nothing_of_precipitation(tmp_path):
    data = _load(
        tmp_path,
        b"KAAA 161150Z AUTO 24012KT 10SM CLR 12/10 A2992 RMK AO1=\n"
        b"KBBB 161150Z AUTO 24012KT 10SM CLR 12/10 A2992 RMK AO2=\n"
        b"KCCC 161150Z AUTO 24012KT 10SM -RA CLR 12/10 A2992 RMK AO1=\n",
        month="2024-10",
    )
    got = _by_station(data)
    assert got["KAAA"].precip_mm is None  # no sensor that could say "dry"
    assert got["KBBB"].precip_mm == 0.0 and got["KCCC"].precip_mm == 1.0


def test_a_day_the_month_lacks_is_the_previous_month_s_end(tmp_path):
    data = _load(tmp_path, b"KJFK 312351Z 24012KT 10SM FEW020 12/10 A2992=\n", month="2024-11")
    assert data.intervals[0].start.isoformat() == "2024-10-31T23:51:00+00:00"
