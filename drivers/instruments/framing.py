"""Framers shared by the instrument drivers: lines, and start/end-delimited telegrams.

Both framers take whatever the port or file gives, split or merged arbitrarily, keep what is
incomplete for the next :meth:`feed`, count the bytes they drop in ``garbage_bytes`` and hand
back :class:`~drivers.instruments.base.Frame` objects in order. Any split of a stream gives
the same frames (a property the tests check with Hypothesis).

- :class:`LineFramer` cuts at CR, LF or CRLF. An optional **prefix** (a logger's timestamp at
  the start of each line) gives ``Frame.t_ns`` and is removed from the frame; an optional
  **sync** byte (Vaisala's SOH) makes a line start at its last occurrence, what comes before
  it being garbage (noise at power-up glued to the first message).
- :class:`DelimitedFramer` cuts ``start ... end`` telegrams (STX ... ETX by default),
  resynchronising on a new start byte; an end byte outside a telegram is garbage.

Times from a prefix are UTC: a logger time without a zone is taken as UTC.
"""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Callable

from .base import Frame

__all__ = [
    "PREFIX_DMY_HMS",
    "PREFIX_ISO",
    "PREFIX_TOA5",
    "PREFIX_YMDHMS",
    "DelimitedFramer",
    "LineFramer",
    "PrefixParser",
    "first_prefix",
    "is_blank",
    "regex_prefix",
    "unix_prefix",
]

#: ``prefix(line) -> (t_ns or None, rest of the line)``; ``(None, line)`` when absent.
PrefixParser = Callable[[bytes], tuple[int | None, bytes]]

#: ``20231204000047;`` (OTT/Campbell style loggers), ``20190410230720.646;`` with
#: milliseconds; separator ``;``, ``,`` or blanks.
PREFIX_YMDHMS = (
    rb"(?P<year>\d{4})(?P<month>\d{2})(?P<day>\d{2})"
    rb"(?P<hour>\d{2})(?P<minute>\d{2})(?P<second>\d{2})(?:\.(?P<fraction>\d{1,9}))?[;, \t]"
)
#: A Campbell TOA5 row: ``"2024-04-14 00:01:00",552609,`` (TIMESTAMP, RECORD); the rest
#: keeps its quotes (a telegram stored as a string is ``"00;2965;..."``).
PREFIX_TOA5 = (
    rb'"(?P<year>\d{4})-(?P<month>\d{2})-(?P<day>\d{2}) '
    rb'(?P<hour>\d{2}):(?P<minute>\d{2})(?::(?P<second>\d{2})(?:\.(?P<fraction>\d{1,9}))?)?",'
    rb"\d+,"
)
#: ``[2024-01-14 00:00:00``, ``2024-01-14T00:00:00.250Z;``, ``2019/11/15 10:00:00``: ISO-like
#: logger stamps, bracketed or not, before a telegram on the same line or alone on a line.
PREFIX_ISO = (
    rb"\[?(?P<year>\d{4})[-/](?P<month>\d{2})[-/](?P<day>\d{2})[ T]"
    rb"(?P<hour>\d{2}):(?P<minute>\d{2})(?::(?P<second>\d{2})(?:[.,](?P<fraction>\d{1,9}))?)?"
    rb"Z?\]?(?:[;, \t]+|$)"
)
#: ``06.04.2004   05:51:21   `` (Vaisala FD12P logger); seconds optional.
PREFIX_DMY_HMS = (
    rb"\s*(?P<day>\d{2})\.(?P<month>\d{2})\.(?P<year>\d{4})[ \t;]+"
    rb"(?P<hour>\d{2}):(?P<minute>\d{2})(?::(?P<second>\d{2}))?[ \t;]+"
)

_TERMINATOR = re.compile(rb"[\r\n]")
_BLANK = re.compile(rb"[\x00-\x20\x7f]*")
_EPOCH = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)


def first_prefix(*parsers: PrefixParser) -> PrefixParser:
    """A prefix parser trying ``parsers`` in turn: the first that finds a time wins."""

    def parse(line: bytes) -> tuple[int | None, bytes]:
        for parser in parsers:
            t_ns, rest = parser(line)
            if t_ns is not None:
                return t_ns, rest
        return None, line

    return parse


_UNIX = re.compile(rb"(?P<s>1\d{9})(?:(?P<ms>\d{3})|\.(?P<fraction>\d{1,9}))?[;, \t]")


def unix_prefix(line: bytes) -> tuple[int | None, bytes]:
    """A logger's Unix time before the telegram: ``1702166447;`` (seconds, 2001...2286),
    ``1702166447.250;`` or ``1702166447250;`` (milliseconds). UTC by definition."""
    m = _UNIX.match(line)
    if m is None:
        return None, line
    t_ns = int(m["s"]) * 1_000_000_000
    if m["ms"]:
        t_ns += int(m["ms"]) * 1_000_000
    elif m["fraction"]:
        t_ns += int(m["fraction"].decode().ljust(9, "0")[:9])
    return t_ns, line[m.end() :]


