"""The procedural street of :class:`~.scene.Scene`, painted: still background and movers.

A street seen from a mast: sky, hazy distant buildings, façades with windows and pilasters, a side
street and a zebra crossing running to a vanishing point, lane markings, lamp posts, a pole, a
tree whose crown is a separate layer that the wind can move; and the things that cross it, cars,
vans and walkers. Everything is drawn in float32 grey levels with OpenCV at 1/16 px, from a
numpy Generator, so that a seed gives the same street.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import cv2
import numpy as np

from ._common import _ONE, _SHIFT

# Layout, as fractions of the height: horizon, far pavement, road, near pavement.
_Y_HORIZON, _Y_PAVEMENT, _Y_ROAD, _Y_NEAR = 0.40, 0.56, 0.62, 0.88
_VP = (0.65, 0.42)  # vanishing point of the side street, fractions of (W, H)
#: px per metre (fraction of the height) on the far pavement, far lane and near lane.
_SCALE_PAVEMENT, _SCALE_FAR, _SCALE_NEAR = 0.032, 0.036, 0.045


def _fx(points: Iterable[tuple[float, float]]) -> np.ndarray:
    """(N, 2) int32 fixed-point coordinates for OpenCV drawing with ``shift=_SHIFT``."""
    return np.rint(np.asarray(list(points), np.float64) * _ONE).astype(np.int32)


def _poly(img: np.ndarray, points: Iterable[tuple[float, float]], value: float) -> None:
    cv2.fillPoly(img, [_fx(points)], float(value), cv2.LINE_8, _SHIFT)


def _rect(img: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: float) -> None:
    _poly(img, ((x0, y0), (x1, y0), (x1, y1), (x0, y1)), value)


def _line(
    img: np.ndarray,
    p0: tuple[float, float],
    p1: tuple[float, float],
    value: float,
    thickness: float,
) -> None:
    a, b = _fx((p0, p1))
    cv2.line(
        img,
        tuple(a.tolist()),
        tuple(b.tolist()),
        float(value),
        max(1, round(thickness)),
        cv2.LINE_8,
        _SHIFT,
    )


def _circle(img: np.ndarray, c: tuple[float, float], r: float, value: float) -> None:
    ((cx, cy),) = _fx((c,))
    cv2.circle(
        img, (int(cx), int(cy)), max(1, round(r * _ONE)), float(value), -1, cv2.LINE_8, _SHIFT
    )


def _value_noise(shape: tuple[int, int], cell: float, rng: np.random.Generator) -> np.ndarray:
    """(H, W) float32 smooth noise of unit std, features about ``cell`` px wide."""
    h, w = shape
    coarse = rng.standard_normal((max(2, int(h / cell) + 2), max(2, int(w / cell) + 2)))
    smooth = cv2.resize(coarse.astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
    return smooth / max(float(smooth.std()), 1e-6)


@dataclass(frozen=True)
class _Foliage:
    """The tree's crown as a movable layer: grey value and opacity over a patch of the frame."""

    value: np.ndarray  # (ph, pw) float32 grey levels
    alpha: np.ndarray  # (ph, pw) float32 opacity in [0, 1]
    origin: tuple[int, int]  # (y0, x0) of the patch in the frame
    grid_x: np.ndarray  # (ph, pw) float32 pixel coordinates, for cv2.remap
    grid_y: np.ndarray
    grid_phase: np.ndarray  # (gh, gw) phase of the wind's wave over a coarse grid

    def over(self, img: np.ndarray) -> np.ndarray:
        """A copy of ``img`` with the crown at rest."""
        out = img.copy()
        y0, x0 = self.origin
        ph, pw = self.alpha.shape
        patch = out[y0 : y0 + ph, x0 : x0 + pw]
        patch += self.alpha * (self.value - patch)
        return out


