"""Helpers shared by the renderer's modules: argument checks and fixed-point drawing coordinates."""

from __future__ import annotations

_SHIFT = 4  # fixed-point bits of OpenCV drawing coordinates: 1/16 px endpoints
_ONE = 1 << _SHIFT


def _require(ok: bool, where: str, what: str) -> None:
    if not ok:
        raise ValueError(f"{where}: {what}")
