"""Site calibration of the camera's rain intensity R (eq. 31) into a rain rate in mm/h.

Each used reference interval (see :mod:`daemon.offline.series`) gives one point: x = the mean R
of the camera's judged frames, y = the reference rate ``precip_mm / hours``. Two models:

``linear``  mm/h = a·R (through the origin: no rain seen, no rain rate)
``power``   mm/h = a·R^b (the shape of radar Z–R and disdrometer relations)

The fit
    Both are fitted in log space, ``log y = log a + b·log x`` (b = 1 for ``linear``): rain-rate
    errors are multiplicative (a gauge's error, and the camera's, grow with the rate), so an
    interval at 20 mm/h must not weigh 400 times one at 1 mm/h. The estimator is an M-estimator
    computed by IRLS: Huber weights (c = 1.345) from the least-squares start to a robust scale
    s = 1.4826·MAD of the residuals, then Tukey's biweight (c = 4.685) with s fixed, which gives
    gross outliers a weight of exactly 0 (an hour of spray or headlights, a gauge that caught a
    shower the camera could not see at night). With fewer than :data:`MIN_ROBUST` points a
    robust scale cannot be estimated: plain least squares. The log-space intercept estimates
    the median rate; Duan's smearing factor (the weighted mean of exp(residual)) turns it into
    the mean rate. Confidence intervals: percentile bootstrap over the intervals (``n_boot``
    resamples, seeded, so the same data give the same CI); each resample is refitted by
    Tukey's IRLS from the data's estimate with the data's robust scale (a robust bootstrap:
    re-estimating the scale on a resample that drew the outliers twice lets them win, and the
    interval then slides off its own estimate — see :func:`_resample_rows`). The interval is
    widened, if need be, to contain the estimate.
Which intervals enter the fit
    *wet* intervals (reference ``precip_mm >= threshold_mm``) where the camera saw something
    (mean R > 0). *Dry* intervals and wet intervals with R = 0 (the camera saw nothing: night,
    fog on the lens) do not enter the fit — the log of 0 has no place in it, and deciding
    *whether* it rains is the detector's job, scored by :mod:`daemon.offline.compare`; the
    calibration is the rate *given* precipitation. They are kept for the scores: ``r2`` and
    ``rmse_mm_h`` are computed over every used interval with an amount (dry ones included,
    predicted a·R^b); ``r2_wet`` and ``rmse_wet_mm_h`` over the fitted ones.
Choosing the model
    ``power`` only if it can be fitted (at least :data:`MIN_POWER` wet intervals, R not
    constant), its exponent's CI excludes 1, and it lowers the RMSE of the wet intervals;
    otherwise ``linear`` — the simpler model unless the data demand a curve.
"""

from __future__ import annotations

import logging
import math
import os
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from drivers.errors import InputError

from .series import IntervalStats, ReferenceInterval, Series, load_series

__all__ = [
    "MIN_POWER",
    "MIN_ROBUST",
    "MODELS",
    "CalibrationPoints",
    "Fit",
    "calibrate",
    "calibration_points",
    "ci_bounds",
    "fit_calibration",
    "fit_model",
    "predict",
    "scores",
    "toml_text",
    "write_calibration_toml",
]

log = logging.getLogger(__name__)

MODELS = ("linear", "power")
#: Fewest wet intervals for the power model (two parameters and something left to judge them).
MIN_POWER = 5
#: Fewest points for the robust weights (below: least squares in log space).
MIN_ROBUST = 6
_HUBER_C = 1.345
_TUKEY_C = 4.685
_MAD_K = 1.4826
_CHUNK = 2_000_000  # bootstrap elements (resamples x points) computed at once


@dataclass(frozen=True)
class CalibrationPoints:
    """The used intervals of one camera, split by how they enter the calibration.

    Attributes
    ----------
    r, rate_mm_h : (N,) wet intervals with R > 0: the fit's points (R relative, rate in mm/h)
    r_all, rate_all_mm_h : (M,) every used interval with an amount, for the scores
    n_dry : used intervals below ``threshold_mm``
    n_unseen : wet intervals with R = 0 (or no R)
    intervals : the IntervalStats of the fit's points, in the same order as ``r``
    """

    r: np.ndarray
    rate_mm_h: np.ndarray
    r_all: np.ndarray
    rate_all_mm_h: np.ndarray
    n_dry: int
    n_unseen: int
    intervals: list[IntervalStats] = field(default_factory=list)


