"""Is the system clock synchronised? The offline comparison with station data trusts UTC.

Every message carries the frame's UTC time, and ``weatherd calibrate`` / ``compare`` match those
times to station intervals of 6 minutes to an hour. A box whose clock drifts or was never set
(no RTC battery, no NTP) writes logs that match the wrong intervals, silently. The daemon
therefore reports, in its status and its log, whether the kernel says the clock is synchronised.

Two sources, in order:

1. ``adjtimex(2)`` in read-only mode (``modes = 0``): the kernel's own view, set by whatever
   disciplines the clock (systemd-timesyncd, chrony, ntpd, ptp4l). ``STA_UNSYNC`` in its status,
   or the return value ``TIME_ERROR``, means unsynchronised; ``maxerror`` is the kernel's bound
   on the error. Reading needs no privilege, but systemd's ``ProtectClock=yes`` filters the
   system call out (EPERM);
2. then ``/run/systemd/timesync/synchronized``, which systemd-timesyncd (Debian's default)
   creates once it has synchronised.

Neither: ``synchronized`` is None (unknown), and the log says so once.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from dataclasses import dataclass
from pathlib import Path

__all__ = ["ClockStatus", "clock_status"]

TIMESYNCD_FLAG = Path("/run/systemd/timesync/synchronized")
_STA_UNSYNC = 0x0040
_TIME_ERROR = 5


class _Timex(ctypes.Structure):
    """``struct timex`` of <sys/timex.h> on Linux (64-bit longs): the fields read here, then
    the rest of the struct as padding."""

    _fields_ = [
        ("modes", ctypes.c_uint),
        ("offset", ctypes.c_long),
        ("freq", ctypes.c_long),
        ("maxerror", ctypes.c_long),
        ("esterror", ctypes.c_long),
        ("status", ctypes.c_int),
        ("_rest", ctypes.c_byte * 256),
    ]


@dataclass(frozen=True)
class ClockStatus:
    """``synchronized``: True, False, or None when no source could tell; ``source``: where the
    answer came from; ``max_error_s``: the kernel's bound on the clock's error, when known."""

    synchronized: bool | None
    source: str | None
    max_error_s: float | None = None

    def to_json(self) -> dict[str, object]:
        return {
            "synchronized": self.synchronized,
            "source": self.source,
            "max_error_s": self.max_error_s,
        }


def _adjtimex() -> ClockStatus | None:
    name = ctypes.util.find_library("c")
    if name is None:
        return None
    libc = ctypes.CDLL(name, use_errno=True)
    tx = _Timex(modes=0)
    state = libc.adjtimex(ctypes.byref(tx))
    if state < 0:  # EPERM under ProtectClock=yes's seccomp filter
        return None
    unsync = bool(tx.status & _STA_UNSYNC) or state == _TIME_ERROR
    return ClockStatus(not unsync, "adjtimex", round(tx.maxerror * 1e-6, 6))


def clock_status(*, timesyncd_flag: Path = TIMESYNCD_FLAG) -> ClockStatus:
    """The system clock's synchronisation, from the first source that can tell (module doc)."""
    if os.environ.get("WEATHERD_CLOCK_ADJTIMEX", "1") != "0":
        status = _adjtimex()
        if status is not None:
            return status
    if timesyncd_flag.exists():
        return ClockStatus(True, "timesyncd")
    if timesyncd_flag.parent.is_dir():  # timesyncd runs but has not synchronised yet
        return ClockStatus(False, "timesyncd")
    return ClockStatus(None, None)