def _paint_background(w: int, h: int, rng: np.random.Generator) -> tuple[np.ndarray, _Foliage]:
    """The static street, (H, W) float32 grey levels, and the tree's crown as a layer."""
    s = h / 540.0
    y_hz, y_pv, y_rd, y_nr = (f * h for f in (_Y_HORIZON, _Y_PAVEMENT, _Y_ROAD, _Y_NEAR))
    vx, vy = _VP[0] * w, _VP[1] * h
    img = np.empty((h, w), np.float32)

    # Sky: brighter toward the horizon, with soft clouds.
    rows = np.arange(h, dtype=np.float32)[:, None] / max(y_hz, 1.0)
    img[:] = 150.0 + 55.0 * np.minimum(rows, 1.0)
    img += 6.0 * _value_noise((h, w), w / 10, rng)

    # Distant hazy buildings behind everything (seen down the side street).
    x = 0.0
    while x < w:
        bw = rng.uniform(0.04, 0.09) * w
        top = rng.uniform(0.27, 0.36) * h
        grey = rng.uniform(150, 180)
        _rect(img, x, top, x + bw, y_pv, grey)
        for wx in np.arange(x + 0.01 * w, x + bw - 0.01 * w, 0.015 * w):
            _rect(img, wx, top + 0.02 * h, wx + 0.006 * w, y_pv - 0.02 * h, grey - 12)
        x += bw

    # Façades left and right of the side street.
    for xa, xb in ((-0.01 * w, 0.545 * w), (0.755 * w, 1.01 * w)):
        x = xa
        while x < xb - 1:
            bw = rng.uniform(0.07, 0.16) * w
            if xb - (x + bw) < 0.04 * w:
                bw = xb - x
            _paint_facade(img, x, x + bw, rng.uniform(0.06, 0.30) * h, y_pv, w, h, rng)
            x += bw

    # Far pavement, road and near pavement.
    img[int(y_pv) : int(y_rd) + 1] = 150.0
    road_rows = np.linspace(94.0, 80.0, int(y_nr) - int(y_rd), dtype=np.float32)[:, None]
    img[int(y_rd) : int(y_nr)] = road_rows
    img[int(y_nr) :] = 140.0

    # Side street running to the vanishing point, with its dashed centre line.
    def toward_vp(x_bottom: float, y: float) -> float:
        return vx + (x_bottom - vx) * (y - vy) / (y_rd - vy)

    _poly(img, ((vx - 1, vy), (vx + 1, vy), (0.75 * w, y_rd), (0.55 * w, y_rd)), 96.0)
    for z in np.arange(1.0, 8.0, 0.9):  # dashes at depths z (in units of the street's near end)
        ya, yb = vy + (y_rd - vy) / z, vy + (y_rd - vy) / (z + 0.45)
        half_a, half_b = 0.004 * w / z, 0.004 * w / (z + 0.45)
        _poly(
            img, ((vx - half_a, ya), (vx + half_a, ya), (vx + half_b, yb), (vx - half_b, yb)), 200.0
        )

    # Zebra crossing on the main road in line with the side street: stripes whose ends run to
    # the vanishing point (structured edges along vanishing lines).
    n_stripes = 7
    ys = np.linspace(y_rd + 0.01 * h, y_nr - 0.01 * h, 2 * n_stripes)
    for ya, yb in zip(ys[0::2], ys[1::2], strict=True):
        xl_a, xr_a = toward_vp(0.55 * w, ya), toward_vp(0.75 * w, ya)
        xl_b, xr_b = toward_vp(0.55 * w, yb), toward_vp(0.75 * w, yb)
        _poly(img, ((xl_a, ya), (xr_a, ya), (xr_b, yb), (xl_b, yb)), 205.0)

    # Lane markings: a dashed centre line and continuous edge lines, kerbs with their shadow.
    y_c = 0.5 * (y_rd + y_nr)
    dash, gap = 0.05 * w, 0.035 * w
    for x in np.arange(-rng.uniform(0, dash), w, dash + gap):
        if not toward_vp(0.55 * w, y_c) - dash < x < toward_vp(0.75 * w, y_c):
            _rect(img, x, y_c - 2.5 * s, x + dash, y_c + 2.5 * s, 200.0)
    _rect(img, 0, y_rd + 5 * s, w, y_rd + 7 * s, 190.0)
    _rect(img, 0, y_nr - 8 * s, w, y_nr - 5 * s, 190.0)
    _rect(img, 0, y_rd - 3 * s, w, y_rd, 185.0)
    _rect(img, 0, y_nr, w, y_nr + 4 * s, 195.0)
    _rect(img, 0, y_nr + 4 * s, w, y_nr + 6 * s, 105.0)

    # Paving joints on the near pavement: across, and along lines running to the vanishing point.
    for y in np.arange(y_nr + 0.035 * h, h, 0.04 * h):
        _line(img, (0, y), (w, y), 118.0, s)
    for xb in np.arange(-0.5 * w, 1.5 * w, 0.06 * w):
        y_top = y_nr + 6 * s
        _line(img, (toward_vp(xb, y_top), y_top), (toward_vp(xb, h), h), 118.0, s)

    # Lamp posts on the far pavement, a tall pole and a sign in the foreground.
    pw = max(2.0, 0.005 * w)
    for xp in (0.28 * w, 0.47 * w, 0.84 * w):
        top = 0.17 * h
        _rect(img, xp, top, xp + pw, y_pv + 0.035 * h, 55.0)
        _rect(img, xp - 0.03 * w, top, xp + pw, top + 2.5 * s, 60.0)
        _rect(img, xp - 0.035 * w, top + 2.5 * s, xp - 0.015 * w, top + 6 * s, 175.0)
    xp, pw = 0.92 * w, max(3.0, 0.012 * w)
    _rect(img, xp, 0.03 * h, xp + pw, h, 72.0)
    _rect(img, xp + 0.6 * pw, 0.03 * h, xp + pw, h, 118.0)
    _rect(img, xp - 0.02 * w, 0.22 * h, xp + pw + 0.02 * w, 0.31 * h, 60.0)
    _rect(img, xp - 0.017 * w, 0.225 * h, xp + pw + 0.017 * w, 0.305 * h, 215.0)

    # The tree's trunk (the crown is a separate, movable layer).
    xt = 0.15 * w
    _poly(
        img,
        (
            (xt - 0.013 * w, 0.96 * h),
            (xt + 0.013 * w, 0.96 * h),
            (xt + 0.006 * w, 0.35 * h),
            (xt - 0.006 * w, 0.35 * h),
        ),
        62.0,
    )

    # Mild texture everywhere, then the lens's blur.
    img += 3.0 * _value_noise((h, w), 6.0 * max(s, 0.5), rng)
    img += rng.normal(0.0, 1.5, (h, w)).astype(np.float32)
    img = cv2.GaussianBlur(img, (0, 0), 0.7)
    return np.clip(img, 0, 255), _paint_crown(w, h, xt, rng)


