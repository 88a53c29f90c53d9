"""DWD (Deutscher Wetterdienst) station data: 10-minute and hourly precipitation, as text or
as the ZIP the Climate Data Center serves.

Format (``dwd``; field descriptions: the CDC dataset descriptions
``DESCRIPTION_obsgermany-climate-10min-precipitation_en.pdf`` and
``…hourly_precipitation…``, and the ``Metadaten_Parameter_*`` file in each ZIP)

``produkt_zehn_min_rr_<from>_<to>_<station>.txt`` (in ``10minutenwerte_nieder_<station>_
{akt,hist}.zip``; also ``produkt_zh_10min_rr_…`` and ``produkt_zehn_now_rr_…``)
    ``;``-separated, fields padded with blanks, header
    ``STATIONS_ID;MESS_DATUM;  QN;RWS_DAU_10;RWS_10;RWS_IND_10;eor`` and rows
    ``       2667;201911290000;    3;  10;   0.13;   1;eor`` (the ``eor`` "end of record"
    column may be absent). ``MESS_DATUM`` is ``YYYYMMDDhhmm``, ``RWS_10`` "Summe der
    Niederschlagshöhe der vorangegangenen 10 min" in mm, ``-999`` = missing, ``QN`` the
    quality level (reported as ``quality``). The stamp marks the END of the interval: the
    dataset metadata says "The measurements are assigned to a timestamp in UTC which marks
    the end of the 10-minute interval", so ``[stamp - 10 min, stamp)``. Time zone: "As of
    1.1.2000 the time stamp is given in UTC, for the period before that in CET" (MEZ, UTC+1
    all year, no summer time): stamps before ``200001010000`` are read as UTC+1, later ones
    as UTC (the change wetterdienst#541 reports it had missed). ``tz`` is not used.
``produkt_rr_stunde_<from>_<to>_<station>.txt`` (in ``stundenwerte_RR_<station>_{akt,hist}
.zip``)
    ``STATIONS_ID;MESS_DATUM;  QN_8;  R1;RS_IND;WRTR;eor``, ``MESS_DATUM`` = ``YYYYMMDDhh``
    in UTC (the metadata's "Zusatz-Info: in UTC"), ``R1`` "stündliche Niederschlagshöhe" in
    mm over the hour ENDING at the stamp ("precipitation height during the previous hour"):
    ``[stamp - 1 h, stamp)``, quality ``QN_8``.

The ZIP as downloaded is read as is: its ``produkt_*.txt`` member is the data, the
``Metadaten_*`` files are ignored. Rows whose field count differs from the header's, or whose
date or amount does not parse, are skipped as malformed.
"""

from __future__ import annotations

import logging
import zipfile
import zlib
from collections.abc import Iterable, Iterator
from datetime import UTC, datetime, timedelta, timezone
from typing import IO

from daemon.offline.reference_common import Interval, ReadContext, iter_lines, parse_number

__all__ = ["ZIP_MAGIC", "looks_like_dwd", "read_dwd", "read_dwd_binary", "zip_has_product"]

logger = logging.getLogger(__name__)

ZIP_MAGIC = b"PK\x03\x04"
MEZ = timezone(timedelta(hours=1), "MEZ")
UTC_FROM = datetime(2000, 1, 1, tzinfo=MEZ)  # 10-minute stamps from here on are UTC
MISSING = -999.0
#: amount column -> (step, digits of MESS_DATUM, quality column, MEZ before 2000)
PRODUCTS = {
    "RWS_10": (timedelta(minutes=10), 12, "QN", True),
    "R1": (timedelta(hours=1), 10, "QN_8", False),
}
ZIP_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, OSError, NotImplementedError, ValueError)


def looks_like_dwd(first_line: str) -> bool:
    """Whether ``first_line`` is the header of a DWD ``produkt_*`` file."""
    names = {name.strip().upper() for name in first_line.split(";")}
    return {"STATIONS_ID", "MESS_DATUM"} <= names


def zip_has_product(binary: IO[bytes]) -> bool:
    """Whether ``binary`` (at a ZIP's start) holds a ``produkt_*.txt`` member."""
    try:
        with zipfile.ZipFile(binary) as archive:
            return _product(archive) is not None
    except ZIP_ERRORS:
        return False


