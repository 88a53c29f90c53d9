"""The daemon's configuration: one TOML file, validated once at start-up.

Every table and key is checked by pydantic models with ``extra="forbid"``, so a misspelt key is
an error, and every error names its key the way it is written in the file
(``camera[0].fps: must be greater than 0``). The detector's parameters are the frozen dataclasses
of :mod:`hos.params`, checked by :func:`detector_params`. The configuration does not change while
the daemon runs.

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
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from drivers.errors import ConfigError
from hos.params import DetectorParams

__all__ = [
    "CalibrationConfig",
    "CameraConfig",
    "Config",
    "InstrumentConfig",
    "PublishConfig",
    "RecordingConfig",
    "SiteConfig",
    "ZenohConfig",
    "default_recording_dir",
    "detector_params",
    "load_config",
    "load_toml",
    "parse_config",
    "state_dir",
]

#: Site and camera ids become Zenoh key chunks and file names: no '/', '*', '$', '?', '#', space.
_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
_ID_RULE = "letters, digits, '_', '.', '-' (at most 64, starting with a letter or digit)"
_SOURCE_SCHEMES = ("v4l2:", "file:", "demo:", "rtsp://", "rtsps://", "http://", "https://")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)


def _check_id(value: str) -> str:
    if not _ID.match(value):
        raise ValueError(f"must be {_ID_RULE}, got {value!r}")
    return value


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
    #: ``file:`` sources: start again at the end; pace frames at the file's rate.
    loop: bool = False
    realtime: bool = True
    #: Region-of-interest mask: an image, nonzero pixels analysed (exclude sky, trees, the road).
    roi: str | None = None
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

    @model_validator(mode="after")
    def _size_pair(self) -> CameraConfig:
        if (self.width is None) != (self.height is None):
            raise ValueError("width and height go together: give both or neither")
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
    baudrate: Annotated[int, Field(gt=0)] | None = None
    bytesize: Literal[5, 6, 7, 8] | None = None
    parity: Literal["N", "E", "O", "M", "S"] | None = None
    stopbits: Literal[1, 1.5, 2] | None = None
    #: ``automatic`` (the instrument sends by itself) or ``polled`` (we ask every interval).
    mode: Literal["automatic", "polled"] = "automatic"
    poll_interval_s: Annotated[float, Field(gt=0)] = 60.0
    #: ``present_weather`` (knows the type) or ``gauge``; default from the driver.
    kind: Literal["present_weather", "gauge"] | None = None
    #: A reading older than this cannot judge; default 3 x the interval, at least 180 s.
    stale_s: Annotated[float, Field(gt=0)] | None = None
    #: Reopen the port when nothing at all arrives for this long (a serial-to-Ethernet
    #: converter that vanished without closing the connection); default: never.
    idle_timeout_s: Annotated[float, Field(gt=0)] | None = None
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
    window_s: Annotated[float, Field(gt=0)] = 900.0
    #: Accepted windows before camera-only mm/h is published.
    min_windows: Annotated[int, Field(ge=1)] = 4
    #: Windows with less rain than this at the gauge are not measurements.
    min_rate_mm_h: Annotated[float, Field(ge=0)] = 0.2
    #: Time constant of the running mean of R behind camera-only mm/h and ``camera_R``
    #: (an instrument's intensity is typically a 1-minute mean).
    rate_smoothing_s: Annotated[float, Field(gt=0)] = 60.0


class ZenohConfig(_Strict):
    """``[zenoh]``: the session that publishes ``weather/<site>/...``."""

    enabled: bool = True
    mode: Literal["peer", "client", "router"] = "peer"
    #: Endpoints such as ``"tcp/192.0.2.10:7447"``.
    connect: list[str] = Field(default_factory=list)
    listen: list[str] = Field(default_factory=list)
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
    rotate_s: Annotated[float, Field(gt=0)] = 3600.0
    rotate_mb: Annotated[float, Field(gt=0)] = 256.0
    #: The oldest files are deleted while the recordings exceed ``budget_mb`` or the disk has
    #: less than ``min_free_mb`` free.
    budget_mb: Annotated[float, Field(gt=0)] = 4096.0
    min_free_mb: Annotated[float, Field(ge=0)] = 512.0
    #: At most this much is lost at a power cut or ``kill -9``.
    flush_interval_s: Annotated[float, Field(gt=0, le=60)] = 1.0
    fsync_interval_s: Annotated[float, Field(gt=0, le=600)] = 5.0
    #: An overlay thumbnail (``foxglove.CompressedImage``) per camera every so many seconds;
    #: 0 disables them.
    thumbnail_interval_s: Annotated[float, Field(ge=0)] = 10.0
    thumbnail_width: Annotated[int, Field(ge=32, le=1920)] = 320
    #: Record every frame's result and histogram; false keeps only the 1 Hz summaries.
    per_frame: bool = True


class PublishConfig(_Strict):
    """``[publish]``: how often each Zenoh key is published (seconds)."""

    #: ``weather/<site>/state``; also at once when precipitation starts or stops.
    state_interval_s: Annotated[float, Field(gt=0)] = 1.0
    #: ``weather/<site>/camera/<cam>/hos``.
    camera_interval_s: Annotated[float, Field(gt=0)] = 1.0
    #: ``weather/<site>/status`` and the ``/status`` MCAP topic.
    status_interval_s: Annotated[float, Field(gt=0)] = 10.0


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
        cam = self.camera[index]
        merged = {g: dict(v) for g, v in self.detector.items()}
        for group, values in cam.detector.items():
            merged.setdefault(group, {}).update(values)
        try:
            return detector_params({"detector": merged})
        except ConfigError as exc:
            raise ConfigError(f"camera[{index}].{exc}") from None


def load_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A TOML file as a dict.

    Raises
    ------
    ConfigError : the file cannot be read or is not valid TOML.
    """
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the configuration ({exc.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None


def parse_config(data: dict[str, Any]) -> Config:
    """Validate a configuration dict (as read from TOML).

    Raises
    ------
    ConfigError : the first problem, naming its key (``camera[0].fps: ...``).
    """
    try:
        config = Config.model_validate(data)
    except pydantic.ValidationError as exc:
        raise ConfigError(_first_error(exc)) from None
    detector_params({"detector": config.detector})  # the global table, checked on its own
    for i in range(len(config.camera)):
        config.camera_params(i)
    return config


def load_config(path: str | os.PathLike[str]) -> Config:
    """Read and validate the configuration file; errors start with the file name."""
    data = load_toml(path)
    try:
        return parse_config(data)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


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


def _first_error(exc: pydantic.ValidationError) -> str:
    err = exc.errors(include_url=False)[0]
    key = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in err["loc"]).lstrip(".")
    kind = err["type"]
    if kind == "extra_forbidden":
        what = "unknown key"
    elif kind == "missing":
        what = "required key missing"
    else:
        what = err["msg"].removeprefix("Value error, ")
        if "input" in err and kind not in ("value_error",):
            what += f", got {err['input']!r}"
    return f"{key}: {what}" if key else what


# -- detector parameters -----------------------------------------------------------------------
def detector_params(config: dict[str, Any]) -> DetectorParams:
    """Detector parameters from the optional ``[detector]`` table of the configuration.

    Sub-tables ``segmentation``, ``histogram``, ``mixture``, ``decision``, ``robustness`` hold
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
    for group, values in table.items():
        if not isinstance(values, dict):
            raise ConfigError(f"detector.{group}: must be a table")
        if group not in groups:
            continue  # from_dict names it
        hints = typing.get_type_hints(getattr(DetectorParams(), group).__class__)
        for key, value in values.items():
            hint = hints.get(key.removesuffix("_deg"))
            if hint is not None:
                _check_value(f"detector.{group}.{key}", value, hint)
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
