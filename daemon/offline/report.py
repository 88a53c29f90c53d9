"""Plots (PNG) and one self-contained HTML report of a calibration and a comparison.

The figures follow the paper's (Bossu, Hautière & Tarel 2011):

``timeseries.png``   reference rain rate and the camera's R over time (Figs. 13–14), with the
                     calibrated rate when there is a calibration, and the share of rain frames
``calibration.png``  reference rate against mean R, the fit, its confidence band and R² (Fig. 15)
``roc.png``          ROC curves of the decision rules, frame and interval level (Fig. 9)
``orientation.png``  the orientation of the rain μ over time
``hos.png``          the mean HOS of the most intense intervals with the mean fitted mixture

Figures are drawn with matplotlib's object API on the Agg canvas (no display, no global
state); the HTML embeds them as base64 ``data:`` URIs and needs nothing else.
"""

from __future__ import annotations

import base64
import html
import io
import logging
import math
import os
from collections.abc import Sequence
from datetime import UTC
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import dates as mdates
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from drivers.errors import InputError

from .series import IntervalStats, Series, mean_histograms

__all__ = [
    "fitted_labels",
    "plot_calibration",
    "plot_hos",
    "plot_orientation",
    "plot_roc",
    "plot_timeseries",
    "render_html",
    "write_report",
]

log = logging.getLogger(__name__)

_DPI = 110
_ROC_STYLE = {  # the paper's Fig. 9: green + GoF alone, blue o GoF + Π_rain, red * full process
    "gof": ("tab:green", "+", "GoF alone (D ≤ D_c)"),
    "pi": ("tab:blue", "o", "GoF + Π_rain (raw Π)"),
    "pi_smoothed": ("tab:red", "*", "full process (smoothed Π)"),
}
_MAX_TABLE_ROWS = 2000


def _png(fig: Figure) -> bytes:
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI)
    return buf.getvalue()


def _time_axis(ax) -> None:
    locator = mdates.AutoDateLocator(tz=UTC)
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator, tz=UTC))


def _mid(s: IntervalStats):
    return s.start + (s.end - s.start) / 2


def plot_timeseries(
    stats: Sequence[IntervalStats],
    *,
    camera: str,
    calibration: dict[str, Any] | None = None,
    camera_fraction: float = 0.1,
) -> bytes:
    """Reference rate, camera R and share of rain frames per interval over time; PNG bytes."""
    fig = Figure(figsize=(11, 7.5), layout="constrained")
    ax_ref, ax_r, ax_f = fig.subplots(3, 1, sharex=True, height_ratios=[3, 3, 1.4])
    used = [s for s in stats if s.used]
    unused = [s for s in stats if not s.used]
    width_days = [(s.end - s.start).total_seconds() / 86400 * 0.9 for s in used]
    amounts = [s for s in used if s.kind == "amount" and s.rate_mm_h is not None]
    presence = [s for s in used if s.kind == "presence" and s.precip_mm is not None]
    if amounts:
        ax_ref.bar(
            [_mid(s) for s in amounts],
            [s.rate_mm_h for s in amounts],
            width=[(s.end - s.start).total_seconds() / 86400 * 0.9 for s in amounts],
            color="tab:green",
            alpha=0.7,
            label="reference (station)",
        )
        ax_ref.set_ylabel("rain rate (mm/h)")
    if presence:
        ax_ref.bar(
            [_mid(s) for s in presence],
            [s.precip_mm for s in presence],
            width=[(s.end - s.start).total_seconds() / 86400 * 0.9 for s in presence],
            color="tab:green",
            alpha=0.7,
            label="reference reports precipitation",
        )
        if not amounts:
            ax_ref.set_ylabel("presence (1 = yes)")
    if calibration is not None and used:
        a, b = float(calibration["a"]), float(calibration["b"])
        est = [a * s.r_mean**b if s.r_mean and s.r_mean > 0 else 0.0 for s in used]
        ax_ref.plot(
            [_mid(s) for s in used],
            est,
            "o-",
            color="tab:orange",
            ms=3,
            lw=1.2,
            label=f"camera, calibrated ({calibration['model']})",
        )
    ax_ref.set_title(f"Precipitation and camera rain intensity — camera {camera}")
    ax_ref.grid(alpha=0.3)
    if amounts or presence or calibration is not None:
        ax_ref.legend(loc="best")

    r_used = [(_mid(s), s.r_mean) for s in used if s.r_mean is not None]
    if r_used:
        ax_r.plot(*zip(*r_used, strict=True), "o-", color="tab:blue", ms=3, lw=1.2, label="mean R")
    r_unused = [(_mid(s), s.r_mean) for s in unused if s.r_mean is not None]
    if r_unused:
        ax_r.plot(
            *zip(*r_unused, strict=True),
            "x",
            color="0.5",
            label="not used (too few judged frames)",
        )
    ax_r.set_ylabel("R = S·Π (relative)")
    ax_r.set_ylim(bottom=0)
    ax_r.grid(alpha=0.3)
    if r_used or r_unused:
        ax_r.legend(loc="best")

    if used:
        ax_f.bar(
            [_mid(s) for s in used],
            [s.rain_fraction for s in used],
            width=width_days,
            color="tab:purple",
            alpha=0.7,
            label="judged frames with rain",
        )
    ax_f.axhline(camera_fraction, color="k", lw=0.8, ls="--", label="camera says wet")
    ax_f.set_ylim(0, 1)
    ax_f.set_ylabel("rain share")
    ax_f.set_xlabel("time (UTC)")
    ax_f.legend(loc="best", fontsize="small")
    ax_f.grid(alpha=0.3)
    _time_axis(ax_f)
    return _png(fig)


