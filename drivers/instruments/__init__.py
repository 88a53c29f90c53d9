"""Serial weather instruments: rain gauges, disdrometers and present-weather sensors.

Each driver module exports ``DRIVER`` (a :class:`~drivers.instruments.base.DriverSpec`); the
registry :data:`DRIVERS` maps the names used in the configuration and on the command line
(``weatherd instruments decode --driver NAME``) to them:

==================  ===================================================================
name                instrument
==================  ===================================================================
``vaisala-pwd``     Vaisala PWD10/12/20/22/50/52 and FD12P, message 2 (and 7)
``ott-parsivel``    OTT Parsivel² disdrometer: ``CS/PA`` answer and user telegrams
``thies-lnm``       Thies Laser Precipitation Monitor (LNM / Clima), telegram 4
``lambrecht-raine`` Lambrecht rain[e] weighing gauge, minute lines and t2/t3 telegrams
``tipping-bucket``  a tipping-bucket gauge on a serial modem-status line (CTS/DSR/DCD/RI)
``ascii-regex``     any line-oriented instrument, by a regular expression with units
==================  ===================================================================
"""

from __future__ import annotations

from . import ascii_regex, lambrecht, parsivel, thies, tipping, vaisala
from .base import DriverSpec, Frame, Framer, ParseError, Reading, SerialDefaults

__all__ = ["DRIVERS", "DriverSpec", "Frame", "Framer", "ParseError", "Reading", "SerialDefaults"]

#: Driver name -> specification.
DRIVERS: dict[str, DriverSpec] = {
    module.DRIVER.name: module.DRIVER
    for module in (vaisala, parsivel, thies, lambrecht, tipping, ascii_regex)
}
