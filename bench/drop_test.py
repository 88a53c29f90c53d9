"""The paper's eq. 32, a two-sided test of a drop, measured on the detector's blobs: how many
of them, on the drawn streaks and off them, were there for one frame only.

    .venv/bin/python bench/drop_test.py [--cells drizzle/wind snow/static ...] [--n 2]
                                        [--first 200] [--frames 240] [--gap 1] [--jobs 2]

A drop crosses a pixel within one exposure: the pixel is brighter than in the frame before
and in the frame after, ``I_n - I_n-1 >= c and I_n - I_n+1 >= c`` (eq. 32, section 9.2 of
the paper, after Garg and Nayar's photometric constraint). Eq. 8 compares the frame with the
background instead, which an edge the wind sways, a shade's edge or the residue of its
correction also pass. This script asks how
well the two-sided test tells the detector's blobs apart, as a measurement for
``docs/method.md`` ("A drop is there for one frame: measured, not taken"): the detector
itself does not use it.

Scenes come from the *tuning* settings (``drivers.simulator.families``, indices from
``--first``, 200 by default, which ``make eval`` never scores): the evaluation split is not
used. For each frame from the 120th on, each blob of the detector (defaults) is put in a
class (``voting``: rain and noise, the blobs of the HOS; ``structure``: recurs in place, was
found again, or lies where the light moved; ``traffic``), on a streak if any of its pixels
is on the drawn streak mask, and it *passes* when at least half of its pixels are eq. 8's
c (3 grey levels) brighter than ``--gap`` frames before and ``--gap`` frames after. The
table gives each class's blobs a frame and the share of them that pass.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import deque
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from drivers.simulator.families import CAMERAS, CONDITIONS, case_frames, sample_case
from hos import DetectorParams, HosDetector
from hos.result import BlobClass

#: frames left out at the start: the warm-up and the structure rule's first learning
FIRST_FRAME = 120
CLASSES = ("voting", "structure", "traffic")
_CLASS_OF = {
    BlobClass.RAIN: "voting",
    BlobClass.NOISE: "voting",
    BlobClass.STRUCTURE: "structure",
    BlobClass.TRAFFIC: "traffic",
}


def two_sided_share(
    before: np.ndarray,
    now: np.ndarray,
    after: np.ndarray,
    labels: np.ndarray,
    n_labels: int,
    c: float,
) -> np.ndarray:
    """(n_labels,) float: the share of each label's pixels at least ``c`` brighter in ``now``
    than in ``before`` and than in ``after`` (NaN for a label without a pixel; label 0 is
    counted like the others). ``before``, ``now``, ``after``: (H, W) grey frames;
    ``labels``: (H, W) int labels of ``now``'s blobs."""
    b, m, a = (f.astype(np.int16) for f in (before, now, after))
    both = ((m - b) >= c) & ((m - a) >= c)
    lab = labels.reshape(-1)
    area = np.bincount(lab, minlength=n_labels).astype(np.float64)
    hits = np.bincount(lab, weights=both.reshape(-1), minlength=n_labels)
    with np.errstate(invalid="ignore", divide="ignore"):
        return hits / area


def measure(args: tuple[str, int, str, str, int, int]) -> tuple[str, dict]:
    """One scene: ``{(class, on_streak): [blobs, passed]}`` over its frames, and its name."""
    split, index, condition, camera, frames, gap = args
    case = sample_case(split, index, condition=condition, camera=camera, frames=frames)
    params = DetectorParams()
    c = params.segmentation.photometric_c
    det = HosDetector(params)
    window: deque = deque(maxlen=2 * gap + 1)
    counts = {(k, on): [0, 0] for k in CLASSES for on in (True, False)}
    n_frames = 0
    for k, frame in enumerate(case_frames(case)):
        result = det.process(frame.gray, k / case.fps)
        labels = result.label_image()
        window.append(
            (
                frame.gray,
                None if labels is None else labels.copy(),
                None if result.blob_class is None else result.blob_class.copy(),
                frame.streaks,
            )
        )
        if k < FIRST_FRAME + gap or len(window) < window.maxlen:
            continue
        now, labels, classes, streaks = window[gap]
        if labels is None or classes is None:
            continue
        n_frames += 1
        n = classes.shape[0]
        share = two_sided_share(window[0][0], now, window[-1][0], labels, n, c)
        on = np.zeros(n, bool)
        if streaks is not None:
            on = np.bincount(labels[streaks].reshape(-1), minlength=n) > 0
        passed = share >= 0.5
        for code, name in _CLASS_OF.items():
            for side in (True, False):
                sel = (classes == code) & (on == side)
                sel[0] = False
                counts[(name, side)][0] += int(sel.sum())
                counts[(name, side)][1] += int((sel & passed).sum())
    return case.name, {"frames": n_frames, **{f"{k}|{int(v)}": c for (k, v), c in counts.items()}}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--cells",
        nargs="+",
        default=[
            "drizzle/wind",
            "light/static",
            "heavy/static",
            "snow/static",
            "snow/wind",
            "clear/wind",
        ],
        help="condition/camera pairs",
    )
    ap.add_argument("--n", type=int, default=2, help="scenes a cell")
    ap.add_argument("--first", type=int, default=200, help="first scene index (tuning settings)")
    ap.add_argument("--frames", type=int, default=240)
    ap.add_argument("--gap", type=int, default=1, help="frames before and after")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    jobs = []
    for cell in a.cells:
        condition, camera = cell.split("/")
        if condition not in CONDITIONS or camera not in CAMERAS:
            ap.error(f"unknown cell {cell!r}")
        jobs += [("tuning", a.first + i, condition, camera, a.frames, a.gap) for i in range(a.n)]
    t0 = time.monotonic()
    head = "".join(f"  {k} on / off streaks" for k in CLASSES)
    print(f"scene                          frames{head}")
    print("  (blobs a frame, share passing the two-sided test)")
    with ProcessPoolExecutor(a.jobs) as pool:
        for name, c in pool.map(measure, jobs):
            f = max(c["frames"], 1)
            cols = []
            for k in CLASSES:
                for on in (1, 0):
                    n, p = c[f"{k}|{on}"]
                    cols.append(f"{n / f:6.1f} {p / n:4.2f}" if n else f"{0:6.1f}    -")
            print(f"{name:30s} {c['frames']:6d}  " + "  ".join(cols), flush=True)
    print(f"{len(jobs)} scenes in {time.monotonic() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
