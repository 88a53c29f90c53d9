"""What a video codec leaves of the rain: drawn streaks that still stand out after H.264, and
what the detector makes of them, scene by scene and quality by quality.

    .venv/bin/python bench/codec_survival.py [--cells light/wind light/static] [--n 4]
                                             [--crf none 23 28 32] [--frames 200] [--jobs 2]

``make eval`` fails its detection target on windy faint rain under H.264 at CRF 32 (the
evaluation split's harshest codec; the tuning split stops at 28). This measures why, on
*tuning-settings* scenes (``drivers.simulator.families``, indices from 200, never scored by
``make eval``) re-encoded at each constant-quality factor: the evaluation split is not used.

For each scene and quality, per judged rain frame (after ``SETTLE``):

* ``drawn``: streaks drawn (connected places of the streak mask);
* ``stand out``: those of them brighter, somewhere, than the same frame rendered dry (its twin,
  through the same codec) by ``2 c`` (6 grey levels, twice eq. 8's c): a streak the
  photometric rule can still find against a background;
* ``by chance``: the same test at the same places moved off the streaks (17 rows, 23 columns):
  what the codec's own noise passes. ``stand out - by chance`` is the evidence left;
* ``contrast``: the median over streak pixels of (frame - dry twin), grey levels;
* ``detected``: the detector's rain verdict on those frames, %; ``votes``: blobs in its HOS.
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eval_scenes import _SEG, SETTLE, _dry_twin  # frames not scored, as make eval

from drivers.simulator.families import SceneCase, case_frames, sample_case
from hos import DetectorParams, HosDetector, State

#: Where the control test looks: the streak places moved by this many rows and columns.
SHIFT = (17, 23)
#: A streak stands out when it is brighter than its dry twin by this many grey levels
#: somewhere: twice eq. 8's c (6), so that a pixel's rounding is not enough.
STAND_OUT = 2 * _SEG.photometric_c


def standing_out(
    wet: np.ndarray, dry: np.ndarray, streaks: np.ndarray, level: float = STAND_OUT
) -> tuple[int, int, int]:
    """``(drawn, stand out, by chance)`` for one frame: the places of the streak mask
    ``streaks`` (bool), how many are at least ``level`` brighter than ``dry`` somewhere, and
    how many pass the same test at the places moved by ``SHIFT`` (off the streaks)."""
    n, labels = cv2.connectedComponents(streaks.view(np.uint8), connectivity=8)
    if n <= 1:
        return 0, 0, 0
    diff = wet.astype(np.int16) - dry.astype(np.int16)
    peak = np.full(n, np.iinfo(np.int16).min, np.int16)
    np.maximum.at(peak, labels[streaks], diff[streaks])
    moved = np.roll(labels, SHIFT, axis=(0, 1))
    off = (moved > 0) & ~streaks
    chance = np.full(n, np.iinfo(np.int16).min, np.int16)
    np.maximum.at(chance, moved[off], diff[off])
    out = int(np.count_nonzero(peak[1:] >= level))
    return n - 1, out, int(np.count_nonzero(chance[1:] >= level))


def dry_twin(case: SceneCase) -> SceneCase:
    """``case`` with no streak drawn and every other draw the same (make eval's twin)."""
    if case.params.rain is None:
        raise ValueError(f"{case.name}: no rain to measure (a rain condition is needed)")
    return _dry_twin(case)


@dataclass
class Row:
    name: str
    size: str
    wind_px: float
    crf: int | None
    frames: int = 0
    drawn: float = 0.0
    stand_out: float = 0.0
    chance: float = 0.0
    contrast: float = 0.0
    detected: float = 0.0
    votes: float = 0.0


def measure(case: SceneCase) -> Row:
    """One scene at its codec setting: the streaks that stand out, and the detector's verdicts."""
    row = Row(case.name, f"{case.width}x{case.height}", case.params.shake_px, case.h264_crf)
    det = HosDetector(DetectorParams())
    sums = np.zeros(5)
    contrast: list[np.ndarray] = []
    for i, (f, d) in enumerate(zip(case_frames(case), case_frames(dry_twin(case)), strict=True)):
        r = det.process(f.gray, i / case.fps)
        if i < SETTLE or not f.precipitation or r.state != State.OK:
            continue
        mask = f.streaks > 0.5
        drawn, out, chance = standing_out(f.gray, d.gray, mask)
        sums += (drawn, out, chance, float(r.rain), r.n_blobs)
        contrast.append(f.gray[mask].astype(np.int16) - d.gray[mask])
        row.frames += 1
    if row.frames:
        row.drawn, row.stand_out, row.chance, row.detected, row.votes = sums / row.frames
        row.detected *= 100.0
        row.contrast = float(np.median(np.concatenate(contrast))) if contrast else 0.0
    return row


def cases(cells: list[str], n: int, crfs: list[int | None], frames: int) -> list[SceneCase]:
    """Tuning-settings scenes 200+ of each condition/camera cell, each at every quality (their
    own JPEG, if any, dropped: the codec is the one under test)."""
    out = []
    for j, cell in enumerate(cells):
        condition, camera = cell.split("/")
        for k in range(n):
            base = sample_case(
                "tuning", 200 + 1000 * j + k, condition=condition, camera=camera, frames=frames
            )
            base = replace(base, params=replace(base.params, jpeg_quality=None))
            out += [replace(base, h264_crf=crf) for crf in crfs]
    return out


_MEANS = ("drawn", "stand_out", "chance", "contrast", "detected")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", nargs="+", default=["light/wind", "light/static", "drizzle/wind"])
    ap.add_argument("--n", type=int, default=4, help="scenes per cell")
    ap.add_argument("--crf", nargs="+", default=["none", "23", "28", "32"])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    crfs = [None if c.lower() == "none" else int(c) for c in args.crf]
    started = time.perf_counter()
    todo = cases(args.cells, args.n, crfs, args.frames)
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(measure, todo))
    print(
        f"{'scene':26s} {'size':9s} {'wind':>5s} {'crf':>4s} {'drawn':>6s} {'stand out':>9s} "
        f"{'by chance':>9s} {'left':>5s} {'contrast':>8s} {'votes':>6s} {'detected %':>10s}"
    )
    for r in rows:
        print(
            f"{r.name:26s} {r.size:9s} {r.wind_px:5.2f} {r.crf or '-':>4} {r.drawn:6.1f} "
            f"{r.stand_out:9.1f} {r.chance:9.1f} {r.stand_out - r.chance:5.1f} "
            f"{r.contrast:8.1f} {r.votes:6.1f} {r.detected:10.1f}"
        )
    print()
    for crf in crfs:
        sel = [r for r in rows if r.crf == crf and r.frames]
        if not sel:
            continue
        m = {k: float(np.mean([getattr(r, k) for r in sel])) for k in _MEANS}
        print(
            f"crf {crf or '-':>4}: {len(sel)} scenes, drawn {m['drawn']:.1f}, stand out "
            f"{m['stand_out']:.1f}, by chance {m['chance']:.1f}, contrast {m['contrast']:.1f}, "
            f"detected {m['detected']:.1f} %"
        )
    print(f"{time.perf_counter() - started:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
