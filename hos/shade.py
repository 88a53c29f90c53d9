"""Cloud shade: a smooth, local change of light, undone before the background model sees it.

Beyond the paper (docs/method.md, departure 31). The exposure compensation of
``HosDetector._compensate_exposure`` undoes one gain for the whole view; the shade of a
passing cloud darkens part of it, and its soft edge sweeps over the scene for seconds. Eq. 8
then sees every textured pixel under the moving edge change, the camera-offset fit reads the
sweep as motion (2-3 px on a camera that does not move), and the edges of walls and posts that
the light crosses cut thin vertical slivers that vote like rain.

Light multiplies: under a shade of gain g every pixel of a cell reads g times what it did,
whatever its texture, so the log ratio of the reference to the frame is the same for all of
them. An object that enters the cell (a vehicle, a pedestrian) changes each pixel by its own
amount, spreads that ratio, and brings a texture of its own. :func:`shade_field` takes a
cell's change for light when

- it is more than ``tolerance``, or, where no correction is under way around the cell, more
  than ``onset`` (a cloud's shade takes a fifth of the light or more; rain's veil and a
  truck's spray change a cell by a few per cent);
- it is coherent: the median absolute deviation of the cell's log ratios is at most
  ``coherence`` times their median (a ramp across the cell has 0.5);
- the cell's texture, where it has one, is the reference's (correlation 0.7 or more); a plain
  cell (sky, an empty road) has none to tell by and needs most of its neighbours coherent the
  same way;
- at least two of its neighbours changed alike: a change of light is wider than a cell.

A cell changed otherwise (foliage, a vehicle under the shade) takes its neighbours' mean when
most of them are light, and is *in doubt* when they are not: the detector lets the correction
it holds there fade. The field is the cells' gains, bilinear between the cell centres.

Rain only adds light, to few pixels of a cell: the median ratio does not see it.
"""

from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

__all__ = ["ShadeStep", "apply_field", "shade_field", "upsample"]

_LO, _HI = 12.0, 243.0  # grey levels outside are clipped or too dark to give a ratio
_MIN_SHARE = 0.25  # a cell needs this share of usable samples
_ALIKE = 2  # a changed cell is kept with this many of its 8 neighbours changed alike
_MOST = 5 / 8  # most of a cell's neighbours (5 of 8; 4 of 5 on an edge, 2 of 3 in a corner)
_TEXTURE = 0.03  # a cell whose reference varies less (log grey levels) has no texture
_STEP = 0.1  # the largest change of a cell's log gain from one frame to the next
_CORRELATION = 0.7  # the frame's texture follows the reference's this well under light


class ShadeStep(NamedTuple):
    """What one frame says about the shade's cells."""

    #: (ny, nx) float32: log gain to add to each cell's (0: none)
    step: np.ndarray
    #: (ny, nx) bool: cells that differ from the reference by more than the tolerance, in a
    #: way light does not explain (an object, or a shade that has gone)
    doubt: np.ndarray