def is_blank(line: bytes) -> bool:
    """True when ``line`` holds only blanks and control characters (or nothing)."""
    return _BLANK.fullmatch(line) is not None


def regex_prefix(pattern: str | bytes | re.Pattern[bytes], *, strip: bool = True) -> PrefixParser:
    """A prefix parser from a regular expression matched at the start of a line.

    Parameters
    ----------
    pattern : bytes regex with the named groups ``year``, ``month``, ``day``, ``hour``,
        ``minute`` and optionally ``second`` and ``fraction`` (decimal digits of a second);
        a ``str`` is encoded as ASCII. The time is UTC.
    strip : remove the matched prefix from the frame (default) or keep the line whole.

    Returns
    -------
    PrefixParser : ``(t_ns, rest)``; ``(None, line)`` when the line does not start with the
        pattern or the date is impossible (31 February...), so the parser sees the line whole.
    """
    if isinstance(pattern, str):
        pattern = pattern.encode("ascii")
    regex = re.compile(pattern) if isinstance(pattern, bytes) else pattern

    def parse(line: bytes) -> tuple[int | None, bytes]:
        m = regex.match(line)
        if m is None:
            return None, line
        g = m.groupdict()
        try:
            t = dt.datetime(
                int(g["year"]),
                int(g["month"]),
                int(g["day"]),
                int(g["hour"]),
                int(g["minute"]),
                int(g.get("second") or 0),
                tzinfo=dt.UTC,
            )
        except ValueError:
            return None, line
        delta = t - _EPOCH
        t_ns = (delta.days * 86_400 + delta.seconds) * 1_000_000_000
        fraction = g.get("fraction")
        if fraction:
            t_ns += int(fraction.decode().ljust(9, "0")[:9])
        return t_ns, (line[m.end() :] if strip else line)

    return parse


class LineFramer:
    """Cuts a byte stream into lines at CR, LF or CRLF.

    Parameters
    ----------
    prefix : optional logger-timestamp prefix: a :data:`PrefixParser`, or a regex for
        :func:`regex_prefix` (named groups ``year``... ``second``; UTC). A line without the
        prefix gives a frame with ``t_ns=None``.
    sync : optional byte string; a line containing it starts at its last occurrence and the
        bytes before are garbage (e.g. ``b"\\x01"``, Vaisala's SOH).
    max_line_bytes : a longer line (wrong-baud noise without terminators) is dropped and its
        bytes counted as garbage, up to the next terminator; ``dropped_lines`` counts them.
    keep_blank : hand out blank lines (only blanks/control characters) as frames; by default
        they are dropped and their bytes counted as garbage.
    lstrip : bytes removed from the start of each line (and counted as garbage) before the
        sync and prefix are looked for, e.g. the NUL or ETX an instrument sends after a CR LF.

    Frames carry the line without its terminator and ``line``, its 1-based line number
    (a CRLF pair counts once; a lone CR or LF ends a line as well).
    """

    def __init__(
        self,
        *,
        prefix: PrefixParser | str | bytes | re.Pattern[bytes] | None = None,
        sync: bytes | None = None,
        max_line_bytes: int = 16384,
        keep_blank: bool = False,
        lstrip: bytes = b"",
    ) -> None:
        if max_line_bytes < 1:
            raise ValueError("max_line_bytes must be >= 1")
        if prefix is not None and not callable(prefix):
            prefix = regex_prefix(prefix)
        self._prefix: PrefixParser | None = prefix
        self._sync = sync or None
        self._max = int(max_line_bytes)
        self._keep_blank = keep_blank
        self._lstrip = bytes(lstrip)
        self._buf = bytearray()
        self._skip_lf = False  # the last chunk ended with CR: a leading LF belongs to it
        self._discarding = False  # inside an over-long line
        self._line_no = 1
        self.garbage_bytes = 0
        self.dropped_lines = 0

    def feed(self, data: bytes) -> list[Frame]:
        """Frames of the lines completed by ``data``, in order."""
        frames: list[Frame] = []
        pos = 0
        if self._skip_lf and data[:1] == b"\n":
            pos = 1
        if data:
            self._skip_lf = False
        n = len(data)
        while pos < n:
            m = _TERMINATOR.search(data, pos)
            if m is None:
                self._hold(data[pos:])
                break
            end = m.start()
            self._hold(data[pos:end])
            self._end_line(frames)
            if data[end] == 0x0D:  # CR: swallow the LF of a CRLF, even in the next chunk
                if end + 1 < n:
                    pos = end + 2 if data[end + 1] == 0x0A else end + 1
                else:
                    self._skip_lf = True
                    pos = end + 1
            else:
                pos = end + 1
        return frames

    def flush(self) -> list[Frame]:
        """At the end of a file: the last line if it has no terminator."""
        frames: list[Frame] = []
        if self._buf or self._discarding:
            self._end_line(frames)
        self._skip_lf = False
        return frames

    def _hold(self, piece: bytes) -> None:
        if self._discarding:
            self.garbage_bytes += len(piece)
            return
        self._buf += piece
        if len(self._buf) > self._max:
            self.garbage_bytes += len(self._buf)
            self._buf.clear()
            self._discarding = True

    def _end_line(self, frames: list[Frame]) -> None:
        line_no = self._line_no
        self._line_no += 1
        if self._discarding:
            self._discarding = False
            self.dropped_lines += 1
            return
        line = bytes(self._buf)
        self._buf.clear()
        if is_blank(line):
            if self._keep_blank:
                frames.append(Frame(line, None, line_no))
            else:
                self.garbage_bytes += len(line)
            return
        if self._lstrip:
            stripped = line.lstrip(self._lstrip)
            self.garbage_bytes += len(line) - len(stripped)
            line = stripped
        if self._sync is not None:
            i = line.rfind(self._sync)
            if i > 0:
                self.garbage_bytes += i
                line = line[i:]
        t_ns = None
        if self._prefix is not None:
            t_ns, line = self._prefix(line)
        frames.append(Frame(line, t_ns, line_no))


