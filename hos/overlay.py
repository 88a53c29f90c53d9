"""What the detector saw, drawn over the frame: the view of the paper's Fig. 12.

The frame in grey with every blob coloured by its class (rain green, noise red, rejected by the
size rule blue, structural or found again purple, traffic orange), an inset plotting the HOS
with the fitted mixture of eq. 23 and the Kalman-smoothed Gaussian, and a line of text with
the verdict and its numbers.

Pure: arrays in, a new BGR image out; the inputs are never modified. OpenCV drawing only.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .angles import wrapped_normal_pdf
from .params import DetectorParams
from .result import BlobClass, FrameResult

__all__ = ["CLASS_COLOURS", "draw_overlay", "mixture_curves"]

#: (5, 3) uint8 BGR colour of each :class:`~hos.result.BlobClass`, indexed by class.
CLASS_COLOURS = np.zeros((6, 3), dtype=np.uint8)
CLASS_COLOURS[BlobClass.RAIN] = (0, 220, 0)  # green
CLASS_COLOURS[BlobClass.NOISE] = (0, 0, 235)  # red
CLASS_COLOURS[BlobClass.SIZE] = (255, 140, 0)  # blue
CLASS_COLOURS[BlobClass.STRUCTURE] = (150, 40, 110)  # darker blue-purple
CLASS_COLOURS[BlobClass.TRAFFIC] = (0, 140, 255)  # orange
CLASS_COLOURS.flags.writeable = False

_WHITE = (255, 255, 255)
_GREEN = (0, 220, 0)
_RED = (60, 60, 240)
_CYAN = (255, 255, 0)
_GREY = (150, 150, 150)
_PANEL = (24, 24, 24)
_PANEL_OPACITY = 0.75
_FONT = cv2.FONT_HERSHEY_SIMPLEX
_SHIFT = 4  # fixed-point bits for sub-pixel polylines
_MIN_INSET_WIDTH = 64  # px; below this the inset is not drawn


def draw_overlay(
    gray: np.ndarray, result: FrameResult, *, params: DetectorParams | None = None
) -> np.ndarray:
    """Draw the detector's view of one frame.

    Parameters
    ----------
    gray : (H, W) uint8, the frame given to the detector ((H, W, 3) BGR is converted)
    result : FrameResult of that frame; ``labels`` None draws no blob, a failed fit no curve
    params : DetectorParams, optional; its ``decision.pi_rain`` is shown beside the smoothed Pi

    Returns
    -------
    (H, W, 3) uint8 BGR image, newly allocated.
    """
    params = params or DetectorParams()
    gray = np.asarray(gray)
    if gray.ndim == 3:
        gray = cv2.cvtColor(gray, cv2.COLOR_BGR2GRAY)
    if gray.ndim != 2 or gray.dtype != np.uint8:
        raise ValueError(f"expected a (H, W) uint8 frame, got {gray.shape} {gray.dtype}")
    out = cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR)
    _colour_blobs(out, result.label_image(), result.blob_class)
    _draw_inset(out, result)
    _draw_text(out, _summary_tokens(result, params), rain=result.rain)
    return out


def mixture_curves(result: FrameResult, theta: np.ndarray) -> dict[str, np.ndarray | None]:
    """The fitted mixture at ``theta``, in the units of ``result.histogram`` (votes per bin).

    A density ``f`` over [0, pi) (1/rad) is scaled to ``f * sum(h) * (pi / bins)``, the
    expected content of a bin of the histogram ``h``.

    Parameters
    ----------
    result : FrameResult
    theta : (M,) radians

    Returns
    -------
    dict of (M,) float arrays, None where there is nothing to draw:
    ``"gaussian"`` Pi N(theta | mu, sigma), ``"uniform"`` (1 - Pi) / pi, ``"total"`` their sum
    (eq. 23, the per-frame fit), ``"smoothed"`` the Kalman-smoothed Pi N(theta | mu, sigma).
    """
    hist = np.asarray(result.histogram, dtype=np.float64)
    scale = float(hist.sum()) * math.pi / max(hist.size, 1)
    curves: dict[str, np.ndarray | None] = dict.fromkeys(("gaussian", "uniform", "total"))
    fit = result.fit
    if fit.ok and _finite(fit.pi, fit.mu, fit.sigma) and fit.sigma > 0:
        gaussian = fit.pi * wrapped_normal_pdf(theta, fit.mu, fit.sigma) * scale
        uniform = np.full_like(gaussian, (1.0 - fit.pi) / math.pi * scale)
        curves.update(gaussian=gaussian, uniform=uniform, total=gaussian + uniform)
    pi_s, mu_s, sigma_s = result.pi_smoothed, result.mu_smoothed, result.sigma_smoothed
    curves["smoothed"] = (
        pi_s * wrapped_normal_pdf(theta, mu_s, sigma_s) * scale
        if _finite(pi_s, mu_s, sigma_s) and sigma_s > 0
        else None
    )
    return curves


# -- blobs -------------------------------------------------------------------------------
def _colour_blobs(out: np.ndarray, labels: np.ndarray | None, classes: np.ndarray | None) -> None:
    """Paint each labelled pixel with its blob's class colour: one lookup, no loop over blobs."""
    if labels is None or classes is None or labels.shape != out.shape[:2] or classes.size == 0:
        return
    classes = np.clip(np.asarray(classes), 0, len(CLASS_COLOURS) - 1)
    colour_of_label = CLASS_COLOURS[classes]  # (n_labels, 3)
    drawn = classes != BlobClass.NONE  # (n_labels,)
    selected = np.take(drawn, labels, mode="clip") & (labels > 0)
    out[selected] = colour_of_label[np.minimum(labels[selected], classes.size - 1)]


