"""Station reference-data readers: real Météo-France samples and crafted files in every format."""

from __future__ import annotations

import dataclasses
import gzip
import json
import logging
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.writer import Writer

from daemon.offline.reference import (
    FORMATS,
    Interval,
    detect_format,
    load_reference,
    read_reference,
    reference_json,
)
from drivers.errors import InputError

MF = "meteofrance"
ROUEN = "76116001"
PARIS = "75114001"
H_HEADER = "NUM_POSTE;NOM_USUEL;LAT;LON;ALTI;AAAAMMJJHH;RR1;QRR1;DRR1;QDRR1;T;QT"
MN_HEADER = "NUM_POSTE;NOM_USUEL;LAT;LON;ALTI;AAAAMMJJHHMN;RR;QRR"


def utc(*args: int) -> datetime:
    return datetime(*args, tzinfo=UTC)


def write(path: Path, text: str, *, encoding: str = "utf-8", newline: str = "\n") -> Path:
    path.write_bytes(text.replace("\n", newline).encode(encoding))
    return path


def h_row(station: str, stamp: str, rr1: str, q: str = "1") -> str:
    name = "PARIS-MONTSOURIS" if station == PARIS else "ROUEN-BOOS"
    return f"{station};{name};48.821667;2.337833;75;{stamp};{rr1};{q};0;1;12.5;1"


# --- real samples ------------------------------------------------------------------------------


def test_real_commande_hourly_sample(shared_fixtures: Path) -> None:
    data = load_reference(shared_fixtures / MF / "commande_horaires_sample.csv")
    assert data.fmt == "mf-commande"
    assert data.intervals == [
        Interval(utc(2024, 6, 15, 11), utc(2024, 6, 15, 12), 0.0, ROUEN),
        Interval(utc(2024, 6, 15, 12), utc(2024, 6, 15, 13), 0.0, ROUEN),
    ]
    assert all(iv.start.tzinfo is UTC for iv in data.intervals)


