"""The report: PNG plots that decode, and one self-contained HTML page."""

from __future__ import annotations

import base64
import re

import cv2
import numpy as np
import pytest

from daemon.offline.calibrate import calibrate
from daemon.offline.compare import compare
from drivers.errors import InputError
from tests.daemon.offline.test_series import HOUR_NS, T0_NS, frame, hours, write_mcap

GAIN = 0.006
R_BY_HOUR = [0.0, 80.0, 240.0, 150.0, 0.0, 400.0, 320.0, 60.0]


def _logs(tmp_path, camera="cam1"):
    """Eight hours of crafted frames (and histograms) with known R, rain and μ."""
    rng = np.random.default_rng(0)
    frames, hists = [], []
    theta = np.arange(180) + 0.5
    for h, r in enumerate(R_BY_HOUR):
        for i in range(30):
            t = T0_NS + h * HOUR_NS + i * 120 * 10**9
            wet = r > 0
            pi = float(rng.uniform(0.4, 0.7)) if wet else float(rng.uniform(0.0, 0.2))
            frames.append(
                frame(
                    t,
                    camera=camera,
                    R=r * float(rng.uniform(0.8, 1.2)),
                    rain=wet,
                    pi=pi,
                    gof_d=0.03 if wet else 0.12,
                    gof_ok=wet,
                    mu_deg=float(rng.normal(95, 3)) if wet else None,
                    pi_smoothed=pi,
                )
            )
            peak = np.exp(-0.5 * ((theta - 95) / 8) ** 2) * r / 20
            hists.append(
                {
                    "t_ns": t,
                    "camera": camera,
                    "histogram": (peak + 0.2).tolist(),
                    "bin_width_deg": 1.0,
                    "pi": pi,
                    "mu_deg": 95.0,
                    "sigma_deg": 8.0,
                }
            )
    write_mcap(tmp_path / "logs" / "site.mcap", frames, histograms=hists)
    return tmp_path / "logs"


def _decode(png: bytes) -> np.ndarray:
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None
    return image


def test_calibration_report_files_and_html(tmp_path):
    logs = _logs(tmp_path, camera="c&1")
    amounts = [GAIN * r for r in R_BY_HOUR]
    amounts[6] = 0.0  # the camera saw rain that the gauge did not: a false positive
    plots = tmp_path / "plots"
    report = tmp_path / "out" / "report.html"
    result = calibrate(
        [logs], hours(amounts), out=None, plots_dir=plots, report=report, progress=False
    )
    names = sorted(p.name for p in plots.iterdir())
    assert names == ["calibration.png", "hos.png", "orientation.png", "roc.png", "timeseries.png"]
    assert sorted(result["plots"]) == sorted(str(plots / n) for n in names)
    for name in names:
        image = _decode((plots / name).read_bytes())
        assert image.shape[0] > 300 and image.shape[1] > 600
        assert image.std() > 10  # not blank
    page = report.read_text()
    assert result["report"] == str(report)
    embedded = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
    assert len(embedded) == 5
    for data in embedded:
        _decode(base64.b64decode(data))
    assert not re.search(r'(src|href)="(?!data:)', page)  # self-contained
    assert "c&amp;1" in page and "c&1<" not in page  # escaped
    assert "FP 1" in page and "TP 5" in page
    assert "Calibration of R" in page and f"{result['a']:.4g}" in page


def test_compare_report_has_no_calibration(tmp_path):
    logs = _logs(tmp_path)
    plots = tmp_path / "plots"
    result = compare([logs], hours([GAIN * r for r in R_BY_HOUR]), plots_dir=plots, progress=False)
    assert sorted(p.name for p in plots.iterdir()) == [
        "hos.png",
        "orientation.png",
        "roc.png",
        "timeseries.png",
    ]
    assert result["report"] is None


def test_unwritable_plots_dir_is_an_input_error(tmp_path):
    logs = _logs(tmp_path)
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(InputError, match="cannot write"):
        compare([logs], hours([GAIN * r for r in R_BY_HOUR]), plots_dir=blocker, progress=False)