@dataclass(frozen=True)
class Fit:
    """A robust fit of ``mm/h = a·R^b`` (``b`` = 1 for ``linear``).

    Attributes
    ----------
    model : "linear" or "power"
    a : gain, mm/h per R^b; b : exponent, dimensionless
    a_ci, b_ci : (lo, hi) percentile-bootstrap confidence interval (``ci_level``)
    n : points fitted; n_outliers : points given weight 0 by Tukey's biweight
    weights : (n,) final IRLS weights in [0, 1]
    scale_log : robust scale of the log residuals (≈ relative error of one interval)
    boot_a, boot_b : (n_boot,) bootstrap replicates (NaN where a resample was degenerate)
    """

    model: str
    a: float
    b: float
    a_ci: tuple[float, float]
    b_ci: tuple[float, float]
    n: int
    n_outliers: int
    weights: np.ndarray
    scale_log: float
    ci_level: float
    boot_a: np.ndarray
    boot_b: np.ndarray

    def predict(self, r: np.ndarray | float) -> np.ndarray:
        """Rain rate, mm/h, for R (relative units)."""
        return predict(self.a, self.b, r)

    def band(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) mm/h: the pointwise bootstrap interval of ``a·R^b`` at each R of ``r``, at
        ``ci_level`` and containing the fit itself (for ``linear``, exactly ``a_ci``·R)."""
        r = np.asarray(r, dtype=np.float64)
        fitted = self.predict(r)
        ok = np.isfinite(self.boot_a) & np.isfinite(self.boot_b)
        if not ok.any():
            return fitted, fitted
        preds = predict(self.boot_a[ok, None], self.boot_b[ok, None], r[None, :])
        q = (100 * (1 - self.ci_level) / 2, 100 * (1 + self.ci_level) / 2)
        lo, hi = np.percentile(preds, q, axis=0)
        return np.minimum(lo, fitted), np.maximum(hi, fitted)


def predict(a: float, b: float, r: np.ndarray | float) -> np.ndarray:
    """``a·R^b`` in mm/h; R <= 0 gives 0."""
    r = np.asarray(r, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r > 0, a * np.power(np.maximum(r, 1e-300), b), 0.0)


def scores(rate_mm_h: np.ndarray, predicted_mm_h: np.ndarray) -> tuple[float | None, float | None]:
    """(R², RMSE in mm/h) of predictions; R² is None when the rates do not vary, both None
    when there is no point."""
    y = np.asarray(rate_mm_h, dtype=np.float64)
    p = np.asarray(predicted_mm_h, dtype=np.float64)
    if y.size == 0:
        return None, None
    ss_res = float(np.sum((y - p) ** 2))
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    rmse = math.sqrt(ss_res / y.size)
    return (1.0 - ss_res / ss_tot if ss_tot > 0 else None), rmse


# ---------------------------------------------------------------------------------------------
# Robust regression in log space, vectorised over rows (row 0: the data, others: resamples)


def _mad_scale(res: np.ndarray) -> np.ndarray:
    """(B,) 1.4826·median |r - median r| of each row (NaN for a degenerate row)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: degenerate resamples
        med = np.nanmedian(res, axis=1, keepdims=True)
        return _MAD_K * np.nanmedian(np.abs(res - med), axis=1)


def _wls(u: np.ndarray, v: np.ndarray, w: np.ndarray, *, slope: bool) -> tuple:
    """Weighted least squares per row of ``v = alpha + b·u`` (or ``b`` = 1): (alpha, b)."""
    sw = w.sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        if not slope:
            return (w * (v - u)).sum(axis=1) / sw, np.ones(u.shape[0])
        su, sv = (w * u).sum(axis=1), (w * v).sum(axis=1)
        suu, suv = (w * u * u).sum(axis=1), (w * u * v).sum(axis=1)
        det = sw * suu - su * su
        ok = det > 1e-12 * np.maximum(sw * suu, 1e-300)
        b = np.where(ok, (sw * suv - su * sv) / np.where(ok, det, 1.0), np.nan)
        return (sv - b * su) / sw, b


