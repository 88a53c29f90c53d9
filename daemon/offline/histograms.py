"""Mean histograms of oriented streaks (HOS) of one camera over chosen time windows of MCAP logs.

The one job of this module is :func:`mean_histograms`: a second, indexed pass over the
``/hos/<cam>/histogram`` messages of a few time windows only (for the report's figures).
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader

from .mcap_frames import _DAMAGED, _time_span

__all__ = ["mean_histograms"]

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------------------------
# Histograms at chosen moments (a second, indexed pass over a few time windows only)


def mean_histograms(
    mcap_files: Sequence[str | os.PathLike[str]],
    windows: Sequence[tuple[int, int]],
    *,
    camera: str,
    samples: int = 12,
    sample_s: float = 10.0,
) -> list[dict[str, Any] | None]:
    """Mean HOS of ``camera`` over each time window, from ``/hos/<cam>/histogram``.

    Only the chunks that overlap a window are read (the MCAP index), so a handful of windows
    costs little even in months of logs. A window longer than ``samples`` × ``sample_s`` is
    averaged over ``samples`` evenly spaced stretches of ``sample_s`` seconds (an hour at 25 fps
    is 90,000 histograms: 3,000 are plenty for a mean).

    Parameters
    ----------
    mcap_files : finished MCAP files (damaged ones are skipped)
    windows : [start, end) in UTC ns
    camera : camera id
    samples, sample_s : how long windows are sampled: count and length (s) of the stretches

    Returns
    -------
    per window, None when it holds no histogram, else a dict: ``histogram`` (bins,) float mean
    HOS (the unnormalised h(θ) of eq. 20), ``bin_width_deg``, ``frames``, and the mean fitted
    mixture of the frames that have one: ``pi`` (mean), ``mu_deg`` (circular mean),
    ``sigma_deg`` (median) — None when no frame has a fit.
    """
    topic = f"/hos/{camera}/histogram"
    spans = [(p, _time_span(Path(p))) for p in mcap_files]
    results: list[dict[str, Any] | None] = []
    for w_start, w_end in windows:
        total: np.ndarray | None = None
        n = 0
        width = 1.0
        pis: list[float] = []
        mus: list[float] = []
        sigmas: list[float] = []
        for path, span in spans:
            if span is None or span[1] < w_start or span[0] >= w_end:
                continue
            try:
                with open(path, "rb") as f:
                    reader = make_reader(f)
                    for payload in _sampled(reader, topic, w_start, w_end, samples, sample_s):
                        hist = np.asarray(payload.get("histogram", ()), dtype=np.float64)
                        if hist.size == 0:
                            continue
                        if total is None:
                            total = np.zeros_like(hist)
                        if hist.shape != total.shape:
                            continue
                        total += hist
                        n += 1
                        width = float(payload.get("bin_width_deg", 180.0 / hist.size))
                        if payload.get("pi") is not None and payload.get("mu_deg") is not None:
                            pis.append(float(payload["pi"]))
                            mus.append(float(payload["mu_deg"]))
                            sigmas.append(float(payload.get("sigma_deg") or math.nan))
            except _DAMAGED as exc:
                log.warning("%s: histograms unreadable (%s)", path, exc)
        if total is None or n == 0:
            results.append(None)
            continue
        fit = None
        if pis:
            doubled = np.radians(2.0 * np.asarray(mus))
            mu = (np.degrees(np.arctan2(np.sin(doubled).sum(), np.cos(doubled).sum())) / 2) % 180
            fit = {
                "pi": float(np.mean(pis)),
                "mu_deg": float(mu),
                "sigma_deg": float(np.nanmedian(sigmas)) if np.isfinite(sigmas).any() else None,
            }
        results.append({"histogram": total / n, "bin_width_deg": width, "frames": n, "fit": fit})
    return results


def _sampled(reader, topic: str, start: int, end: int, samples: int, sample_s: float):
    """JSON payloads of ``topic`` in [start, end), or in evenly spaced stretches of it."""
    step = int(sample_s * 1e9)
    if samples < 1 or end - start <= samples * step:
        stretches = [(start, end)]
    else:
        gap = (end - start - step) // max(samples - 1, 1)
        stretches = [(start + i * gap, start + i * gap + step) for i in range(samples)]
    for lo, hi in stretches:
        for _, _, message in reader.iter_messages(
            topics=[topic], starting_at=lo, ending_before=hi, log_time_order=False
        ):
            yield json.loads(message.data)