# -- inset -------------------------------------------------------------------------------
def _draw_inset(out: np.ndarray, result: FrameResult) -> None:
    """The HOS and the mixture, in a semi-opaque panel at the bottom right."""
    height, width = out.shape[:2]
    panel_w = round(0.3 * width)
    panel_h = min(round(0.6 * panel_w), round(0.45 * height))
    if panel_w < _MIN_INSET_WIDTH or panel_h < 32:
        return
    margin = max(2, width // 100)
    x0, y0 = width - margin - panel_w, height - margin - panel_h
    roi = out[y0 : y0 + panel_h, x0 : x0 + panel_w]
    panel = np.empty_like(roi)
    panel[:] = _PANEL
    cv2.addWeighted(panel, _PANEL_OPACITY, roi, 1.0 - _PANEL_OPACITY, 0.0, dst=roi)

    font_scale = max(panel_h / 260.0, 0.28)
    (_, text_h), _ = cv2.getTextSize("0", _FONT, font_scale, 1)
    pad = max(3, panel_w // 40)
    left, right = x0 + pad, x0 + panel_w - pad
    top, bottom = y0 + pad + text_h + 2, y0 + panel_h - pad - text_h - 3
    if right - left < 16 or bottom - top < 12:
        return
    cv2.putText(out, "HOS", (left, y0 + pad + text_h), _FONT, font_scale, _GREY, 1, cv2.LINE_AA)

    hist = np.nan_to_num(np.asarray(result.histogram, dtype=np.float64), nan=0.0)
    theta = np.linspace(0.0, math.pi, 2 * (right - left) + 1)
    curves = mixture_curves(result, theta)
    peak = max(
        [float(hist.max(initial=0.0))] + [float(c.max()) for c in curves.values() if c is not None]
    )
    y_scale = (bottom - top) / (1.1 * peak) if peak > 0 else 0.0

    def to_px(t: np.ndarray, v: np.ndarray) -> np.ndarray:
        x = left + t / math.pi * (right - left)
        y = bottom - np.minimum(v * y_scale, bottom - top)
        return np.round(np.stack([x, y], axis=1) * (1 << _SHIFT)).astype(np.int32)

    if hist.size and peak > 0:  # the histogram as a filled step curve
        edges = np.linspace(0.0, math.pi, hist.size + 1)
        t = np.concatenate([[0.0], np.repeat(edges, 2)[1:-1], [math.pi]])
        v = np.concatenate([[0.0], np.repeat(hist, 2), [0.0]])
        cv2.fillPoly(out, [to_px(t, v)], (110, 110, 110), cv2.LINE_AA, _SHIFT)
    for name, colour in (("uniform", _RED), ("gaussian", _GREEN), ("smoothed", _CYAN)):
        if curves[name] is not None:
            cv2.polylines(out, [to_px(theta, curves[name])], False, colour, 1, cv2.LINE_AA, _SHIFT)
    if curves["total"] is not None:
        cv2.polylines(out, [to_px(theta, curves["total"])], False, _WHITE, 1, cv2.LINE_AA, _SHIFT)

    cv2.line(out, (left, bottom), (right, bottom), _GREY, 1)
    for degrees in (0, 90, 180):
        x = left + round(degrees / 180 * (right - left))
        cv2.line(out, (x, bottom), (x, bottom + 2), _GREY, 1)
        label = str(degrees)
        (w, _), _ = cv2.getTextSize(label, _FONT, font_scale, 1)
        tx = min(max(x - w // 2, x0 + 1), x0 + panel_w - w - 1)
        cv2.putText(out, label, (tx, bottom + 4 + text_h), _FONT, font_scale, _GREY, 1, cv2.LINE_AA)


# -- text --------------------------------------------------------------------------------
def _summary_tokens(result: FrameResult, params: DetectorParams) -> list[str]:
    fit = result.fit

    def num(x: float, fmt: str) -> str:
        return format(x, fmt) if _finite(x) else "-"

    def deg(x: float) -> str:
        return format(math.degrees(x) % 180.0, ".1f") if _finite(x) else "-"

    tokens = ["RAIN" if result.rain else "no rain", result.state]
    if fit.ok:
        tokens += [
            f"Pi={num(fit.pi, '.2f')}",
            f"mu={deg(fit.mu)}",
            f"sigma={deg(fit.sigma)}",
            f"D={num(fit.gof_d, '.3f')}" + ("" if fit.gof_ok else "!"),
        ]
    else:
        tokens.append(f"no fit ({fit.reason})" if fit.reason else "no fit")
    tokens += [
        f"Pi_s={num(result.pi_smoothed, '.2f')}/{params.decision.pi_rain:.2f}",
        f"R={num(result.R, '.0f')}",
    ]
    return tokens


def _draw_text(out: np.ndarray, tokens: list[str], *, rain: bool) -> None:
    """The tokens at the top left on a dark strip, wrapped to the width; the first (the
    verdict) in green when it is rain."""
    height, width = out.shape[:2]
    margin = max(2, width // 100)
    scale = min(max(height / 600.0, 0.35), 0.8)
    thickness = 1 if scale < 0.6 else 2
    gap = 2 * cv2.getTextSize(" ", _FONT, scale, thickness)[0][0]
    line_h = cv2.getTextSize("Ag", _FONT, scale, thickness)[0][1] + max(4, round(8 * scale))
    lines: list[list[tuple[str, int]]] = [[]]  # (token, x offset) per line
    x = 0
    for token in tokens:
        w = cv2.getTextSize(token, _FONT, scale, thickness)[0][0]
        if lines[-1] and x + gap + w > width - 2 * margin:
            lines.append([])
            x = 0
        elif lines[-1]:
            x += gap
        lines[-1].append((token, x))
        x += w
    strip_h = min(line_h * len(lines) + margin, height)
    strip = out[:strip_h]
    cv2.addWeighted(
        strip, 1.0 - _PANEL_OPACITY, np.zeros_like(strip), _PANEL_OPACITY, 0.0, dst=strip
    )
    for row, line in enumerate(lines):
        baseline = margin + line_h * (row + 1) - max(3, round(6 * scale))
        for column, (token, tx) in enumerate(line):
            first = row == 0 and column == 0
            colour = (_GREEN if rain else _GREY) if first else _WHITE
            cv2.putText(
                out, token, (margin + tx, baseline), _FONT, scale, colour, thickness, cv2.LINE_AA
            )


# -- maths -------------------------------------------------------------------------------


def _finite(*values: float) -> bool:
    return all(v is not None and math.isfinite(v) for v in values)
