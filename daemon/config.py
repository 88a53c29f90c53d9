"""The daemon's configuration: one TOML file, validated once at start-up.

Every table and key is checked by pydantic models with ``extra="forbid"``, so a misspelt key is
an error, and every error names its key the way it is written in the file
(``camera[0].fps: must be greater than 0``). The detector's parameters are the frozen dataclasses
of :mod:`hos.params`, checked by :func:`detector_params`. Every problem of a file is reported
at once (:class:`ConfigErrors`, one line each). Values are strictly typed, finite and bounded:
what passes here does not fail the daemon at start-up (``weatherd check-config`` and ``run``
add the checks that need the file system: :func:`daemon.cli.common.validated_config`). The
configuration does not change while the daemon runs.

Contract keys (relied on by users): ``[site] id``; ``[[camera]] id, source`` (plus resolution,
fps, region-of-interest mask and detector parameters per camera); ``[zenoh] mode, connect,
listen, config_file``; ``[recording] dir``; ``[publish]`` rates. ``config/weatherd.toml``
documents every key with its default.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import tomllib
import typing
from pathlib import Path
from typing import Annotated, Any, Literal

import pydantic
from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    field_validator,
    model_validator,
)

from drivers.errors import ConfigError
from drivers.frame_size import MAX_FRAME_PIXELS, MAX_PIXELS_LIMIT, MIN_FRAME_PIXELS, frame_memory_mb
from hos.params import DetectorParams

__all__ = [
    "MAX_FRAME_PIXELS",
    "CalibrationConfig",
    "CameraConfig",
    "Config",
    "ConfigErrors",
    "InstrumentConfig",
    "PublishConfig",
    "RecordingConfig",
    "SiteConfig",
    "WebConfig",
    "ZenohConfig",
    "check_endpoint",
    "check_polygon",
    "config_error",
    "default_recording_dir",
    "detector_params",
    "error_lines",
    "is_loopback",
    "load_config",
    "load_toml",
    "parse_config",
    "split_listen",
    "state_dir",
]

#: Site and camera ids become Zenoh key chunks and file names: no '/', '*', '$', '?', '#', space.
_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
_ID_RULE = "letters, digits, '_', '.', '-' (at most 64, starting with a letter or digit)"
_SOURCE_SCHEMES = ("v4l2:", "file:", "demo:", "rtsp://", "rtsps://", "http://", "https://")
#: TOML nested deeper than this is refused (Python's TOML parser recurses once per level: far
#: deeper, it fails with a RecursionError, which is caught and reported the same way).
_MAX_TOML_DEPTH = 64
#: Zenoh endpoints: ``<protocol>/<address>[?metadata][#config]``.
_IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws", "vsock")
_PATH_PROTOCOLS = ("unixsock-stream", "unixpipe", "serial")
_HOST_PORT = re.compile(r"^(?:\[[0-9A-Fa-f:.]+(?:%\w+)?\]|[A-Za-z0-9_.-]+):(?P<port>[0-9]{1,5})$")
#: Seconds in a day and a week: upper bounds of intervals (beyond them a value is a typo).
_DAY_S = 86_400.0
_WEEK_S = 7 * _DAY_S


class ConfigErrors(ConfigError):
    """Several problems in one configuration, each naming its key; ``str()`` joins them with
    ``"; "`` and :attr:`errors` keeps them apart (the command line prints one per line)."""

    def __init__(self, errors: typing.Sequence[str]):
        self.errors = tuple(errors)
        super().__init__("; ".join(self.errors))


#: A file with more problems than this is not worth reading line by line.
_MAX_ERRORS = 20


def config_error(errors: typing.Sequence[str]) -> ConfigError:
    """One :class:`ConfigError` for one problem, :class:`ConfigErrors` for several (at most
    ``_MAX_ERRORS`` lines, the last saying how many more there are)."""
    if len(errors) == 1:
        return ConfigError(errors[0])
    if len(errors) > _MAX_ERRORS:
        more = len(errors) - (_MAX_ERRORS - 1)
        errors = [*errors[: _MAX_ERRORS - 1], f"... and {more} more problems"]
    return ConfigErrors(errors)


def error_lines(exc: ConfigError) -> tuple[str, ...]:
    """The problems an error reports, one per item."""
    return exc.errors if isinstance(exc, ConfigErrors) else (str(exc),)


class _Strict(BaseModel):
    # Strict types: TOML has real ones, so `true` is not 1 and "60" is not 60. inf and nan are
    # refused everywhere: no interval, rate or size of ours means anything infinite (and
    # int(inf) would fail only once the daemon runs).
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


def _check_id(value: str) -> str:
    if not _ID.match(value):
        raise ValueError(f"must be {_ID_RULE}, got {value!r}")
    return value


def check_endpoint(endpoint: str, *, listen: bool = False) -> str:
    """A Zenoh endpoint, checked as Zenoh would only check it when the session opens.

    ``tcp|udp|tls|quic|ws/HOST:PORT`` (HOST a name, an IPv4 address or ``[IPv6]``; PORT
    1-65535, or 0 to listen on any free port), ``unixsock-stream|unixpipe|serial/PATH``,
    ``vsock/CID:PORT``, each optionally followed by ``?metadata`` and ``#config``.

    Raises
    ------
    ValueError : naming the endpoint and what was expected.
    """
    core = endpoint.split("#", 1)[0].split("?", 1)[0]
    protocol, sep, address = core.partition("/")
    known = ", ".join(_IP_PROTOCOLS + _PATH_PROTOCOLS)
    if not sep or not address:
        raise ValueError(f"{endpoint!r}: expected PROTOCOL/ADDRESS, e.g. 'tcp/192.0.2.10:7447'")
    if protocol in _PATH_PROTOCOLS:
        return endpoint
    if protocol not in _IP_PROTOCOLS:
        raise ValueError(f"{endpoint!r}: unknown protocol {protocol!r} (known: {known})")
    match = _HOST_PORT.match(address)
    if match is None:
        raise ValueError(f"{endpoint!r}: expected HOST:PORT after '{protocol}/'")
    port = int(match["port"])
    if not (0 if listen else 1) <= port <= 65535:
        rule = "0 (any free port) to 65535" if listen else "1 to 65535"
        raise ValueError(f"{endpoint!r}: port must be {rule}, got {port}")
    return endpoint


def _listen_endpoint(endpoint: str) -> str:
    return check_endpoint(endpoint, listen=True)


#: A region-of-interest polygon has at most this many vertices, each within this many pixels.
MAX_POLYGON_POINTS = 1000
_MAX_POLYGON_COORD = 65_536.0


def check_polygon(points: typing.Sequence[typing.Sequence[float]]) -> list[list[float]]:
    """A region-of-interest polygon ``[[x, y], ...]`` in image pixels, checked.

    At least 3 and at most :data:`MAX_POLYGON_POINTS` vertices, each coordinate finite and in
    [0, 65536], enclosing a non-zero area.

    Raises
    ------
    ValueError : saying which rule the polygon breaks.
    """
    if not 3 <= len(points) <= MAX_POLYGON_POINTS:
        raise ValueError(
            f"a polygon needs 3 to {MAX_POLYGON_POINTS} points [x, y], got {len(points)}"
        )
    out = []
    for i, point in enumerate(points):
        if len(point) != 2:
            raise ValueError(f"point {i}: expected [x, y], got {list(point)!r}")
        x, y = (float(v) for v in point)
        if not (0 <= x <= _MAX_POLYGON_COORD and 0 <= y <= _MAX_POLYGON_COORD):
            raise ValueError(f"point {i}: [x, y] must be pixels in [0, 65536], got [{x}, {y}]")
        out.append([x, y])
    # Shoelace formula: twice the signed area.
    area2 = sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(out, out[1:] + out[:1], strict=True))
    if abs(area2) < 1.0:
        raise ValueError("the polygon encloses no area (its points are on one line)")
    return out


class SiteConfig(_Strict):
    """``[site]``: the station."""

    #: Names the station in logs, Zenoh keys (``weather/<id>/...``) and MCAP file names.
    id: str = "demo"
    #: Where state that must survive restarts is kept (the calibration); default
    #: ``$STATE_DIRECTORY`` under systemd, else ``state`` in the working directory.
    state_dir: str | None = None

    _id = field_validator("id")(_check_id)


class CameraConfig(_Strict):
    """``[[camera]]``: one camera and its detector."""

    id: str
    #: ``"v4l2:/dev/video0"``, ``"file:PATH"``, ``"rtsp://..."``, ``"http(s)://..."``, ``"demo:"``.
    source: str
    #: Requested frame size and rate (a device is asked for them; frames of another size are
    #: resized). None: the source's own.
    width: Annotated[int, Field(gt=0, le=8192)] | None = None
    height: Annotated[int, Field(gt=0, le=8192)] | None = None
    fps: Annotated[float, Field(gt=0, le=240)] | None = None
    #: Frames with more pixels than this are shrunk by the smallest integer factor that brings
    #: them within it before detection (docs/daemon.md, "Limits"); a requested width x height
    #: may not exceed it.
    max_pixels: Annotated[int, Field(ge=MIN_FRAME_PIXELS, le=MAX_PIXELS_LIMIT)] = MAX_FRAME_PIXELS
    #: ``file:`` sources: start again at the end; pace frames at the file's rate.
    loop: bool = False
    realtime: bool = True
    #: Region of interest: the path of a mask image (nonzero pixels are analysed), or a polygon
    #: ``[[x, y], ...]`` in pixels of the frames the detector sees (the status page draws one).
    #: Exclude sky, trees, the road.
    roi: str | list[Annotated[list[float], Field(min_length=2, max_length=2)]] | None = None
    #: Detector parameters for this camera, over the global ``[detector]`` table.
    detector: dict[str, dict[str, Any]] = Field(default_factory=dict)

    _id = field_validator("id")(_check_id)

    @field_validator("source")
    @classmethod
    def _known_scheme(cls, value: str) -> str:
        if not value.startswith(_SOURCE_SCHEMES):
            raise ValueError(
                f"unknown source {value!r}: use one of "
                + ", ".join(f"'{s}...'" for s in _SOURCE_SCHEMES)
            )
        return value

    @field_validator("roi")
    @classmethod
    def _roi_polygon(cls, value: str | list[list[float]] | None) -> str | list[list[float]] | None:
        if isinstance(value, list):
            check_polygon(value)
        return value

    @model_validator(mode="after")
    def _size_pair(self) -> CameraConfig:
        if (self.width is None) != (self.height is None):
            raise ValueError("width and height go together: give both or neither")
        if self.width is not None and self.height is not None:
            pixels = self.width * self.height
            if pixels > self.max_pixels:
                raise ValueError(
                    f"width x height = {self.width}x{self.height} = {pixels} pixels, more than "
                    f"max_pixels = {self.max_pixels} (about {frame_memory_mb(pixels):.0f} MB "
                    "of memory): request a smaller size"
                )
        return self


class InstrumentConfig(_Strict):
    """``[[instrument]]``: one serial instrument."""

    id: str
    #: ``vaisala-pwd``, ``ott-parsivel``, ``thies-lnm``, ``lambrecht-raine``,
    #: ``tipping-bucket``, ``ascii-regex``.
    driver: str
    #: A device path (``/dev/ttyUSB0``) or a pyserial URL (``socket://192.0.2.5:4001``).
    port: str
    #: Serial settings; default: the instrument's factory settings.
    baudrate: Annotated[int, Field(gt=0, le=4_000_000)] | None = None
    bytesize: Literal[5, 6, 7, 8] | None = None
    parity: Literal["N", "E", "O", "M", "S"] | None = None
    stopbits: Literal[1, 1.5, 2] | None = None
    #: ``automatic`` (the instrument sends by itself) or ``polled`` (we ask every interval).
    mode: Literal["automatic", "polled"] = "automatic"
    poll_interval_s: Annotated[float, Field(ge=0.1, le=_DAY_S)] = 60.0
    #: ``present_weather`` (knows the type) or ``gauge``; default from the driver.
    kind: Literal["present_weather", "gauge"] | None = None
    #: A reading older than this cannot judge; default 3 x the interval, at least 180 s.
    stale_s: Annotated[float, Field(ge=1, le=_WEEK_S)] | None = None
    #: Reopen the port when nothing at all arrives for this long (a serial-to-Ethernet
    #: converter that vanished without closing the connection); default: never.
    idle_timeout_s: Annotated[float, Field(ge=1, le=_WEEK_S)] | None = None
    #: Per-driver options (see docs/instruments.md).
    options: dict[str, Any] = Field(default_factory=dict)

    _id = field_validator("id")(_check_id)

    def serial_settings(self) -> dict[str, Any]:
        return {
            k: v
            for k, v in (
                ("baudrate", self.baudrate),
                ("bytesize", self.bytesize),
                ("parity", self.parity),
                ("stopbits", self.stopbits),
            )
            if v is not None
        }


class CalibrationConfig(_Strict):
    """``[calibration]``: R into mm/h (docs/instruments.md, "Calibration")."""

    #: Learn the calibration online from the instruments' rain rates.
    online: bool = True
    #: A calibration file written by ``weatherd calibrate`` (its ``[calibration]`` table):
    #: used until (and as the prior of) the online fit.
    file: str | None = None
    #: Aggregation window of camera R against the instruments' rate.
    window_s: Annotated[float, Field(ge=1, le=_DAY_S)] = 900.0
    #: Accepted windows before camera-only mm/h is published.
    min_windows: Annotated[int, Field(ge=1, le=100_000)] = 4
    #: Windows with less rain than this at the gauge are not measurements.
    min_rate_mm_h: Annotated[float, Field(ge=0, le=1000)] = 0.2
    #: Time constant of the running mean of R behind camera-only mm/h and ``camera_R``
    #: (an instrument's intensity is typically a 1-minute mean).
    rate_smoothing_s: Annotated[float, Field(ge=1, le=_DAY_S)] = 60.0


class ZenohConfig(_Strict):
    """``[zenoh]``: the session that publishes ``weather/<site>/...``."""

    enabled: bool = True
    mode: Literal["peer", "client", "router"] = "peer"
    #: Endpoints such as ``"tcp/192.0.2.10:7447"``.
    connect: list[Annotated[str, AfterValidator(check_endpoint)]] = Field(default_factory=list)
    listen: list[Annotated[str, AfterValidator(_listen_endpoint)]] = Field(default_factory=list)
    #: A full Zenoh JSON5 configuration (TLS, user/password, access control), loaded first;
    #: ``mode``, ``connect`` and ``listen`` given here override it.
    config_file: str | None = None

    @field_validator("config_file")
    @classmethod
    def _readable(cls, value: str | None) -> str | None:
        if value is not None and not os.access(value, os.R_OK):
            raise ValueError(f"{value}: no such readable file")
        return value


class RecordingConfig(_Strict):
    """``[recording]``: MCAP files on disk."""

    enabled: bool = True
    #: Directory of the MCAP files; default ``$STATE_DIRECTORY/recordings`` under systemd, else
    #: ``recordings`` in the working directory.
    dir: str | None = None
    #: A new file every ``rotate_s`` seconds or ``rotate_mb`` MiB, whichever comes first.
    rotate_s: Annotated[float, Field(ge=1, le=_WEEK_S)] = 3600.0
    rotate_mb: Annotated[float, Field(ge=0.1, le=1_048_576)] = 256.0
    #: The oldest files are deleted while the recordings exceed ``budget_mb`` or the disk has
    #: less than ``min_free_mb`` free.
    budget_mb: Annotated[float, Field(ge=0.1, le=1e9)] = 4096.0
    min_free_mb: Annotated[float, Field(ge=0, le=1e9)] = 512.0
    #: At most this much is lost at a power cut or ``kill -9``.
    flush_interval_s: Annotated[float, Field(ge=0.1, le=60)] = 1.0
    fsync_interval_s: Annotated[float, Field(ge=0.1, le=600)] = 5.0
    #: An overlay thumbnail (``foxglove.CompressedImage``) per camera every so many seconds;
    #: 0 disables them; else at least 1.
    thumbnail_interval_s: Annotated[float, Field(ge=0, le=_DAY_S)] = 10.0
    thumbnail_width: Annotated[int, Field(ge=32, le=1920)] = 320
    #: Record every frame's result and histogram; false keeps only the 1 Hz summaries.
    per_frame: bool = True

    @field_validator("thumbnail_interval_s")
    @classmethod
    def _thumbnails(cls, value: float) -> float:
        if 0 < value < 1:
            raise ValueError(f"must be 0 (no thumbnails) or at least 1 s, got {value!r}")
        return value


class PublishConfig(_Strict):
    """``[publish]``: how often each Zenoh key is published (seconds)."""

    #: ``weather/<site>/state``; also at once when precipitation starts or stops.
    #: Each at least 0.1 s (the main loop's period), at most an hour.
    state_interval_s: Annotated[float, Field(ge=0.1, le=3600)] = 1.0
    #: ``weather/<site>/camera/<cam>/hos``.
    camera_interval_s: Annotated[float, Field(ge=0.1, le=3600)] = 1.0
    #: ``weather/<site>/status`` and the ``/status`` MCAP topic.
    status_interval_s: Annotated[float, Field(ge=0.1, le=3600)] = 10.0


class FusionConfig(_Strict):
    """``[fusion]``: how long the site's precipitation must be seen before it starts, and not
    seen before it stops (docs/daemon.md, "The site state does not flicker")."""

    #: Seconds of precipitation seen (by any source that can judge) before the site says so.
    onset_s: Annotated[float, Field(ge=0, le=3600)] = 10.0
    #: Seconds of none seen before the site says it stopped.
    end_s: Annotated[float, Field(ge=0, le=3600)] = 60.0


#: The status page's port when ``[web] listen`` is not given (docs/daemon.md, "Status page").
WEB_PORT = 8750
#: The environment variable that holds the status page's token, unless ``[web] token_env``.
WEB_TOKEN_ENV = "WEATHERD_WEB_TOKEN"


def split_listen(listen: str) -> tuple[str, int]:
    """``HOST:PORT`` (HOST a name, an IPv4 address or ``[IPv6]``) as ``(host, port)``.

    Raises
    ------
    ValueError : not HOST:PORT, or a port outside 0-65535 (0: any free port).
    """
    match = _HOST_PORT.match(listen)
    if match is None:
        raise ValueError(f"{listen!r}: expected HOST:PORT, e.g. '127.0.0.1:{WEB_PORT}'")
    port = int(match["port"])
    if port > 65535:
        raise ValueError(f"{listen!r}: port must be 0 (any free port) to 65535, got {port}")
    host = listen[: match.start("port") - 1].strip("[]")
    return host, port


def is_loopback(host: str) -> bool:
    """True for an address only this machine reaches: 127.0.0.0/8, ::1 and ``localhost``."""
    import ipaddress

    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.split("%", 1)[0]).is_loopback
    except ValueError:
        return False


class WebConfig(_Strict):
    """``[web]``: the status page and its read-only JSON API (docs/daemon.md, "Status page")."""

    enabled: bool = True
    #: ``HOST:PORT``; the default reaches this machine only. Any other address needs a
    #: password (``password_file``) or a token (in the environment variable ``token_env``).
    listen: str = f"127.0.0.1:{WEB_PORT}"
    #: A file whose first line is the password (any user name); keep it mode 0600.
    password_file: str | None = None
    #: The environment variable holding a token, sent as ``Authorization: Bearer TOKEN`` (or as
    #: the password). Only its name is configured: a secret never sits in the TOML in clear.
    token_env: str = WEB_TOKEN_ENV
    #: HTTPS with this certificate chain and key (PEM); both or neither.
    tls_cert: str | None = None
    tls_key: str | None = None
    #: The live overlay image: its width (px) and how often it is redrawn while someone
    #: watches (it costs nothing while nobody does).
    overlay_width: Annotated[int, Field(ge=160, le=1920)] = 960
    overlay_interval_s: Annotated[float, Field(ge=0.1, le=60)] = 0.5

    @field_validator("listen")
    @classmethod
    def _listen(cls, value: str) -> str:
        split_listen(value)
        return value

    @field_validator("password_file", "tls_cert", "tls_key")
    @classmethod
    def _readable(cls, value: str | None) -> str | None:
        if value is not None and not os.access(value, os.R_OK):
            raise ValueError(f"{value}: no such readable file")
        return value

    @field_validator("token_env")
    @classmethod
    def _env_name(cls, value: str) -> str:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]{0,127}", value):
            raise ValueError(f"must be an environment variable's name, got {value!r}")
        return value

    @model_validator(mode="after")
    def _tls_pair(self) -> WebConfig:
        if (self.tls_cert is None) != (self.tls_key is None):
            raise ValueError("tls_cert and tls_key go together: give both or neither")
        return self


class Config(_Strict):
    """The whole file."""

    site: SiteConfig = Field(default_factory=SiteConfig)
    camera: list[CameraConfig] = Field(default_factory=list)
    detector: dict[str, dict[str, Any]] = Field(default_factory=dict)
    instrument: list[InstrumentConfig] = Field(default_factory=list)
    calibration: CalibrationConfig = Field(default_factory=CalibrationConfig)
    zenoh: ZenohConfig = Field(default_factory=ZenohConfig)
    recording: RecordingConfig = Field(default_factory=RecordingConfig)
    publish: PublishConfig = Field(default_factory=PublishConfig)
    fusion: FusionConfig = Field(default_factory=FusionConfig)
    web: WebConfig = Field(default_factory=WebConfig)

    @model_validator(mode="after")
    def _unique_ids(self) -> Config:
        for what, items in (("camera", self.camera), ("instrument", self.instrument)):
            seen: set[str] = set()
            for item in items:
                if item.id in seen:
                    raise ValueError(f"{what} id {item.id!r} is used twice")
                seen.add(item.id)
        return self

    def camera_params(self, index: int) -> DetectorParams:
        """The detector parameters of camera ``index``: its own table over ``[detector]``."""
        merged = _merged_detector(self.detector, self.camera[index].detector)
        try:
            return detector_params({"detector": merged})
        except ConfigError as exc:
            raise config_error([f"camera[{index}].{e}" for e in error_lines(exc)]) from None


def load_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A TOML file as a dict.

    Raises
    ------
    ConfigError : the file cannot be read or is not valid TOML.
    """
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the configuration ({exc.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:  # Python's TOML parser recurses once per level of nesting
        raise ConfigError(
            f"{path}: not valid TOML for weatherd (arrays or tables nested too deeply; "
            f"at most {_MAX_TOML_DEPTH} levels)"
        ) from None
    deep = _too_deep(data)
    if deep is not None:
        raise ConfigError(f"{path}: {deep}: nested more than {_MAX_TOML_DEPTH} levels deep")
    return data


def _too_deep(data: object) -> str | None:
    """The key of the first value nested deeper than ``_MAX_TOML_DEPTH``, or None (iterative:
    the check itself must not recurse)."""
    stack: list[tuple[object, str, int]] = [(data, "", 0)]
    while stack:
        value, key, depth = stack.pop()
        if depth > _MAX_TOML_DEPTH:
            return key or "(top level)"
        if isinstance(value, dict):
            stack.extend((v, f"{key}.{k}".lstrip("."), depth + 1) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, f"{key}[{i}]", depth + 1) for i, v in enumerate(value))
    return None


def _non_finite(value: object, key: str) -> list[str]:
    """Keys under ``key`` whose value is an infinite or NaN float (free-form tables)."""
    if isinstance(value, float) and not math.isfinite(value):
        return [f"{key}: must be a finite number, got {value!r}"]
    if isinstance(value, dict):
        return [e for k, v in value.items() for e in _non_finite(v, f"{key}.{k}")]
    if isinstance(value, list):
        return [e for i, v in enumerate(value) for e in _non_finite(v, f"{key}[{i}]")]
    return []


def parse_config(data: dict[str, Any]) -> Config:
    """Validate a configuration dict (as read from TOML).

    Raises
    ------
    ConfigError : naming the key (``camera[0].fps: ...``); :class:`ConfigErrors` when there
        are several problems, all of them.
    """
    errors: list[str] = []
    instruments = data.get("instrument")
    if isinstance(instruments, list):  # free-form driver options: pydantic does not look
        for i, item in enumerate(instruments):
            if isinstance(item, dict):
                errors += _non_finite(item.get("options"), f"instrument[{i}].options")
    config: Config | None = None
    try:
        config = Config.model_validate(data)
    except pydantic.ValidationError as exc:
        errors += _errors(exc)
    reported = {e.partition(": ")[0] for e in errors}  # pydantic may have named a key already
    errors += [e for e in _detector_errors(data) if e.partition(": ")[0] not in reported]
    if errors or config is None:
        raise config_error(errors)
    return config


def _merged_detector(table: dict[str, Any], own: dict[str, Any]) -> dict[str, Any]:
    """A camera's detector table over the global one, group by group (a group that is not a
    table is kept as is, for :func:`detector_params` to name)."""
    merged = {g: dict(v) if isinstance(v, dict) else v for g, v in table.items()}
    for group, values in own.items():
        if isinstance(values, dict) and isinstance(merged.get(group, {}), dict):
            merged[group] = {**merged.get(group, {}), **values}
        else:
            merged[group] = values
    return merged


def _detector_errors(data: dict[str, Any]) -> list[str]:
    """Problems of the global ``[detector]`` table and of each camera's over it (checked on
    the raw tables, so that they are reported beside pydantic's own)."""
    table = data.get("detector", {})
    tables = [("", {"detector": table})]
    cameras = data.get("camera")
    if isinstance(table, dict) and isinstance(cameras, list):
        for i, cam in enumerate(cameras):
            own = cam.get("detector") if isinstance(cam, dict) else None
            if isinstance(own, dict):
                tables.append((f"camera[{i}].", {"detector": _merged_detector(table, own)}))
    errors: list[str] = []
    for prefix, config in tables:
        try:
            detector_params(config)
        except ConfigError as exc:
            # a camera inherits the global table's mistakes: each is said once
            errors += [prefix + e for e in error_lines(exc) if e not in errors]
    return errors


def load_config(path: str | os.PathLike[str]) -> Config:
    """Read and validate the configuration file; errors start with the file name."""
    data = load_toml(path)
    try:
        return parse_config(data)
    except ConfigError as exc:
        raise config_error([f"{path}: {e}" for e in error_lines(exc)]) from None


def default_recording_dir(config: RecordingConfig) -> Path:
    """Where the MCAP files go: the configured directory, else systemd's state directory."""
    if config.dir:
        return Path(config.dir)
    state = os.environ.get("STATE_DIRECTORY", "").split(":")[0]
    return Path(state, "recordings") if state else Path("recordings")


def state_dir(site: SiteConfig) -> Path:
    """Where state that survives restarts lives: configured, systemd's, or ``./state``."""
    if site.state_dir:
        return Path(site.state_dir)
    state = os.environ.get("STATE_DIRECTORY", "").split(":")[0]
    return Path(state) if state else Path("state")


def _errors(exc: pydantic.ValidationError) -> list[str]:
    """Every problem pydantic found, one line each, naming its key as written in the file."""
    out = []
    for err in exc.errors(include_url=False):
        key = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in err["loc"])
        key = key.lstrip(".")
        kind = err["type"]
        if kind == "extra_forbidden":
            what = "unknown key"
        elif kind == "missing":
            what = "required key missing"
        else:
            what = err["msg"].removeprefix("Value error, ")
            if "input" in err and kind not in ("value_error",):
                what += f", got {_short(err['input'])}"
        line = f"{key}: {what}" if key else what
        if line not in out:
            out.append(line)
    return out


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