def read_dwd_binary(binary: IO[bytes], ctx: ReadContext) -> list[Interval]:
    """Intervals of a DWD ZIP as downloaded, or of its ``produkt_*.txt`` (see the module
    docstring)."""
    head = binary.read(len(ZIP_MAGIC))
    binary.seek(0)
    if head != ZIP_MAGIC:
        return read_dwd(iter_lines(binary, ctx), ctx)
    try:
        with zipfile.ZipFile(binary) as archive:
            name = _product(archive)
            if name is None:
                members = ", ".join(archive.namelist()[:6]) or "nothing"
                raise ctx.error(f"ZIP without a DWD produkt_*.txt (it holds {members})")
            logger.info("%s: reading %s", ctx.name, name)
            with archive.open(name) as member:
                return read_dwd(_guarded(iter_lines(member, ctx), ctx), ctx)
    except ZIP_ERRORS as err:
        raise ctx.error(f"damaged ZIP: {err}") from None


def read_dwd(lines: Iterable[tuple[int, str]], ctx: ReadContext) -> list[Interval]:
    """Intervals of a DWD ``produkt_*`` text (see the module docstring)."""
    lines = iter(lines)
    header: list[str] = []
    for _, text in lines:
        if text.strip():
            header = [name.strip().upper() for name in text.split(";")]
            break
    if not header:
        raise ctx.error("empty file")
    amount_col = next((name for name in PRODUCTS if name in header), None)
    if amount_col is None or "MESS_DATUM" not in header:
        raise ctx.error(
            "DWD header without MESS_DATUM and RWS_10 (10 min) or R1 (hourly); "
            f"it has {', '.join(header)}",
            1,
        )
    step, digits, quality_col, mez_before_2000 = PRODUCTS[amount_col]
    i_time, i_value = header.index("MESS_DATUM"), header.index(amount_col)
    i_station = header.index("STATIONS_ID") if "STATIONS_ID" in header else None
    i_quality = header.index(quality_col) if quality_col in header else None
    n_fields = len(header)
    out: list[Interval] = []
    for line, text in lines:
        if not text.strip():
            continue
        ctx.stats.rows += 1
        fields = [f.strip() for f in text.split(";")]
        if len(fields) != n_fields:
            ctx.bad_row(line, f"{len(fields)} fields, the header has {n_fields}")
            continue
        station = fields[i_station] if i_station is not None else None
        if not ctx.wants(station):
            continue
        try:
            end = _stamp(fields[i_time], digits, mez_before_2000)
            value = parse_number(fields[i_value])
        except ValueError as err:
            ctx.bad_row(line, str(err))
            continue
        if value == MISSING:
            value = None
        quality = (fields[i_quality] or None) if i_quality is not None else None
        out.append(Interval(end - step, end, ctx.amount(value), station or None, quality))
    return out


def _product(archive: zipfile.ZipFile) -> str | None:
    names = [
        n
        for n in archive.namelist()
        if n.rsplit("/", 1)[-1].lower().startswith("produkt_") and n.lower().endswith(".txt")
    ]
    return names[0] if names else None


def _guarded(lines: Iterator[tuple[int, str]], ctx: ReadContext) -> Iterator[tuple[int, str]]:
    """The member's lines, a damaged member (bad CRC, truncated deflate) as an InputError."""
    try:
        yield from lines
    except ZIP_ERRORS as err:
        raise ctx.error(f"damaged ZIP member: {err}") from None


def _stamp(text: str, digits: int, mez_before_2000: bool) -> datetime:
    if len(text) != digits or not text.isdigit():
        raise ValueError(f"MESS_DATUM {text!r} is not {digits} digits")
    minute = int(text[10:12]) if digits == 12 else 0
    naive = datetime(int(text[:4]), int(text[4:6]), int(text[6:8]), int(text[8:10]), minute)
    if mez_before_2000 and naive.replace(tzinfo=MEZ) < UTC_FROM:
        return naive.replace(tzinfo=MEZ).astimezone(UTC)
    return naive.replace(tzinfo=UTC)
