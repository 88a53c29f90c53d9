"""Calibration of R -> mm/h: robust fits on crafted points, the TOML file, and end to end from
logs written by ``weatherd replay`` of rendered rain."""

from __future__ import annotations

import fcntl
import json
import math
import os
import shutil
import subprocess
import sys
import tomllib
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from daemon.offline.calibrate import (
    CalibrationPoints,
    calibrate,
    calibration_points,
    fit_calibration,
    fit_model,
    toml_text,
    write_calibration_toml,
)
from daemon.offline.compare import compare
from daemon.offline.series import aggregate
from drivers.errors import InputError
from tests.conftest import REPO
from tests.daemon.offline.test_series import HOUR_NS, T0, T0_NS, frame, hours, write_mcap


def noisy(rng, r, a, b=1.0, sigma=0.2):
    """Rates a·R^b with multiplicative log-normal noise of mean 1."""
    return a * r**b * np.exp(rng.normal(0.0, sigma, r.size) - sigma**2 / 2)


def points(r, y, **kw) -> CalibrationPoints:
    r, y = np.asarray(r, float), np.asarray(y, float)
    return CalibrationPoints(
        r=r, rate_mm_h=y, r_all=kw.get("r_all", r), rate_all_mm_h=kw.get("y_all", y),
        n_dry=0, n_unseen=0,
    )  # fmt: skip


# ---------------------------------------------------------------------------------------------
# Fits on crafted points


@pytest.mark.parametrize("model", ["linear", "power"])
def test_known_linear_gain_is_recovered_by_both_models(model):
    rng = np.random.default_rng(1)
    r = rng.uniform(20, 800, 60)
    fit = fit_model(r, noisy(rng, r, 0.01), model=model, n_boot=400)
    assert fit.predict(400.0) == pytest.approx(4.0, rel=0.05)
    if model == "linear":
        assert fit.a == pytest.approx(0.01, rel=0.04)
        assert fit.a_ci[0] < 0.01 < fit.a_ci[1]
        assert fit.b == 1.0
    else:
        assert fit.b_ci[0] < 1.0 < fit.b_ci[1]


def test_known_power_law_is_recovered_and_chosen():
    rng = np.random.default_rng(2)
    r = rng.uniform(10, 1000, 80)
    y = noisy(rng, r, 0.002, 1.4, sigma=0.15)
    result, fits = fit_calibration(points(r, y), n_boot=400)
    assert result["model"] == "power", result["choice"]
    assert result["b"] == pytest.approx(1.4, abs=0.05)
    assert result["a"] == pytest.approx(0.002, rel=0.3)
    assert result["b_ci"][0] < 1.4 < result["b_ci"][1]
    assert result["r2"] > 0.9
    assert set(result["candidates"]) == {"linear", "power"}
    assert fits["power"].n == 80


def test_linear_data_choose_the_linear_model():
    rng = np.random.default_rng(3)
    r = rng.uniform(20, 800, 40)
    result, _ = fit_calibration(points(r, noisy(rng, r, 0.005)), n_boot=400)
    assert result["model"] == "linear", result["choice"]
    assert "includes 1" in result["choice"]


def test_outliers_are_rejected():
    rng = np.random.default_rng(4)
    r = rng.uniform(20, 800, 50)
    y = noisy(rng, r, 0.01, sigma=0.1)
    bad = np.array([3, 11, 17, 29, 41])
    y[bad[:3]] *= 8.0  # gauge caught what the camera did not see
    y[bad[3:]] /= 10.0  # spray seen as rain
    clean = fit_model(r, y, model="linear", n_boot=0)
    assert clean.a == pytest.approx(0.01, rel=0.03)
    assert np.all(clean.weights[bad] == 0.0)
    assert clean.n_outliers >= bad.size
    # ordinary least squares in log space would be pulled away
    ols = math.exp(np.mean(np.log(y) - np.log(r)))
    assert abs(ols / 0.01 - 1) > 2 * abs(clean.a / 0.01 - 1)


