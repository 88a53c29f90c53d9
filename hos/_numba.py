"""numba, where it can load: the decorator every compiled kernel of the detector uses.

The kernels live in ``_jit`` (the per-pixel and per-blob steps), ``_jit_mixture`` (the EM) and
``_jit_motion`` (the camera-offset estimate); each imports its decorator from here, so that
none of them imports another.
"""

from __future__ import annotations

import logging
import os

__all__ = ["ENABLED", "_njit", "numba", "why_disabled"]

log = logging.getLogger(__name__)

#: False when ``HOS_JIT=0``: numba is then not even imported (it and the LLVM it loads cost
#: 50 MiB at import and as much again once the kernels are loaded).
_WANTED = os.environ.get("HOS_JIT", "1") != "0"
numba = None
_why = "HOS_JIT=0"
if _WANTED:
    try:  # numba is a dependency, but the detector must still run (slower) where it cannot load
        import numba
    except Exception as exc:
        _why = f"numba unavailable ({exc.__class__.__name__}: {exc})"
    else:
        _why = ""

#: True when the compiled kernels are used (numba imported and ``HOS_JIT`` is not "0").
ENABLED = numba is not None


def why_disabled() -> str:
    """Why the kernels are not used ("" when they are)."""
    return "" if ENABLED else _why


def _njit(fn=None, *, fastmath: bool | set[str] = False):
    """``numba.njit`` with the GIL released and machine code cached on disk (next to this file,
    or in ``NUMBA_CACHE_DIR``); without a writable cache the kernels are compiled at each start
    (a few seconds). Without numba, ``fn`` itself (the callers then use the numpy path).
    ``@_njit(fastmath=...)`` passes numba's fastmath flags."""
    if fn is None:
        return lambda f: _njit(f, fastmath=fastmath)
    if numba is None:
        return fn
    try:
        return numba.njit(cache=True, nogil=True, fastmath=fastmath)(fn)
    except RuntimeError as exc:  # "cannot cache function ...: no locator available"
        log.warning("numba cannot cache %s (%s); it is compiled at each start", fn.__name__, exc)
        return numba.njit(nogil=True, fastmath=fastmath)(fn)