def _paint_facade(
    img: np.ndarray,
    x0: float,
    x1: float,
    top: float,
    bottom: float,
    w: int,
    h: int,
    rng: np.random.Generator,
) -> None:
    """A building front: wall, cornice, a grid of windows, pilasters, a shop front."""
    s = h / 540.0
    base = rng.uniform(95, 175)
    _rect(img, x0, top, x1, bottom, base)
    _rect(img, x0, top, x1, top + 5 * s, base - 35)
    cw, rh = rng.uniform(0.018, 0.03) * w, rng.uniform(0.045, 0.07) * h
    dark = rng.uniform(40, 75)
    cols = np.arange(x0 + 0.35 * cw, x1 - 0.8 * cw, cw)
    for y in np.arange(top + 0.03 * h, bottom - 0.09 * h - 0.6 * rh, rh):
        for x in cols:
            glass = dark if rng.random() < 0.8 else rng.uniform(160, 205)
            _rect(
                img,
                x - 1.5 * s,
                y - 1.5 * s,
                x + 0.55 * cw + 1.5 * s,
                y + 0.6 * rh + 1.5 * s,
                min(base + 25, 235),
            )
            _rect(img, x, y, x + 0.55 * cw, y + 0.6 * rh, glass)
    step = int(rng.integers(2, 5))
    for x in cols[::step]:
        _rect(
            img,
            x - 0.3 * cw,
            top + 5 * s,
            x - 0.3 * cw + max(2.0, 0.004 * w),
            bottom,
            base + rng.choice((-28.0, 28.0)),
        )
    shop = bottom - 0.06 * h
    _rect(img, x0, shop - 0.012 * h, x1, shop, base - 40)
    _rect(img, x0 + 0.01 * w, shop + 3 * s, x1 - 0.01 * w, bottom, rng.uniform(35, 70))
    door = rng.uniform(x0 + 0.02 * w, max(x0 + 0.02 * w, x1 - 0.04 * w))
    _rect(img, door, shop + 3 * s, door + 0.02 * w, bottom, rng.uniform(20, 50))
    _rect(img, x0, top, x0 + max(1.5, 2 * s), bottom, base - 45)