def plot_calibration(
    calibration: dict[str, Any],
    fits: dict[str, Any],
    points: Any,
    *,
    camera: str,
) -> bytes:
    """Reference rate against mean R: the points, the fit, its CI band and R² (Fig. 15); PNG."""
    fig = Figure(figsize=(8.5, 6.5), layout="constrained")
    ax = fig.subplots()
    chosen = fits[calibration["model"]]
    inlier = chosen.weights > 0
    inlier_label, outlier_label = fitted_labels(chosen)
    ax.scatter(
        points.r[inlier],
        points.rate_mm_h[inlier],
        s=28,
        color="tab:blue",
        label=inlier_label,
        zorder=3,
    )
    if outlier_label is not None:
        ax.scatter(
            points.r[~inlier],
            points.rate_mm_h[~inlier],
            s=50,
            marker="x",
            color="tab:red",
            label=outlier_label,
            zorder=3,
        )
    fit_set = set(zip(points.r.tolist(), points.rate_mm_h.tolist(), strict=True))
    others = [
        (r, y)
        for r, y in zip(points.r_all.tolist(), points.rate_all_mm_h.tolist(), strict=True)
        if (r, y) not in fit_set
    ]
    if others:
        ox, oy = zip(*others, strict=True)
        ax.scatter(
            ox, oy, s=18, color="0.6", label=f"dry or unseen, not fitted (n = {len(others)})"
        )
    r_hi = max(float(points.r_all.max()) if points.r_all.size else 0.0, float(points.r.max()))
    grid = np.linspace(0.0, r_hi * 1.05, 200)[1:]
    if chosen.boot_a.size:
        lo, hi = chosen.band(grid)
        ax.fill_between(
            grid,
            lo,
            hi,
            color="tab:orange",
            alpha=0.25,
            label=f"{100 * chosen.ci_level:.0f} % confidence band",
        )
    ax.plot(grid, chosen.predict(grid), color="tab:orange", lw=2, label=_equation(calibration))
    other = "power" if calibration["model"] == "linear" else "linear"
    if other in fits:
        ax.plot(
            grid,
            fits[other].predict(grid),
            color="0.3",
            lw=1,
            ls="--",
            label=f"{other} model (not chosen)",
        )
    r2 = calibration.get("r2")
    r2_txt = "n/a" if r2 is None else f"{r2:.3f}"
    numbers = (
        f"R² = {r2_txt} over all {points.r_all.size} used intervals, "
        f"{_fmt(calibration.get('r2_wet'))} over the {points.r.size} fitted;  "
        f"RMSE = {calibration['rmse_mm_h']:.3g} mm/h\n"
        f"a = {calibration['a']:.4g} [{calibration['a_ci'][0]:.4g}, {calibration['a_ci'][1]:.4g}]"
    )
    if calibration["model"] == "power":
        numbers += (
            f",  b = {calibration['b']:.3f} [{calibration['b_ci'][0]:.3f}, "
            f"{calibration['b_ci'][1]:.3f}]"
        )
    # a small margin below 0 so that the dry intervals (rate 0) are not hidden by the axis
    ax.set_xlim(left=-0.02 * r_hi)
    ax.set_ylim(bottom=-0.03 * max(ax.get_ylim()[1], 1e-9))
    ax.set_xlabel("camera rain intensity R = S·Π, mean over the interval (relative)")
    ax.set_ylabel("reference rain rate (mm/h)")
    fig.suptitle(f"Calibration of R → mm/h — camera {camera}")
    ax.set_title(numbers + f" ({100 * chosen.ci_level:.0f} % CI)", fontsize="small")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    return _png(fig)


