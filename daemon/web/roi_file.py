"""A region-of-interest polygon drawn on the status page, written into the configuration file.

Only the camera's ``roi`` key changes: tomlkit keeps every comment and the layout of the rest.
The new file is validated as a whole before it replaces the old one (atomically, with the old
file's permissions), so a save can never leave a configuration the daemon would refuse. The
running detector keeps its region until the daemon restarts: the configuration does not
change at runtime.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import tomlkit

from daemon.config import check_polygon, parse_config
from drivers.errors import ConfigError

__all__ = ["RoiWriter", "roi_snippet", "rounded_polygon"]


def rounded_polygon(points: Any) -> list[list[float]]:
    """A polygon from the page, checked (:func:`daemon.config.check_polygon`) and rounded to
    0.1 px. Raises ValueError."""
    if not isinstance(points, list) or not all(
        isinstance(p, list) and all(isinstance(v, int | float) for v in p) for p in points
    ):
        raise ValueError("expected a list of [x, y] points")
    return [[round(x, 1), round(y, 1)] for x, y in check_polygon(points)]


def roi_snippet(camera: str, source: str, polygon: list[list[float]]) -> str:
    """The TOML to paste into the ``[[camera]]`` table of ``camera``."""
    doc = tomlkit.document()
    table = tomlkit.aot()
    cam = tomlkit.table()
    cam["id"] = camera
    cam["source"] = source
    cam["roi"] = _inline(polygon)
    table.append(cam)
    doc["camera"] = table
    return tomlkit.dumps(doc)


def _inline(polygon: list[list[float]]) -> Any:
    arr = tomlkit.array()
    for x, y in polygon:
        point = tomlkit.array()
        point.extend([x, y])
        arr.append(point)
    return arr


class RoiWriter:
    """Writes polygons into the configuration file the daemon was started with.

    Parameters
    ----------
    path : the configuration file, or None (started without one: nothing to write)
    """

    def __init__(self, path: str | os.PathLike[str] | None):
        self.path = None if path is None else Path(path)

    def why_not(self) -> str | None:
        """Why the file cannot be written, or None if it can."""
        if self.path is None:
            return "the daemon was started without --config: there is no file to write"
        if not os.access(self.path, os.W_OK) or not os.access(self.path.parent, os.W_OK):
            return f"the service may not write {self.path} (or its directory)"
        return None

    def save(self, camera: str, polygon: list[list[float]]) -> Path:
        """Set ``roi`` of camera ``camera`` and replace the file.

        Raises
        ------
        ConfigError : the file cannot be written, has no such camera, or would be invalid.
        """
        why = self.why_not()
        if why is not None or self.path is None:
            raise ConfigError(why or "no configuration file")
        try:
            text = self.path.read_text(encoding="utf-8")
            doc = tomlkit.parse(text)
        except (OSError, UnicodeDecodeError, tomlkit.exceptions.TOMLKitError) as exc:
            raise ConfigError(f"{self.path}: cannot read it back ({exc})") from None
        cameras = doc.get("camera")
        entry = next(
            (c for c in (cameras or []) if isinstance(c, dict) and c.get("id") == camera), None
        )
        if entry is None:
            raise ConfigError(
                f"{self.path}: no [[camera]] with id {camera!r} (the daemon runs the built-in "
                "demo camera when the file has none): add the snippet by hand"
            )
        entry["roi"] = _inline(polygon)
        new_text = tomlkit.dumps(doc)
        parse_config(tomlkit.parse(new_text).unwrap())  # never write what run would refuse
        mode = self.path.stat().st_mode & 0o7777
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", dir=self.path.parent)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(new_text)
                f.flush()
                os.fsync(f.fileno())
            os.chmod(tmp, mode)
            os.replace(tmp, self.path)
        except OSError as exc:
            Path(tmp).unlink(missing_ok=True)
            raise ConfigError(f"{self.path}: cannot write it ({exc.strerror})") from None
        return self.path
