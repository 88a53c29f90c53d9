"""OTT Parsivel² as loggers really write it: real captures from cloudnetpy's tests (see
data/PROVENANCE.md) and layouts built from them."""

from __future__ import annotations

import os
import random
from pathlib import Path

import pytest

from drivers.instruments import parsivel
from drivers.instruments.base import Frame, ParseError
from drivers.instruments.decode import DecodeStats, decode_chunks, decode_file

DATA = Path(__file__).parent / "data"
SPEC = parsivel.DRIVER
#: Warsaw's telegram: sensor date and time, then values, the spectrum last.
WARSAW = [21, 20, 1, 2, 3, 5, 6, 7, 8, 10, 11, 12, 16, 17, 34, 18, 93]
#: Palaiseau's (its header line names them).
PALAISEAU = [21, 20, 1, 2, 7, 8, 10, 11, 12, 16, 17, 34, 35, 3, 5, 6, 18, 93]


def decode(path: Path, **options) -> tuple[list[dict], DecodeStats]:
    stats = DecodeStats()
    readings = [r.to_json() for r in decode_file(SPEC, path, options=options, stats=stats)]
    return readings, stats


def test_raining_rows_with_a_spectrum_of_values_are_read():
    """Warsaw: three raining rows whose <SPECTRUM> holds values; none may be lost."""
    readings, stats = decode(DATA / "parsivel_warsaw.txt", fields=WARSAW)
    assert (len(readings), stats.bad) == (3, [])
    assert [r["t"] for r in readings] == [f"2021-08-06T00:00:{s}Z" for s in ("00", "10", "20")]
    assert [r["rain_rate_mm_h"] for r in readings] == [0.75, 0.844, 1.865]  # decimal commas
    assert {r["wawa"] for r in readings} == {62} and readings[0]["metar"] == "RA"
    assert readings[0]["visibility_m"] == 8931 and readings[0]["time_source"] == "sensor"


@pytest.mark.parametrize("options", [{"fields": PALAISEAU}, {}])
def test_zero_and_valued_spectra_side_by_side_with_slash_dates(options):
    """Palaiseau: its header line names the columns, so no option is needed."""
    readings, stats = decode(DATA / "parsivel_palaiseau.txt", **options)
    assert (stats.bad, stats.garbage_bytes) == ([], 0)
    assert [r["t"] for r in readings] == [f"2019-11-15T00:5{m}:00Z" for m in range(3)]
    assert [r["wawa"] for r in readings] == [0, 57, 0]  # the valued spectrum is row 2
    assert readings[1]["metar"] == "-RADZ" and readings[1]["rain_rate_mm_h"] == 0.05


def test_a_cut_spectrum_says_so():
    row = (DATA / "parsivel_warsaw.txt").read_bytes().splitlines()[0]
    with pytest.raises(ParseError, match="without </SPECTRUM>"):
        parsivel.parse(Frame(row.split(b"</SPECTRUM>")[0]), {"fields": WARSAW})
    assert parsivel.parse(Frame(row), {"fields": WARSAW}).rain_rate_mm_h == 0.75


@pytest.mark.parametrize("step", [7, 333, 5000])
def test_valued_spectra_survive_any_split(step):
    data = (DATA / "parsivel_warsaw.txt").read_bytes()
    chunks = [data[i : i + step] for i in range(0, len(data), step)]
    stats = DecodeStats()
    readings = list(decode_chunks(SPEC, chunks, options={"fields": WARSAW}, stats=stats))
    assert len(readings) == 3 and stats.bad == []


@pytest.mark.parametrize(
    ("name", "t", "first"),
    [
        (  # pyAtmosLogger-style: datetime_utc;rain rate [mm/h];...
            "parsivel_kenttarova_excerpt.csv",
            ["2025-11-18T00:00:03Z", "2025-11-18T00:01:03Z"],
            {"rain_accum_mm": 0.4, "wawa": 0, "metar": "", "temperature_c": -10.0},
        ),
        (
            "parsivel_bucharest_20240219_excerpt.csv",
            ["2024-02-19T00:00:07Z", "2024-02-19T00:01:07Z"],
            {"rain_accum_mm": 3.69, "visibility_m": 20000.0, "temperature_c": 3.0},
        ),
        (  # Campbell TOA5: 4 header lines, "TIMESTAMP","RECORD",named columns
            "parsivel_granada_toa5_excerpt.dat",
            ["2021-02-08T20:08:00Z", "2021-02-08T20:09:00Z"],
            {"rain_accum_mm": 37.22, "wawa": 0, "visibility_m": 20000.0},
        ),
    ],
)
def test_header_csvs_are_read_by_their_column_names(name, t, first):
    readings, stats = decode(DATA / name)
    assert (stats.bad, stats.garbage_bytes) == ([], 0)
    assert [r["t"] for r in readings] == t
    assert {r["time_source"] for r in readings} == {"logger"}
    assert {k: readings[0][k] for k in first} == first


