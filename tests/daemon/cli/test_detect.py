"""``weatherd detect``, run as a real subprocess: the JSONL contract, the overlay, exit statuses."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from daemon import cli
from daemon.service import detection
from drivers.simulator import Scene, SceneParams, StreakParams, write_video
from drivers.video import open_video
from hos.params import DetectorParams
from tests.conftest import REPO

FIXTURE_VIDEO = REPO.parent / "shared" / "fixtures" / "video"
N_FRAMES = DetectorParams().robustness.warmup_frames + 20  # some frames after the warm-up
WIDTH, HEIGHT = 320, 240

#: The contract fields of one JSONL line (docs: DESIGN.md, "Command line") and their types;
#: ``None`` allowed where the contract says null.
CONTRACT: dict[str, tuple[type, ...]] = {
    "frame": (int,),
    "t_s": (float, int),
    "rain": (bool,),
    "state": (str,),
    "pi": (float, int, type(None)),
    "mu_deg": (float, int, type(None)),
    "sigma_deg": (float, int, type(None)),
    "gof_d": (float, int, type(None)),
    "gof_ok": (bool, type(None)),
    "pi_smoothed": (float, int),
    "mu_smoothed_deg": (float, int),
    "sigma_smoothed_deg": (float, int),
    "S": (float, int),
    "R": (float, int),
    "n_blobs": (int,),
    "n_rain_blobs": (int,),
}
ANGLES = ("mu_deg", "sigma_deg", "mu_smoothed_deg", "sigma_smoothed_deg")


def weatherd(*args: str | Path, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "daemon.cli", *map(str, args)],
        env={**os.environ, "PYTHONPATH": str(REPO)},
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=REPO,
    )


def stderr_lines(proc: subprocess.CompletedProcess[str]) -> list[str]:
    return [line for line in proc.stderr.splitlines() if line.strip()]


def assert_one_line_error(proc: subprocess.CompletedProcess[str], *, names: str) -> None:
    lines = stderr_lines(proc)
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("weatherd: error: ")
    assert names in lines[0]
    assert "Traceback" not in proc.stderr


def main_in_process(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, str]:
    """``cli.main`` in this process (no interpreter start-up) for the many pure-Python error
    cases; the subprocess tests prove the same path end to end."""
    capsys.readouterr()
    status = cli.main([str(a) for a in args])
    return status, capsys.readouterr().err


@pytest.fixture(scope="module")
def rainy_clip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small rendered clip: warm-up, then rain at 70 degrees."""
    scene = Scene(
        WIDTH,
        HEIGHT,
        seed=5,
        params=SceneParams(
            rain=StreakParams(mu_deg=70.0, sigma_deg=6.0, count=120, length_px=8.0),
            sensor_noise=1.0,
        ),
    )
    path = tmp_path_factory.mktemp("clip") / "rain.mp4"
    write_video(path, (gray for gray, _ in scene.frames(0, N_FRAMES)), fps=25)
    return path


@pytest.fixture(scope="module")
def detect_run(
    rainy_clip: Path, tmp_path_factory: pytest.TempPathFactory
) -> tuple[subprocess.CompletedProcess[str], Path, Path]:
    out = tmp_path_factory.mktemp("out")
    jsonl, overlay = out / "frames.jsonl", out / "overlay.mp4"
    proc = weatherd("detect", rainy_clip, "--jsonl", jsonl, "--overlay", overlay)
    return proc, jsonl, overlay


# -- the contract ------------------------------------------------------------------------
def test_jsonl_has_one_contract_line_per_frame(detect_run) -> None:
    proc, jsonl, _ = detect_run
    assert proc.returncode == 0, proc.stderr
    lines = jsonl.read_text().splitlines()
    assert len(lines) == N_FRAMES
    records = [json.loads(line) for line in lines]
    for i, (line, rec) in enumerate(zip(lines, records, strict=True)):
        assert ": " not in line and ", " not in line  # compact
        assert set(CONTRACT) <= set(rec)
        for key, types in CONTRACT.items():
            assert isinstance(rec[key], types), (key, rec[key])
            if bool not in types:
                assert not isinstance(rec[key], bool), key
        assert rec["frame"] == i
        for key in ANGLES:
            assert rec[key] is None or 0.0 <= rec[key] < 180.0, (key, rec[key])
        has_fit = rec["pi"] is not None
        for key in ("mu_deg", "sigma_deg", "gof_d", "gof_ok"):
            assert (rec[key] is not None) == has_fit, key
        assert all(
            math.isfinite(v) for v in rec.values() if isinstance(v, float)
        )  # no NaN sneaks in as a number
    t = [rec["t_s"] for rec in records]
    assert t[0] == 0.0
    assert np.all(np.diff(t) > 0)
    assert records[0]["state"] == "warming_up"
    assert any(rec["state"] == "ok" for rec in records)
    assert any(rec["n_blobs"] > 0 for rec in records)


def test_summary_is_one_line_on_stderr(detect_run) -> None:
    proc, _, _ = detect_run
    lines = stderr_lines(proc)
    assert len(lines) == 1, proc.stderr
    assert f"{N_FRAMES} frames" in lines[0]
    assert "frames/s" in lines[0]
    assert proc.stdout == ""