def shade_field(
    frame: np.ndarray,
    reference: np.ndarray,
    *,
    cell: int,
    tolerance: float,
    coherence: float,
    onset: float = 0.0,
    active: np.ndarray | None = None,
) -> ShadeStep | None:
    """Per-cell log gain that brings ``frame`` onto ``reference``; None when every cell
    matches it.

    Parameters
    ----------
    frame, reference : (h, w) float32, the reduced frame (exposure-corrected) and the reduced
        slow background it is compared with
    cell : cell side, pixels of these images
    tolerance : a cell's log gain below this is no change
    coherence : a cell's gain is kept when the median absolute deviation of its pixels' log
        ratios is at most this times the log gain
    onset : a change of light begins with a log gain above this (a cloud's shade), where
        ``active`` (ny, nx) bool, the cells already corrected and their neighbours, does not
        say that one is under way: a few per cent of a cell are rain's veil, a truck's spray

    Returns
    -------
    :class:`ShadeStep`: the log gains to add to the cells (the frame is multiplied by their
    ``exp``), and the cells in doubt; None when no cell differs.
    """
    h, w = frame.shape
    ny, nx = -(-h // cell), -(-w // cell)
    if active is None and h >= cell and w >= cell:
        # no shade under way: a cell's mean moved by half the onset at least, or nothing to do
        # (two area reductions, a tenth of the rest's cost on most frames)
        fy, fx = h // cell, w // cell
        size = (fx, fy)
        mf = cv2.resize(frame[: fy * cell, : fx * cell], size, interpolation=cv2.INTER_AREA)
        mr = cv2.resize(reference[: fy * cell, : fx * cell], size, interpolation=cv2.INTER_AREA)
        if np.all(np.abs(np.log((mr + 1.0) / (mf + 1.0))) < 0.5 * max(onset, tolerance)):
            return None
    # a sample every 4th pixel of every 4th row (5 x 5 in a cell of 20) is plenty for a
    # median and a deviation
    step = next(k for k in (4, 2, 1) if cell % k == 0 and cell // k >= 4)
    f = frame[::step, ::step]
    r = reference[::step, ::step]
    c = cell // step
    valid = (f > _LO) & (f < _HI) & (r > _LO) & (r < _HI)
    with np.errstate(divide="ignore", invalid="ignore"):
        lf = _cells(np.where(valid, np.log(f), np.nan), ny, nx, c)
        lr = _cells(np.where(valid, np.log(r), np.nan), ny, nx, c)
    # per cell, from the samples valid in both: the log ratio's median and its median absolute
    # deviation, and how well the frame's texture follows the reference's (correlation)
    ratio = lr - lf
    samples = np.sort(ratio, axis=2)  # NaNs go last
    count = np.count_nonzero(~np.isnan(samples), axis=2)
    usable = count >= _MIN_SHARE * c * c
    half = np.maximum(count - 1, 0) // 2
    median = np.take_along_axis(samples, half[..., None], axis=2)[..., 0]
    deviation = np.sort(np.abs(samples - median[..., None]), axis=2)
    mad = np.take_along_axis(deviation, half[..., None], axis=2)[..., 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        n = np.maximum(count, 1)[..., None]
        df = lf - np.nansum(lf, axis=2, keepdims=True) / n
        dr = lr - np.nansum(lr, axis=2, keepdims=True) / n
        vf, vr = np.nansum(df * df, axis=2), np.nansum(dr * dr, axis=2)
        corr = np.nansum(df * dr, axis=2) / np.sqrt(vf * vr)
        vr = vr / n[..., 0]
    textured = usable & (vr >= _TEXTURE**2)
    strength = np.abs(median)
    threshold = np.float32(max(onset, tolerance))
    if active is not None and active.shape == strength.shape:
        threshold = np.where(active, np.float32(tolerance), threshold)
    changed = usable & (strength > threshold)
    # light multiplies: every pixel alike (coherent), the texture kept where there is one
    coherent = changed & (mad <= coherence * strength)
    keep = coherent & textured & (corr >= _CORRELATION)  # NaN compares False
    # neighbours a cell has (8; 5 on an edge of the grid, 3 in a corner), and "most" of them
    neighbours = _box(np.ones_like(median)) - 1.0
    most = np.ceil(_MOST * neighbours)
    # a plain cell (sky, an empty road) has no texture to tell by: its change is light when it
    # is coherent and so are most of its neighbours (a shade, not a vehicle)
    for sign in (1.0, -1.0):
        alike = (coherent & (sign * median > 0)).astype(np.float32)
        keep |= (alike > 0) & ~textured & (_box(alike) - alike >= most)
    # an object over the view: texture of its own; or no texture to tell by
    spread = (changed & ~keep) | ~usable
    # A change of light is wider than a cell: a cell is kept with at least two of its
    # neighbours changed the same way (an edge of the shade has three), never alone; a cell
    # the light changed under a moving object (swaying foliage, a vehicle), too spread to
    # pass, or with too few usable pixels, takes the mean of its neighbours when most of them
    # changed alike.
    gains = np.where(keep, median, np.float32(0.0)).astype(np.float32)
    step = np.zeros_like(gains)
    explained = np.zeros(gains.shape, bool)
    for sign in (1.0, -1.0):
        same = (keep & (sign * median > 0)).astype(np.float32)
        around = _box(same) - same
        total = _box(gains * same) - gains * same
        kept = (same > 0) & (around >= _ALIKE)
        filled = spread & (around >= most)
        step[kept] = gains[kept]
        step[filled] = total[filled] / around[filled]
        explained |= kept | filled
    doubt = changed & ~explained
    if not explained.any() and not doubt.any():
        return None
    # the shade of a cloud comes over a cell in a second or more, not in a frame
    return ShadeStep(np.clip(step, -_STEP, _STEP, out=step), doubt)


def _cells(a: np.ndarray, ny: int, nx: int, c: int) -> np.ndarray:
    """(ny, nx, c * c): the samples of each cell of ``a``, NaN beyond its edge."""
    out = np.full((ny * c, nx * c), np.nan, np.float32)
    out[: a.shape[0], : a.shape[1]] = a
    return out.reshape(ny, c, nx, c).transpose(0, 2, 1, 3).reshape(ny, nx, c * c)


def _box(a: np.ndarray) -> np.ndarray:
    """Sum of each cell's 3 x 3 neighbourhood (zero outside the grid)."""
    return cv2.boxFilter(a, -1, (3, 3), normalize=False, borderType=cv2.BORDER_CONSTANT)


def apply_field(gray: np.ndarray, log_gains: np.ndarray, gain: float, cell: float) -> np.ndarray:
    """``gray`` times ``gain`` times the field of ``log_gains``, as uint8.

    ``cell`` is the cells' side in pixels of ``gray``: the field is bilinear between the cell
    centres, cell (0, 0) starting at the top left corner.
    """
    h, w = gray.shape
    return cv2.multiply(gray, upsample(log_gains, cell, (h, w)), scale=gain, dtype=cv2.CV_8U)


def upsample(log_gains: np.ndarray, cell: float, shape: tuple[int, int]) -> np.ndarray:
    """(H, W) float32 gains from the cells' log gains (cells of ``cell`` pixels from the top
    left corner; bilinear between their centres, constant beyond the outer ones)."""
    h, w = shape
    ny, nx = log_gains.shape
    span_w, span_h = max(round(nx * cell), w), max(round(ny * cell), h)
    field = cv2.resize(np.exp(log_gains), (span_w, span_h), interpolation=cv2.INTER_LINEAR)
    return field[:h, :w]