def _paint_crown(w: int, h: int, xt: float, rng: np.random.Generator) -> _Foliage:
    """The tree's crown: clumps of leaves of many greys, fine texture, gaps, soft edges."""
    s = h / 540.0
    cx, cy, rx, ry = xt, 0.30 * h, 0.11 * w, 0.19 * h
    margin = int(np.ceil(0.05 * h)) + 8
    x0, y0 = max(0, int(cx - rx) - margin), max(0, int(cy - ry) - margin)
    x1, y1 = min(w, int(cx + rx) + margin), min(h, int(cy + ry) + margin)
    ph, pw = y1 - y0, x1 - x0
    value = np.zeros((ph, pw), np.float32)
    alpha = np.zeros((ph, pw), np.float32)
    for _ in range(int(700 * max(rx * ry / (0.11 * 960 * 0.19 * 540), 0.3))):
        r, a = math.sqrt(rng.random()), rng.uniform(0, 2 * math.pi)
        ex, ey = r * math.cos(a), r * math.sin(a)
        c = (int((cx + ex * rx - x0) * _ONE), int((cy + ey * ry - y0) * _ONE))
        size = rng.uniform(0.008, 0.026) * h
        axes = (max(1, int(size * _ONE)), max(1, int(size * rng.uniform(0.55, 1.0) * _ONE)))
        grey = rng.uniform(40, 100) - 25.0 * (ex + ey) / 2  # lit from the top left
        angle = rng.uniform(0, 180)
        cv2.ellipse(value, c, axes, angle, 0, 360, float(grey), -1, cv2.LINE_8, _SHIFT)
        cv2.ellipse(alpha, c, axes, angle, 0, 360, 1.0, -1, cv2.LINE_8, _SHIFT)
    for _ in range(45):  # gaps where the sky shows through
        r, a = math.sqrt(rng.random()) * 0.85, rng.uniform(0, 2 * math.pi)
        c = (
            int((cx + r * math.cos(a) * rx - x0) * _ONE),
            int((cy + r * math.sin(a) * ry - y0) * _ONE),
        )
        axes = (max(1, int(rng.uniform(1.5, 5) * s * _ONE)),) * 2
        cv2.ellipse(alpha, c, axes, 0, 0, 360, 0.0, -1, cv2.LINE_8, _SHIFT)
    inside = alpha > 0
    value += 14.0 * rng.standard_normal((ph, pw)).astype(np.float32)
    value += 8.0 * _value_noise((ph, pw), 4.0 * max(s, 0.5), rng)
    speckle = (rng.random((ph, pw)) < 0.02) & inside
    value[speckle] += 60.0  # leaves catching the light
    value = cv2.GaussianBlur(np.clip(value, 0, 255), (0, 0), 0.6)
    alpha = cv2.GaussianBlur(alpha, (0, 0), 1.0)
    grid_y, grid_x = np.mgrid[0:ph, 0:pw].astype(np.float32)
    gy, gx = np.mgrid[0:6, 0:6] / 5.0
    phase = 2 * np.pi * (rng.uniform(0.4, 0.9) * gx + rng.uniform(0.2, 0.6) * gy)
    return _Foliage(value, alpha, (y0, x0), grid_x, grid_y, phase + rng.uniform(0, 2 * np.pi))


