"""``weatherd instruments decode``: the contract JSON lines, bad lines reported, never fatal."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from tests.conftest import (
    run_weatherd,
)

CONTRACT = (
    "t",
    "driver",
    "visibility_m",
    "rain_rate_mm_h",
    "rain_accum_mm",
    "wawa",
    "metar",
    "status",
)


def decode(*args: object) -> subprocess.CompletedProcess[str]:
    return run_weatherd("instruments", "decode", *args)


@pytest.mark.parametrize(
    ("driver", "path", "n", "first"),
    [
        (
            "vaisala-pwd",
            "vaisala-fd12p/PW040406.DAT",
            3,
            {"visibility_m": 9163.0, "rain_rate_mm_h": 0.18, "rain_accum_mm": 50.3, "wawa": 52},
        ),
        (
            "ott-parsivel",
            "ott-parsivel2/bucharest_0000000123_20231025221800.txt",
            1,
            {
                "rain_rate_mm_h": 2.356,
                "rain_accum_mm": 5.48,
                "wawa": 61,
                "metar": "-RA",
                "visibility_m": 8134.0,
            },
        ),
        (
            "ott-parsivel",
            "ott-parsivel2/Lindenberg_Parsivel_20231204.log",
            3,
            {"t": "2023-12-04T00:00:47Z", "rain_rate_mm_h": 0.0},
        ),
        (
            "thies-lnm",
            "thies-lnm/2024041723-leipzig-lim.txt",
            3,
            {"t": "2024-04-17T23:00:50Z", "rain_rate_mm_h": 0.0, "wawa": 0},
        ),
        (
            "lambrecht-raine",
            "lambrecht-raine/Lindenberg_RainE_20230514.txt",
            18,
            {"t": "2023-05-14T00:00:39Z", "rain_rate_mm_h": 0.0, "rain_accum_mm": 0.406},
        ),
    ],
)
def test_real_captures(shared_fixtures: Path, driver: str, path: str, n: int, first: dict) -> None:
    proc = decode("--driver", driver, shared_fixtures / "instruments" / path)
    assert proc.returncode == 0, proc.stderr
    lines = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(lines) == n
    for rec in lines:
        assert set(CONTRACT) <= set(rec) and rec["driver"] == driver
        assert rec["t"] is None or rec["t"].endswith("Z")
    assert {k: lines[0][k] for k in first} == first
    assert f"{n} readings, 0 bad frame(s)" in proc.stderr


def test_bad_lines_are_reported_with_their_number_and_counted(tmp_path: Path) -> None:
    good = b"\x01PW  1\x02 00  6839  7505   R-   61   61   61  0.33  12.16     0\x03\r\n"
    capture = tmp_path / "pwd.raw"
    capture.write_bytes(
        b"\xff\xfe power-up garbage\r\n" + good + b"\x01PW  1\x02 00 12 //\x03\r\n" + good
    )
    proc = decode("--driver", "vaisala-pwd", capture)
    assert proc.returncode == 0, proc.stderr
    readings = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(readings) == 2
    assert readings[0]["rain_rate_mm_h"] == 0.33 and readings[0]["t"] is None
    bad = [line for line in proc.stderr.splitlines() if f"{capture}:" in line and ": " in line]
    assert any(f"{capture}:3:" in line for line in bad), proc.stderr
    assert any(f"{capture}:1:" in line for line in bad)  # the power-up garbage line
    assert "2 readings, 2 bad frame(s)" in proc.stderr


def test_driver_options_and_the_tipping_bucket_capture(tmp_path: Path) -> None:
    capture = tmp_path / "tips.txt"
    capture.write_text(
        "".join(f"2024-05-01T10:00:{s:02d}Z tip\n" for s in range(0, 60, 10))
        + "2024-05-01T10:01:30Z tip\nnot a line\n2024-05-01T10:02:05Z tip\n"
    )
    proc = decode(
        "--driver",
        "tipping-bucket",
        capture,
        "--option",
        "mm_per_tip=0.5",
        "--option",
        "report_interval_s=60",
    )
    assert proc.returncode == 0, proc.stderr
    readings = [json.loads(line) for line in proc.stdout.splitlines()]
    assert readings[0]["rain_rate_mm_h"] == pytest.approx(6 * 0.5 * 60)
    assert "not a line" in proc.stderr or ":8:" in proc.stderr


@pytest.mark.parametrize(
    ("args", "names"),
    [
        (["--driver", "vaisala-pwd", "missing.dat"], "missing.dat"),
        (["--driver", "no-such-driver", "x"], "--driver"),
        (["--driver", "tipping-bucket", "FILE", "--option", "mm_per_tip=-1"], "mm_per_tip"),
        (["--driver", "ascii-regex", "FILE", "--option", "pattern='('"], "pattern"),
    ],
)
def test_errors_are_one_line_and_exit_2(tmp_path: Path, args: list[str], names: str) -> None:
    f = tmp_path / "capture.txt"
    f.write_text("2024-05-01T10:00:00Z tip\n")
    proc = decode(*[str(f) if a == "FILE" else a for a in args])
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and lines[0].startswith("weatherd: error: ") and names in lines[0]


def test_time_option_picks_the_clock_and_the_off_clock_is_said_once(tmp_path: Path) -> None:
    answer = b"TYP OP4A\r\n01:0000.123\r\n02:0012.34\r\n03:61\r\n20:00:30:27\r\n21:14.01.2024\r\n"
    capture = tmp_path / "hyytiala-like.txt"
    capture.write_bytes((b"[2024-01-14 00:00:00\r\n" + answer) * 3)
    got = {}
    for time in ("logger", "sensor"):
        proc = decode("--driver", "ott-parsivel", capture, "--time", time)
        assert proc.returncode == 0, proc.stderr
        got[time] = [json.loads(line) for line in proc.stdout.splitlines()]
        assert proc.stderr.count("the sensor clock is off by +30 min 27 s") == 1, proc.stderr
    assert {(r["t"], r["time_source"]) for r in got["logger"]} == {
        ("2024-01-14T00:00:00Z", "logger")
    }
    assert {(r["t"], r["time_source"], r["logger_t"]) for r in got["sensor"]} == {
        ("2024-01-14T00:30:27Z", "sensor", "2024-01-14T00:00:00Z")
    }


DATA = Path(__file__).parents[2] / "drivers" / "instruments" / "data"


def test_a_checksum_convention_is_said_once_and_the_readings_kept() -> None:
    capture = DATA / "thies_2025060200.txt"
    proc = decode("--driver", "thies-lnm", capture)
    assert proc.returncode == 0, proc.stderr
    assert len(proc.stdout.splitlines()) == 3
    lines = proc.stderr.splitlines()
    assert len(lines) == 2 and "fail their checksum the same way" in lines[0], proc.stderr
    assert "3 readings, 0 bad frame(s)" in lines[1]
    proc = decode("--driver", "thies-lnm", capture, "--checksum", "enforce")
    assert proc.stdout == "" and "3 bad frame(s)" in proc.stderr
    proc = decode("--driver", "thies-lnm", capture, "--checksum", "report")
    assert [json.loads(line)["checksum_ok"] for line in proc.stdout.splitlines()] == [False] * 3
    assert "same way" not in proc.stderr


@pytest.mark.parametrize("driver", ["thies-lnm", "ott-parsivel"])
def test_a_file_without_any_reading_says_what_was_expected(tmp_path: Path, driver: str) -> None:
    capture = tmp_path / "notes.txt"
    capture.write_text("hello world\nnothing here\n")
    proc = decode("--driver", driver, capture)
    assert proc.returncode == 0 and proc.stdout == ""
    said = [line for line in proc.stderr.splitlines() if "no reading" in line]
    assert len(said) == 1 and f"{driver} expects" in said[0] and "telegram" in said[0]
    assert f"{capture}:1:" in proc.stderr  # and each line says why it is not one