def fitted_labels(fit: Any) -> tuple[str, str | None]:
    """Legend labels of the fitted intervals: those weighed in, and the outliers (None if
    there are none). Both name the fit's ``n``, the number the subtitle and the JSON give:
    an outlier is fitted too, with weight 0."""
    n_out = int(np.count_nonzero(fit.weights == 0))
    if n_out == 0:
        return f"wet intervals, fitted (n = {fit.n})", None
    return (
        f"wet intervals, fitted (n = {fit.n}): {fit.n - n_out} weighed in",
        f"… and {n_out} outlier(s), weight 0",
    )


def _equation(cal: dict[str, Any]) -> str:
    if cal["model"] == "linear":
        return f"fit: mm/h = {cal['a']:.4g}·R"
    return f"fit: mm/h = {cal['a']:.4g}·R^{cal['b']:.3f}"


def plot_roc(comparison: dict[str, Any], *, camera: str) -> bytes:
    """ROC curves of the three decision rules, frame and interval level (Fig. 9); PNG bytes."""
    fig = Figure(figsize=(12, 5.8), layout="constrained")
    axes = fig.subplots(1, 2)
    conf = comparison["confusion"]
    titles = {
        "frame": "per frame (each judged frame labelled by its interval)",
        "interval": (
            f"per interval (≥ {100 * comparison['camera_fraction']:.0f} % of frames say rain)"
        ),
    }
    for ax, level in zip(axes, ("frame", "interval"), strict=True):
        for name, (color, marker, label) in _ROC_STYLE.items():
            curve = comparison["roc"][level][name]
            pts = [
                (f, t)
                for f, t in zip(curve["fpr"], curve["tpr"], strict=True)
                if f is not None and t is not None
            ]
            if not pts:
                continue
            f, t = (np.asarray(v) * 100 for v in zip(*pts, strict=True))
            auc = curve["auc"]
            auc_txt = "" if auc is None else f", AUC {auc:.3f}"
            ax.plot(f, t, marker=marker, color=color, lw=1, ms=5, label=label + auc_txt)
        ax.plot([0, 100], [0, 100], color="0.6", ls=":", lw=1, label="chance")
        if level == "interval" and conf["tpr"] is not None and conf["fpr"] is not None:
            ax.plot(
                conf["fpr"] * 100,
                conf["tpr"] * 100,
                "kD",
                ms=8,
                label="the daemon's decision",
            )
        ax.set_xlim(-2, 102)
        ax.set_ylim(-2, 102)
        ax.set_aspect("equal")
        ax.set_xlabel("FPR (%)")
        ax.set_ylabel("TPR (%)")
        ax.set_title(titles[level], fontsize="medium")
        ax.grid(alpha=0.3)
        ax.legend(loc="lower right", fontsize="small")
    fig.suptitle(
        f"ROC of precipitation detection — camera {camera}, "
        f"{comparison['n_wet']} wet / {comparison['n_dry']} dry intervals"
    )
    return _png(fig)