class DelimitedFramer:
    """Cuts ``start ... end`` telegrams (STX ... ETX by default) out of a byte stream.

    Parameters
    ----------
    start, end : the single-or-multi-byte delimiters; frames include both.
    max_frame_bytes : a longer unterminated telegram is dropped as garbage and the framer
        waits for the next start.
    flush_partial : at :meth:`flush`, hand out an unterminated last telegram (without its end
        delimiter) instead of counting it as garbage; for captures cut before the end byte.

    Bytes outside telegrams (including a stray end byte) are garbage. A start inside a
    telegram resynchronises: the unfinished telegram is garbage and a new one begins. Frames
    get ``line``, the 1-based line number (LF count) where their start byte sits.
    """

    def __init__(
        self,
        start: bytes = b"\x02",
        end: bytes = b"\x03",
        *,
        max_frame_bytes: int = 65536,
        flush_partial: bool = False,
    ) -> None:
        if not start or not end or start == end:
            raise ValueError("start and end must be distinct, non-empty byte strings")
        self._start = bytes(start)
        self._end = bytes(end)
        self._max = int(max_frame_bytes)
        self._flush_partial = flush_partial
        self._buf = bytearray()  # held: from a start byte (in a frame) or a possible prefix
        self._in_frame = False
        self._frame_line = 0
        self._line_no = 1  # line number at the start of ``_buf``
        self.garbage_bytes = 0
        self.dropped_frames = 0

    def feed(self, data: bytes) -> list[Frame]:
        """Telegrams completed by ``data``, in order."""
        frames: list[Frame] = []
        buf = self._buf
        buf += data
        pos = 0
        while True:
            if not self._in_frame:
                i = buf.find(self._start, pos)
                if i < 0:
                    # keep a tail that may be the beginning of a multi-byte start delimiter
                    keep = self._partial_suffix(buf, pos, self._start)
                    self._drop(buf, pos, len(buf) - keep)
                    pos = len(buf) - keep
                    break
                self._drop(buf, pos, i)
                pos = i
                self._in_frame = True
                self._frame_line = self._line_no
                continue
            body_from = pos + len(self._start)
            j = buf.find(self._end, body_from)
            k = buf.find(self._start, body_from)
            if k >= 0 and (j < 0 or k < j):  # a new start before the end: resynchronise
                self.dropped_frames += 1
                self._drop(buf, pos, k)
                pos = k
                self._frame_line = self._line_no
                continue
            if j < 0:
                if len(buf) - pos > self._max:
                    self.dropped_frames += 1
                    self._in_frame = False
                    self._drop(buf, pos, len(buf))
                    pos = len(buf)
                break
            stop = j + len(self._end)
            if stop - pos > self._max:  # as if dropped while incomplete: split-independent
                self.dropped_frames += 1
                self._drop(buf, pos, stop)
            else:
                frames.append(Frame(bytes(buf[pos:stop]), None, self._frame_line))
                self._line_no += buf.count(b"\n", pos, stop)
            pos = stop
            self._in_frame = False
        del buf[:pos]
        return frames

    def flush(self) -> list[Frame]:
        """At the end of a file: an unterminated telegram if ``flush_partial``, else nothing."""
        frames: list[Frame] = []
        if self._in_frame and self._flush_partial and len(self._buf) > len(self._start):
            frames.append(Frame(bytes(self._buf), None, self._frame_line))
            self._line_no += self._buf.count(b"\n")
        else:
            self.garbage_bytes += len(self._buf)
            if self._in_frame:
                self.dropped_frames += 1
        self._buf.clear()
        self._in_frame = False
        return frames

    def _drop(self, buf: bytearray, a: int, b: int) -> None:
        if b > a:
            self.garbage_bytes += b - a
            self._line_no += buf.count(b"\n", a, b)

    @staticmethod
    def _partial_suffix(buf: bytearray, pos: int, delim: bytes) -> int:
        """Length of the longest tail of ``buf[pos:]`` that is a proper prefix of ``delim``."""
        for k in range(min(len(delim) - 1, len(buf) - pos), 0, -1):
            if buf.endswith(delim[:k]):
                return k
        return 0


