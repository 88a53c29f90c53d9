"""A reference "gauge" for the worked example of docs/offline.md, derived from the truth that
``weatherd simulate --truth`` wrote: what the simulator drew, frame by frame.

The simulator's rain is a number of streaks per frame, ``rain_intensity`` times the demo's
moderate rain; the example's gauge takes that as ``--mm-h`` mm/h per unit of intensity (4 mm/h
by default: WMO "moderate" rain at intensity 1). Over each interval of ``--interval`` seconds it
reports the amount that fell, ``mean intensity × mm/h × interval / 3600``, with a seeded
multiplicative error of ``--noise`` (a real gauge is a point, the camera sees a street), in the
generic CSV format of ``weatherd reference``: the time is the END of the interval.

    python docs/example/gauge_from_truth.py truth.csv --start 2026-03-01T12:00:00Z > gauge.csv
"""

from __future__ import annotations

import argparse
import csv
import math
import random
import sys
from collections import defaultdict
from datetime import UTC, datetime, timedelta


def gauge_rows(
    truth: csv.DictReader,
    *,
    start: datetime,
    interval_s: float,
    mm_h: float,
    noise: float,
    seed: int,
) -> list[tuple[str, float]]:
    """(end time ISO-8601 Z, amount mm) per interval of the truth file, in time order."""
    sums: dict[int, float] = defaultdict(float)
    counts: dict[int, int] = defaultdict(int)
    for row in truth:
        k = int(float(row["t_s"]) // interval_s)
        sums[k] += float(row["rain_intensity"])
        counts[k] += 1
    rng = random.Random(seed)
    rows = []
    for k in sorted(counts):
        intensity = sums[k] / counts[k]
        error = math.exp(rng.gauss(0.0, noise)) if noise > 0 else 1.0
        amount = intensity * mm_h * interval_s / 3600.0 * error
        end = start + timedelta(seconds=(k + 1) * interval_s)
        rows.append((end.strftime("%Y-%m-%dT%H:%M:%SZ"), round(amount, 4)))
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("truth", help="the CSV written by weatherd simulate --truth")
    parser.add_argument("--start", required=True, help="UTC time of frame 0 (replay --start)")
    parser.add_argument("--interval", type=float, default=60.0, help="seconds (default 60)")
    parser.add_argument("--mm-h", type=float, default=4.0, help="mm/h at intensity 1")
    parser.add_argument("--noise", type=float, default=0.1, help="log-normal error, sigma")
    parser.add_argument("--seed", type=int, default=0, help="seed of the gauge's error")
    parser.add_argument("--station", default="example-gauge", help="station id column")
    args = parser.parse_args(argv)
    start = datetime.fromisoformat(args.start.replace("Z", "+00:00")).astimezone(UTC)
    with open(args.truth, newline="", encoding="utf-8") as f:
        rows = gauge_rows(
            csv.DictReader(f),
            start=start,
            interval_s=args.interval,
            mm_h=args.mm_h,
            noise=args.noise,
            seed=args.seed,
        )
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow(["time", "precip_mm", "station"])
    for end, amount in rows:
        out.writerow([end, f"{amount:.4f}", args.station])
    return 0


if __name__ == "__main__":
    sys.exit(main())
