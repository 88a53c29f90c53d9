"""DWD 10-minute and hourly precipitation, as text and as the downloaded ZIP.

No public repository we could reach ships a DWD ``produkt_*`` file, so the files here are BUILT
from the DWD dataset descriptions, around the real header lines and the real row that
public code quotes from DWD's files (station 2667, 2019-11-29 00:00:
``      2667;201911290000;    3;  10;   0.13;   1;eor``; see data/PROVENANCE.md).
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import pytest

from daemon.offline.reference import detect_format, load_reference
from drivers.errors import InputError
from tests.conftest import run_weatherd

TEN_MIN = (
    "STATIONS_ID;MESS_DATUM;  QN;RWS_DAU_10;RWS_10;RWS_IND_10;eor\n"
    "       2667;201911282340;    3;   0;   0.00;   0;eor\n"
    "       2667;201911282350;    3;   4;   0.04;   1;eor\n"
    "       2667;201911290000;    3;  10;   0.13;   1;eor\n"
    "       2667;201911290010;    3;-999;-999.00;-999;eor\n"
    "       2667;201911290020;    3;  10;   0.30;   1;eor\n"
)
# Before 2000 the stamps are MEZ (UTC+1); historical files may lack the eor column.
TEN_MIN_1999 = (
    "STATIONS_ID;MESS_DATUM;QN;RWS_DAU_10;RWS_10;RWS_IND_10\n"
    "       2667;199912312350;    1;  10;   0.20;   1\n"
    "       2667;200001010000;    1;  10;   0.10;   1\n"
    "       2667;200001010010;    1;  10;   0.10;   1\n"
)
HOURLY = (
    "STATIONS_ID;MESS_DATUM;  QN_8;  R1;RS_IND;WRTR;eor\n"
    "       1684;2025040100;    3;   0.1;   1;   6;eor\n"
    "       1684;2025040101;    3;   0.0;   0;-999;eor\n"
    "       1684;2025040102;    3;-999;-999;-999;eor\n"
)


def _write(tmp_path: Path, text: str, name: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="latin-1")
    return path


def _zip(tmp_path: Path, members: dict[str, str], name: str) -> Path:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for member, text in members.items():
            archive.writestr(member, text.encode("latin-1"))
    path = tmp_path / name
    path.write_bytes(buffer.getvalue())
    return path


def test_ten_minute_rows_end_at_their_stamp_in_utc(tmp_path):
    path = _write(tmp_path, TEN_MIN, "produkt_zehn_min_rr_20191128_20191129_02667.txt")
    assert detect_format(path) == "dwd"
    data = load_reference(path)
    assert [iv.precip_mm for iv in data.intervals] == [0.0, 0.04, 0.13, None, 0.3]
    real = data.intervals[2]
    assert real.start.isoformat() == "2019-11-28T23:50:00+00:00"
    assert real.end.isoformat() == "2019-11-29T00:00:00+00:00"
    assert real.station == "2667" and real.quality == "3"
    assert data.stats.missing == 1 and data.stats.negative == 0 and data.stats.malformed == 0


def test_stamps_before_2000_are_mez(tmp_path):
    data = load_reference(_write(tmp_path, TEN_MIN_1999, "produkt_zehn_min_rr_hist.txt"))
    ends = [iv.end.isoformat() for iv in data.intervals]
    # 1999-12-31 23:50 MEZ is 22:50 UTC; 2000-01-01 00:00 on is UTC: an hour's gap, no overlap
    assert ends == [
        "1999-12-31T22:50:00+00:00",
        "2000-01-01T00:00:00+00:00",
        "2000-01-01T00:10:00+00:00",
    ]


def test_hourly_r1(tmp_path):
    data = load_reference(_write(tmp_path, HOURLY, "produkt_rr_stunde_20250401_02_01684.txt"))
    assert [iv.precip_mm for iv in data.intervals] == [0.1, 0.0, None]
    first = data.intervals[0]
    assert (first.start.hour, first.end.hour) == (23, 0) and first.quality == "3"


def test_the_zip_as_downloaded(tmp_path):
    members = {
        "Metadaten_Geographie_02667.txt": "Stations_id;Stationshoehe\n2667;92\n",
        "produkt_zehn_min_rr_20191128_20191129_02667.txt": TEN_MIN,
    }
    path = _zip(tmp_path, members, "10minutenwerte_nieder_02667_akt.zip")
    assert detect_format(path) == "dwd"
    assert [iv.precip_mm for iv in load_reference(path).intervals][2] == 0.13
    done = run_weatherd("reference", path, "--station", "02667")
    assert done.returncode == 0, done.stderr
    assert "dwd, 5 intervals" in done.stderr and done.stdout.count("\n") == 5


def test_a_zip_of_something_else_and_a_damaged_zip_are_one_line_errors(tmp_path):
    other = _zip(tmp_path, {"readme.txt": "hello\n"}, "other.zip")
    with pytest.raises(InputError, match="produkt"):
        load_reference(other)
    with pytest.raises(InputError, match="produkt"):
        load_reference(other, fmt="dwd")
    raw = _zip(tmp_path, {"produkt_zehn_min_rr_x.txt": TEN_MIN * 50}, "x.zip").read_bytes()
    damaged = tmp_path / "damaged.zip"
    damaged.write_bytes(raw[: len(raw) // 2])
    done = run_weatherd("reference", damaged, "--format", "dwd")
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


def test_bad_rows_are_skipped_and_a_foreign_header_is_refused(tmp_path):
    text = TEN_MIN + "       2667;2019112900;    3;  10;   0.13;   1;eor\n"
    text += "       2667;201911290030\n"
    text += "       2667;201911290040;    3;  10;   abc;   1;eor\n"
    data = load_reference(_write(tmp_path, text, "produkt.txt"))
    assert len(data.intervals) == 5 and data.stats.malformed == 3
    with pytest.raises(InputError, match="RWS_10"):
        load_reference(_write(tmp_path, "STATIONS_ID;MESS_DATUM;TT_10\n1;1;1\n", "t.txt"))


# Real: the first lines of DWD's produkt_tu_stunde_20190912_20210314_00044.txt (hourly air
# temperature, station 44), as Arombolosh/dwdImporter ships it (data/PROVENANCE.md).
REAL_TU = (
    "STATIONS_ID;MESS_DATUM;QN_9;TT_TU;RF_TU;eor\n"
    "         44;2019091200;    3;  15.2;  96.0;eor\n"
    "         44;2019091201;    3;  15.4;  96.0;eor\n"
)


def test_a_real_dwd_product_without_precipitation_is_recognised_and_refused(tmp_path):
    path = _write(tmp_path, REAL_TU, "produkt_tu_stunde_20190912_20210314_00044.txt")
    assert detect_format(path) == "dwd"
    with pytest.raises(InputError, match="it has STATIONS_ID, MESS_DATUM, QN_9, TT_TU"):
        load_reference(path)