def _along(x_left: float, length: float, direction: float) -> Callable[[float], float]:
    """x of the point a fraction f along a vehicle's body, 0 = rear, 1 = front."""

    def at(f: float) -> float:
        return x_left + length * (f if direction > 0 else 1.0 - f)

    return at


def _draw_vehicle(
    img: np.ndarray,
    x_left: float,
    base: float,
    px_m: float,
    length_m: float,
    direction: float,
    van: bool,
    rng: np.random.Generator,
) -> None:
    """A car or van, side view, wheels on ``base``; ``direction`` +1 drives to the right."""
    h, w = img.shape
    length = length_m * px_m
    x_right = x_left + length

    at = _along(x_left, length, direction)

    # Shadow on the road.
    ys = slice(max(0, int(base - 0.12 * px_m)), min(h, int(base + 0.12 * px_m) + 1))
    xs = slice(max(0, int(x_left + 0.05 * length)), min(w, int(x_right - 0.05 * length) + 1))
    img[ys, xs] *= 0.55
    colour = rng.choice((rng.uniform(25, 70), rng.uniform(110, 150), rng.uniform(175, 230)))
    top_body = base - (2.3 if van else 0.95) * px_m
    _rect(img, x_left, top_body, x_right, base - 0.28 * px_m, colour)
    _rect(img, x_left, base - 0.55 * px_m, x_right, base - 0.28 * px_m, colour * 0.7)
    _rect(img, x_left, top_body, x_right, top_body + 0.06 * px_m, min(colour + 45, 250))
    glass = rng.uniform(30, 70) if rng.random() < 0.7 else rng.uniform(140, 190)
    if van:
        _poly(
            img,
            (
                (at(0.80), top_body + 0.15 * px_m),
                (at(0.97), top_body + 0.15 * px_m),
                (at(0.99), base - 1.2 * px_m),
                (at(0.80), base - 1.2 * px_m),
            ),
            glass,
        )
        _line(img, (at(0.78), top_body), (at(0.78), base - 0.3 * px_m), colour * 0.6, 1)
    else:
        roof = base - 1.45 * px_m
        cabin = ((at(0.20), top_body), (at(0.82), top_body), (at(0.68), roof), (at(0.30), roof))
        _poly(img, cabin, colour)
        inset = 0.07 * px_m
        _poly(
            img,
            (
                (at(0.24), top_body - inset),
                (at(0.78), top_body - inset),
                (at(0.66), roof + inset),
                (at(0.32), roof + inset),
            ),
            glass,
        )
        _line(img, (at(0.50), roof), (at(0.50), base - 0.3 * px_m), colour * 0.6, 1)
    r = 0.33 * px_m
    for f in (0.18, 0.82):
        _circle(img, (at(f), base - r), r, 22.0)
        _circle(img, (at(f), base - r), 0.45 * r, 115.0)
    y_light = base - 0.75 * px_m
    head = 250.0 if rng.random() < 0.6 else 210.0
    _rect(img, at(0.985) - 0.1 * px_m, y_light, at(0.985) + 0.1 * px_m, y_light + 0.12 * px_m, head)
    _rect(
        img,
        at(0.015) - 0.08 * px_m,
        y_light,
        at(0.015) + 0.08 * px_m,
        y_light + 0.15 * px_m,
        rng.uniform(70, 170),
    )


