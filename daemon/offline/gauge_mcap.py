"""The daemon's own rain-gauge channel in an MCAP recording, as reference intervals.

Format (``mcap-gauge``, or any ``.mcap`` file)
    Messages on topics ``/instrument/<id>/reading`` with JSON payloads holding ``t_ns`` (UTC
    ns; the message log time when absent), ``rain_accum_mm`` (the instrument's accumulation
    counter) and ``rain_rate_mm_h``. Read streaming with ``mcap.reader.make_reader``; other
    topics are not decoded. ``<id>`` is the station of the intervals.

Aggregation
    Readings of one instrument are taken in time order. The rain between two consecutive
    readings is the difference of their accumulations; a negative difference (the counter
    wrapped or was reset) is dropped and counted. When either reading lacks the accumulation
    the rate is integrated instead (``rain_rate_mm_h`` of the later reading × the time
    between them). Each difference is placed in the interval holding the later reading.
    Intervals are ``interval_s`` long (default 3600 s), aligned on the Unix epoch (so on the
    hour in UTC). An interval gets an amount only when the readings' spans cover at least 90 %
    of it; otherwise (the first and last partial intervals, a gap in the recording) its
    amount is None. Two readings further apart than ``interval_s`` do not cover anything.
"""

from __future__ import annotations

import json
import re
from collections import defaultdict
from datetime import UTC, datetime, timedelta
from itertools import pairwise
from typing import IO

from mcap.exceptions import InvalidMagic, McapError
from mcap.reader import make_reader

from daemon.offline.reference_common import Interval, ReadContext

__all__ = ["DEFAULT_INTERVAL_S", "MIN_COVERAGE", "READING_TOPIC_RE", "read_gauge_mcap"]

READING_TOPIC_RE = re.compile(r"^/instrument/([^/]+)/reading$")
DEFAULT_INTERVAL_S = 3600.0
MIN_COVERAGE = 0.9
EPOCH = datetime(1970, 1, 1, tzinfo=UTC)

#: (t_ns, rain_accum_mm or None, rain_rate_mm_h or None)
_Reading = tuple[int, float | None, float | None]


def read_gauge_mcap(binary: IO[bytes], ctx: ReadContext) -> list[Interval]:
    """Intervals of the gauge readings in an MCAP file (see the module docstring)."""
    readings = _readings(binary, ctx)
    if not readings:
        raise ctx.error("no /instrument/<id>/reading messages")
    interval_ns = round((ctx.interval_s or DEFAULT_INTERVAL_S) * 1e9)
    out: list[Interval] = []
    for station, series in readings.items():
        out.extend(_aggregate(sorted(series), station, interval_ns, ctx))
    return out


def _readings(binary: IO[bytes], ctx: ReadContext) -> dict[str, list[_Reading]]:
    try:
        reader = make_reader(binary)
        summary = reader.get_summary()
    except InvalidMagic:
        raise ctx.error("not an MCAP file (it does not start with the MCAP magic)") from None
    except (McapError, ValueError, EOFError, OSError) as err:
        raise ctx.error(f"not a readable MCAP file ({err}); try weatherd recover") from err
    topics = None
    if summary is not None:
        topics = [c.topic for c in summary.channels.values() if READING_TOPIC_RE.match(c.topic)]
        if not topics:
            return {}
    readings: dict[str, list[_Reading]] = defaultdict(list)
    index = 0
    try:
        for _, channel, message in reader.iter_messages(topics=topics, log_time_order=False):
            match = READING_TOPIC_RE.match(channel.topic)
            if match is None:
                continue
            index += 1
            station = match.group(1)
            ctx.stats.rows += 1
            if not ctx.wants(station):
                continue
            try:
                reading = _parse(message.data, message.log_time)
            except (ValueError, TypeError, UnicodeDecodeError) as err:
                ctx.bad_row(index, str(err), unit="message")
                continue
            readings[station].append(reading)
    except (McapError, EOFError, ValueError) as err:
        ctx.stats.truncated = True
        ctx.bad_row(index + 1, f"MCAP stream ends or breaks here ({err})", unit="message")
    return readings


def _parse(data: bytes, log_time_ns: int) -> _Reading:
    obj = json.loads(data)
    if not isinstance(obj, dict):
        raise ValueError("payload is not a JSON object")
    t_ns = obj.get("t_ns", log_time_ns)
    if isinstance(t_ns, bool) or not isinstance(t_ns, int):
        raise ValueError(f"t_ns {t_ns!r} is not an integer")
    return t_ns, _number(obj.get("rain_accum_mm")), _number(obj.get("rain_rate_mm_h"))


def _number(value: object) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{value!r} is not a number")
    return float(value)


def _aggregate(
    series: list[_Reading], station: str, interval_ns: int, ctx: ReadContext
) -> list[Interval]:
    """Amounts per aligned interval from one instrument's readings (sorted by time)."""
    amount: dict[int, float] = defaultdict(float)
    covered: dict[int, int] = defaultdict(int)
    for (t0, accum0, _), (t1, accum1, rate1) in pairwise(series):
        span = t1 - t0
        if span <= 0 or span > interval_ns:
            continue
        if accum0 is not None and accum1 is not None:
            rain = accum1 - accum0
            if rain < 0.0:
                ctx.stats.negative += 1
                continue
        elif rate1 is not None and rate1 >= 0.0:
            rain = rate1 * span / 3.6e12
        else:
            continue
        slot = t1 // interval_ns
        amount[slot] += rain
        covered[slot] += span
    if not series:
        return []
    first, last = series[0][0] // interval_ns, series[-1][0] // interval_ns
    step = timedelta(microseconds=interval_ns // 1000)
    out = []
    for slot in range(first, last + 1):
        start = EPOCH + timedelta(microseconds=slot * interval_ns // 1000)
        complete = covered.get(slot, 0) >= MIN_COVERAGE * interval_ns
        value = round(amount[slot], 6) if complete else None
        out.append(Interval(start, start + step, ctx.amount(value), station))
    return out