def test_overlay_is_a_video_with_one_frame_per_input_frame(detect_run) -> None:
    _, _, overlay = detect_run
    with open_video(overlay) as video:
        frames = list(video)
        assert (video.width, video.height) == (WIDTH, HEIGHT)
    assert len(frames) == N_FRAMES


def test_jsonl_to_stdout_and_quiet(rainy_clip: Path) -> None:
    proc = weatherd("detect", rainy_clip, "--jsonl", "-", "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    lines = proc.stdout.splitlines()
    assert len(lines) == N_FRAMES
    assert json.loads(lines[-1])["frame"] == N_FRAMES - 1


def test_config_and_roi_of_another_size_are_accepted(rainy_clip: Path, tmp_path: Path) -> None:
    config = tmp_path / "site.toml"
    config.write_text(
        '[site]\nid = "x"\n\n[detector.decision]\npi_rain = 0.4\nsigma_max_deg = 25\n'
        "[detector.robustness]\nwarmup_frames = 10\n"
    )
    mask = np.zeros((HEIGHT // 2, WIDTH // 2), np.uint8)
    mask[HEIGHT // 4 :, :] = 255  # the lower half of the image
    cv2.imwrite(str(tmp_path / "roi.png"), mask)
    jsonl = tmp_path / "out.jsonl"
    proc = weatherd(
        "detect", rainy_clip, "--config", config, "--roi", tmp_path / "roi.png", "--jsonl", jsonl
    )
    assert proc.returncode == 0, proc.stderr
    records = [json.loads(line) for line in jsonl.read_text().splitlines()]
    assert len(records) == N_FRAMES
    assert records[12]["state"] != "warming_up"  # the config's warm-up of 10 frames applied


def test_roi_polygon_equals_the_same_mask_image(
    rainy_clip: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mask = np.zeros((HEIGHT, WIDTH), np.uint8)
    mask[HEIGHT // 2 :, 8:] = 255
    cv2.imwrite(str(tmp_path / "roi.png"), mask)
    polygon = json.dumps(
        [[8, HEIGHT // 2], [WIDTH - 1, HEIGHT // 2], [WIDTH - 1, HEIGHT - 1], [8, HEIGHT - 1]]
    )
    out = {}
    for name, roi in (("mask", str(tmp_path / "roi.png")), ("polygon", polygon)):
        jsonl = tmp_path / f"{name}.jsonl"
        status, err = main_in_process(capsys, "detect", rainy_clip, "--roi", roi, "--jsonl", jsonl)
        assert status == 0, err
        out[name] = jsonl.read_text()
    assert out["polygon"] == out["mask"]
    whole = tmp_path / "whole.jsonl"
    assert main_in_process(capsys, "detect", rainy_clip, "--jsonl", whole)[0] == 0
    assert whole.read_text() != out["mask"]  # the region mattered
    status, err = main_in_process(capsys, "detect", rainy_clip, "--roi", "[[1, 2], [3, 4]]")
    assert status == 2 and "--roi: not a polygon" in err and err.count("\n") == 1


def test_the_shipped_config_is_valid() -> None:
    from daemon.config import detector_params, load_config

    config = load_config(REPO / "config" / "weatherd.toml")
    detector_params({"detector": config.detector})
    assert config.site.id == "demo"


# -- bad input: one line, exit 2 ---------------------------------------------------------
def _bad_video(tmp_path: Path, kind: str, clip: Path) -> Path:
    path = tmp_path / "input.avi"
    if kind == "missing":
        return tmp_path / "no-such-file.mp4"
    if kind == "zero-byte":
        path.write_bytes(b"")
    elif kind == "random-bytes":
        path.write_bytes(np.random.default_rng(1).integers(0, 256, 100_000, np.uint8).tobytes())
    elif kind == "text-named-avi":
        path.write_text("hello, I am not a video\n")
    elif kind == "truncated-garbage":  # the start of a real video, cut before any frame
        path = tmp_path / "input.mp4"
        path.write_bytes(clip.read_bytes()[:1500])
    elif kind == "empty-folder":
        path = tmp_path / "frames"
        path.mkdir()
    return path


@pytest.mark.parametrize(
    "kind",
    ["missing", "zero-byte", "random-bytes", "text-named-avi", "truncated-garbage", "empty-folder"],
)
def test_bad_video_is_one_error_line_and_status_2(
    tmp_path: Path, rainy_clip: Path, kind: str
) -> None:
    path = _bad_video(tmp_path, kind, rainy_clip)
    jsonl = tmp_path / "out.jsonl"
    proc = weatherd("detect", path, "--jsonl", jsonl)
    assert_one_line_error(proc, names=str(path))
    assert not jsonl.exists()  # nothing is created before the input is known to be good


@pytest.mark.parametrize(
    "text, key",
    [
        ("[detector.decision]\npi_rainn = 0.3\n", "detector.decision.pi_rainn"),
        ("[detector.decision]\npi_rain = 'high'\n", "detector.decision.pi_rain"),
        ("[detector.histogram]\nbins = 90.5\n", "detector.histogram.bins"),
        ("[detector.segmentation]\nmethod = 'magic'\n", "detector.segmentation.method"),
        ("[detector.weather]\nx = 1\n", "detector.weather"),
        ("[detector]\ndecision = 3\n", "detector.decision"),
        ("[detector.decision\npi_rain = 0.3\n", "not valid TOML"),
    ],
)
def test_bad_config_names_the_key(
    tmp_path: Path, rainy_clip: Path, capsys: pytest.CaptureFixture[str], text: str, key: str
) -> None:
    config = tmp_path / "bad.toml"
    config.write_text(text)
    status, err = main_in_process(capsys, "detect", rainy_clip, "--config", config)
    assert status == 2
    assert err.count("\n") == 1 and err.startswith(f"weatherd: error: {config}: ")
    assert key in err


def test_bad_config_as_a_subprocess(tmp_path: Path, rainy_clip: Path) -> None:
    config = tmp_path / "bad.toml"
    config.write_text("[detector.decision]\npi_rainn = 0.3\n")
    proc = weatherd("detect", rainy_clip, "--config", config)
    assert_one_line_error(proc, names="detector.decision.pi_rainn")


def test_missing_config_is_status_2(
    tmp_path: Path, rainy_clip: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, err = main_in_process(capsys, "detect", rainy_clip, "--config", tmp_path / "no.toml")
    assert status == 2
    assert err.count("\n") == 1 and "no.toml" in err


@pytest.mark.parametrize("kind", ["not-an-image", "all-zero", "missing"])
def test_bad_roi_is_status_2(
    tmp_path: Path, rainy_clip: Path, capsys: pytest.CaptureFixture[str], kind: str
) -> None:
    roi = tmp_path / "roi.png"
    if kind == "not-an-image":
        roi.write_text("not a png")
    elif kind == "all-zero":
        cv2.imwrite(str(roi), np.zeros((HEIGHT, WIDTH), np.uint8))
    status, err = main_in_process(capsys, "detect", rainy_clip, "--roi", roi)
    assert status == 2
    assert err.count("\n") == 1 and err.startswith(f"weatherd: error: {roi}: ")


def test_bad_roi_as_a_subprocess(tmp_path: Path, rainy_clip: Path) -> None:
    roi = tmp_path / "roi.png"
    roi.write_text("not a png")
    proc = weatherd("detect", rainy_clip, "--roi", roi)
    assert_one_line_error(proc, names=str(roi))


def test_usage_error_is_one_line_and_status_2() -> None:
    proc = weatherd("detect")
    assert_one_line_error(proc, names="VIDEO")


# -- damaged but usable input, interruption, internal errors ------------------------------
def test_truncated_real_clip_is_processed_with_a_warning(tmp_path: Path) -> None:
    source = FIXTURE_VIDEO / "road_surface_clear_640x360.avi"
    if not source.is_file():
        pytest.skip(f"{source} is not beside this checkout")
    data = source.read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: len(data) // 8])
    jsonl = tmp_path / "out.jsonl"
    proc = weatherd("detect", cut, "--jsonl", jsonl)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    assert 0 < len(jsonl.read_text().splitlines()) < 374


def test_ctrl_c_exits_130_and_keeps_the_output(tmp_path: Path) -> None:
    source = FIXTURE_VIDEO / "motorway_clear_320x240.avi"  # long enough to interrupt
    if not source.is_file():
        pytest.skip(f"{source} is not beside this checkout")
    jsonl = tmp_path / "out.jsonl"
    proc = subprocess.Popen(
        [sys.executable, "-m", "daemon.cli", "detect", str(source), "--jsonl", str(jsonl)],
        env={**os.environ, "PYTHONPATH": str(REPO)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 60
        while not (jsonl.exists() and jsonl.stat().st_size > 0):  # the first 8 KiB flushed
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline
            time.sleep(0.02)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    records = [json.loads(line) for line in jsonl.read_text().splitlines()]
    assert 0 < len(records) < 748
    assert [r["frame"] for r in records] == list(range(len(records)))


def test_internal_error_is_one_line_and_status_1(
    rainy_clip: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def broken(detector, frames, **kwargs):
        raise ZeroDivisionError("a bug")
        yield

    # the command imports it when it runs (daemon/cli/detect.py: a light parser)
    monkeypatch.setattr(detection, "detect_frames", broken)
    assert cli.main(["detect", str(rainy_clip)]) == 1
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert err == ["weatherd: error: internal error: ZeroDivisionError: a bug"]


def test_an_interrupt_garbled_by_native_code_still_reads_as_ctrl_c() -> None:
    """A KeyboardInterrupt raised while a numba kernel ran surfaces as a SystemError whose
    context is the interrupt: it is still an interruption (exit 130), not an internal error."""
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemError("CPUDispatcher returned a result with an exception set")  # noqa: B904
    except SystemError as exc:
        garbled = exc
    assert cli._raised_by_interrupt(garbled)
    assert not cli._raised_by_interrupt(SystemError("something else"))