def test_real_commande_hour_stamp_ends_the_hour(shared_fixtures: Path) -> None:
    """The hour's extremes (HTN, HTX, HXI: hhmm) fall inside the interval read for the row."""
    path = shared_fixtures / MF / "commande_horaires_sample.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(";")
    intervals = list(read_reference(path))
    for line, iv in zip(lines[1:], intervals, strict=True):
        row = dict(zip(header, line.split(";"), strict=True))
        for field in ("HTN", "HTX", "HXI", "HXY"):
            hhmm = int(row[field])
            t = iv.end.replace(hour=0) + timedelta(hours=hhmm // 100, minutes=hhmm % 100)
            assert iv.start < t <= iv.end, (field, row[field], iv)


def test_real_commande_six_minute_sample(shared_fixtures: Path) -> None:
    intervals = list(read_reference(shared_fixtures / MF / "commande_infrahoraires_sample.csv"))
    assert [(iv.start, iv.end, iv.precip_mm) for iv in intervals] == [
        (utc(2024, 6, 15, 11, 54), utc(2024, 6, 15, 12), 0.0),
        (utc(2024, 6, 15, 12), utc(2024, 6, 15, 12, 6), 0.0),
    ]


def test_real_observation_json_sample(shared_fixtures: Path) -> None:
    path = shared_fixtures / MF / "obs-infrahoraire-6m_76116001_2024-10-16T12_06_00Z.json"
    assert detect_format(path) == "mf-obs-json"
    (iv,) = read_reference(path, station=ROUEN)
    assert iv == Interval(utc(2024, 10, 16, 12), utc(2024, 10, 16, 12, 6), 0.0, ROUEN)


def test_real_sample_station_filter(shared_fixtures: Path) -> None:
    path = shared_fixtures / MF / "commande_horaires_sample.csv"
    assert len(list(read_reference(path, station=ROUEN))) == 2
    with pytest.raises(InputError, match="no data for station 75114001"):
        read_reference(path, station=PARIS)


@pytest.mark.parametrize("name", ["H_descriptif_champs.csv", "MN_descriptif_champs.csv"])
def test_real_field_descriptions_are_not_data(shared_fixtures: Path, name: str) -> None:
    with pytest.raises(InputError, match=r"descriptif_champs\.csv.*lacks column"):
        read_reference(shared_fixtures / MF / name)


def test_descriptif_says_what_the_reader_relies_on(shared_fixtures: Path) -> None:
    text = (shared_fixtures / MF / "H_descriptif_champs.csv").read_text()
    rr1 = next(line for line in text.splitlines() if line.startswith("RR1 "))
    assert "tombée en 1 heure" in rr1
    for code in ("9 : donnée filtrée", "0 : donnée protégée", "1 : donnée validée"):
        assert code in text
    assert "2 : donnée douteuse" in text


# --- Météo-France climatological files, crafted -------------------------------------------------


def test_hourly_quality_missing_negative_and_stations(tmp_path: Path) -> None:
    rows = [
        h_row(PARIS, "2024011001", "0.4", "1"),
        h_row(PARIS, "2024011002", "", ""),
        h_row(PARIS, "2024011003", "-1.0", "2"),
        h_row(PARIS, "2024011000", "12.6", "9"),
        h_row(ROUEN, "2024011001", "3", "0"),
    ]
    path = write(tmp_path / "H_75_latest-2023-2024.csv", "\n".join([H_HEADER, *rows]) + "\n")
    data = load_reference(path)
    assert data.fmt == "mf-hourly"
    assert [(iv.station, iv.end.hour, iv.precip_mm, iv.quality) for iv in data.intervals] == [
        (PARIS, 0, 12.6, "9"),
        (PARIS, 1, 0.4, "1"),
        (ROUEN, 1, 3.0, "0"),
        (PARIS, 2, None, None),
        (PARIS, 3, None, "2"),
    ]
    assert data.intervals[0].start == utc(2024, 1, 9, 23)
    assert data.stats.missing == 1 and data.stats.negative == 1
    only = load_reference(path, station="75114001")
    assert {iv.station for iv in only.intervals} == {PARIS}
    assert only.stats.other_stations == 1


def test_hourly_gzip_bom_crlf_duplicates_and_truncated_last_line(tmp_path: Path, caplog) -> None:
    rows = [
        h_row(PARIS, "2024011001", "0.4"),
        h_row(PARIS, "2024011001", "9.9"),  # duplicate: the first is kept
        h_row(PARIS, "2024011002", "1.2"),
        h_row(PARIS, "2024011003", "2.5")[:40],  # truncated last line, no newline
    ]
    text = "\ufeff" + "\r\n".join([H_HEADER, *rows])
    path = tmp_path / "H_75_previous-2020-2022.csv.gz"
    path.write_bytes(gzip.compress(text.encode()))
    with caplog.at_level(logging.WARNING):
        data = load_reference(path)
    assert [(iv.end.hour, iv.precip_mm) for iv in data.intervals] == [(1, 0.4), (2, 1.2)]
    assert data.stats.duplicates == 1 and data.stats.malformed == 1
    assert data.stats.first_malformed_line == 5
    bad = [r.getMessage() for r in caplog.records if "malformed row" in r.getMessage()]
    assert len(bad) == 1 and "line 5" in bad[0]


def test_truncated_gzip_keeps_rows_before_the_damage(tmp_path: Path) -> None:
    rows = [h_row(PARIS, f"20240110{h:02d}", "0.2") for h in range(24)]
    blob = gzip.compress(("\n".join([H_HEADER, *rows]) + "\n").encode())
    path = tmp_path / "H_75.csv.gz"
    path.write_bytes(blob[: len(blob) - 12])  # lose the gzip trailer and a little data
    data = load_reference(path)
    assert data.stats.truncated
    assert 0 < len(data.intervals) <= 24
    assert all(iv.precip_mm == 0.2 for iv in data.intervals)


def test_hourly_bad_date_and_number_are_skipped(tmp_path: Path) -> None:
    rows = [
        h_row(PARIS, "20240110", "0.2"),  # short date
        h_row(PARIS, "2024023101", "0.2"),  # 31 February
        h_row(PARIS, "2024011001", "abc"),
        h_row(PARIS, "2024011002", "0.6"),
    ]
    data = load_reference(write(tmp_path / "H_x.csv", "\n".join([H_HEADER, *rows])))
    assert [iv.precip_mm for iv in data.intervals] == [0.6]
    assert data.stats.malformed == 3 and data.stats.first_malformed_line == 2


def test_six_minute_file(tmp_path: Path) -> None:
    rows = [
        f"{PARIS};PARIS-MONTSOURIS;48.82;2.34;75;202401100006;0.2;1",
        f"{PARIS};PARIS-MONTSOURIS;48.82;2.34;75;202401100012;;",
        f"{PARIS};PARIS-MONTSOURIS;48.82;2.34;75;202401100000;0;9",
    ]
    path = write(tmp_path / "MN_75_2024.csv", "\n".join([MN_HEADER, *rows]) + "\n")
    data = load_reference(path)
    assert data.fmt == "mf-6min"
    assert [(iv.start, iv.end, iv.precip_mm, iv.quality) for iv in data.intervals] == [
        (utc(2024, 1, 9, 23, 54), utc(2024, 1, 10), 0.0, "9"),
        (utc(2024, 1, 10, 0, 0), utc(2024, 1, 10, 0, 6), 0.2, "1"),
        (utc(2024, 1, 10, 0, 6), utc(2024, 1, 10, 0, 12), None, None),
    ]


def test_commande_decimal_comma_and_overseas_time_zone(tmp_path: Path) -> None:
    text = "POSTE;DATE;RR1;T\n97101001;2024061512;1,4;28,1\n97101001;2024061513;0,0;27,9\n"
    path = write(tmp_path / "commande.csv", text)
    intervals = list(read_reference(path, tz="America/Guadeloupe"))  # FU = UTC-4
    assert [(iv.end, iv.precip_mm) for iv in intervals] == [
        (utc(2024, 6, 15, 16), 1.4),
        (utc(2024, 6, 15, 17), 0.0),
    ]


def test_observation_package_json(tmp_path: Path) -> None:
    objs = [
        {"geo_id_insee": ROUEN, "validity_time": "2024-10-17T09:00:00Z", "rr1": -0.1},
        {"geo_id_insee": ROUEN, "validity_time": "2024-10-17T08:00:00Z", "rr1": 1.2},
        {"geo_id_insee": "76217001", "validity_time": "2024-10-17T08:00:00Z", "rr1": None},
        {"geo_id_insee": ROUEN, "validity_time": "yesterday", "rr1": 0.0},
        {"geo_id_insee": ROUEN, "validity_time": "2024-10-17T07:00:00Z", "t": 288.4},
    ]
    path = write(tmp_path / "paquetobs-horaire_76.json", json.dumps(objs, indent=2))
    data = load_reference(path)
    assert [(iv.station, iv.end.hour, iv.precip_mm) for iv in data.intervals] == [
        (ROUEN, 8, 1.2),
        ("76217001", 8, None),
        (ROUEN, 9, None),
    ]
    assert data.intervals[0].end - data.intervals[0].start == timedelta(hours=1)
    assert data.stats.malformed == 2 and data.stats.negative == 1 and data.stats.missing == 1
    assert [iv.station for iv in read_reference(path, station="76217001")] == ["76217001"]


# --- generic CSV ---------------------------------------------------------------------------------


def test_generic_csv_amounts_with_median_spacing(tmp_path: Path) -> None:
    text = (
        "time,precip_mm\n"
        "2024-06-15T10:10:00Z,0.5\n"
        "2024-06-15T10:20:00Z,\n"
        "2024-06-15T12:30:00+02:00,0.25\n"
        "2024-06-15T10:40:00Z,-3\n"
        "2024-06-15T10:50:00Z,1.5\n"
    )
    data = load_reference(write(tmp_path / "gauge.csv", text))
    assert data.fmt == "csv"
    got = [(iv.start, iv.end, iv.precip_mm) for iv in data.intervals]
    assert got[0] == (utc(2024, 6, 15, 10), utc(2024, 6, 15, 10, 10), 0.5)
    assert got[2] == (utc(2024, 6, 15, 10, 20), utc(2024, 6, 15, 10, 30), 0.25)
    assert [g[2] for g in got] == [0.5, None, 0.25, None, 1.5]
    assert data.stats.negative == 1 and data.stats.missing == 1


def test_generic_csv_rate_semicolon_comma_local_time(tmp_path: Path) -> None:
    text = "Date;Rain_Rate_mm_h;station\n2024-01-10 12:00;1,5;A\n2024-01-10 12:05;3;A\n"
    path = write(tmp_path / "rates.txt", text)
    intervals = list(read_reference(path, tz="Europe/Paris", interval_s=300))
    assert [(iv.end, iv.precip_mm, iv.station) for iv in intervals] == [
        (utc(2024, 1, 10, 11, 0), 0.125, "A"),
        (utc(2024, 1, 10, 11, 5), 0.25, "A"),
    ]


def test_generic_csv_without_station_column_reports_the_option(tmp_path: Path) -> None:
    path = write(tmp_path / "x.csv", "timestamp,mm\n1718445600,0.2\n1718449200,0.4\n")
    intervals = list(read_reference(path, station="roof"))
    assert [(iv.start, iv.station) for iv in intervals] == [
        (utc(2024, 6, 15, 9), "roof"),
        (utc(2024, 6, 15, 10), "roof"),
    ]


def test_generic_csv_single_row_needs_interval(tmp_path: Path) -> None:
    path = write(tmp_path / "one.csv", "time,mm\n2024-06-15T10:00:00Z,0.2\n")
    with pytest.raises(InputError, match="pass interval_s"):
        read_reference(path)
    (iv,) = read_reference(path, interval_s=600)
    assert iv.start == utc(2024, 6, 15, 9, 50)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(
    steps=st.lists(st.integers(min_value=1, max_value=3), min_size=2, max_size=30),
    amounts=st.lists(
        st.one_of(st.none(), st.decimals(min_value=0, max_value=200, places=2)),
        min_size=30,
        max_size=30,
    ),
    sep=st.sampled_from([",", ";"]),
)
def test_generic_csv_round_trip(tmp_path_factory, steps, amounts, sep) -> None:
    t0 = utc(2024, 3, 1)
    ends = [t0 + timedelta(minutes=10 * sum(steps[: i + 1])) for i in range(len(steps))]
    values = amounts[: len(ends)]

    def fmt(v) -> str:
        return "" if v is None else (str(v).replace(".", ",") if sep == ";" else str(v))

    body = "".join(
        f"{t:%Y-%m-%d %H:%M:%S}{sep}{fmt(v)}\n" for t, v in zip(ends, values, strict=True)
    )
    path = tmp_path_factory.mktemp("rt") / "rt.csv"
    write(path, f"datetime{sep}precip_mm\n" + body)
    intervals = list(read_reference(path, interval_s=600))
    assert [iv.end for iv in intervals] == ends
    assert all(iv.end - iv.start == timedelta(minutes=10) for iv in intervals)
    assert [iv.precip_mm for iv in intervals] == [None if v is None else float(v) for v in values]


# --- METAR ---------------------------------------------------------------------------------------

METARS = """\
202410161200 METAR LFPG 161200Z 20012KT 9999 -RA BR SCT020 BKN040 15/12 Q1012 NOSIG=
202410161230 METAR LFPG 161230Z 20012KT 9999 VCSH FEW020 15/12 Q1012 NOSIG=
202410161300 METAR LFPG 161300Z 20012KT 9999 FEW020 15/12 Q1012 RERA=
this is not a report
202410161500 METAR LFPG 161500Z 20012KT 9999 +SHRASN BKN010 01/M01 Q0999=
202410161500 METAR LFPG 161500Z 20012KT 9999 +SHRASN BKN010 01/M01 Q0999=
202410161530 METAR LFPG 161530Z 27025KT 9999 BLSN BKN010 M01/M03 Q0999=
202410161600 METAR LFPB 161600Z NIL=
"""


def test_metar_presence_types_and_intervals(tmp_path: Path) -> None:
    data = load_reference(write(tmp_path / "lfpg.txt", METARS))
    assert data.fmt == "metar"
    got = [
        (iv.station, iv.start, iv.end - iv.start, iv.precip_mm, iv.weather, iv.kind)
        for iv in data.intervals
    ]
    half, hour = timedelta(minutes=30), timedelta(hours=1)
    assert got == [
        ("LFPG", utc(2024, 10, 16, 12), half, 1.0, "-RA BR", "presence"),
        ("LFPG", utc(2024, 10, 16, 12, 30), half, 0.0, "VCSH", "presence"),
        ("LFPG", utc(2024, 10, 16, 13), hour, 0.0, None, "presence"),  # 2 h gap capped at 1 h
        ("LFPG", utc(2024, 10, 16, 15), half, 1.0, "+SHRASN", "presence"),
        ("LFPG", utc(2024, 10, 16, 15, 30), half, 0.0, "BLSN", "presence"),
        ("LFPB", utc(2024, 10, 16, 16), half, None, None, "presence"),
    ]
    assert data.stats.malformed == 1 and data.stats.first_malformed_line == 4
    assert data.stats.duplicates == 1
    assert [iv.station for iv in read_reference(tmp_path / "lfpg.txt", station="lfpb")] == ["LFPB"]


@pytest.mark.parametrize(
    ("weather", "expected"),
    [
        ("-DZ", 1.0),
        ("UP", 1.0),
        ("TSGR", 1.0),
        ("SN BLSN", 1.0),
        ("+TSRA", 1.0),
        ("PL", 1.0),
        ("TS", 0.0),
        ("FZFG", 0.0),
        ("VCSH", 0.0),
        ("DRSN", 0.0),
        ("//", None),
    ],
)
def test_metar_presence_of_each_group(tmp_path: Path, weather: str, expected: float | None) -> None:
    line = f"201001011200 METAR EGLL 011200Z 24010KT 3000 {weather} OVC010 02/01 Q1000=\n"
    (iv,) = read_reference(write(tmp_path / "one.txt", line))
    assert (iv.precip_mm, iv.weather) == (expected, weather)


def test_metar_raw_reports_need_a_month(tmp_path: Path) -> None:
    text = (
        "LFPG 312330Z 20005KT 9999 -DZ OVC008 08/07 Q1020\n"
        "LFPG 312345Z 20005KT 9999 OVC008 08/07 Q1020\n"
    )
    path = write(tmp_path / "raw.metar", text)
    with pytest.raises(InputError, match=r"raw\.metar:1: METAR report without a date"):
        read_reference(path)
    intervals = list(read_reference(path, fmt="metar", month="2024-12"))
    assert [(iv.start, iv.precip_mm, iv.weather) for iv in intervals] == [
        (utc(2024, 12, 31, 23, 30), 1.0, "-DZ"),
        (utc(2024, 12, 31, 23, 45), 0.0, None),
    ]


def test_metar_dated_forms_and_month_boundary(tmp_path: Path) -> None:
    text = (
        "2024/10/31 23:50\n"
        "LFPG 312350Z 20005KT 9999 RA OVC008 08/07 Q1020\n"
        "202411010000 METAR LFPG 312359Z 20005KT 9999 FZDZ OVC008 08/07 Q1020=\n"
        "LFPG,2024,11,01,00,30,METAR LFPG 010030Z 20005KT 9999 SN OVC008 00/M01 Q1020=\n"
    )
    intervals = list(read_reference(write(tmp_path / "ogimet.txt", text)))
    assert [(iv.start, iv.weather) for iv in intervals] == [
        (utc(2024, 10, 31, 23, 50), "RA"),
        (utc(2024, 10, 31, 23, 59), "FZDZ"),
        (utc(2024, 11, 1, 0, 30), "SN"),
    ]
    assert all(iv.precip_mm == 1.0 for iv in intervals)


# --- the daemon's gauge channel in MCAP ----------------------------------------------------------


def write_gauge_mcap(path: Path, series: dict[str, list[dict]], *, other: bool = True) -> Path:
    with path.open("wb") as f:
        writer = Writer(f)
        writer.start(profile="", library="test")
        schema = writer.register_schema(
            name="weather.instrument", encoding="jsonschema", data=b"{}"
        )
        if other:
            state = writer.register_channel("/weather/state", "json", schema)
            writer.add_message(state, 1, b'{"rain": true}', 1)
        for instrument, readings in series.items():
            channel = writer.register_channel(f"/instrument/{instrument}/reading", "json", schema)
            for reading in readings:
                data = reading.get("raw") or json.dumps(reading).encode()
                t_ns = reading.get("t_ns", 1)
                writer.add_message(channel, t_ns, data, t_ns)
        writer.finish()
    return path


def ns(t: datetime) -> int:
    return round(t.timestamp()) * 1_000_000_000


def gauge_series() -> dict[str, list[dict]]:
    g1, accum = [], 5.0
    t = utc(2024, 6, 15, 9, 30)
    while t <= utc(2024, 6, 15, 12, 30):
        if utc(2024, 6, 15, 10) <= t < utc(2024, 6, 15, 11):
            accum += 0.02
        elif t == utc(2024, 6, 15, 11, 30):
            accum = 0.0  # counter reset
        elif utc(2024, 6, 15, 11) <= t < utc(2024, 6, 15, 12):
            accum += 0.01
        g1.append({"t_ns": ns(t), "rain_accum_mm": round(accum, 4), "rain_rate_mm_h": None})
        if t == utc(2024, 6, 15, 10, 15):
            g1.append({"t_ns": ns(t) + 1, "raw": b"\x00not json"})
        t += timedelta(minutes=1)
    g2 = [
        {"t_ns": ns(utc(2024, 6, 15, 10) + timedelta(minutes=m)), "rain_rate_mm_h": 6.0}
        for m in range(61)
    ]
    return {"g1": g1, "g2": g2}


def test_gauge_mcap_hourly_amounts(tmp_path: Path) -> None:
    path = write_gauge_mcap(tmp_path / "site_20240615T093000Z.mcap", gauge_series())
    data = load_reference(path)
    assert data.fmt == "mcap-gauge"
    got = {(iv.station, iv.start.hour): iv.precip_mm for iv in data.intervals}
    assert got[("g1", 9)] is None  # only half covered
    assert got[("g1", 10)] == pytest.approx(1.2)
    assert got[("g1", 11)] == pytest.approx(0.59)  # the reset minute is dropped
    assert got[("g1", 12)] is None
    assert got[("g2", 10)] == pytest.approx(5.9)  # rate x 59 min covered
    assert got[("g2", 11)] is None
    assert data.stats.negative == 1 and data.stats.malformed == 1
    assert all(iv.end - iv.start == timedelta(hours=1) for iv in data.intervals)


def test_gauge_mcap_station_filter_and_interval(tmp_path: Path) -> None:
    path = write_gauge_mcap(tmp_path / "log.bin", gauge_series())
    intervals = list(read_reference(path, fmt="mcap-gauge", station="g1", interval_s=1800))
    assert {iv.station for iv in intervals} == {"g1"}
    amounts = {iv.start: iv.precip_mm for iv in intervals}
    assert amounts[utc(2024, 6, 15, 10)] == pytest.approx(0.6)
    assert amounts[utc(2024, 6, 15, 10, 30)] == pytest.approx(0.6)


def test_gauge_mcap_without_readings_or_broken(tmp_path: Path) -> None:
    empty = write_gauge_mcap(tmp_path / "empty.mcap", {})
    with pytest.raises(InputError, match=r"empty\.mcap: no /instrument/<id>/reading"):
        read_reference(empty)
    full = write_gauge_mcap(tmp_path / "full.mcap", gauge_series()).read_bytes()
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(full[: len(full) // 2])
    with pytest.raises(InputError, match=r"broken\.mcap"):
        read_reference(broken)


# --- wrong files and the JSON lines ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "content"),
    [
        ("photo.csv", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR"),
        ("notes.txt", b"dear diary,\nit rained today\n"),
        ("empty.csv", b""),
        ("other.json", b'{"hello": "world"}'),
        ("broken.json", b'[{"validity_time": "2024-10-16T12:00:00Z",'),
    ],
)
def test_wrong_files_raise_one_line_input_error(tmp_path: Path, name: str, content: bytes) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(InputError) as err:
        read_reference(path)
    message = str(err.value)
    assert name in message and "\n" not in message


def test_missing_file_unknown_format_and_bad_options(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"nope\.csv: cannot open"):
        read_reference(tmp_path / "nope.csv")
    path = write(tmp_path / "x.csv", "time,mm\n2024-06-15T10:00:00Z,0.2\n")
    with pytest.raises(InputError, match="unknown format"):
        read_reference(path, fmt="excel")
    with pytest.raises(InputError, match="time zone"):
        read_reference(path, tz="Mars/Olympus")
    with pytest.raises(InputError, match="interval_s"):
        read_reference(path, interval_s=0)
    assert set(FORMATS) >= {"mf-hourly", "mf-6min", "mf-commande", "mf-obs-json", "csv"}


def test_reference_json_lines() -> None:
    amount = Interval(utc(2024, 6, 15, 11), utc(2024, 6, 15, 12), 0.4, PARIS, quality="1")
    assert reference_json(amount) == {
        "start": "2024-06-15T11:00:00Z",
        "end": "2024-06-15T12:00:00Z",
        "precip_mm": 0.4,
        "station": PARIS,
        "quality": "1",
    }
    seen = Interval(
        utc(2024, 6, 15, 11), utc(2024, 6, 15, 11, 30), 1.0, "LFPG", None, "presence", "-RA"
    )
    assert reference_json(seen) == {
        "start": "2024-06-15T11:00:00Z",
        "end": "2024-06-15T11:30:00Z",
        "precip_mm": 1.0,
        "station": "LFPG",
        "kind": "presence",
        "weather": "-RA",
    }
    missing = reference_json(Interval(utc(2024, 6, 15, 11), utc(2024, 6, 15, 12), None, None))
    assert json.loads(json.dumps(missing)) == {
        "start": "2024-06-15T11:00:00Z",
        "end": "2024-06-15T12:00:00Z",
        "precip_mm": None,
        "station": None,
    }
    with pytest.raises(dataclasses.FrozenInstanceError):
        amount.precip_mm = 1.0  # type: ignore[misc]