def _irls(
    u: np.ndarray,
    v: np.ndarray,
    alpha: np.ndarray,
    b: np.ndarray,
    weigh: Callable[[np.ndarray], np.ndarray],
    *,
    slope: bool,
    steps: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Iteratively reweighted least squares from (alpha, b) with the weights ``weigh(res)``,
    until the parameters settle or ``steps`` run out: (alpha, b, last weights)."""
    for _ in range(steps):
        w = weigh(v - alpha[:, None] - b[:, None] * u)
        new_alpha, new_b = _wls(u, v, w, slope=slope)
        done = np.allclose(new_alpha, alpha, atol=1e-10, equal_nan=True) and np.allclose(
            new_b, b, atol=1e-10, equal_nan=True
        )
        alpha, b = new_alpha, new_b
        if done:
            break
    return alpha, b, w


def _robust_rows(u: np.ndarray, v: np.ndarray, *, slope: bool) -> tuple:
    """Huber then Tukey IRLS per row; returns (alpha, b, weights, scale, smearing factor).

    With fewer than :data:`MIN_ROBUST` points a robust scale means nothing: least squares.
    """
    w = np.ones_like(u)
    alpha, b = _wls(u, v, w, slope=slope)
    res = v - alpha[:, None] - b[:, None] * u
    scale = _mad_scale(res)
    if u.shape[1] < MIN_ROBUST:
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return alpha, b, w, scale, np.exp(res).mean(axis=1)

    def huber(res: np.ndarray) -> np.ndarray:  # the scale is re-estimated each step
        nonlocal scale
        scale = _mad_scale(res)
        cs = (_HUBER_C * scale)[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            w = np.where(np.abs(res) <= cs, 1.0, cs / np.abs(res))
        return np.where(scale[:, None] > 0, w, 1.0)

    def tukey(res: np.ndarray) -> np.ndarray:  # the scale is the one Huber ended with
        with np.errstate(divide="ignore", invalid="ignore"):
            z = res / (_TUKEY_C * scale)[:, None]
        w = np.where(np.abs(z) < 1.0, (1.0 - z * z) ** 2, 0.0)
        return np.where(scale[:, None] > 0, w, 1.0)

    alpha, b, w = _irls(u, v, alpha, b, huber, slope=slope, steps=50)
    alpha, b, w = _irls(u, v, alpha, b, tukey, slope=slope, steps=100)
    res = v - alpha[:, None] - b[:, None] * u
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        smear = (w * np.exp(res)).sum(axis=1) / w.sum(axis=1)
    return alpha, b, w, scale, smear


def fit_model(
    r: np.ndarray,
    rate_mm_h: np.ndarray,
    *,
    model: str = "linear",
    n_boot: int = 1000,
    seed: int = 0,
    ci_level: float = 0.95,
) -> Fit:
    """Fit one model robustly (see the module docstring), with bootstrap confidence intervals.

    Parameters
    ----------
    r : (N,) mean R of each interval, relative units, > 0
    rate_mm_h : (N,) reference rain rate of each interval, mm/h, > 0
    model : "linear" (mm/h = a·R) or "power" (mm/h = a·R^b)
    n_boot : bootstrap resamples (0: no CI, the CI is then [a, a])
    seed : seed of the bootstrap's random generator
    ci_level : confidence level of the intervals, in (0, 1)

    Raises
    ------
    InputError : an unknown model, too few points, non-positive values, or (power) constant R.
    """
    if model not in MODELS:
        raise InputError(f"unknown model {model!r}: expected one of {', '.join(MODELS)}")
    x = np.asarray(r, dtype=np.float64).ravel()
    y = np.asarray(rate_mm_h, dtype=np.float64).ravel()
    if x.shape != y.shape:
        raise ValueError(f"r and rate_mm_h differ in shape: {x.shape} vs {y.shape}")
    if not (np.all(np.isfinite(x) & (x > 0)) and np.all(np.isfinite(y) & (y > 0))):
        raise InputError("calibration points must have R > 0 and a rain rate > 0")
    need = 3 if model == "power" else 1
    if x.size < need:
        raise InputError(f"{model} model: {x.size} wet interval(s), need at least {need}")
    slope = model == "power"
    u, v = np.log(x), np.log(y)
    if slope and np.ptp(u) <= 1e-9 * max(1.0, float(np.abs(u).max())):
        raise InputError("power model: R is the same in every interval, the exponent is unknown")
    alpha, b, w, scale, smear = _robust_rows(u[None, :], v[None, :], slope=slope)
    a_hat = float(np.exp(alpha[0]) * smear[0])
    b_hat = float(b[0])

    boot_a = np.empty(0)
    boot_b = np.empty(0)
    if n_boot > 0 and x.size > 1:
        rng = np.random.default_rng(seed)
        rows_per_chunk = max(1, _CHUNK // x.size)
        parts_a, parts_b = [], []
        for start in range(0, n_boot, rows_per_chunk):
            rows = min(rows_per_chunk, n_boot - start)
            idx = rng.integers(0, x.size, size=(rows, x.size))
            ba, bb, bs = _resample_rows(u[idx], v[idx], alpha[0], b_hat, scale[0], slope=slope)
            with np.errstate(over="ignore", invalid="ignore"):
                parts_a.append(np.exp(ba) * bs)
            parts_b.append(bb)
        boot_a, boot_b = np.concatenate(parts_a), np.concatenate(parts_b)
    a_ci = ci_bounds(boot_a, a_hat, ci_level=ci_level)
    b_ci = ci_bounds(boot_b, b_hat, ci_level=ci_level) if slope else (1.0, 1.0)
    weights = w[0]
    return Fit(
        model=model,
        a=a_hat,
        b=b_hat,
        a_ci=a_ci,
        b_ci=b_ci,
        n=int(x.size),
        n_outliers=int(np.count_nonzero(weights == 0)),
        weights=weights,
        scale_log=float(scale[0]),
        ci_level=ci_level,
        boot_a=boot_a,
        boot_b=boot_b if slope else np.ones_like(boot_a),
    )


def _resample_rows(
    u: np.ndarray, v: np.ndarray, alpha: float, b: float, scale: float, *, slope: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fit of each bootstrap resample (rows of ``u``, ``v``): (alpha, b, smearing factor).

    With :data:`MIN_ROBUST` points or more, Tukey's IRLS started at the data's estimate with
    the data's robust scale held fixed, in the manner of the robust bootstrap of Salibian-Barrera
    & Zamar (Ann. Statist. 2002). Re-running the whole estimator on a resample (a least-squares
    start and a new MAD) breaks down whenever the resample happens to draw the outliers more
    often than the data hold them: with tight inliers and two low outliers among 8 intervals,
    a third of the resamples then followed the outliers, the replicates of ``a`` had a long low
    tail and none above, and the 95 % interval ended just above the estimate — the band of the
    calibration plot lay below its own fit (issue 13).
    """
    if u.shape[1] < MIN_ROBUST:
        alpha_r, b_r, _, _, smear = _robust_rows(u, v, slope=slope)
        return alpha_r, b_r, smear

    def tukey(res: np.ndarray) -> np.ndarray:
        if not scale > 0:
            return np.ones_like(res)
        z = res / (_TUKEY_C * scale)
        return np.where(np.abs(z) < 1.0, (1.0 - z * z) ** 2, 0.0)

    rows = u.shape[0]
    alpha_r, b_r, w = _irls(
        u, v, np.full(rows, alpha), np.full(rows, b), tukey, slope=slope, steps=100
    )
    res = v - alpha_r[:, None] - b_r[:, None] * u
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        smear = (w * np.exp(res)).sum(axis=1) / w.sum(axis=1)
    return alpha_r, b_r, smear


def ci_bounds(
    replicates: np.ndarray, estimate: float, *, ci_level: float = 0.95
) -> tuple[float, float]:
    """Percentile-bootstrap interval at ``ci_level`` of ``replicates`` (NaN ignored), widened
    if need be to contain ``estimate``: an interval that leaves out the number it qualifies
    says the bootstrap failed, and the estimate is still the best value there is."""
    finite = replicates[np.isfinite(replicates)]
    if finite.size == 0:
        return (estimate, estimate)
    q = (100 * (1 - ci_level) / 2, 100 * (1 + ci_level) / 2)
    lo, hi = np.percentile(finite, q)
    return (float(min(lo, estimate)), float(max(hi, estimate)))


# ---------------------------------------------------------------------------------------------
# From aggregated intervals to a calibration


def calibration_points(
    stats: Iterable[IntervalStats], *, threshold_mm: float = 0.1
) -> CalibrationPoints:
    """Split the used amount intervals of one camera into fit points, dry and unseen ones.

    Parameters
    ----------
    stats : one camera's IntervalStats
    threshold_mm : reference amount at and above which an interval is wet, mm
    """
    fit_r, fit_y, all_r, all_y, fit_iv = [], [], [], [], []
    n_dry = n_unseen = 0
    for s in stats:
        rate = s.rate_mm_h
        if not s.used or rate is None or s.precip_mm is None:
            continue
        r = s.r_mean if s.r_mean is not None else 0.0
        all_r.append(r)
        all_y.append(rate)
        if s.precip_mm < threshold_mm or rate <= 0:
            n_dry += 1
        elif r <= 0:
            n_unseen += 1
        else:
            fit_r.append(r)
            fit_y.append(rate)
            fit_iv.append(s)
    return CalibrationPoints(
        r=np.asarray(fit_r, dtype=np.float64),
        rate_mm_h=np.asarray(fit_y, dtype=np.float64),
        r_all=np.asarray(all_r, dtype=np.float64),
        rate_all_mm_h=np.asarray(all_y, dtype=np.float64),
        n_dry=n_dry,
        n_unseen=n_unseen,
        intervals=fit_iv,
    )


def fit_calibration(
    points: CalibrationPoints,
    *,
    model: str | None = None,
    n_boot: int = 1000,
    seed: int = 0,
    ci_level: float = 0.95,
) -> tuple[dict[str, Any], dict[str, Fit]]:
    """Fit both models (or ``model``), choose one, and score it.

    Returns
    -------
    (result, fits) : ``result`` is the JSON-able calibration (``model``, ``a``, ``b``, ``a_ci``,
        ``b_ci``, ``n``, ``r2``, ``rmse_mm_h``, ``r_min``, ``r_max``, ``r2_wet``,
        ``rmse_wet_mm_h``, ``n_dry``, ``n_unseen``, ``n_outliers``, ``scale_log``, ``ci_level``,
        ``choice`` and ``candidates``: each model's numbers); ``fits`` the :class:`Fit` objects.

    Raises
    ------
    InputError : fewer than two wet intervals where the camera saw something, an unknown model,
        or ``power`` asked for but impossible.
    """
    if model is not None and model not in MODELS:
        raise InputError(f"unknown model {model!r}: expected one of {', '.join(MODELS)}")
    n = points.r.size
    if n < 2:
        raise InputError(
            f"{n} wet interval(s) with camera intensity R > 0 (need at least 2 to calibrate; "
            f"{points.n_dry} dry, {points.n_unseen} wet but unseen by the camera)"
        )
    kw = {"n_boot": n_boot, "seed": seed, "ci_level": ci_level}
    fits = {"linear": fit_model(points.r, points.rate_mm_h, model="linear", **kw)}
    power_reason = None
    if model == "power" or model is None:
        try:
            fits["power"] = fit_model(points.r, points.rate_mm_h, model="power", **kw)
        except InputError as exc:
            if model == "power":
                raise
            power_reason = str(exc)
    candidates = {name: _describe(fit, points) for name, fit in fits.items()}
    if model is not None:
        chosen, choice = model, "asked for"
    else:
        chosen, choice = _choose(fits, candidates, power_reason)
    fit = fits[chosen]
    result = dict(candidates[chosen])
    result.update(
        model=chosen,
        choice=choice,
        n_dry=points.n_dry,
        n_unseen=points.n_unseen,
        r_min=float(points.r.min()),
        r_max=float(points.r.max()),
        ci_level=ci_level,
        n_boot=n_boot,
        candidates=candidates,
    )
    log.info(
        "calibration: %s a=%.4g b=%.3g on %d intervals (%d outliers), R2=%s",
        chosen,
        fit.a,
        fit.b,
        fit.n,
        fit.n_outliers,
        result["r2"],
    )
    return result, fits


def _describe(fit: Fit, points: CalibrationPoints) -> dict[str, Any]:
    r2, rmse = scores(points.rate_all_mm_h, fit.predict(points.r_all))
    r2_wet, rmse_wet = scores(points.rate_mm_h, fit.predict(points.r))
    return {
        "model": fit.model,
        "a": fit.a,
        "b": fit.b,
        "a_ci": list(fit.a_ci),
        "b_ci": list(fit.b_ci),
        "n": fit.n,
        "n_outliers": fit.n_outliers,
        "r2": r2,
        "rmse_mm_h": rmse,
        "r2_wet": r2_wet,
        "rmse_wet_mm_h": rmse_wet,
        "scale_log": fit.scale_log,
    }


def _choose(fits: dict[str, Fit], candidates: dict, power_reason: str | None) -> tuple[str, str]:
    power = fits.get("power")
    if power is None:
        return "linear", f"power model not fitted: {power_reason}"
    if power.n < MIN_POWER:
        return "linear", f"fewer than {MIN_POWER} wet intervals for the power model"
    lo, hi = power.b_ci
    if lo <= 1.0 <= hi:
        return "linear", f"exponent b CI [{lo:.3g}, {hi:.3g}] includes 1"
    if candidates["power"]["rmse_wet_mm_h"] >= candidates["linear"]["rmse_wet_mm_h"]:
        return "linear", "power model does not lower the RMSE"
    return "power", f"exponent b CI [{lo:.3g}, {hi:.3g}] excludes 1 and the RMSE is lower"


# ---------------------------------------------------------------------------------------------
# calibration.toml


def toml_text(values: dict[str, Any]) -> str:
    """A ``[calibration]`` TOML table of scalars, strings and lists of numbers."""
    lines = ["[calibration]"]
    for key, value in values.items():
        lines.append(f"{key} = {_toml_value(value)}")
    return "\n".join(lines) + "\n"


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        escaped = value.replace("\\", "\\\\").replace('"', '\\"')
        escaped = "".join(c if c >= " " and c != "\x7f" else f"\\u{ord(c):04x}" for c in escaped)
        return f'"{escaped}"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"no TOML form for {type(value).__name__}")


def write_calibration_toml(
    path: str | os.PathLike[str],
    result: dict[str, Any],
    *,
    reference: str | None,
    station: str | None,
    camera: str,
    fitted_at: datetime | None = None,
) -> dict[str, Any]:
    """Write ``calibration.toml`` (the keys the daemon loads) and return the table written.

    A missing R² (constant rates) is written as ``nan``; ``reference`` and ``station`` are
    left out when unknown.

    Raises
    ------
    InputError : the file cannot be written.
    """
    stamp = (fitted_at or datetime.now(UTC)).astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    table: dict[str, Any] = {
        "model": result["model"],
        "a": float(result["a"]),
        "b": float(result["b"]),
        "a_ci": [float(v) for v in result["a_ci"]],
        "b_ci": [float(v) for v in result["b_ci"]],
        "n": int(result["n"]),
        "r2": math.nan if result["r2"] is None else float(result["r2"]),
        "rmse_mm_h": float(result["rmse_mm_h"]),
        "r_min": float(result["r_min"]),
        "r_max": float(result["r_max"]),
        "source": "offline",
        "fitted_at": stamp,
    }
    if reference is not None:
        table["reference"] = reference
    if station is not None:
        table["station"] = station
    table["camera"] = camera
    path = Path(path)
    try:
        path.write_text(toml_text(table), encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot write ({exc.strerror})") from None
    return table


def _too_few(
    points: CalibrationPoints,
    series: Series,
    camera: str,
    stats: Sequence[IntervalStats],
    *,
    threshold_mm: float,
) -> str:
    """Why fewer than two intervals can be fitted: each rule that left intervals out, with
    its count and the option that changes it."""
    reasons = series.unused_reasons(camera)
    used = [s for s in stats if s.used]
    no_amount = sum(s.precip_mm is None for s in used)
    if no_amount:
        reasons.append(f"{no_amount} have no reference amount (missing data)")
    if points.n_dry:
        amounts = [s.precip_mm for s in used if s.precip_mm is not None]
        reasons.append(
            f"{points.n_dry} are dry: their amount is below --threshold-mm {threshold_mm:g} mm "
            f"(the largest amount is {max(amounts):g} mm)"
        )
    if points.n_unseen:
        reasons.append(
            f"{points.n_unseen} are wet but the camera's mean R is 0 (it saw no rain: night, "
            "fog, a lens it cannot see through)"
        )
    n_ref = series.counts.get("reference_intervals", len(stats))
    return (
        f"camera {camera}: {points.r.size} wet interval(s) with camera intensity R > 0, need at "
        f"least 2 to calibrate: of {n_ref} reference interval(s), {points.r.size} can be "
        "fitted; " + "; ".join(reasons)
    )


# ---------------------------------------------------------------------------------------------
# The command


def calibrate(
    mcap_paths: Sequence[str | os.PathLike[str]],
    reference_path: str | os.PathLike[str] | Iterable[ReferenceInterval],
    *,
    station: str | None = None,
    camera: str | None = None,
    model: str | None = None,
    plots_dir: str | os.PathLike[str] | None = None,
    report: str | os.PathLike[str] | None = None,
    out: str | os.PathLike[str] | None = "calibration.toml",
    threshold_mm: float = 0.1,
    min_judged: float = 0.5,
    min_coverage: float = 0.5,
    n_boot: int = 1000,
    seed: int = 0,
    progress: bool | None = None,
    reference_options: Mapping[str, Any] | None = None,
    series: Series | None = None,
) -> dict[str, Any]:
    """``weatherd calibrate``: fit R → mm/h from MCAP logs against station data.

    Parameters
    ----------
    mcap_paths : MCAP files or directories
    reference_path : station file (any format of :mod:`daemon.offline.reference`), or intervals
    station : station to keep from a multi-station file
    camera : camera to calibrate (required when the logs hold several)
    model : "linear", "power", or None to choose (see the module docstring)
    plots_dir : write the PNG plots there; report : write the HTML report there
    out : calibration.toml to write; None: write nothing
    threshold_mm : reference amount at and above which an interval is wet, mm
    min_judged, min_coverage : see :func:`daemon.offline.series.aggregate`
    n_boot, seed : bootstrap resamples and their seed
    progress : progress bar in frame messages, with an ETA (None: on a terminal only)
    reference_options : more keyword arguments of ``read_reference`` (``fmt``, ``tz``,
        ``interval_s``, ``month``)
    series : already aggregated logs (then ``mcap_paths`` and ``reference_path`` are not read)

    Returns
    -------
    dict, JSON-able: the calibration (see :func:`fit_calibration`) plus ``camera``, ``station``,
    ``reference``, ``out``, ``plots`` (files written), ``report`` and ``intervals`` (counts).

    Raises
    ------
    InputError : one line, for any bad input (paths, reference, too few usable intervals...).
    """
    if not threshold_mm > 0:
        raise InputError(f"threshold_mm must be > 0, got {threshold_mm}")
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
    cam = series.select_camera(camera)
    stats = series.for_camera(cam)
    if stats and all(s.kind != "amount" for s in stats):
        raise InputError(
            "the reference reports presence only (METAR), not amounts: use weatherd compare"
        )
    points = calibration_points(stats, threshold_mm=threshold_mm)
    if points.r.size < 2:
        raise InputError(_too_few(points, series, cam, stats, threshold_mm=threshold_mm))
    result, fits = fit_calibration(points, model=model, n_boot=n_boot, seed=seed)
    result["camera"] = cam
    result["station"] = series.station
    result["reference"] = series.reference
    result["threshold_mm"] = threshold_mm
    result["intervals"] = dict(series.counts)
    if out is not None:
        write_calibration_toml(
            out, result, reference=series.reference, station=series.station, camera=cam
        )
        result["out"] = str(out)
    if plots_dir is not None or report is not None:
        from .compare import score
        from .report import write_report

        comparison = score(series, camera=cam, threshold_mm=threshold_mm)
        written = write_report(
            series,
            camera=cam,
            calibration=result,
            fits=fits,
            points=points,
            comparison=comparison,
            plots_dir=plots_dir,
            report=report,
        )
        result["plots"] = written["plots"]
        result["report"] = written["report"]
    return result
