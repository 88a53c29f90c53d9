"""Streaming the per-frame results of MCAP logs onto reference intervals."""

from __future__ import annotations

import json
import logging
import math
import shutil
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.writer import Writer

from daemon.offline import series as series_mod
from daemon.offline.reference import Interval
from daemon.offline.series import (
    GOF_GRID,
    PI_GRID,
    aggregate,
    find_mcap_files,
    iter_frames,
    load_series,
    mean_histograms,
    reference_intervals,
)
from drivers.errors import InputError

T0 = datetime(2026, 3, 1, tzinfo=UTC)
HOUR_NS = 3600 * 10**9
T0_NS = int(T0.timestamp()) * 10**9


# ---------------------------------------------------------------------------------------------
# Helpers shared with the other offline tests


def frame(t_ns: int, camera: str = "cam1", **fields: Any) -> dict[str, Any]:
    """A ``hos.frame/1``-like payload; judged, no rain, no fit unless told."""
    out = {
        "schema": "hos.frame/1",
        "t_ns": int(t_ns),
        "camera": camera,
        "state": "ok",
        "rain": False,
        "pi": None,
        "mu_deg": None,
        "sigma_deg": None,
        "gof_d": None,
        "gof_ok": None,
        "pi_smoothed": 0.0,
        "S": 0.0,
        "R": 0.0,
    }
    out.update(fields)
    return out


