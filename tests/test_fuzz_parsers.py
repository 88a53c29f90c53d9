"""Property tests: random and damaged bytes given to every instrument driver and every
reference format. Each must give a clean error (a WeatherdError: one line, exit status 2) or
valid output, never another exception (an internal error), never a hang.

The seeds are small files in each layout, written here; damaged copies of them (cut, a stretch
overwritten, bytes flipped) reach deeper into the parsers than random bytes do. Where
``../shared/fixtures`` is beside the checkout, its real captures are damaged too.
"""

from __future__ import annotations

import gzip
import io
import json
import sqlite3
import zipfile
from contextlib import closing
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from daemon.offline.reference import FORMATS, load_reference
from drivers.errors import WeatherdError
from drivers.instruments import DRIVERS
from drivers.instruments.decode import DecodeStats, decode_file
from tests.test_fuzz_inputs import FUZZ, damaged, time_limit

from .daemon.service.test_e2e_instruments import pwd_message
from .drivers.instruments.test_lambrecht import t3 as raine_t3
from .drivers.instruments.test_thies import telegram as thies_telegram

OPTIONS = {"ascii-regex": {"pattern": r"rain (?P<r>[0-9.]+)", "fields": {"r": "rain_rate_mm_h"}}}

INSTRUMENT_SEEDS = {
    "vaisala-pwd": pwd_message("1") * 3,
    "ott-parsivel": b"TYP OP4A\r\n01:0000.123\r\n02:0012.34\r\n03:61\r\n04:53\r\n05:-RA\r\n"
    b"07:-9.999\r\n11:00042\r\n12:021\r\n20:22:18:00\r\n21:25.10.2023\r\n\r\n",
    "thies-lnm": thies_telegram() * 2,
    "lambrecht-raine": raine_t3() * 3,
    "tipping-bucket": b"2024-01-14T00:00:00Z tip\n2024-01-14T00:01:00Z tip\n",
    "ascii-regex": b"rain 1.25\nrain 0.50\n",
}

REFERENCE_SEEDS = {
    "csv": b"time,precip_mm\n2024-10-16T12:00:00Z,0.2\n2024-10-16T13:00:00Z,1.4\n",
    "mf-hourly": b"NUM_POSTE;NOM_USUEL;LAT;LON;ALTI;AAAAMMJJHH;RR1;QRR1\n"
    b"75114001;PARIS-MONTSOURIS;48.82;2.34;75;2024101612;0.2;1\n",
    "mf-6min": b"NUM_POSTE;NOM_USUEL;LAT;LON;ALTI;AAAAMMJJHHMN;RR;QRR\n"
    b"75114001;PARIS-MONTSOURIS;48.82;2.34;75;202410161206;0.2;1\n",
    "mf-commande": b"POSTE;DATE;RR1\n75114001;2024101612;0,2\n75114001;2024101613;1,4\n",
    "mf-obs-json": json.dumps(
        [{"geo_id_insee": "76116001", "validity_time": "2024-10-16T12:06:00Z", "rr_per": 0.2}]
    ).encode(),
    "metar": b"LFPO 161200Z 24012KT 9999 -RA BKN020 12/10 Q1012\n"
    b"LFPO 161230Z 24012KT 9999 RA BKN020 12/10 Q1012\n",
    "dwd": b"STATIONS_ID;MESS_DATUM;  QN;RWS_DAU_10;RWS_10;RWS_IND_10;eor\n"
    b"       2667;199912312350;    3;  10;   0.13;   1;eor\n"
    b"       2667;201911290000;    3;-999;-999.00;-999;eor\n",
    "knmi": b"# SOURCE: ROYAL NETHERLANDS METEOROLOGICAL INSTITUTE (KNMI)\n"
    b"# STN,YYYYMMDD,   HH,   DR,   RH\n  260,20000729,   16,   10,  217\n"
    b"  260,20000729,   24,    0,   -1\n",
    "noaa-isd": b'"STATION","DATE","REPORT_TYPE","AA1","AA2"\n'
    b'"94733099999","2019-01-05T22:00:00","FM-12","24,0004,3,1",""\n'
    b'"94733099999","2019-01-06T04:00:00","FM-12","06,0000,2,1","24,9999,9,9"\n',
    "noaa-lcd": b'"STATION","DATE","REPORT_TYPE","HourlyPrecipitation"\n'
    b'"72503014732","2024-06-15T06:51:00","FM-15","0.10"\n'
    b'"72503014732","2024-06-15T07:51:00","FM-15","0.02s"\n',
    "weewx": b"dateTime,usUnits,interval,rain\n1413937800,1,5,0.01\n1413938100,17,5,\n",
}


