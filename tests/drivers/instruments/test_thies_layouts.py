"""Thies LNM as loggers really write it (real captures from cloudnetpy's tests, see
data/PROVENANCE.md): stamps before the telegram, header lines, TOA5, a sensor clock years off."""

from __future__ import annotations

from pathlib import Path

import pytest

from drivers.instruments import DRIVERS
from drivers.instruments.decode import DecodeStats, decode_file

DATA = Path(__file__).parent / "data"
SPEC = DRIVERS["thies-lnm"]


def decode(path: Path, **kw) -> tuple[list[dict], DecodeStats]:
    stats = DecodeStats()
    return [r.to_json() for r in decode_file(SPEC, path, stats=stats, **kw)], stats


@pytest.mark.parametrize(
    ("name", "t", "offsets", "accum"),
    [
        (  # header line, then ``YYYY-MM-DD hh:mm:ss;`` + telegram, CR LF
            "thies_lindenberg_20241003_excerpt.csv",
            ["2024-10-03T00:00:41Z", "2024-10-03T00:01:41Z"],
            [-1.0, -1.0],
            382.44,
        ),
        (  # the same, LF, 4-digit spectrum values
            "thies_payerne_20240702_excerpt.csv",
            ["2024-07-02T00:00:00Z", "2024-07-02T00:01:00Z"],
            [63.0, 63.0],
            0.0,
        ),
    ],
)
def test_a_logger_stamp_before_the_telegram_dates_it(name, t, offsets, accum):
    readings, stats = decode(DATA / name)
    assert (stats.bad, stats.garbage_bytes) == ([], 0)
    assert [r["t"] for r in readings] == t
    assert [r["time_source"] for r in readings] == ["logger"] * 2
    assert [r["sensor_clock_offset_s"] for r in readings] == offsets
    assert readings[0]["rain_accum_mm"] == accum
    assert not any("sensor clock" in note for note in stats.notes)  # a minute is not "off"


def test_toa5_with_a_sensor_clock_five_years_behind():
    """The CR6's TOA5 file: 2024-04-14 by the logger, 18.02.19 by the sensor. The logger's
    time is used and the gap said once; --time sensor gives the sensor's back."""
    readings, stats = decode(DATA / "thies_toa5_2024_04_14.dat")
    assert (len(readings), stats.bad, stats.garbage_bytes) == (3, [], 0)
    assert [r["t"] for r in readings] == [f"2024-04-14T00:0{m}:00Z" for m in (1, 2, 3)]
    clock = [n for n in stats.notes if "sensor clock" in n]
    assert len(clock) == 1 and "2019-02-18T13:41:00Z" in clock[0]
    assert "2024-04-14T00:01:00Z" in clock[0] and "off by -5 year(s)" in clock[0]
    assert readings[0]["rain_accum_mm"] == 17.16 and readings[0]["serial_number"] == "2965"
    sensor, _ = decode(DATA / "thies_toa5_2024_04_14.dat", time="sensor")
    assert sensor[0]["t"] == "2019-02-18T13:41:00Z" and sensor[0]["time_source"] == "sensor"
    assert sensor[0]["logger_t"] == "2024-04-14T00:01:00Z"


def test_without_a_logger_the_file_name_is_the_check(tmp_path):
    """No stamp: the sensor's clock dates the readings; a file named for another day says so."""
    data = (DATA / "thies_2025060200.txt").read_bytes()
    readings, stats = decode(DATA / "thies_2025060200.txt")
    assert readings[0]["t"] == "2025-06-02T00:00:00Z"
    assert not any("file's name" in note for note in stats.notes)
    moved = tmp_path / "lnm_2024-04-14.txt"
    moved.write_bytes(data)
    readings, stats = decode(moved)
    notes = [n for n in stats.notes if "file's name" in n]
    assert len(notes) == 1 and "2025-06-02T00:00:00Z" in notes[0] and "2024-04-14" in notes[0]
    assert readings[0]["t"] == "2025-06-02T00:00:00Z"


def test_header_lines_are_neither_frames_nor_garbage():
    data = (DATA / "thies_toa5_2024_04_14.dat").read_bytes()
    framer = SPEC.make_framer(SPEC.check_options({}))
    frames = framer.feed(data) + framer.flush()
    assert len(frames) == 3 and framer.header_lines == 4 and framer.garbage_bytes == 0
    assert all(f.t_ns is not None and f.data.startswith(b'"00;') for f in frames)