def test_toa5_raining_row():
    readings, _ = decode(DATA / "parsivel_granada_toa5_excerpt.dat")
    assert (readings[1]["rain_rate_mm_h"], readings[1]["wawa"]) == (0.837, 61)
    assert readings[1]["visibility_m"] == 18282


def test_millisecond_stamps_and_a_cut_first_line():
    """Ny-Ålesund: ``20190410230720.646;``; the file starts mid-telegram, line 3 holds a
    stray byte: both said, with what was expected."""
    readings, stats = decode(DATA / "parsivel_ny_alesund_ms_excerpt.log")
    assert [r["t"] for r in readings] == ["2019-04-10T23:07:20.646000Z"]
    assert [line for line, _ in stats.bad] == [1, 3]
    assert "expected 1105 values" in stats.bad[0][1] and "U0000.000" in stats.bad[1][1]


LINDENBERG = (
    "20231204000047;0000.000;0058.68;00;-9.999;20000;00060;21922;00000;-10;451221;2.11.6;"
    "0.00;23.8;0;LINDENBERG;0000.000;000;"
)


@pytest.mark.parametrize(
    ("prefix", "t"),
    [
        (b"1701648047;", "2023-12-04T00:00:47Z"),
        (b"1701648047250;", "2023-12-04T00:00:47.250000Z"),
        (b"1701648047.25;", "2023-12-04T00:00:47.250000Z"),
        (b"20231204000047.250;", "2023-12-04T00:00:47.250000Z"),
        (b"2023-12-04 00:00:47;", "2023-12-04T00:00:47Z"),
        (b"2023-12-04T00:00:47Z ", "2023-12-04T00:00:47Z"),
        (b'"2023-12-04 00:00:47",17,', "2023-12-04T00:00:47Z"),
    ],
)
def test_logger_prefixes(prefix, t):
    telegram = LINDENBERG.split(";", 1)[1].encode()
    options = {"fields": [1, 2, 3, 7, 8, 9, 10, 11, 12, 13, 14, 16, 17, 18, 22, 24, 25]}
    stats = DecodeStats()
    (r,) = decode_chunks(SPEC, [prefix + telegram + b"\r\n"], options=options, stats=stats)
    assert r.to_json()["t"] == t and r.extra["time_source"] == "logger"
    assert (r.rain_accum_mm, r.extra["station_name"]) == (58.68, "LINDENBERG")


EPFL = Path(os.environ.get("WEATHERD_DATA", "/work/data")) / "instruments"
EPFL = EPFL / "epfl_parsivel_2007_toa5.dat"


@pytest.mark.skipif(not EPFL.exists(), reason="GPL capture kept outside git (PROVENANCE)")
def test_toa5_with_quoted_values_and_vectors_in_one_column():
    """disdrodb's EPFL 2007 capture: every value quoted, each vector a quoted list."""
    readings, stats = decode(EPFL)
    assert (len(readings), stats.bad, stats.garbage_bytes) == (25, [], 0)
    assert readings[0]["t"] == "2007-07-23T14:15:30Z"
    assert readings[-1]["t"] == "2007-07-23T14:19:30Z"
    assert {r["time_source"] for r in readings} == {"logger"}
    assert readings[0]["visibility_m"] == 5000 and readings[0]["laser_amplitude"] == 13717


def test_quoted_vectors_in_one_column_built():
    """The EPFL layout, built: a vector column holding commas does not shift the others."""
    data = (
        b'"TOA5","7481","CR1000","7481","CR1000.Std.11","CPU:Parsivel.CR1","49567","P"\r\n'
        b'"TIMESTAMP","RECORD","Intensity","AccumulatedAmount","Code4680","FieldN",'
        b'"Visibility"\r\n"TS","RN","","","","",""\r\n"","","Smp","Smp","Smp","Smp","Smp"\r\n'
        b'"2007-07-23 14:15:30",0,"0001.250","0000.76","61","-9.999,0.5,1.25","4500"\r\n'
    )
    stats = DecodeStats()
    (r,) = decode_chunks(SPEC, [data], stats=stats)
    assert (r.rain_rate_mm_h, r.rain_accum_mm, r.wawa, r.visibility_m) == (1.25, 0.76, 61, 4500)
    assert r.to_json()["t"] == "2007-07-23T14:15:30Z" and stats.bad == []


@pytest.mark.parametrize(
    "name", ["parsivel_granada_toa5_excerpt.dat", "parsivel_kenttarova_excerpt.csv"]
)
def test_header_csvs_survive_any_split(name):
    data = (DATA / name).read_bytes()
    rng = random.Random(12)
    whole = [r.to_json() for r in decode_chunks(SPEC, [data])]
    assert len(whole) == 2
    for _ in range(5):
        cuts = sorted(rng.sample(range(1, len(data)), 40))
        chunks = [data[a:b] for a, b in zip([0, *cuts], [*cuts, len(data)], strict=True)]
        assert [r.to_json() for r in decode_chunks(SPEC, chunks)] == whole