# -- detector parameters -----------------------------------------------------------------------
def detector_params(config: dict[str, Any]) -> DetectorParams:
    """Detector parameters from the optional ``[detector]`` table of the configuration.

    Sub-tables ``segmentation``, ``histogram``, ``mixture``, ``decision``, ``robustness``,
    ``precipitation_type`` hold
    the fields of :mod:`hos.params` (angles as ``*_deg`` keys). Values are checked against the
    field types (an int is accepted for a float).

    Raises
    ------
    ConfigError : naming the key, for an unknown group or key or a value of the wrong type.
    """
    table = config.get("detector", {})
    if not isinstance(table, dict):
        raise ConfigError("detector: must be a table")
    groups = {f.name: f for f in dataclasses.fields(DetectorParams)}
    errors: list[str] = []
    for group, values in table.items():
        if not isinstance(values, dict):
            errors.append(f"detector.{group}: must be a table")
            continue
        if group not in groups:
            errors.append(f"detector.{group}: unknown parameter group")
            continue
        hints = typing.get_type_hints(getattr(DetectorParams(), group).__class__)
        for key, value in values.items():
            hint = hints.get(key.removesuffix("_deg"))
            if hint is not None:
                try:
                    _check_value(f"detector.{group}.{key}", value, hint)
                except ConfigError as exc:
                    errors.append(str(exc))
    if errors:
        raise config_error(errors)
    try:
        return DetectorParams.from_dict(table)
    except (ValueError, TypeError) as exc:
        raise ConfigError(str(exc)) from None


def _check_value(key: str, value: object, hint: object) -> None:
    if typing.get_origin(hint) is typing.Literal:
        choices = typing.get_args(hint)
        if value not in choices:
            raise ConfigError(f"{key}: must be one of {', '.join(map(repr, choices))}")
    elif hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{key}: must be true or false, got {value!r}")
    elif hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{key}: must be an integer, got {value!r}")
    elif hint is float and (
        isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value)
    ):
        raise ConfigError(f"{key}: must be a finite number, got {value!r}")