def plot_orientation(stats: Sequence[IntervalStats], *, camera: str) -> bytes:
    """Circular mean of the fitted μ per interval over time; PNG bytes."""
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    ax = fig.subplots()
    pts = [(_mid(s), s.mu_mean_deg, s.rain_fraction) for s in stats if s.mu_mean_deg is not None]
    if pts:
        t, mu, share = zip(*pts, strict=True)
        sc = ax.scatter(t, mu, c=share, cmap="viridis", vmin=0, vmax=1, s=22, zorder=3)
        fig.colorbar(sc, ax=ax, label="share of judged frames with rain")
    else:
        ax.text(0.5, 0.5, "no frame with a fit", ha="center", transform=ax.transAxes)
    ax.axhline(90, color="0.4", ls="--", lw=1, label="90° = vertical")
    ax.set_ylim(0, 180)
    ax.set_yticks([0, 45, 90, 135, 180])
    ax.set_ylabel("rain orientation μ (degrees)")
    ax.set_xlabel("time (UTC)")
    ax.set_title(
        f"Orientation of the streaks — camera {camera} (circular mean per interval, "
        "frames whose fit passed the GoF test)"
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    _time_axis(ax)
    return _png(fig)


def plot_hos(
    moments: Sequence[tuple[IntervalStats, dict[str, Any]]],
    *,
    camera: str,
) -> bytes:
    """The mean HOS of chosen intervals with the mean fitted mixture (eq. 23); PNG bytes."""
    n = max(1, len(moments))
    fig = Figure(figsize=(4.2 * n, 4.0), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, n))
    for ax, (s, h) in zip(axes, moments, strict=False):
        hist = np.asarray(h["histogram"], dtype=np.float64)
        width = float(h["bin_width_deg"])
        centres = (np.arange(hist.size) + 0.5) * width
        ax.bar(centres, hist, width=width, color="tab:blue", alpha=0.7, label="mean HOS")
        fit = h.get("fit")
        if fit is not None and fit.get("sigma_deg"):
            theta = np.linspace(0, 180, 721)
            ax.plot(
                theta,
                _mixture(theta, fit, total=float(hist.sum()), width=width),
                color="tab:red",
                lw=1.5,
                label=f"mixture: Π {fit['pi']:.2f}, μ {fit['mu_deg']:.0f}°",
            )
            ax.legend(loc="upper right", fontsize="x-small")
        rate = s.rate_mm_h
        what = f"{rate:.2f} mm/h" if rate is not None else f"ref {s.precip_mm}"
        r_txt = f"{s.r_mean:.3g}" if s.r_mean is not None else "n/a"
        ax.set_title(
            f"{s.start.astimezone(UTC):%Y-%m-%d %H:%M} UTC\n{what}, R {r_txt}, "
            f"{h['frames']} frames",
            fontsize="small",
        )
        ax.set_xlim(0, 180)
        ax.set_xticks([0, 45, 90, 135, 180])
        ax.set_xlabel("θ (degrees)")
        ax.set_ylabel("h(θ)")
        ax.grid(alpha=0.3)
    if not moments:
        axes[0].text(0.5, 0.5, "no histogram recorded", ha="center", transform=axes[0].transAxes)
    fig.suptitle(f"HOS at the most intense intervals — camera {camera}")
    return _png(fig)


def _mixture(theta_deg: np.ndarray, fit: dict[str, Any], *, total: float, width: float):
    """Expected h(θ) per bin of the Gaussian–uniform mixture (eq. 23), wrapped over 180°."""
    pi, mu, sigma = float(fit["pi"]), float(fit["mu_deg"]), float(fit["sigma_deg"])
    gauss = sum(np.exp(-0.5 * ((theta_deg - mu + k * 180.0) / sigma) ** 2) for k in (-1, 0, 1)) / (
        sigma * math.sqrt(2 * math.pi)
    )
    return total * width * (pi * gauss + (1.0 - pi) / 180.0)


# ---------------------------------------------------------------------------------------------
# HTML


