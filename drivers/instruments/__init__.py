"""Serial weather instruments: rain gauges, disdrometers and present-weather sensors.

Each driver module exports ``DRIVER`` (a :class:`~drivers.instruments.base.DriverSpec`); the
registry below maps the names used in the configuration and on the command line to them.
"""

from __future__ import annotations

from .base import DriverSpec, Frame, Framer, ParseError, Reading, SerialDefaults

__all__ = ["DRIVERS", "DriverSpec", "Frame", "Framer", "ParseError", "Reading", "SerialDefaults"]

#: Driver name -> specification (filled as the drivers land).
DRIVERS: dict[str, DriverSpec] = {}