def dwd_zip(product: bytes) -> bytes:
    """``product`` as the ``produkt_*.txt`` of a ZIP, as DWD serves it."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("Metadaten_Geographie_02667.txt", b"Stations_id;Stationshoehe\n")
        archive.writestr("produkt_zehn_min_rr_20191129_20191129_02667.txt", product)
    return buffer.getvalue()


def weewx_sqlite() -> bytes:
    """A two-row weewx ``archive`` table as SQLite file bytes."""
    with closing(sqlite3.connect(":memory:")) as db:
        db.execute("CREATE TABLE archive (dateTime INTEGER, usUnits INTEGER, interval, rain)")
        db.executemany(
            "INSERT INTO archive VALUES (?, ?, ?, ?)", [(1413937800, 1, 5, 0.01), (1, 16, 5, None)]
        )
        db.commit()
        return db.serialize()


# The binary layouts of two formats: a DWD ZIP and a weewx SQLite archive.
BINARY_SEEDS = {"dwd": dwd_zip(REFERENCE_SEEDS["dwd"]), "weewx": weewx_sqlite()}


def _write(tmp_path: Path, name: str, data: bytes) -> Path:
    path = tmp_path / name
    path.write_bytes(data)
    return path


def _decode(driver: str, path: Path) -> None:
    with time_limit():
        try:
            for reading in decode_file(
                DRIVERS[driver], path, options=OPTIONS.get(driver), stats=DecodeStats()
            ):
                json.dumps(reading.to_json(), allow_nan=False)
        except WeatherdError:
            pass


def _reference(path: Path, fmt: str | None) -> None:
    with time_limit():
        try:
            data = load_reference(path, fmt=fmt)
        except WeatherdError:
            return
    for interval in data.intervals:
        assert interval.start < interval.end


def test_every_driver_and_format_has_a_seed():
    assert set(INSTRUMENT_SEEDS) == set(DRIVERS)
    assert set(REFERENCE_SEEDS) | {"mcap-gauge"} == set(FORMATS)


@pytest.mark.parametrize("driver", sorted(DRIVERS))
@FUZZ
@given(data=st.data())
def test_instrument_drivers_never_fail_inside(tmp_path_factory, driver, data):
    raw = data.draw(st.one_of(st.binary(max_size=2048), damaged(INSTRUMENT_SEEDS[driver])))
    _decode(driver, _write(tmp_path_factory.mktemp("fuzz"), "capture.txt", raw))


@pytest.mark.parametrize("fmt", sorted(REFERENCE_SEEDS))
@FUZZ
@given(data=st.data())
def test_reference_formats_never_fail_inside(tmp_path_factory, fmt, data):
    seed = REFERENCE_SEEDS[fmt]
    raw = data.draw(
        st.one_of(st.binary(max_size=2048), damaged(seed), damaged(gzip.compress(seed)))
    )
    path = _write(tmp_path_factory.mktemp("fuzz"), "reference.dat", raw)
    _reference(path, fmt)
    _reference(path, None)  # and detected


@pytest.mark.parametrize("fmt", sorted(BINARY_SEEDS))
@FUZZ
@given(data=st.data())
def test_binary_reference_layouts_never_fail_inside(tmp_path_factory, fmt, data):
    raw = data.draw(damaged(BINARY_SEEDS[fmt]))
    path = _write(tmp_path_factory.mktemp("fuzz"), "reference.dat", raw)
    _reference(path, fmt)
    _reference(path, None)  # and detected


@pytest.mark.parametrize(
    ("driver", "relative"),
    [
        ("vaisala-pwd", "vaisala-fd12p/PW040406.DAT"),
        ("ott-parsivel", "ott-parsivel2/bucharest_0000000123_20231025221800.txt"),
        ("ott-parsivel", "ott-parsivel2/Lindenberg_Parsivel_20231204.log"),
        ("thies-lnm", "thies-lnm/2024041723-leipzig-lim.txt"),
        ("lambrecht-raine", "lambrecht-raine/Lindenberg_RainE_20230514.txt"),
    ],
)
@FUZZ
@given(data=st.data())
def test_damaged_real_captures(shared_fixtures, tmp_path_factory, driver, relative, data):
    original = (shared_fixtures / "instruments" / relative).read_bytes()[:8192]
    raw = data.draw(damaged(original))
    _decode(driver, _write(tmp_path_factory.mktemp("fuzz"), "capture.txt", raw))
