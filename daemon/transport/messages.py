"""The messages the daemon publishes over Zenoh and records in MCAP, and their JSON Schemas.

Every message is a JSON object with a ``schema`` field naming its type and version
(``"weather.state/1"``), the ``site``, and its UTC time twice: ``t`` (ISO-8601, ``Z``) and
``t_ns`` (integer nanoseconds since the Unix epoch). The JSON Schemas live
in ``daemon/transport/schemas/<type>.schema.json`` (``docs/schemas/`` points there) and the
tests validate every published message against them.

============================  ==========================================  =====================
schema                        Zenoh key (under ``weather/<site>/``)        MCAP topic
============================  ==========================================  =====================
``weather.state/1``           ``state``                                    ``/weather/state``
``weather.camera/1``          ``camera/<cam>/hos``                         ``/hos/<cam>/summary``
``weather.status/1``          ``status``                                   ``/status``
``hos.frame/1``               (not published)                              ``/hos/<cam>/frame``
``hos.histogram/1``           (not published)                              ``/hos/<cam>/histogram``
``foxglove.CompressedImage``  (not published)                              ``/hos/<cam>/thumbnail``
``foxglove.Log``              (not published)                              ``/log``
============================  ==========================================  =====================
"""

from __future__ import annotations

import datetime as dt
import functools
import json
from importlib import resources
from typing import Any

import numpy as np

from hos.result import FrameResult, json_angle_deg, json_float

__all__ = [
    "SCHEMAS",
    "frame_message",
    "histogram_message",
    "iso_utc",
    "schema_for",
    "stamp",
]

#: Message types and the MCAP schema names they are recorded under.
SCHEMAS = (
    "weather.state",
    "weather.camera",
    "weather.status",
    "hos.frame",
    "hos.histogram",
    "instrument.reading",
    "instrument.raw",
)
VERSION = 1


@functools.cache
def schema_for(name: str) -> dict[str, Any]:
    """The JSON Schema of message type ``name`` (``"weather.state"``), as a dict."""
    if name not in SCHEMAS:
        raise KeyError(name)
    schemas = resources.files("daemon.transport").joinpath("schemas")
    text = schemas.joinpath(f"{name}.schema.json").read_text()
    return json.loads(text)


def iso_utc(t_ns: int) -> str:
    """``t_ns`` (UTC ns since the epoch) as ISO-8601 with microseconds and ``Z``."""
    t = dt.datetime.fromtimestamp(t_ns // 1000 / 1e6, tz=dt.UTC)
    return t.strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def stamp(kind: str, *, site: str, t_ns: int, **fields: Any) -> dict[str, Any]:
    """A message of type ``kind`` with the common header, then ``fields`` in order."""
    return {"schema": f"{kind}/{VERSION}", "site": site, "t": iso_utc(t_ns), "t_ns": int(t_ns)} | (
        fields
    )


def frame_message(result: FrameResult, *, site: str, camera: str, t_ns: int) -> dict[str, Any]:
    """``hos.frame/1``: the ``weatherd detect --jsonl`` fields of one frame, with its time."""
    return stamp("hos.frame", site=site, t_ns=t_ns, camera=camera, **result.to_json())


def histogram_message(result: FrameResult, *, site: str, camera: str, t_ns: int) -> dict[str, Any]:
    """``hos.histogram/1``: the HOS of one frame (4 significant digits) and its fit."""
    hist = np.asarray(result.histogram, dtype=np.float64)
    values = [float(f"{v:.4g}") for v in hist.tolist()] if hist.size else []
    fit = result.fit
    ok = fit.ok
    return stamp(
        "hos.histogram",
        site=site,
        t_ns=t_ns,
        camera=camera,
        frame=int(result.frame),
        bin_width_deg=180.0 / max(len(values), 1),
        histogram=values,
        pi=json_float(fit.pi) if ok else None,
        mu_deg=json_angle_deg(fit.mu) if ok else None,
        sigma_deg=json_angle_deg(fit.sigma) if ok else None,
    )
