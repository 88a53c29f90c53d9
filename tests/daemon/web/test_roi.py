"""Region-of-interest polygons: checked in the configuration, drawn into masks, and written
into the configuration file by the status page without losing a comment."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from daemon.config import check_polygon, load_config, parse_config
from daemon.web.roi_file import RoiWriter, roi_snippet, rounded_polygon
from drivers.errors import ConfigError, InputError
from drivers.video import polygon_mask

CONFIG = """\
# A site with comments the page must keep.
[site]
id = "s1"   # the station

[[camera]]
id = "north"
source = "demo:"
# no region yet

[[camera]]
id = "south"
source = "demo:"
roi = [[1, 1], [5, 1], [5, 5]]
"""


def test_config_takes_a_polygon_and_refuses_bad_ones() -> None:
    cfg = parse_config(
        {"camera": [{"id": "a", "source": "demo:", "roi": [[0, 0], [9, 0], [0, 9]]}]}
    )
    assert cfg.camera[0].roi == [[0.0, 0.0], [9.0, 0.0], [0.0, 9.0]]
    for bad, message in [
        ([[0, 0], [1, 1]], "3 to 1000 points"),
        ([[0, 0], [1, 1], [2, 2]], "no area"),
        ([[0, 0], [1, 0], [-1, 5]], r"pixels in \[0, 65536\]"),
        ([[0, 0], [1, 0, 2], [1, 5]], "camera.0..roi"),
    ]:
        with pytest.raises(ConfigError, match=message):
            parse_config({"camera": [{"id": "a", "source": "demo:", "roi": bad}]})


def test_polygon_mask_covers_the_polygon() -> None:
    mask = polygon_mask([[2, 1], [7, 1], [7, 4], [2, 4]], width=10, height=6)
    assert mask.dtype == bool and mask.shape == (6, 10)
    ys, xs = np.nonzero(mask)
    assert (xs.min(), xs.max(), ys.min(), ys.max()) == (2, 7, 1, 4)
    assert mask.sum() == 6 * 4
    # a triangle: the half of the square under its diagonal, and invariant to vertex order
    tri = polygon_mask([[0, 0], [40, 40], [0, 40]], width=50, height=50)
    assert tri.sum() == pytest.approx(41 * 42 / 2, rel=0.03)
    assert (polygon_mask([[0, 40], [40, 40], [0, 0]], width=50, height=50) == tri).all()
    with pytest.raises(InputError, match="covers no pixel"):
        polygon_mask([[100, 100], [120, 100], [120, 130]], width=50, height=50)


def test_rounded_polygon_checks_what_the_page_sends() -> None:
    assert rounded_polygon([[1.04, 2.06], [10, 2], [10, 9]]) == [[1.0, 2.1], [10, 2], [10, 9]]
    for bad in (None, "x", [[1, 2], [3, "4"], [5, 6]], [[1, 2]], {"a": 1}):
        with pytest.raises(ValueError):
            rounded_polygon(bad)


def test_snippet_is_valid_toml_for_the_camera() -> None:
    import tomllib

    text = roi_snippet("north", "rtsp://cam/1", [[1.5, 2.0], [10.0, 2.0], [10.0, 9.0]])
    data = tomllib.loads(text)
    assert data["camera"][0] == {
        "id": "north",
        "source": "rtsp://cam/1",
        "roi": [[1.5, 2.0], [10.0, 2.0], [10.0, 9.0]],
    }
    check_polygon(data["camera"][0]["roi"])


def test_save_changes_one_key_and_keeps_comments(tmp_path: Path) -> None:
    path = tmp_path / "weatherd.toml"
    path.write_text(CONFIG)
    path.chmod(0o640)
    writer = RoiWriter(path)
    assert writer.why_not() is None
    writer.save("north", [[0.0, 0.0], [320.5, 0.0], [320.5, 180.0], [0.0, 180.0]])
    text = path.read_text()
    for comment in ("# A site with comments", "# the station", "# no region yet"):
        assert comment in text
    cfg = load_config(path)
    assert cfg.camera[0].roi == [[0.0, 0.0], [320.5, 0.0], [320.5, 180.0], [0.0, 180.0]]
    assert cfg.camera[1].roi == [[1.0, 1.0], [5.0, 1.0], [5.0, 5.0]]  # untouched
    assert path.stat().st_mode & 0o777 == 0o640
    assert [p.name for p in tmp_path.iterdir()] == ["weatherd.toml"]  # no temporary left
    # replacing a region
    writer.save("south", [[2.0, 2.0], [8.0, 2.0], [8.0, 8.0]])
    assert load_config(path).camera[1].roi == [[2.0, 2.0], [8.0, 2.0], [8.0, 8.0]]


def test_save_refuses_what_it_cannot_do(tmp_path: Path) -> None:
    assert "without --config" in RoiWriter(None).why_not()
    path = tmp_path / "weatherd.toml"
    path.write_text(CONFIG)
    with pytest.raises(ConfigError, match="no \\[\\[camera\\]\\] with id 'east'"):
        RoiWriter(path).save("east", [[0.0, 0.0], [5.0, 0.0], [5.0, 5.0]])
    assert path.read_text() == CONFIG
    if os.geteuid() != 0:  # root may write anything
        path.chmod(0o444)
        assert "may not write" in RoiWriter(path).why_not()
