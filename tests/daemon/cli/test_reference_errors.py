"""`weatherd reference` on the damaged files of issue 11: one line naming the file, status 2."""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest

from tests.conftest import run_weatherd


def _corrupt_gzip(path: Path) -> Path:
    data = bytearray(gzip.compress(b"time,precip_mm\n" + b"2024-01-01T00:00:00Z,1.0\n" * 2000))
    for i in range(30, len(data) - 20, 7):  # the header stays: it looks like gzip
        data[i] ^= 0x55
    path.write_bytes(bytes(data))
    return path


def _text(content: str):
    def make(path: Path) -> Path:
        path.write_text(content)
        return path

    return make


CASES = {
    "corrupt.csv.gz": (_corrupt_gzip, (), "corrupt compressed data"),
    "year99999.csv": (
        _text("time,precip_mm\n99999-01-01T00:00:00Z,1.0\n"),
        (),
        "no usable data",
    ),
    "nested.json": (
        _text("[" * 100_000 + "]" * 100_000),
        (),
        "nested too deeply",
    ),
    "plain.csv": (
        _text("time,precip_mm\n2024-01-01T00:00:00Z,1.0\n"),
        ("--format", "mcap-gauge"),
        "not an MCAP file",
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_damaged_reference_is_one_clean_line(tmp_path, name):
    make, options, expected = CASES[name]
    path = make(tmp_path / name)
    done = run_weatherd("reference", path, *options)
    assert done.returncode == 2, done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("weatherd: error:")]
    assert len(errors) == 1 and str(path) in errors[0] and expected in errors[0], done.stderr
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr
