"""How well the camera detects precipitation, scored against station data (paper §5.2).

Per used reference interval (see :mod:`daemon.offline.series`):

truth
    the reference says precipitation when ``precip_mm >= threshold_mm`` (default 0.1 mm, the
    resolution of a tipping-bucket gauge); for presence reports (METAR, ``kind="presence"``,
    1.0 or 0.0) when the report says so.
camera
    the camera says precipitation when at least ``camera_fraction`` (default 0.1) of its judged
    frames have ``rain`` — the daemon's smoothed decision.

From these, the confusion matrix of the paper's Table 1 — TP, FP, TN, FN, TPR = TP/(TP+FN),
FPR = FP/(FP+TN), accuracy AC = (TP+TN)/all (eq. 27) — as in its Tables 2–4.

ROC curves (the paper's Fig. 9), recomputed from the recorded per-frame fits, over three
decision rules, each for a range of thresholds:

``gof``          GoF alone: a frame says rain when its fit's distance ``gof_d <= D_c``
``pi``           GoF + Π_rain: the fit passed the daemon's GoF test and ``pi >= Π_rain``
``pi_smoothed``  the full process: the Kalman-smoothed ``pi_smoothed >= Π_rain``

at two levels: ``frame`` — every judged frame is a sample, labelled by its interval's truth, as
in the paper's 6,000 + 6,000 frames; and ``interval`` — an interval is detected when at least
``camera_fraction`` of its judged frames say rain. AUC by the trapezoid rule, with the (0, 0)
and (1, 1) ends added.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from drivers.errors import InputError

from .series import GOF_GRID, PI_GRID, IntervalStats, ReferenceInterval, Series, load_series

__all__ = ["auc", "compare", "confusion", "reference_wet", "roc_curves", "score"]

log = logging.getLogger(__name__)

_CURVES = {
    "gof": ("gof_counts", GOF_GRID),
    "pi": ("pi_counts", PI_GRID),
    "pi_smoothed": ("pi_smoothed_counts", PI_GRID),
}


def reference_wet(stats: IntervalStats, *, threshold_mm: float = 0.1) -> bool | None:
    """Whether the reference says precipitation in the interval; None when it is missing."""
    if stats.precip_mm is None:
        return None
    if stats.kind == "presence":
        return stats.precip_mm >= 0.5
    return stats.precip_mm >= threshold_mm


def confusion(truth: np.ndarray, detected: np.ndarray) -> dict[str, Any]:
    """The confusion matrix of boolean truth vs detection, and its rates.

    Parameters
    ----------
    truth, detected : (N,) bool

    Returns
    -------
    dict: ``tp``, ``fp``, ``tn``, ``fn``, ``n`` (ints) and ``tpr``, ``fpr``, ``accuracy``,
    ``precision`` (floats in [0, 1], None when undefined).
    """
    truth = np.asarray(truth, dtype=bool)
    detected = np.asarray(detected, dtype=bool)
    tp = int(np.count_nonzero(truth & detected))
    fp = int(np.count_nonzero(~truth & detected))
    tn = int(np.count_nonzero(~truth & ~detected))
    fn = int(np.count_nonzero(truth & ~detected))
    n = tp + fp + tn + fn
    return {
        "tp": tp,
        "fp": fp,
        "tn": tn,
        "fn": fn,
        "n": n,
        "tpr": _ratio(tp, tp + fn),
        "fpr": _ratio(fp, fp + tn),
        "accuracy": _ratio(tp + tn, n),
        "precision": _ratio(tp, tp + fp),
    }


def _ratio(num: int, den: int) -> float | None:
    return num / den if den else None


def auc(fpr: np.ndarray, tpr: np.ndarray) -> float | None:
    """Area under a ROC curve given by points (FPR, TPR), with (0, 0) and (1, 1) added.

    Returns None when there is no point or a coordinate is missing (NaN).
    """
    f = np.asarray(fpr, dtype=np.float64)
    t = np.asarray(tpr, dtype=np.float64)
    if f.size == 0 or not (np.all(np.isfinite(f)) and np.all(np.isfinite(t))):
        return None
    f = np.concatenate([[0.0], f, [1.0]])
    t = np.concatenate([[0.0], t, [1.0]])
    order = np.lexsort((t, f))
    f, t = f[order], t[order]
    return float(np.sum(np.diff(f) * (t[1:] + t[:-1]) / 2.0))


def roc_curves(
    stats: Sequence[IntervalStats],
    truth: np.ndarray,
    *,
    camera_fraction: float = 0.1,
) -> dict[str, dict[str, dict[str, Any]]]:
    """ROC curves of the three decision rules at the frame and interval levels.

    Parameters
    ----------
    stats : the scored intervals of one camera
    truth : (N,) bool, the reference's verdict for each of ``stats``
    camera_fraction : share of judged frames that makes an interval "detected"

    Returns
    -------
    ``{"frame" | "interval": {"gof" | "pi" | "pi_smoothed": {"thresholds", "tpr", "fpr",
    "auc"}}}``; TPR/FPR lists hold None where undefined (no wet or no dry sample).
    """
    truth = np.asarray(truth, dtype=bool)
    judged = np.array([s.judged for s in stats], dtype=np.float64)
    out: dict[str, dict[str, dict[str, Any]]] = {"frame": {}, "interval": {}}
    for name, (attr, grid) in _CURVES.items():
        counts = np.array([getattr(s, attr) for s in stats], dtype=np.float64)
        counts = counts.reshape(len(stats), grid.size)
        # frame level: pooled counts over the wet and the dry intervals
        wet_n, dry_n = judged[truth].sum(), judged[~truth].sum()
        tpr_f = counts[truth].sum(axis=0) / wet_n if wet_n else np.full(grid.size, np.nan)
        fpr_f = counts[~truth].sum(axis=0) / dry_n if dry_n else np.full(grid.size, np.nan)
        # interval level
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.where(judged[:, None] > 0, counts / judged[:, None], 0.0)
        detected = share >= camera_fraction
        n_wet, n_dry = int(truth.sum()), int((~truth).sum())
        tpr_i = detected[truth].sum(axis=0) / n_wet if n_wet else np.full(grid.size, np.nan)
        fpr_i = detected[~truth].sum(axis=0) / n_dry if n_dry else np.full(grid.size, np.nan)
        for level, tpr, fpr in (("frame", tpr_f, fpr_f), ("interval", tpr_i, fpr_i)):
            out[level][name] = {
                "thresholds": grid.tolist(),
                "tpr": _floats(tpr),
                "fpr": _floats(fpr),
                "auc": auc(fpr, tpr),
            }
    return out


def _floats(values: np.ndarray) -> list[float | None]:
    return [round(float(v), 6) if np.isfinite(v) else None for v in values]


def score(
    series: Series,
    *,
    camera: str | None = None,
    threshold_mm: float = 0.1,
    camera_fraction: float = 0.1,
) -> dict[str, Any]:
    """Confusion matrix and ROC curves of one camera from aggregated logs (no I/O).

    Returns
    -------
    dict, JSON-able: ``camera``, ``threshold_mm``, ``camera_fraction``, ``confusion`` (see
    :func:`confusion`), ``roc`` (see :func:`roc_curves`), ``n_wet``, ``n_dry``,
    ``intervals_scored``, ``intervals_missing`` (no reference value), and ``table``: one row per
    scored interval (start, end, precip_mm, rain_fraction, judged_fraction, r_mean, outcome).

    Raises
    ------
    InputError : no camera, several cameras and none chosen, bad thresholds, no interval to score.
    """
    if not threshold_mm > 0:
        raise InputError(f"threshold_mm must be > 0, got {threshold_mm}")
    if not 0.0 < camera_fraction <= 1.0:
        raise InputError(f"camera_fraction must be within (0, 1], got {camera_fraction}")
    cam = series.select_camera(camera)
    used = [s for s in series.for_camera(cam) if s.used]
    verdicts = [reference_wet(s, threshold_mm=threshold_mm) for s in used]
    scored = [s for s, v in zip(used, verdicts, strict=True) if v is not None]
    if not scored:
        reasons = series.unused_reasons(cam)
        if len(used) > len(scored):
            reasons.append(f"{len(used) - len(scored)} have no reference value (missing data)")
        n_ref = series.counts.get("reference_intervals", len(series.for_camera(cam)))
        raise InputError(
            f"camera {cam}: no interval to score: of {n_ref} reference interval(s), "
            + "; ".join(reasons)
        )
    truth = np.array([v for v in verdicts if v is not None], dtype=bool)
    detected = np.array([s.rain_fraction >= camera_fraction for s in scored], dtype=bool)
    table = [
        {
            **s.to_json(),
            "reference_wet": bool(t),
            "camera_wet": bool(d),
            "outcome": ("TP" if d else "FN") if t else ("FP" if d else "TN"),
        }
        for s, t, d in zip(scored, truth, detected, strict=True)
    ]
    result = {
        "camera": cam,
        "station": series.station,
        "reference": series.reference,
        "threshold_mm": threshold_mm,
        "camera_fraction": camera_fraction,
        "confusion": confusion(truth, detected),
        "n_wet": int(truth.sum()),
        "n_dry": int((~truth).sum()),
        "intervals_scored": len(scored),
        "intervals_missing": len(used) - len(scored),
        "roc": roc_curves(scored, truth, camera_fraction=camera_fraction),
        "table": table,
    }
    c = result["confusion"]
    log.info(
        "camera %s: TP %d FP %d TN %d FN %d over %d intervals",
        cam,
        c["tp"],
        c["fp"],
        c["tn"],
        c["fn"],
        c["n"],
    )
    return result


def compare(
    mcap_paths: Sequence[str | os.PathLike[str]],
    reference_path: str | os.PathLike[str] | Iterable[ReferenceInterval],
    *,
    station: str | None = None,
    camera: str | None = None,
    threshold_mm: float = 0.1,
    camera_fraction: float = 0.1,
    min_judged: float = 0.5,
    min_coverage: float = 0.5,
    plots_dir: str | os.PathLike[str] | None = None,
    report: str | os.PathLike[str] | None = None,
    progress: bool | None = None,
    reference_options: Mapping[str, Any] | None = None,
    series: Series | None = None,
) -> dict[str, Any]:
    """``weatherd compare``: score the camera's precipitation detection against station data.

    Parameters
    ----------
    mcap_paths : MCAP files or directories
    reference_path : station file (any format of :mod:`daemon.offline.reference`), or intervals
    station : station to keep from a multi-station file
    camera : camera to score (required when the logs hold several)
    threshold_mm : reference amount at and above which an interval is wet, mm
    camera_fraction : share of judged frames with ``rain`` at and above which the camera says wet
    min_judged, min_coverage : see :func:`daemon.offline.series.aggregate`
    plots_dir : write the PNG plots there; report : write the HTML report there
    progress : progress bar in frame messages, with an ETA (None: on a terminal only)
    reference_options : more keyword arguments of ``read_reference`` (``fmt``, ``tz``,
        ``interval_s``, ``month``)
    series : already aggregated logs (then ``mcap_paths`` and ``reference_path`` are not read)

    Returns
    -------
    dict, JSON-able: see :func:`score`, plus ``intervals`` (counts), ``plots`` and ``report``.

    Raises
    ------
    InputError : one line, for any bad input.
    """
    if series is None:
        series = load_series(
            mcap_paths,
            reference_path,
            station=station,
            camera=camera,
            min_judged=min_judged,
            min_coverage=min_coverage,
            progress=progress,
            reference_options=reference_options,
        )
    result = score(
        series, camera=camera, threshold_mm=threshold_mm, camera_fraction=camera_fraction
    )
    result["intervals"] = dict(series.counts)
    if plots_dir is not None or report is not None:
        from .report import write_report

        written = write_report(
            series, camera=result["camera"], comparison=result, plots_dir=plots_dir, report=report
        )
        result["plots"] = written["plots"]
        result["report"] = written["report"]
    return result