def test_confidence_intervals_cover_the_truth():
    covered_a = covered_b = 0
    trials = 30
    for seed in range(trials):
        rng = np.random.default_rng(100 + seed)
        r = rng.uniform(20, 800, 30)
        lin = fit_model(r, noisy(rng, r, 0.01), model="linear", n_boot=200, seed=seed)
        covered_a += lin.a_ci[0] <= 0.01 <= lin.a_ci[1]
        pw = fit_model(r, noisy(rng, r, 0.003, 1.2), model="power", n_boot=200, seed=seed)
        covered_b += pw.b_ci[0] <= 1.2 <= pw.b_ci[1]
    # nominal 95 %; percentile bootstrap on 30 points runs a little narrow
    assert covered_a >= 0.8 * trials
    assert covered_b >= 0.8 * trials


def test_bootstrap_is_reproducible():
    rng = np.random.default_rng(5)
    r = rng.uniform(20, 800, 25)
    y = noisy(rng, r, 0.01)
    one = fit_model(r, y, model="power", n_boot=100, seed=7)
    two = fit_model(r, y, model="power", n_boot=100, seed=7)
    assert one.a_ci == two.a_ci and one.b_ci == two.b_ci


def test_perfect_data():
    r = np.array([10.0, 50.0, 100.0, 400.0, 800.0, 1600.0, 3000.0])
    result, fits = fit_calibration(points(r, 0.004 * r), n_boot=200)
    assert result["model"] == "linear"
    assert result["a"] == pytest.approx(0.004, rel=1e-9)
    assert result["a_ci"] == pytest.approx([0.004, 0.004], rel=1e-9)
    assert result["r2"] == pytest.approx(1.0)
    assert result["rmse_mm_h"] == pytest.approx(0.0, abs=1e-9)
    assert fits["power"].b == pytest.approx(1.0, abs=1e-9)


def test_constant_intensity():
    r = np.full(6, 200.0)
    y = np.array([1.0, 1.2, 0.8, 1.1, 0.9, 1.0])
    with pytest.raises(InputError, match="same in every interval"):
        fit_model(r, y, model="power")
    result, fits = fit_calibration(points(r, y), n_boot=100)
    assert result["model"] == "linear"
    assert "power model not fitted" in result["choice"]
    assert "power" not in fits
    assert result["a"] == pytest.approx(1.0 / 200, rel=0.02)
    # both constant: R² is undefined
    result, _ = fit_calibration(points(r, np.ones(6)), n_boot=50)
    assert result["r2"] is None and result["rmse_mm_h"] == pytest.approx(0.0, abs=1e-12)


def test_too_few_points_and_bad_values():
    with pytest.raises(InputError, match="at least 2"):
        fit_calibration(points([100.0], [1.0]))
    with pytest.raises(InputError, match="R > 0"):
        fit_model(np.array([0.0, 1.0]), np.array([1.0, 1.0]))
    with pytest.raises(InputError, match="unknown model"):
        fit_calibration(points([1.0, 2.0], [1.0, 2.0]), model="cubic")
    with pytest.raises(InputError, match="power"):
        fit_calibration(points([1.0, 2.0], [1.0, 2.0]), model="power")


def test_points_split_wet_dry_unseen_and_unused():
    frames = []
    # hour 0 dry with R 5; hour 1 wet, R 100; hour 2 wet, R 0 (unseen); hour 3 wet, not judged
    for h, r, state in ((0, 5.0, "ok"), (1, 100.0, "ok"), (2, 0.0, "ok"), (3, 50.0, "dark")):
        frames += [frame(T0_NS + h * HOUR_NS + i * 60 * 10**9, R=r, state=state) for i in range(60)]
    stats = aggregate(frames, hours([0.05, 2.0, 1.0, 3.0]))
    p = calibration_points(stats, threshold_mm=0.1)
    assert p.r.tolist() == [100.0] and p.rate_mm_h.tolist() == [2.0]
    assert (p.n_dry, p.n_unseen) == (1, 1)
    assert sorted(p.r_all.tolist()) == [0.0, 5.0, 100.0]  # the unjudged hour is not used
    p = calibration_points(stats, threshold_mm=0.01)
    assert p.n_dry == 0 and sorted(p.r.tolist()) == [5.0, 100.0]


