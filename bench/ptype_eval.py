"""Rain or snow: the camera's precipitation type on rendered scenes, tuning and held-out sets.

Each case renders a street (the simulator's, with traffic, pedestrians, wind in the tree and
sensor noise) in clear weather, rain or snow, and runs the whole detector on it. The frames
after the warm-up are scored: the truth (clear / rain / snow) against ``precipitation_type``.

The **tuning** set is what ``hos/ptype.py``'s boundary was set on; the **held-out** set uses other
seeds, other frame sizes and other rain and snow settings, and no parameter was set on it.

    .venv/bin/python bench/ptype_eval.py                 # both sets, confusion matrices
    .venv/bin/python bench/ptype_eval.py --set tuning --features   # per-case feature medians
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from drivers.simulator import Scene, SceneParams, SnowParams, StreakParams
from hos.pipeline import HosDetector
from hos.ptype import frame_score

KINDS = ("clear", "rain", "snow")
ANSWERS = ("rain", "snow", "unknown")
WARMUP = 60


@dataclass(frozen=True)
class Case:
    name: str
    kind: str  # clear, rain or snow
    width: int
    height: int
    seed: int
    params: SceneParams
    frames: int = 220


def _street(width: int, height: int, **kw: object) -> dict[str, object]:
    base: dict[str, object] = {
        "cars": 3,
        "pedestrians": 3,
        "foliage_sway_px": 1.5,
        "sensor_noise": 1.5,
    }
    base.update(kw)
    return base


def _rain(width: int, height: int, density: float, *, length: float, sigma: float, **kw):
    area = width * height / (640 * 360)
    return StreakParams(
        count=max(1, round(300 * area * density)),
        length_px=max(3.0, length * height / 540),
        sigma_deg=sigma,
        **kw,
    )


def _snow(width: int, height: int, density: float, *, sigma: float, **kw):
    area = width * height / (640 * 360)
    return SnowParams(count=max(1, round(220 * area * density)), sigma_deg=sigma, **kw)


def cases(which: str) -> list[Case]:
    """The tuning set or the held-out set (other seeds, sizes and precipitation settings)."""
    out: list[Case] = []
    if which == "tuning":
        sizes = [(640, 360), (320, 240)]
        seeds = [1, 2]
        rains = [
            ("light", 0.4, {"length": 11.0, "sigma": 10.0}),
            ("moderate", 1.0, {"length": 11.0, "sigma": 10.0}),
            ("heavy", 2.0, {"length": 14.0, "sigma": 8.0}),
            ("short-gusty", 1.0, {"length": 7.0, "sigma": 15.0}),
        ]
        snows = [
            ("light", 0.4, {"sigma": 25.0}),
            ("moderate", 1.0, {"sigma": 25.0}),
            ("heavy", 2.0, {"sigma": 30.0}),
            ("fast", 1.0, {"sigma": 18.0, "blur_px": 5.0}),
        ]
        extra: dict[str, object] = {}
    else:
        sizes = [(960, 540), (480, 270)]
        seeds = [11, 12]
        rains = [
            ("light-short", 0.5, {"length": 8.0, "sigma": 12.0, "brightness": 30.0}),
            ("moderate-wind", 1.2, {"length": 12.0, "sigma": 6.0, "mu_deg": 80.0}),
            ("heavy-wide", 2.5, {"length": 16.0, "sigma": 10.0, "width_px": 1.4}),
        ]
        snows = [
            ("light-slow", 0.5, {"sigma": 20.0, "blur_px": 2.0}),
            ("moderate-drift", 1.3, {"sigma": 30.0, "mu_deg": 100.0}),
            ("heavy-blur", 2.5, {"sigma": 25.0, "blur_px": 4.0, "radius_px": (1.0, 2.5)}),
        ]
        extra = {"jpeg_quality": 85}
    for w, h in sizes:
        for seed in seeds:
            out.append(
                Case(
                    f"clear {w}x{h} s{seed}",
                    "clear",
                    w,
                    h,
                    seed,
                    SceneParams(**_street(w, h, **extra), schedule=0.0),
                )
            )
            for label, k, kw in rains:
                p = SceneParams(**_street(w, h, **extra), rain=_rain(w, h, k, **kw))
                out.append(Case(f"rain {label} {w}x{h} s{seed}", "rain", w, h, seed, p))
            for label, k, kw in snows:
                p = SceneParams(**_street(w, h, **extra), snow=_snow(w, h, k, **kw))
                out.append(Case(f"snow {label} {w}x{h} s{seed}", "snow", w, h, seed, p))
    return out


def run_case(case: Case) -> dict[str, object]:
    scene = Scene(case.width, case.height, seed=case.seed, params=case.params)
    det = HosDetector()
    answers, scores, shapes, rain = [], [], [], []
    for i, (gray, _truth) in enumerate(scene.frames(0, case.frames)):
        r = det.process(gray, i / case.params.fps)
        if i < WARMUP:
            continue
        answers.append(r.precipitation_type)
        rain.append(r.rain)
        s = r.streak_shape
        scores.append(frame_score(s) if s is not None else math.nan)
        if s is not None and s.n:
            shapes.append(
                (
                    s.n,
                    s.elongation,
                    s.width_px,
                    s.length_px,
                    math.degrees(s.sigma),
                    s.contrast,
                    s.across,
                )
            )
    return {
        "case": case.name,
        "kind": case.kind,
        "answers": answers,
        "rain": rain,
        "scores": scores,
        "shapes": shapes,
        "height": case.height,
    }


def confusion(results: list[dict[str, object]]) -> np.ndarray:
    m = np.zeros((len(KINDS), len(ANSWERS)), int)
    for res in results:
        i = KINDS.index(res["kind"])
        for a in res["answers"]:
            m[i, ANSWERS.index(a)] += 1
    return m


def print_confusion(title: str, m: np.ndarray) -> None:
    print(f"\n{title}: frames after the warm-up (rows truth, columns answer)")
    print(f"| truth \\ answer | {' | '.join(ANSWERS)} | frames |")
    print("|---|" + "---:|" * (len(ANSWERS) + 1))
    for kind, row in zip(KINDS, m, strict=True):
        n = row.sum()
        cells = " | ".join(f"{v} ({100 * v / n:.1f} %)" if n else "0" for v in row)
        print(f"| {kind} | {cells} | {n} |")
    wrong = m[1, 1] + m[2, 0]
    said = m[1, :2].sum() + m[2, :2].sum()
    print(f"rain said snow or snow said rain: {wrong} of {said} typed precipitation frames")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("tuning", "held-out", "both"), default="both")
    ap.add_argument("--features", action="store_true", help="per-case medians of the features")
    ap.add_argument("--dump", help="write every frame's features to this .npz (for tuning)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    args = ap.parse_args(argv)
    sets = ("tuning", "held-out") if args.set == "both" else (args.set,)
    t0 = time.perf_counter()
    for which in sets:
        todo = cases(which)
        with ProcessPoolExecutor(args.jobs) as pool:
            results = list(pool.map(run_case, todo))
        if args.dump:
            rows = [
                (KINDS.index(res["kind"]), res["height"], *sh)
                for res in results
                for sh in res["shapes"]
            ]
            np.savez(args.dump, rows=np.array(rows, float))
        if args.features:
            print(f"\n{which}: per case, medians over frames with blobs")
            print(
                "case | precip% | n | elong | width | length | sigma° | contrast | across | score"
                " | answers"
            )
            for res in results:
                sh = np.array(res["shapes"]) if res["shapes"] else np.full((1, 7), np.nan)
                med = np.nanmedian(sh, axis=0)
                sc = np.nanmedian(res["scores"]) if np.isfinite(res["scores"]).any() else math.nan
                counts = {a: res["answers"].count(a) for a in ANSWERS}
                print(
                    f"{res['case']:32s} {100 * np.mean(res['rain']):5.1f} "
                    f"{med[0]:5.0f} {med[1]:5.2f} {med[2]:5.2f} {med[3]:5.2f} {med[4]:5.1f} "
                    f"{med[5]:5.1f} {med[6]:6.1f} "
                    f"{sc:+6.2f} {counts}"
                )
        print_confusion(f"{which} set ({len(todo)} clips)", confusion(results))
    print(f"\n{time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
