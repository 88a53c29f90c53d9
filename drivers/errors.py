"""The project's exceptions, all in one place.

Every error that ``weatherd`` expects to meet in the field is a :class:`WeatherdError`; anything
else is a programming error. The command line maps them to exit statuses: input and
configuration errors exit with status 2 and one line on stderr, an unexpected exception with
status 1. The daemon retries :class:`SourceError` with a bounded backoff and never dies of one.

============  =====================================================  =========================
class         raised when                                            handling
============  =====================================================  =========================
InputError    an input file cannot be opened, is not what it says,   CLI: one line, exit 2
              or holds no usable data (no video stream, no frame)
ConfigError   the configuration is invalid; the message names the    CLI: one line, exit 2;
              key (``detector.decision.pi_rain: expected a float``)  daemon: refuse to start
SourceError   a live frame source failed (camera unplugged, stream   daemon: log, retry with
              dropped); recoverable                                  backoff, report status
============  =====================================================  =========================

A corrupt frame in the middle of a file is none of these: readers skip it, count it and log it.
"""

from __future__ import annotations

__all__ = ["ConfigError", "InputError", "SourceError", "WeatherdError"]


class WeatherdError(Exception):
    """Base of every error ``weatherd`` expects; its message is one line meant for the user."""


class InputError(WeatherdError):
    """An input file is unreadable or malformed (missing, not a video, no frame decodes...)."""


class ConfigError(WeatherdError):
    """The configuration is invalid; the message starts with the offending key."""


class SourceError(WeatherdError):
    """A live frame source failed; recoverable, the daemon retries it."""