# ---------------------------------------------------------------------------------------------
# calibration.toml


def test_toml_has_the_daemon_keys(tmp_path):
    rng = np.random.default_rng(6)
    r = rng.uniform(20, 800, 20)
    result, _ = fit_calibration(points(r, noisy(rng, r, 0.01)), n_boot=100)
    path = tmp_path / "calibration.toml"
    table = write_calibration_toml(
        path, result, reference='H_75_"x".csv.gz', station="75114001", camera="cam1"
    )
    loaded = tomllib.loads(path.read_text())["calibration"]
    assert loaded == table
    for key in ("model", "a", "b", "a_ci", "b_ci", "n", "r2", "rmse_mm_h", "r_min", "r_max"):
        assert loaded[key] == pytest.approx(result[key]) if key != "model" else result[key]
    assert loaded["source"] == "offline"
    assert loaded["fitted_at"].endswith("Z")
    assert loaded["reference"] == 'H_75_"x".csv.gz'
    assert (loaded["station"], loaded["camera"]) == ("75114001", "cam1")
    result["r2"] = None
    write_calibration_toml(path, result, reference=None, station=None, camera="c")
    loaded = tomllib.loads(path.read_text())["calibration"]
    assert math.isnan(loaded["r2"]) and "station" not in loaded
    assert tomllib.loads(toml_text({"s": "a\\b\n"}))["calibration"]["s"] == "a\\b\n"


def test_calibrate_on_crafted_logs(tmp_path):
    gain = 0.005
    r_by_hour = [0.0, 100.0, 300.0, 200.0, 600.0, 50.0, 400.0]
    frames = []
    for h, r in enumerate(r_by_hour):
        frames += [frame(T0_NS + h * HOUR_NS + i * 60 * 10**9, R=r, rain=r > 0) for i in range(60)]
    path = write_mcap(tmp_path / "logs" / "site.mcap", frames)
    ivs = hours([gain * r for r in r_by_hour])
    out = tmp_path / "calibration.toml"
    result = calibrate([tmp_path / "logs"], ivs, out=out, n_boot=100, progress=False)
    json.dumps(result)  # the contract JSON line
    assert result["model"] == "linear"
    assert result["a"] == pytest.approx(gain, rel=1e-6)
    assert result["n"] == 6 and result["n_dry"] == 1
    assert result["camera"] == "cam1" and result["out"] == str(out)
    assert tomllib.loads(out.read_text())["calibration"]["a"] == pytest.approx(gain)
    with pytest.raises(InputError, match="presence"):
        calibrate([path], hours([1.0, 0.0], kind="presence"), out=None)


# ---------------------------------------------------------------------------------------------
# End to end: rendered rain of known density -> weatherd replay -> calibrate / compare

CLIP_FRAMES = 150
DENSITIES = [0, 80, 160, 240, 320]  # streaks per frame, one clip per hour; hour 0 is clear
MM_H_PER_STREAK = 0.01  # the rendering's "truth": rain rate proportional to the density


def _render_clips(folder: Path) -> list[Path]:
    from drivers.simulator import Scene, SceneParams, StreakParams, write_video

    paths = []
    for k, count in enumerate(DENSITIES):
        params = SceneParams(fps=25, rain=StreakParams(count=count) if count else None)
        scene = Scene(320, 240, seed=k, params=params)
        path = folder / f"clip{k}.mp4"
        write_video(path, (img for img, _ in scene.frames(0, CLIP_FRAMES)), fps=25)
        paths.append(path)
    return paths


