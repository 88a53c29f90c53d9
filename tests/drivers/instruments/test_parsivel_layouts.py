"""OTT Parsivel² as loggers really write it: real captures from cloudnetpy's tests (see
data/PROVENANCE.md) and layouts built from them."""

from __future__ import annotations

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


def test_zero_and_valued_spectra_side_by_side_with_slash_dates():
    readings, stats = decode(DATA / "parsivel_palaiseau.txt", fields=PALAISEAU)
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