def _draw_wet_road(
    img: np.ndarray,
    x_left: float,
    base: float,
    px_m: float,
    length_m: float,
    direction: float,
    wet: float,
    rng: np.random.Generator,
) -> None:
    """What a vehicle does to a wet road, drawn after it (``wet`` in (0, 1], ``rng`` fresh each
    frame): the spray its wheels throw up behind them, a cloud of bright specks that changes
    from frame to frame, and its lights mirrored in the road, vertical bright streaks under the
    head- and taillights that flicker with the water film. Both move with the vehicle."""
    h, w = img.shape
    length = length_m * px_m

    at = _along(x_left, length, direction)

    # Reflections of the lights: 0.6-1.1 m long, 0.1 m wide, fading downward.
    for f, bright in ((0.985, 0.45), (0.015, 0.3)):
        x = at(f)
        if not 0 <= x < w:
            continue
        long = rng.uniform(0.6, 1.1) * px_m
        flicker = rng.uniform(0.6, 1.0)
        steps = 4
        for k in range(steps):
            y0 = base + 0.05 * px_m + long * k / steps
            value = 255.0 * bright * wet * flicker * (1.0 - k / steps)
            strip = img[
                max(int(y0), 0) : min(int(y0 + long / steps) + 1, h),
                max(int(x - 0.05 * px_m), 0) : min(int(x + 0.05 * px_m) + 1, w),
            ]
            strip += np.float32(value * 0.35)
    # Spray behind each wheel: specks about 1 px across at 16 px a metre, up to 1.6 m back and
    # 0.9 m up, 15-50 grey levels brighter than what they cover.
    n = int(wet * 70 * (px_m / 16.0) ** 2)
    if n <= 0:
        return
    back = -direction
    xs = np.concatenate(
        [at(f) + back * np.abs(rng.normal(0.2, 0.6, n)) * px_m for f in (0.18, 0.82)]
    )
    ys = base - np.abs(rng.normal(0.0, 0.35, 2 * n)) * px_m
    value = rng.uniform(15.0, 50.0, 2 * n) * wet
    inside = (xs >= 0) & (xs < w) & (ys >= 0) & (ys < h)
    if not inside.any():
        return
    x0, x1 = int(xs[inside].min()), int(xs[inside].max()) + 1
    y0, y1 = int(ys[inside].min()), int(ys[inside].max()) + 1
    pad = 4 + int(px_m / 8)
    x0, y0, x1, y1 = max(x0 - pad, 0), max(y0 - pad, 0), min(x1 + pad, w), min(y1 + pad, h)
    layer = np.zeros((y1 - y0, x1 - x0), np.float32)
    np.add.at(
        layer, ((ys[inside] - y0).astype(np.intp), (xs[inside] - x0).astype(np.intp)), value[inside]
    )
    sigma = max(0.5, 0.5 * px_m / 16.0)
    img[y0:y1, x0:x1] += cv2.GaussianBlur(layer, (0, 0), sigma) * np.float32(
        2 * np.pi * sigma * sigma
    )


def _draw_walker(
    img: np.ndarray, x: float, base: float, height: float, t_s: float, rng: np.random.Generator
) -> None:
    """A walking figure of ``height`` px, feet on ``base``, legs and arms swinging."""
    swing = math.sin(2 * math.pi * 0.9 * t_s + rng.uniform(0, 2 * math.pi))
    coat, trousers = rng.uniform(30, 200), rng.uniform(25, 110)
    hip_y, shoulder_y = base - 0.48 * height, base - 0.82 * height
    limb = max(1.0, 0.075 * height)
    stride = 0.16 * height * swing
    _line(img, (x, hip_y), (x + stride, base), trousers, limb)
    _line(img, (x, hip_y), (x - stride, base), trousers * 0.85, limb)
    _poly(
        img,
        (
            (x - 0.12 * height, shoulder_y),
            (x + 0.12 * height, shoulder_y),
            (x + 0.1 * height, hip_y),
            (x - 0.1 * height, hip_y),
        ),
        coat,
    )
    _line(
        img,
        (x, shoulder_y + 0.03 * height),
        (x - 0.6 * stride, hip_y + 0.04 * height),
        coat * 0.8,
        limb * 0.8,
    )
    _circle(img, (x, shoulder_y - 0.08 * height), 0.07 * height, rng.uniform(120, 175))