def render_html(
    *,
    camera: str,
    series: Series,
    images: dict[str, bytes],
    calibration: dict[str, Any] | None = None,
    comparison: dict[str, Any] | None = None,
) -> str:
    """One self-contained HTML page: the numbers, the tables and the images (data: URIs)."""
    esc = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>weatherd offline report — camera {esc(camera)}</title>",
        "<style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;color:#222}"
        "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
        "padding:3px 8px;text-align:right}th{background:#eee}img{max-width:100%}"
        ".TP{background:#d8f0d8}.TN{background:#eef}.FP{background:#fbdada}"
        ".FN{background:#fde9c8}caption{font-weight:bold;text-align:left}</style>",
        "</head><body>",
        f"<h1>Camera {esc(camera)} against station data</h1>",
    ]
    c = series.counts
    facts = [
        ("reference", series.reference or "—"),
        ("station", series.station or "—"),
        ("MCAP files read", c.get("files_read", 0)),
        ("damaged files skipped", c.get("files_skipped", 0)),
        ("frames read", c.get("frames_read", 0)),
        ("frames outside every interval", c.get("frames_outside", 0)),
        ("reference intervals", c.get("reference_intervals", 0)),
        ("intervals without frames", c.get("intervals_no_frames", 0)),
        ("intervals with too few judged frames", c.get("intervals_low_judged", 0)),
        ("intervals too little covered by the logs", c.get("intervals_low_coverage", 0)),
        ("(interval, camera) pairs used", c.get("intervals_used", 0)),
    ]
    parts.append(_table("Data", ["", ""], [[k, v] for k, v in facts]))
    if calibration is not None:
        parts.append("<h2>Calibration of R → mm/h</h2>")
        rows = [
            ["model", calibration["model"] + f" ({esc(calibration.get('choice', ''))})"],
            ["a", _ci(calibration["a"], calibration["a_ci"])],
            ["b", _ci(calibration["b"], calibration["b_ci"])],
            ["n (wet intervals fitted)", calibration["n"]],
            ["outliers (weight 0)", calibration.get("n_outliers", "")],
            ["dry intervals (not fitted)", calibration.get("n_dry", "")],
            ["wet but unseen (R = 0, not fitted)", calibration.get("n_unseen", "")],
            ["R² (all used intervals)", _fmt(calibration["r2"])],
            ["RMSE (all used intervals), mm/h", _fmt(calibration["rmse_mm_h"])],
            ["R² (fitted intervals)", _fmt(calibration.get("r2_wet"))],
            ["RMSE (fitted intervals), mm/h", _fmt(calibration.get("rmse_wet_mm_h"))],
            ["R range of the fit", f"{_fmt(calibration['r_min'])} – {_fmt(calibration['r_max'])}"],
        ]
        parts.append(_table("Fitted numbers", ["", ""], rows))
        if "calibration" in images:
            parts.append(_img(images["calibration"], "calibration scatter"))
    if comparison is not None:
        conf = comparison["confusion"]
        parts.append("<h2>Detection of precipitation</h2>")
        parts.append(
            f"<p>Reference wet when the amount is at least {comparison['threshold_mm']} mm; "
            f"camera wet when at least {100 * comparison['camera_fraction']:.0f} % of its "
            "judged frames say rain.</p>"
        )
        parts.append(
            _table(
                "Confusion matrix (intervals)",
                ["", "truth: precipitation", "truth: none"],
                [
                    ["detected: precipitation", f"TP {conf['tp']}", f"FP {conf['fp']}"],
                    ["detected: none", f"FN {conf['fn']}", f"TN {conf['tn']}"],
                ],
            )
        )
        parts.append(
            _table(
                "Rates",
                ["TPR", "FPR", "accuracy", "precision", "intervals"],
                [
                    [
                        _pct(conf["tpr"]),
                        _pct(conf["fpr"]),
                        _pct(conf["accuracy"]),
                        _pct(conf["precision"]),
                        conf["n"],
                    ]
                ],
            )
        )
        auc_rows = [
            [
                name,
                _fmt(comparison["roc"]["frame"][name]["auc"]),
                _fmt(comparison["roc"]["interval"][name]["auc"]),
            ]
            for name in ("gof", "pi", "pi_smoothed")
        ]
        parts.append(_table("Area under the ROC curves", ["rule", "frames", "intervals"], auc_rows))
        if "roc" in images:
            parts.append(_img(images["roc"], "ROC curves"))
    for key, alt in (
        ("timeseries", "time series"),
        ("orientation", "orientation over time"),
        ("hos", "HOS"),
    ):
        if key in images:
            parts.append(f"<h2>{esc(alt.capitalize())}</h2>")
            parts.append(_img(images[key], alt))
    if comparison is not None:
        rows = comparison["table"][:_MAX_TABLE_ROWS]
        parts.append("<h2>Intervals</h2>")
        if len(comparison["table"]) > len(rows):
            parts.append(f"<p>First {len(rows)} of {len(comparison['table'])} intervals.</p>")
        head = ["start (UTC)", "reference mm", "judged %", "rain %", "mean R", "μ (°)", "outcome"]
        body = [
            [
                r["start"],
                _fmt(r["precip_mm"]),
                _pct(r["judged_fraction"]),
                _pct(r["rain_fraction"]),
                _fmt(r["r_mean"]),
                _fmt(r["mu_mean_deg"]),
                r["outcome"],
            ]
            for r in rows
        ]
        parts.append(_table("", head, body, row_class=[r["outcome"] for r in rows]))
    parts.append("</body></html>")
    return "\n".join(parts)


