"""Vaisala PWD10/12/20/22/50/52 and FD12P present-weather sensors: messages 2 and 7.

Raw serial frames (PWD22/52 user's guide, "Message types"; FD12P uses the same framing)::

    <SOH>PW<sp><id><STX><body><ETX><CR><LF>      id: two characters, " 1" when unset

and the body of message 2 (message 7 appends the temperature and background luminance)::

    00  6839  7505   R-   61   61   61  0.33  12.16     0   [ 23.4  12345 ]
    |   |     |      |    |    |    |   |     |         |      |     background luminance, cd/m²
    |   |     |      |    |    |    |   |     |         |      temperature, °C
    |   |     |      |    |    |    |   |     |         cumulative snow sum, mm (0...999)
    |   |     |      |    |    |    |   |     cumulative water sum, mm (0...99.99, wraps)
    |   |     |      |    |    |    |   water intensity, 1-minute average, mm/h
    |   |     |      |    |    |    WMO 4680 present weather, 1 hour
    |   |     |      |    |    WMO 4680, 15 minutes
    |   |     |      |    WMO 4680, instant
    |   |     |      NWS present weather code (C, R-, S+, L...)
    |   |     visibility, 10-minute average, m
    |   visibility, 1-minute average, m
    alarm digit (1...3: visibility alarms 1...3) and hardware digit (1: hardware error,
    2: hardware warning, 3: backscatter alarm, 4: backscatter warning)

A value the sensor cannot give is made of ``/`` (``////``) and becomes None. The FD12P
logger lines of Lindenberg (cloudnetpy's ``fd12p.py``) are the same body behind a timestamp
and the header without control characters: ``06.04.2004 05:51:21 FD 100 9163 ...``
(``100`` = id ``1`` + status ``00``). The water sum is reported as the sensor counts it,
wraps at 99.99 mm included; a negative intensity is None, never a negative rate.

Polling (PWD22/52 guide, "Message polling"): ``<CR><ENQ>PW <id> <message><CR>``; use id
``1`` when no id is set. With ``AMES 2 1`` set on the sensor it sends message 2 every minute
by itself (automatic mode). Factory serial settings: 9600 baud, 7 data bits, even parity,
1 stop bit.
"""

from __future__ import annotations

import re
from typing import Any

from drivers.errors import ConfigError

from .base import DriverSpec, Frame, ParseError, Reading, SerialDefaults, with_defaults
from .framing import PREFIX_DMY_HMS, LineFramer

__all__ = ["DRIVER", "check_options", "make_framer", "parse", "poll_command"]

NAME = "vaisala-pwd"
SOH, STX, ETX, ENQ = b"\x01", b"\x02", b"\x03", b"\x05"

#: Options of ``[instrument.options]`` and their defaults.
DEFAULTS: dict[str, Any] = {"unit_id": "1", "message": 2, "device": "PW"}

_HARDWARE = {
    0: "ok",
    1: "hardware error",
    2: "hardware warning",
    3: "backscatter alarm",
    4: "backscatter warning",
}
#: Hardware digits that make the measurement untrustworthy (error; contaminated optics).
_FAULT_DIGITS = frozenset({1, 3})
_BODY_LEN = {10: 2, 12: 7}  # body tokens (status included) -> message number
_UNIT_ID = re.compile(r"[0-9A-Za-z]{1,2}")
_NWS = re.compile(r"[A-Z]{1,3}[+-]?")


def check_options(options: dict[str, Any]) -> dict[str, Any]:
    """``options`` with defaults filled in; ConfigError naming the key when invalid.

    Keys: ``unit_id`` (str, 1-2 letters/digits, "1" when unset on the sensor), ``message``
    (2 or 7, the message polled), ``device`` ("PW", or "FD" for an FD12P).
    """
    out = with_defaults(options, DEFAULTS, NAME)
    if not isinstance(out["unit_id"], str) or not _UNIT_ID.fullmatch(out["unit_id"]):
        raise ConfigError("options.unit_id: expected 1 or 2 letters or digits")
    if out["message"] not in (2, 7) or isinstance(out["message"], bool):
        raise ConfigError("options.message: expected 2 or 7")
    if out["device"] not in ("PW", "FD"):
        raise ConfigError('options.device: expected "PW" or "FD"')
    return out


def make_framer(options: dict[str, Any]) -> LineFramer:
    """Lines (messages end with CR LF), starting at SOH, with the FD12P logger prefix."""
    return LineFramer(prefix=PREFIX_DMY_HMS, sync=SOH)


def poll_command(options: dict[str, Any]) -> bytes:
    """``<CR><ENQ>PW <id> <message><CR>``, e.g. ``b"\\r\\x05PW 1 2\\r"``."""
    o = check_options(options)
    return b"\r" + ENQ + f"{o['device']} {o['unit_id']} {o['message']}\r".encode("ascii")