def write_mcap(
    path: Path,
    frames: list[dict[str, Any]],
    *,
    histograms: list[dict[str, Any]] | None = None,
) -> Path:
    """An MCAP file as the daemon writes it: JSON messages on ``/hos/<cam>/frame`` (and
    ``/hos/<cam>/histogram``), log time = ``t_ns``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start(profile="", library="test")
        schema = writer.register_schema(
            name="hos.frame", encoding="jsonschema", data=json.dumps({"type": "object"}).encode()
        )
        channels: dict[str, int] = {}
        messages = [(m, "frame") for m in frames] + [(m, "histogram") for m in histograms or []]
        messages.sort(key=lambda item: item[0]["t_ns"])
        for seq, (msg, kind) in enumerate(messages):
            topic = f"/hos/{msg['camera']}/{kind}"
            if topic not in channels:
                channels[topic] = writer.register_channel(
                    topic=topic, message_encoding="json", schema_id=schema
                )
            writer.add_message(
                channels[topic],
                log_time=msg["t_ns"],
                publish_time=msg["t_ns"],
                sequence=seq,
                data=json.dumps(msg).encode(),
            )
        writer.finish()
    return path


def hours(amounts: list[float | None], *, station: str = "S1", kind: str = "amount"):
    """Consecutive one-hour intervals from T0 with these amounts (mm)."""
    return [
        Interval(
            start=T0 + timedelta(hours=h),
            end=T0 + timedelta(hours=h + 1),
            precip_mm=mm,
            station=station,
            kind=kind,
        )
        for h, mm in enumerate(amounts)
    ]


# ---------------------------------------------------------------------------------------------
# Aggregation


def test_frames_land_in_their_interval_and_unjudged_frames_are_excluded():
    ivs = hours([0.0, 2.0])
    frames = [
        frame(T0_NS - 1, R=999.0),  # before the first interval
        frame(T0_NS, state="warming_up", R=1e6, rain=True),  # not judged: not in the means
        frame(T0_NS + 10**9, R=10.0, rain=True, pi_smoothed=0.5),
        frame(T0_NS + 2 * 10**9, R=20.0, pi_smoothed=0.3),
        frame(T0_NS + HOUR_NS - 1, R=30.0, pi_smoothed=0.1),  # last ns of hour 0
        frame(T0_NS + HOUR_NS, R=100.0, rain=True),  # exactly the start of hour 1
        frame(T0_NS + HOUR_NS + 5, state="dark", R=None),
        frame(T0_NS + 2 * HOUR_NS, R=5.0),  # end of hour 1 is excluded: outside
    ]
    counts: dict[str, int] = {}
    stats = aggregate(frames, ivs, min_judged=0.5, min_coverage=0.0, counts=counts)
    assert [(s.start, s.camera) for s in stats] == [(ivs[0].start, "cam1"), (ivs[1].start, "cam1")]
    h0, h1 = stats
    assert (h0.frames, h0.judged, h0.rain_frames) == (4, 3, 1)
    assert h0.r_mean == pytest.approx(20.0)
    assert h0.pi_smoothed_mean == pytest.approx(0.3)
    assert h0.judged_fraction == pytest.approx(0.75)
    assert h0.rain_fraction == pytest.approx(1 / 3)
    assert h0.precip_mm == 0.0 and h0.rate_mm_h == 0.0
    assert (h1.frames, h1.judged, h1.rain_frames) == (2, 1, 1)
    assert h1.r_mean == pytest.approx(100.0)
    assert h1.rate_mm_h == pytest.approx(2.0)
    assert h0.used and h1.used  # 0.75 and 0.5 judged
    assert counts == {"frames_read": 8, "frames_outside": 2, "frames_out_of_order": 0}


def test_interval_with_too_few_judged_frames_is_not_used():
    ivs = hours([1.0])
    frames = [frame(T0_NS + i * 10**9, state="ok" if i < 4 else "unstable") for i in range(10)]
    (s,) = aggregate(frames, ivs, min_judged=0.5, min_coverage=0.0)
    assert s.judged_fraction == pytest.approx(0.4)
    assert not s.used
    (s,) = aggregate(frames, ivs, min_judged=0.4, min_coverage=0.0)
    assert s.used


def test_coverage_counts_the_span_of_the_frames():
    ivs = hours([1.0])
    # 10 frames a minute apart: they span 10 minutes of the hour
    frames = [frame(T0_NS + i * 60 * 10**9) for i in range(10)]
    (s,) = aggregate(frames, ivs, min_coverage=0.5)
    assert s.coverage == pytest.approx(10 / 60)
    assert not s.used
    frames = [frame(T0_NS + i * 360 * 10**9) for i in range(10)]  # every 6 min: whole hour
    (s,) = aggregate(frames, ivs, min_coverage=0.5)
    assert s.coverage == pytest.approx(1.0)
    assert s.used


def test_roc_counts_and_circular_mean_orientation(monkeypatch):
    monkeypatch.setattr(series_mod, "_FLUSH", 3)  # exercise the buffered counting
    ivs = hours([1.0])
    pis = [0.1, 0.35, 0.5, 0.9, 0.7]
    gofs = [0.01, 0.05, 0.07, 0.2, 0.5]
    oks = [True, True, False, True, False]
    mus = [179.0, 1.0, 50.0, 3.0, 60.0]  # the GoF-passing ones: 179, 1, 3 -> mean 1
    frames = [
        frame(
            T0_NS + i * 10**9,
            pi=p,
            gof_d=d,
            gof_ok=ok,
            mu_deg=mu,
            pi_smoothed=p / 2,
        )
        for i, (p, d, ok, mu) in enumerate(zip(pis, gofs, oks, mus, strict=True))
    ]
    frames.append(frame(T0_NS + 10 * 10**9, state="dark", pi=0.99, gof_d=0.0, gof_ok=True))
    (s,) = aggregate(frames, ivs, min_coverage=0.0)
    i_half = int(np.flatnonzero(PI_GRID == 0.5)[0])
    i_035 = int(np.flatnonzero(PI_GRID == 0.34)[0])
    assert s.pi_counts[0] == 3  # GoF-passing fits only
    assert s.pi_counts[i_half] == 1  # 0.9 (0.5 failed GoF)
    assert s.pi_counts[i_035] == 2  # 0.35 and 0.9
    assert s.pi_smoothed_counts[0] == 5
    assert s.pi_smoothed_counts[int(np.flatnonzero(PI_GRID == 0.26)[0])] == 2  # 0.35, 0.45
    j = {float(d): k for k, d in enumerate(GOF_GRID)}
    assert s.gof_counts[j[0.0]] == 0
    assert s.gof_counts[j[0.05]] == 2
    assert s.gof_counts[j[0.2]] == 4
    assert s.gof_counts[-1] == 4  # 0.5 is beyond the grid
    assert s.gof_frames == 3
    assert s.mu_mean_deg == pytest.approx(1.0, abs=1e-6)


def test_late_frames_count_while_their_interval_is_open():
    ivs = hours([1.0, 1.0])
    frames = [
        frame(T0_NS + 5 * 10**9),
        frame(T0_NS + 10**9),  # late, but hour 0 is still open: counted
        frame(T0_NS + HOUR_NS + 10**9),
        frame(T0_NS + 6 * 10**9),  # late, and hour 0 is closed: dropped
    ]
    counts: dict[str, int] = {}
    h0, h1 = aggregate(frames, ivs, min_coverage=0.0, counts=counts)
    assert (h0.frames, h1.frames) == (2, 1)
    assert (h0.first_t_ns, h0.last_t_ns) == (T0_NS + 10**9, T0_NS + 5 * 10**9)
    assert counts["frames_out_of_order"] == 1 and counts["frames_outside"] == 0


def test_cameras_are_kept_apart():
    ivs = hours([1.0])
    frames = [frame(T0_NS + i * 10**9, camera="a" if i % 2 else "b", R=float(i)) for i in range(6)]
    stats = aggregate(frames, ivs, min_coverage=0.0)
    assert [s.camera for s in stats] == ["a", "b"]
    assert stats[0].r_mean == pytest.approx(3.0)  # 1, 3, 5
    assert stats[1].r_mean == pytest.approx(2.0)  # 0, 2, 4


# ---------------------------------------------------------------------------------------------
# Reference checks


def test_overlapping_stations_need_a_choice():
    ivs = hours([1.0, 2.0], station="A") + hours([0.5, 0.0], station="B")
    with pytest.raises(InputError, match="--station"):
        reference_intervals(ivs)
    kept = reference_intervals(ivs, station="B")
    assert [iv.precip_mm for iv in kept] == [0.5, 0.0]


def test_no_interval_is_an_input_error():
    with pytest.raises(InputError, match="no reference interval"):
        reference_intervals([])


# ---------------------------------------------------------------------------------------------
# Files


def test_files_and_directories_are_merged_in_time_order(tmp_path, caplog):
    # two files whose times interleave, one in a subdirectory, and a third later one
    a = [frame(T0_NS + (2 * i) * 10**9, R=1.0) for i in range(5)]
    b = [frame(T0_NS + (2 * i + 1) * 10**9, camera="cam2", R=2.0) for i in range(5)]
    c = [frame(T0_NS + HOUR_NS + i * 10**9, R=3.0) for i in range(3)]
    write_mcap(tmp_path / "logs" / "a.mcap", a)
    write_mcap(tmp_path / "logs" / "sub" / "b.mcap", b)
    later = write_mcap(tmp_path / "c.mcap", c)
    # an unfinished file: the first half of a finished one
    whole = write_mcap(tmp_path / "whole.mcap", c)
    broken = tmp_path / "logs" / "broken.mcap"
    broken.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    whole.unlink()
    (tmp_path / "logs" / "notes.txt").write_text("not a log")

    files = find_mcap_files([tmp_path / "logs", later])
    assert [p.name for p in files] == ["a.mcap", "broken.mcap", "b.mcap", "c.mcap"]
    skipped: list[str] = []
    with caplog.at_level(logging.WARNING):
        times = [f["t_ns"] for f in iter_frames([later, tmp_path / "logs"], skipped=skipped)]
    assert times == sorted(times) and len(times) == 13
    assert skipped == [str(broken.resolve())]
    assert "broken.mcap" in caplog.text and "recover" in caplog.text

    only = list(iter_frames([tmp_path / "logs"], camera="cam2"))
    assert {f["camera"] for f in only} == {"cam2"} and len(only) == 5

    s = load_series([tmp_path / "logs", later], hours([0.0, 1.0]), min_coverage=0.0)
    assert s.cameras == ["cam1", "cam2"]
    assert s.counts["files_read"] == 3 and s.counts["files_skipped"] == 1
    assert s.counts["frames_read"] == 13
    with pytest.raises(InputError, match="--camera"):
        s.select_camera(None)
    assert s.select_camera("cam2") == "cam2"
    with pytest.raises(InputError, match="nope"):
        s.select_camera("nope")
    h1 = [x for x in s.for_camera("cam1") if x.start == T0 + timedelta(hours=1)]
    assert h1[0].r_mean == pytest.approx(3.0)


def test_missing_path_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        find_mcap_files([tmp_path / "absent.mcap"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"no \*\.mcap"):
        find_mcap_files([tmp_path / "empty"])


def test_series_counts_excluded_intervals(tmp_path):
    frames = [frame(T0_NS + i * 60 * 10**9) for i in range(60)]  # hour 0: judged
    frames += [
        frame(T0_NS + HOUR_NS + i * 60 * 10**9, state="dark") for i in range(60)
    ]  # hour 1: not judged
    path = write_mcap(tmp_path / "x.mcap", frames)
    s = load_series([path], hours([0.0, 1.0, 2.0]), progress=False)
    assert s.counts["reference_intervals"] == 3
    assert s.counts["intervals_no_frames"] == 1
    assert s.counts["intervals_low_judged"] == 1
    assert s.counts["intervals_used"] == 1
    assert [x.used for x in s.intervals] == [True, False]


def test_mean_histograms_over_windows(tmp_path):
    hists = []
    for i in range(4):
        h = np.zeros(180)
        h[90] = 2.0 * (i + 1)  # 2, 4, 6, 8
        hists.append(
            {
                "t_ns": T0_NS + i * 10**9,
                "camera": "cam1",
                "histogram": h.tolist(),
                "bin_width_deg": 1.0,
                "pi": 0.5,
                "mu_deg": 179.0 if i % 2 else 1.0,
                "sigma_deg": 5.0,
            }
        )
    path = write_mcap(
        tmp_path / "h.mcap", [frame(T0_NS + i * 10**9) for i in range(4)], histograms=hists
    )
    first_two, last, none = mean_histograms(
        [path],
        [(T0_NS, T0_NS + 2 * 10**9), (T0_NS + 3 * 10**9, T0_NS + 4 * 10**9), (0, 10)],
        camera="cam1",
    )
    assert first_two["frames"] == 2 and first_two["histogram"][90] == pytest.approx(3.0)
    assert last["histogram"][90] == pytest.approx(8.0)
    assert first_two["fit"]["mu_deg"] == pytest.approx(0.0, abs=1e-6) or math.isclose(
        first_two["fit"]["mu_deg"], 180.0, abs_tol=1e-6
    )
    assert none is None
    # a long window is sampled: 2 stretches of 1 s at its two ends -> the frames at 0 s and 3 s
    (sampled,) = mean_histograms(
        [path], [(T0_NS, T0_NS + 4 * 10**9)], camera="cam1", samples=2, sample_s=1.0
    )
    assert sampled["frames"] == 2 and sampled["histogram"][90] == pytest.approx(5.0)


def test_copy_of_a_file_is_read_once(tmp_path):
    path = write_mcap(tmp_path / "a.mcap", [frame(T0_NS + i * 10**9) for i in range(3)])
    shutil.copy(path, tmp_path / "b.mcap")
    # the same path twice is one file; a copy is another file (its frames come twice)
    assert len(find_mcap_files([path, path])) == 1
    assert len(list(iter_frames([tmp_path]))) == 6