#: The clips each ``weatherd replay`` process is given, one after the other: a fresh detector
#: per clip, each clip starting where the previous one ended (its hour: ``fps`` below), the
#: frames' results the same as one process a clip would write. Two processes, not one a clip:
#: five on two cores took 29 s of CPU where two take 18 s (start-up, and their threads
#: contending), and two still write two logs for the calibration to read as one series.
REPLAYS = [[0, 1, 2], [3, 4]]


def _replay_all(clips: list[Path], folder: Path) -> list[Path]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    fps = CLIP_FRAMES / 3600.0  # a clip spans its hour
    folder.mkdir(parents=True, exist_ok=True)
    procs, outs = [], []
    for k, ks in enumerate(REPLAYS):
        out = folder / f"replay{k}.mcap"
        start = (T0 + timedelta(hours=ks[0])).strftime("%Y-%m-%dT%H:%M:%SZ")
        cmd = [sys.executable, "-m", "daemon.cli", "replay", *(str(clips[i]) for i in ks)]
        cmd += ["--out", str(out), "--start", start, "--fps", repr(fps)]
        cmd += ["--camera", "cam1", "--no-progress"]
        procs.append(subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE))
        outs.append(out)
    for proc, ks in zip(procs, REPLAYS, strict=True):
        stdout, stderr = proc.communicate(timeout=240)
        assert proc.returncode == 0, stderr.decode()
        summary = json.loads(stdout)
        assert (summary["videos"], summary["frames"]) == (len(ks), CLIP_FRAMES * len(ks))
    return outs