def parse(frame: Frame, options: dict[str, Any] | None = None) -> Reading:
    """One message 2 or 7, raw (SOH...ETX) or a logger line, to a :class:`Reading`.

    Raises
    ------
    ParseError : not a PWD/FD12P message 2 or 7 (wrong field count, a value that is neither
        a number nor ``/``, broken framing, non-ASCII bytes).
    """
    unit_id, tokens = _split(frame.data)
    status = tokens[0]
    if re.fullmatch(r"\d\d", status) is None:
        raise ParseError(f"status {status!r} is not two digits")
    alarm, hardware = int(status[0]), int(status[1])
    message = _BODY_LEN[len(tokens)]
    rate = _float(tokens[7], "intensity")
    extra: dict[str, Any] = {
        "unit_id": unit_id,
        "message": message,
        "visibility_alarm": alarm,
        "hardware_status": _HARDWARE.get(hardware, f"code {hardware}"),
    }
    temperature = None
    if message == 7:
        temperature = _float(tokens[10], "temperature")
        extra["background_luminance_cd_m2"] = _float(tokens[11], "background luminance")
    return Reading(
        driver=NAME,
        t_ns=frame.t_ns,
        visibility_m=_float(tokens[1], "visibility 1 min"),
        visibility_10min_m=_float(tokens[2], "visibility 10 min"),
        nws_code=_nws(tokens[3]),
        wawa=_wawa(tokens[4], "wawa"),
        wawa_15min=_wawa(tokens[5], "wawa 15 min"),
        wawa_1h=_wawa(tokens[6], "wawa 1 h"),
        rain_rate_mm_h=None if rate is None or rate < 0 else rate,
        rain_accum_mm=_float(tokens[8], "water sum"),
        snow_accum_mm=_float(tokens[9], "snow sum"),
        status=status,
        fault=hardware in _FAULT_DIGITS,
        temperature_c=temperature,
        extra=extra,
    )


def _split(data: bytes) -> tuple[str, list[str]]:
    """(unit id, body tokens starting with the status) of a raw frame or a logger line."""
    soh = data.rfind(SOH)
    if soh >= 0:
        stx = data.find(STX, soh)
        if stx < 0:
            raise ParseError("PWD frame without STX")
        etx = data.find(ETX, stx)
        if etx < 0:
            raise ParseError("PWD frame without ETX (truncated message)")
        header = _ascii(data[soh + 1 : stx])
        if header[:2] not in ("PW", "FD"):
            raise ParseError(f"header {header!r} is not PW<id> or FD<id>")
        tokens = _ascii(data[stx + 1 : etx]).split()
        if len(tokens) not in _BODY_LEN:
            raise ParseError(f"expected 10 or 12 fields (message 2 or 7), got {len(tokens)}")
        return header[2:].strip(), tokens
    tokens = _ascii(data).split()
    if not tokens or tokens[0] not in ("PW", "FD"):
        raise ParseError("not a PWD/FD12P message (no SOH, no PW/FD header)")
    rest = tokens[1:]
    if len(rest) - 1 in _BODY_LEN:  # "PW 1 00 ...": id and status apart
        return rest[0], rest[1:]
    if len(rest) in _BODY_LEN and len(rest[0]) >= 2:  # "FD 100 ...": id glued to the status
        return rest[0][:-2], [rest[0][-2:], *rest[1:]]
    raise ParseError(f"expected 10 or 12 fields (message 2 or 7), got {len(rest)}")


def _ascii(raw: bytes) -> str:
    try:
        return raw.decode("ascii")
    except UnicodeDecodeError:
        raise ParseError("non-ASCII bytes (noise, or a wrong baud rate)") from None


def _missing(token: str) -> bool:
    return "/" in token


def _float(token: str, name: str) -> float | None:
    if _missing(token):
        return None
    try:
        return float(token)
    except ValueError:
        raise ParseError(f"{name}: {token!r} is not a number") from None


def _wawa(token: str, name: str) -> int | None:
    if _missing(token):
        return None
    if not token.isdigit() or int(token) > 99:
        raise ParseError(f"{name}: {token!r} is not a WMO 4680 code")
    return int(token)


def _nws(token: str) -> str | None:
    if _missing(token):
        return None
    if _NWS.fullmatch(token) is None:
        raise ParseError(f"NWS code {token!r} is not a code")
    return token


DRIVER = DriverSpec(
    name=NAME,
    make_framer=make_framer,
    parse=parse,
    serial=SerialDefaults(baudrate=9600, bytesize=7, parity="E", stopbits=1),
    modes=("automatic", "polled"),
    poll_command=poll_command,
    check_options=check_options,
    description="Vaisala PWD10...52 / FD12P message 2 or 7 (raw SOH/STX/ETX or logger lines)",
)