_PRINTABLE = re.compile(rb"[\x20-\x7e\t]+")


class DelimitedOrLineFramer:
    """``start ... end`` telegrams, or, in a capture whose logger stripped the control
    characters, one telegram a line; the stream's first bytes decide, for good.

    The first ``start`` byte, unless a whole line that looks like a telegram (printable ASCII
    holding ``marker``, a field separator, at least ``min_markers`` times) ends before it,
    makes the stream delimited; such a line before any ``start`` makes it one telegram a line
    (power-up noise does not look like one). Until either is seen the bytes are held
    (at most ``max_undecided`` of them, then delimited is taken); at :meth:`flush` an undecided
    stream is delimited if it holds a ``start`` byte. The decision depends on the bytes only,
    never on how reads split them. In line mode, ``line_prefix`` reads a logger's stamp at
    the start of a line, and lines that ``is_header`` says are a file's header (column
    names...) are dropped and counted in ``header_lines``, neither frames nor garbage.
    """

    def __init__(
        self,
        start: bytes = b"\x02",
        end: bytes = b"\x03",
        *,
        marker: bytes = b";",
        min_markers: int = 1,
        flush_partial: bool = False,
        max_undecided: int = 65536,
        line_prefix: PrefixParser | None = None,
        is_header: Callable[[bytes], bool] | None = None,
    ) -> None:
        self._delimited = DelimitedFramer(start, end, flush_partial=flush_partial)
        self._lines = LineFramer(prefix=line_prefix)
        self._is_header = is_header
        #: Header lines (column names, a TOA5 file's metadata) dropped in line mode.
        self.header_lines = 0
        self._start, self._marker, self._max = bytes(start), bytes(marker), max_undecided
        self._min_markers = min_markers
        self._chosen: DelimitedFramer | LineFramer | None = None
        self._pending = bytearray()

    @property
    def garbage_bytes(self) -> int:
        return (self._chosen or self._delimited).garbage_bytes

    @property
    def one_a_line(self) -> bool:
        """True once the stream was found to hold one telegram a line."""
        return self._chosen is self._lines

    def _decide(self, *, final: bool) -> None:
        buf = self._pending
        first_start = buf.find(self._start)
        line_from = 0
        for match in re.finditer(rb"\r\n|\r|\n", buf):
            if first_start >= 0 and match.start() > first_start:
                break
            line = bytes(buf[line_from : match.start()])
            if line.count(self._marker) >= self._min_markers and _PRINTABLE.fullmatch(line):
                self._chosen = self._lines
                return
            line_from = match.end()
        if first_start >= 0:
            self._chosen = self._delimited
        elif final:
            self._chosen = self._lines
        elif len(buf) > self._max:
            self._chosen = self._delimited

    def feed(self, data: bytes) -> list[Frame]:
        """Telegrams completed by ``data``, in order."""
        if self._chosen is None:
            self._pending += data
            self._decide(final=False)
            if self._chosen is None:
                return []
            data, self._pending = bytes(self._pending), bytearray()
        return self._headers_out(self._chosen.feed(data))

    def flush(self) -> list[Frame]:
        """At the end of a file: what the chosen framer still holds."""
        frames: list[Frame] = []
        if self._chosen is None:
            self._decide(final=True)
            frames = self._chosen.feed(bytes(self._pending))
            self._pending.clear()
        return self._headers_out(frames + self._chosen.flush())

    def _headers_out(self, frames: list[Frame]) -> list[Frame]:
        if self._is_header is None or self._chosen is not self._lines:
            return frames
        kept = [f for f in frames if f.t_ns is not None or not self._is_header(f.data)]
        self.header_lines += len(frames) - len(kept)
        return kept