def _mean_r_per_hour(paths: list[Path]) -> list[float]:
    """Mean R of the judged frames of each hour of the replayed files, read directly (not with
    series.py)."""
    rs: dict[int, list[float]] = {}
    for path in paths:
        with open(path, "rb") as f:
            for _, _, m in make_reader(f).iter_messages(topics=["/hos/cam1/frame"]):
                v = json.loads(m.data)
                if v["state"] == "ok" and v["R"] is not None:
                    rs.setdefault((v["t_ns"] - T0_NS) // HOUR_NS, []).append(v["R"])
    assert sorted(rs) == list(range(len(DENSITIES)))
    return [float(np.mean(rs[h])) for h in sorted(rs)]


def _reference_csv(path: Path, amounts: list[float]) -> Path:
    lines = ["time,precip_mm"]
    for k, mm in enumerate(amounts):
        end = T0 + timedelta(hours=k + 1)  # the generic CSV stamps the END of the interval
        lines.append(f"{end:%Y-%m-%dT%H:%M:%SZ},{mm:.6f}")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def replayed(tmp_path_factory):
    """The rendered clips replayed into ``logs/``: made once per run, also when the module's
    tests are spread over pytest-xdist's workers (the first to take the lock makes it in the
    folder the workers share, the others wait for it and read it; each test writes only files
    of its own names beside ``logs/``)."""
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    folder = shared / "calibrate-replayed"
    with open(shared / "calibrate-replayed.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            if not (folder / "done").exists():
                shutil.rmtree(folder, ignore_errors=True)
                folder.mkdir()
                _replay_all(_render_clips(folder), folder / "logs")
                (folder / "done").touch()
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
    return folder, sorted((folder / "logs").glob("*.mcap"))


@pytest.mark.e2e
def test_end_to_end_gain_recovered_from_replayed_logs(replayed):
    folder, mcaps = replayed
    mean_r = _mean_r_per_hour(mcaps)
    assert mean_r[0] < 0.05 * mean_r[1]  # the clear hour
    assert mean_r[1:] == sorted(mean_r[1:])  # R grows with the rendered density

    # 1. amounts = a known gain x the camera's mean R: the gain comes back
    gain = 0.004
    ref = _reference_csv(folder / "gain.csv", [0.0] + [gain * r for r in mean_r[1:]])
    out = folder / "calibration.toml"
    # (the plots of the same calibration are drawn, and checked, by the command line below:
    # test_the_command_lines; test_report.py draws them from calibrate() itself)
    result = calibrate([folder / "logs"], ref, out=out, progress=False)
    assert result["model"] == "linear"
    assert result["a"] == pytest.approx(gain, rel=0.01)
    assert result["n"] == 4 and result["n_dry"] == 1
    assert result["r2"] == pytest.approx(1.0, abs=1e-3)
    assert result["reference"] == "gain.csv"
    table = tomllib.loads(out.read_text())["calibration"]
    assert table["camera"] == "cam1" and table["a"] == pytest.approx(result["a"])

    # 2. amounts from the rendering's density: the fitted relation is consistent with it
    ref = _reference_csv(folder / "density.csv", [MM_H_PER_STREAK * d for d in DENSITIES])
    result = calibrate([folder / "logs"], ref, out=None, progress=False)
    assert result["r2"] > 0.9
    truth = np.array([MM_H_PER_STREAK * d for d in DENSITIES[1:]])
    predicted = result["a"] * np.array(mean_r[1:]) ** result["b"]
    np.testing.assert_allclose(predicted, truth, rtol=0.35)
    assert np.all(np.diff(predicted) > 0)


@pytest.mark.e2e
def test_end_to_end_compare_on_replayed_logs(replayed):
    folder, _ = replayed
    ref = _reference_csv(folder / "compare.csv", [MM_H_PER_STREAK * d for d in DENSITIES])
    result = compare([folder / "logs"], ref, report=folder / "report.html", progress=False)
    c = result["confusion"]
    assert (c["tp"], c["fp"], c["tn"], c["fn"]) == (4, 0, 1, 0)
    assert c["accuracy"] == 1.0
    assert result["roc"]["interval"]["pi_smoothed"]["auc"] == pytest.approx(1.0)
    assert result["roc"]["frame"]["pi"]["auc"] > 0.9
    outcomes = [row["outcome"] for row in result["table"]]
    assert outcomes == ["TN", "TP", "TP", "TP", "TP"]
    assert "data:image/png;base64," in (folder / "report.html").read_text()


@pytest.mark.e2e
def test_the_command_lines(replayed):
    """``weatherd calibrate`` ends with the contract JSON line and writes a file the daemon
    loads; ``weatherd compare`` prints the confusion matrix."""
    from daemon.service.calibration import OnlineCalibration, load_calibration_file

    folder, _ = replayed
    mean_r = _mean_r_per_hour(sorted((folder / "logs").glob("*.mcap")))
    ref = _reference_csv(folder / "cli.csv", [0.0] + [0.004 * r for r in mean_r[1:]])
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    out = folder / "cli-calibration.toml"
    cmd = [sys.executable, "-m", "daemon.cli", "calibrate", "--mcap", str(folder / "logs")]
    cmd += ["--reference", str(ref), "--out", str(out), "--plots", str(folder / "cli-plots")]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    line = json.loads(proc.stdout.strip().splitlines()[-1])
    assert {"model", "a", "b", "n", "r2", "rmse_mm_h"} <= set(line)
    assert line["a"] == pytest.approx(0.004, rel=0.01) and line["n"] == 4
    assert (folder / "cli-plots" / "report.html").exists()
    assert (folder / "cli-plots" / "calibration.png").stat().st_size > 10_000
    prior = OnlineCalibration(prior=load_calibration_file(out))
    assert prior.ready
    assert prior.rate_mm_h(mean_r[2]) == pytest.approx(0.004 * mean_r[2], rel=0.01)

    cmd = [sys.executable, "-m", "daemon.cli", "compare", "--mcap", str(folder / "logs")]
    cmd += ["--reference", str(ref)]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert result["confusion"]["accuracy"] == 1.0
    assert "TP 4 FP 0 TN 1 FN 0" in proc.stderr

    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "daemon.cli",
            "calibrate",
            "--mcap",
            str(folder / "nothing"),
            "--reference",
            str(ref),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2 and proc.stderr.startswith("weatherd: error: ")
