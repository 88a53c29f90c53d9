"""decode's clocks: the logger's stamp or the sensor's clock, said in time_source, forced by
``time``; a sensor clock that is off is said once."""

from __future__ import annotations

import pytest

from drivers.instruments import DRIVERS
from drivers.instruments.decode import DecodeStats, decode_chunks

#: A Parsivel CS/PA answer (the layout of hyytiala.txt in cloudnetpy's tests) whose sensor
#: clock (20/21) reads 00:30:27 on 14.01.2024.
ANSWER = (
    b"TYP OP4A\r\n01:0000.123\r\n02:0012.34\r\n03:61\r\n05:  -RA\r\n08:20000\r\n12:021\r\n"
    b"18:0\r\n20:00:30:27\r\n21:14.01.2024\r\n"
)


def decode(data: bytes, driver="ott-parsivel", **kw) -> tuple[list[dict], DecodeStats]:
    stats = DecodeStats()
    readings = decode_chunks(DRIVERS[driver], [data], stats=stats, **kw)
    return [r.to_json() for r in readings], stats


def test_logger_stamp_by_default_sensor_when_asked():
    data = b"[2024-01-14 00:00:00\r\n" + ANSWER
    (logger,), stats = decode(data)
    assert (logger["t"], logger["time_source"]) == ("2024-01-14T00:00:00Z", "logger")
    assert logger["sensor_clock_offset_s"] == 1827
    (sensor,), _ = decode(data, time="sensor")
    assert (sensor["t"], sensor["time_source"]) == ("2024-01-14T00:30:27Z", "sensor")
    assert sensor["logger_t"] == "2024-01-14T00:00:00Z"
    assert len(stats.notes) == 1 and "off by +30 min 27 s" in stats.notes[0]


def test_without_a_logger_stamp_the_sensor_clock_either_way():
    for time in ("logger", "sensor"):
        readings, stats = decode(ANSWER + b"\r\n" + ANSWER, time=time)
        assert len(readings) == 2 and stats.notes == []
        for r in readings:
            assert (r["t"], r["time_source"]) == ("2024-01-14T00:30:27Z", "sensor")
            assert "logger_t" not in r


def test_a_sensor_clock_in_local_time_is_said_once_as_a_whole_hour_offset():
    data = b"".join(
        b"[2024-01-14 06:%02d:00\r\n" % m + ANSWER.replace(b"00:30:27", b"00:%02d:00" % m)
        for m in range(3)
    )
    readings, stats = decode(data)
    assert [r["sensor_clock_offset_s"] for r in readings] == [-6 * 3600] * 3
    assert len(stats.notes) == 1 and "looks like UTC-6" in stats.notes[0]
    fixed, stats = decode(data, options={"timezone": -6})
    assert [r["sensor_clock_offset_s"] for r in fixed] == [0] * 3 and stats.notes == []


def test_bad_time_choice():
    with pytest.raises(ValueError, match="time"):
        decode(ANSWER, time="gps")
