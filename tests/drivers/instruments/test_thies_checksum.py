"""Thies LNM checksums as real sensors write them: the manual's rule, a constant away.

Every real capture found (cloudnetpy's tests: four sensors, firmware 2.52 to 2.70) carries a
checksum that is the manual's (two's complement of the byte sum from STX) plus a constant:
0xAB for the 520-value telegram, 0xA5 with the four external-sensor values. The same offset on
every telegram of a file is a convention, said once; random corruption is not.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from drivers.instruments import DRIVERS, thies
from drivers.instruments.base import Frame, ParseError
from drivers.instruments.decode import DecodeStats, checksum_convention, decode_file

DATA = Path(__file__).parent / "data"
SPEC = DRIVERS["thies-lnm"]


def _lines(name: str) -> list[bytes]:
    return [line for line in (DATA / name).read_bytes().splitlines() if line.count(b";") > 500]


@pytest.mark.parametrize(
    ("name", "n", "offset"),
    [("thies_2021091507_excerpt.txt", 5, 0xAB), ("thies_2025060200.txt", 3, 0xA5)],
)
def test_real_telegrams_are_the_manual_checksum_plus_a_constant(name, n, offset):
    lines = _lines(name)
    assert len(lines) == n
    for line in lines:
        cs = line.rstrip(b";\r").rsplit(b";", 1)[1].decode()
        assert thies.checksum_offset(line, cs) == offset
        with pytest.raises(ParseError, match="checksum mismatch: telegram says"):
            thies.parse(Frame(line), {})
        r = thies.parse(Frame(line), {"checksum": "report"})
        assert r.extra["checksum_ok"] is False and r.extra["checksum_offset"] == f"{offset:02X}"


def test_a_file_that_fails_the_same_way_everywhere_is_a_convention_said_once():
    path = DATA / "thies_2021091507_excerpt.txt"
    stats = DecodeStats()
    readings = list(decode_file(SPEC, path, stats=stats))
    assert len(readings) == 5 and stats.bad == []
    assert (
        len(stats.notes) == 1
        and "all 5 telegrams fail their checksum the same way" in (stats.notes[0])
    )
    assert "0xAB" in stats.notes[0] and "--checksum report" in stats.notes[0]
    assert {r.extra["checksum_ok"] for r in readings} == {False}
    assert readings[0].to_json()["t"] == "2021-09-15T07:00:00Z"
    assert readings[0].extra["serial_number"] == "1025"


def test_enforce_refuses_them_and_ignore_does_not_look():
    path = DATA / "thies_2025060200.txt"
    stats = DecodeStats()
    assert list(decode_file(SPEC, path, stats=stats, checksum="enforce")) == []
    assert len(stats.bad) == 3 and stats.notes == []
    stats = DecodeStats()
    readings = list(decode_file(SPEC, path, stats=stats, checksum="ignore"))
    assert len(readings) == 3 and "checksum_ok" not in readings[0].extra and stats.notes == []
    assert readings[2].extra["serial_number"] == "3778"


def test_corruption_is_not_a_convention(tmp_path):
    """One telegram with a changed value: offsets differ, so the default enforces."""
    lines = _lines("thies_2021091507_excerpt.txt")
    lines[2] = lines[2].replace(b";000.000;", b";001.000;", 1)
    path = tmp_path / "corrupt.txt"
    path.write_bytes(b"\r\n".join(lines) + b"\r\n")
    assert checksum_convention(SPEC, path) is None
    stats = DecodeStats()
    assert list(decode_file(SPEC, path, stats=stats)) == [] and len(stats.bad) == 5
    report = list(decode_file(SPEC, path, checksum="report"))
    offsets = [r.extra["checksum_offset"] for r in report]
    assert offsets.count("AB") == 4 and len(set(offsets)) == 2


def test_telegrams_that_match_the_manual_stay_enforced(tmp_path):
    """A file of good telegrams and one bad: the bad one is refused, nothing is said."""
    from tests.drivers.instruments.test_thies import telegram

    good = telegram()
    bad = good.replace(b"002.345", b"002.346")
    path = tmp_path / "mixed.txt"
    path.write_bytes(good + bad + good)
    stats = DecodeStats()
    assert len(list(decode_file(SPEC, path, stats=stats))) == 2
    assert len(stats.bad) == 1 and stats.notes == []
    assert [r.extra["checksum_ok"] for r in decode_file(SPEC, path, checksum="report")] == [
        True,
        False,
        True,
    ]


def test_a_single_telegram_is_not_enough_to_call_a_convention(tmp_path):
    path = tmp_path / "one.txt"
    path.write_bytes(_lines("thies_2025060200.txt")[0] + b"\r\n")
    assert checksum_convention(SPEC, path) is None