def _img(png: bytes, alt: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return f'<p><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"></p>'


def _table(
    caption: str, head: list[str], rows: list[list[Any]], row_class: list[str] | None = None
) -> str:
    esc = html.escape
    out = ["<table>"]
    if caption:
        out.append(f"<caption>{esc(caption)}</caption>")
    if any(head):
        out.append("<tr>" + "".join(f"<th>{esc(str(h))}</th>" for h in head) + "</tr>")
    for i, row in enumerate(rows):
        cls = f' class="{esc(row_class[i])}"' if row_class else ""
        out.append(f"<tr{cls}>" + "".join(f"<td>{esc(str(v))}</td>" for v in row) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


def _fmt(v: Any) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _pct(v: float | None) -> str:
    return "—" if v is None else f"{100 * v:.1f} %"


def _ci(value: float, ci: Sequence[float]) -> str:
    return f"{value:.4g} [{ci[0]:.4g}, {ci[1]:.4g}]"


# ---------------------------------------------------------------------------------------------


def write_report(
    series: Series,
    *,
    camera: str,
    calibration: dict[str, Any] | None = None,
    fits: dict[str, Any] | None = None,
    points: Any = None,
    comparison: dict[str, Any] | None = None,
    plots_dir: str | os.PathLike[str] | None = None,
    report: str | os.PathLike[str] | None = None,
    n_hos: int = 4,
) -> dict[str, Any]:
    """Draw every plot the inputs allow; save them in ``plots_dir`` and/or the HTML ``report``.

    Parameters
    ----------
    series : the aggregated logs; camera : the camera to show
    calibration, fits, points : from :func:`daemon.offline.calibrate.fit_calibration` and
        :func:`~daemon.offline.calibrate.calibration_points` (the scatter needs all three)
    comparison : from :func:`daemon.offline.compare.score`
    plots_dir : directory for the PNG files (created); report : path of the HTML file
    n_hos : number of intense intervals whose mean HOS is drawn (read from the MCAP files)

    Returns
    -------
    ``{"plots": [paths of the PNG files written], "report": path of the HTML or None}``

    Raises
    ------
    InputError : the directory or the file cannot be written.
    """
    stats = series.for_camera(camera)
    images: dict[str, bytes] = {}
    fraction = comparison["camera_fraction"] if comparison else 0.1
    images["timeseries"] = plot_timeseries(
        stats, camera=camera, calibration=calibration, camera_fraction=fraction
    )
    if calibration is not None and fits is not None and points is not None:
        images["calibration"] = plot_calibration(calibration, fits, points, camera=camera)
    if comparison is not None:
        images["roc"] = plot_roc(comparison, camera=camera)
    images["orientation"] = plot_orientation([s for s in stats if s.used], camera=camera)
    moments = _intense_moments(series, stats, camera=camera, n=n_hos)
    images["hos"] = plot_hos(moments, camera=camera)

    written: list[str] = []
    if plots_dir is not None:
        folder = Path(plots_dir)
        try:
            folder.mkdir(parents=True, exist_ok=True)
            for name, png in images.items():
                path = folder / f"{name}.png"
                path.write_bytes(png)
                written.append(str(path))
        except OSError as exc:
            raise InputError(f"{folder}: cannot write plots ({exc.strerror})") from None
    report_path = None
    if report is not None:
        page = render_html(
            camera=camera,
            series=series,
            images=images,
            calibration=calibration,
            comparison=comparison,
        )
        try:
            Path(report).parent.mkdir(parents=True, exist_ok=True)
            Path(report).write_text(page, encoding="utf-8")
        except OSError as exc:
            raise InputError(f"{report}: cannot write the report ({exc.strerror})") from None
        report_path = str(report)
    log.info("report: %d plots written, HTML %s", len(written), report_path or "not asked")
    return {"plots": written, "report": report_path}


def _intense_moments(
    series: Series, stats: Sequence[IntervalStats], *, camera: str, n: int
) -> list[tuple[IntervalStats, dict[str, Any]]]:
    """The ``n`` used intervals with the most reference precipitation (then the highest R),
    in time order, with their mean histogram."""
    used = [
        s
        for s in stats
        if s.used and s.judged > 0 and ((s.precip_mm or 0) > 0 or (s.r_mean or 0) > 0)
    ]

    def intensity(s: IntervalStats) -> tuple[float, float]:
        rate = s.rate_mm_h if s.rate_mm_h is not None else (s.precip_mm or 0.0)
        return (rate, s.r_mean or 0.0)

    chosen = sorted(sorted(used, key=intensity, reverse=True)[:n], key=lambda s: s.start)
    if not chosen or not series.mcap_files:
        return []
    windows = [(s.first_t_ns, s.last_t_ns + 1) for s in chosen]
    hists = mean_histograms(series.mcap_files, windows, camera=camera)
    return [(s, h) for s, h in zip(chosen, hists, strict=True) if h is not None]
