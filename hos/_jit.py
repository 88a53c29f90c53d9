"""Compiled kernels for the per-pixel and per-blob steps between MOG2 and the HOS.

Why compiled code: after OpenCV's MOG2 (the floor of the method), the detector's remaining work
per frame is many small steps (the photometric rule, the running background, the candidate list,
the connected components, the moments, the candidate rate). Written as numpy and OpenCV calls,
each step is cheap but each is a full pass over the image or a call with fixed overhead; together
they cost about as much again as MOG2 at 960x540 (``docs/figures.md``). numba fuses them into two
passes: one over the pixels (the photometric rule and the background together) and one over the
*candidate pixels only* (labelling, moments and the structure rule's rate together).

The readable reference of every kernel stays in the numpy modules (``hos.background``,
``hos.blobs``, ``hos.moments``); tests prove the kernels equal to it, and the detector falls back
to it when numba is not installed or ``HOS_JIT=0`` is set in the environment.

The loops below are compiled, not interpreted: they are the per-pixel loops that the house style
forbids in Python, written once in the one place where a loop is the clearest and fastest form.
"""

from __future__ import annotations

import time

import numpy as np

from ._numba import ENABLED, _njit, why_disabled
from .moments import _PIXEL_VAR

__all__ = [
    "ENABLED",
    "compile_in_parallel",
    "grown_along_lines",
    "label_sparse",
    "photometric_candidates",
    "warm_up",
    "why_disabled",
]


@_njit
def _photometric_candidates(gray, fg, bg, c, out_index):  # pragma: no cover - compiled
    n = 0
    n_fg = 0
    size = gray.size
    whole = size - size % 8
    words = fg[:whole].view(np.uint64)
    for w in range(words.size):
        if words[w] == 0:  # eight background pixels at once
            continue
        # Branch-free within the word (the foreground bytes are unpredictable): always write
        # the index, advance only for a candidate. eq. 8, saturating at 255 as
        # photometric_rule does.
        for i in range(8 * w, 8 * w + 8):
            f = fg[i] != 0
            n_fg += f
            out_index[n] = i
            n += f & (gray[i] >= min(int(bg[i]) + c, 255))
    for i in range(whole, size):
        f = fg[i] != 0
        n_fg += f
        out_index[n] = i
        n += f & (gray[i] >= min(int(bg[i]) + c, 255))
    return n, n_fg


def photometric_candidates(
    gray: np.ndarray, fg: np.ndarray, background: np.ndarray, *, c: int
) -> tuple[np.ndarray, int]:
    """Eq. 8 at the foreground pixels; see ``hos.background.photometric_rule``.

    One compiled pass that skips background pixels eight at a time and reads the background
    at the (few) foreground pixels only.

    Parameters
    ----------
    gray, fg : (H, W) uint8, the frame and MOG2's foreground (nonzero = foreground)
    background : (H, W) uint8, C-contiguous, the running background as grey levels
    c : grey levels of eq. 8

    Returns
    -------
    index : (N,) intp, flat indices ``y * W + x`` of the candidate pixels, ascending
    n_foreground : pixels in MOG2's foreground
    """
    out = np.empty(gray.size, np.intp)
    n, n_fg = _photometric_candidates(
        gray.reshape(-1), fg.reshape(-1), background.reshape(-1), int(c), out
    )
    return out[:n].copy(), int(n_fg)


@_njit
def _grown_along_lines(index, diff, limit, offsets, c, h, w, out):  # pragma: no cover - compiled
    # state: 0 untested, 1 candidate or joined, 2 tested and refused. ``out`` is the queue:
    # the pixels from ``head`` to ``n`` are found and their neighbours not yet tested.
    state = np.zeros(h * w, np.uint8)
    n = 0
    for k in range(index.size):
        state[index[k]] = 1
        out[n] = index[k]
        n += 1
    n_lines = offsets.shape[0]
    length = offsets.shape[1]
    head = 0
    while head < n:
        p = out[head]
        head += 1
        py = p // w
        px = p - py * w
        for ny in range(max(py - 1, 0), min(py + 2, h)):
            for nx in range(max(px - 1, 0), min(px + 2, w)):
                q = ny * w + nx
                if state[q] != 0:
                    continue
                if diff[q] < c:
                    state[q] = 2
                    continue
                best = -1 << 30
                for i in range(n_lines):
                    total = 0
                    for j in range(length):
                        y = min(max(ny + offsets[i, j, 0], 0), h - 1)
                        x = min(max(nx + offsets[i, j, 1], 0), w - 1)
                        total += diff[y * w + x]
                    best = max(best, total)
                if best >= limit[q]:
                    state[q] = 1
                    out[n] = q
                    n += 1
                else:
                    state[q] = 2
    return n


def grown_along_lines(
    index: np.ndarray, diff: np.ndarray, limit: np.ndarray, offsets: np.ndarray, *, c: int
) -> np.ndarray:
    """The candidates and the pixels that complete them along a line; see
    ``hos.background.grown_along_lines``. A search from the candidates outwards: only the
    pixels next to a candidate or to a pixel joined are tested, so a frame pays for its
    candidates' surroundings, not for its size.

    Parameters
    ----------
    index : (N,) intp, the candidates' flat indices
    diff : (H, W) int16, the frame minus the background
    limit : (H, W) float32, what a line's sum must reach (``hos.background.line_limit``)
    offsets : (orientations, length, 2) int32 (dy, dx) (``hos.background.line_offsets``)
    c : what ``diff`` must be at a pixel joined

    Returns
    -------
    (M,) intp ascending flat indices, ``index`` among them.
    """
    h, w = diff.shape
    out = np.empty(h * w, np.intp)
    n = _grown_along_lines(
        np.ascontiguousarray(index, np.intp),
        np.ascontiguousarray(diff, np.int16).reshape(-1),
        np.ascontiguousarray(limit, np.float32).reshape(-1),
        np.ascontiguousarray(offsets, np.int32),
        int(c),
        h,
        w,
        out,
    )
    return np.sort(out[:n])


@_njit
def _find(parent, k):  # pragma: no cover - compiled
    root = k
    while parent[root] != root:
        root = parent[root]
    while parent[k] != root:  # path compression
        nxt = parent[k]
        parent[k] = root
        k = nxt
    return root


@_njit
def _label_sparse(index, width, rate, pixel_var, min_area, max_area):  # pragma: no cover - compiled
    n = index.size
    parent = np.arange(n)
    xs = np.empty(n)
    ys = np.empty(n)
    j = 0  # first candidate that may touch the row above the current pixel
    y = 0
    row_start = 0
    for k in range(n):
        p = index[k]
        while p >= row_start + width:  # the row, without a division
            y += 1
            row_start += width
        x = p - row_start
        xs[k] = x
        ys[k] = y
        # 8-connectivity with the neighbours met before this pixel in raster order. The
        # candidates are sorted, so the row above is a run of the list just behind a pointer
        # that only moves forward: no image-sized table, no random access.
        # The pixel joins the component of its first neighbour; any other neighbour's component
        # is merged into the older of the two (a component's root is its first pixel).
        root = k
        if x > 0 and k > 0 and index[k - 1] == p - 1:
            root = _find(parent, k - 1)
        if y > 0:
            lo = p - width - (1 if x > 0 else 0)
            hi = p - width + (1 if x < width - 1 else 0)
            while j < k and index[j] < lo:
                j += 1
            q = j
            while q < k and index[q] <= hi:
                other = _find(parent, q)
                if root == k:
                    root = other
                elif other < root:
                    parent[root] = other
                    root = other
                elif other > root:
                    parent[other] = root
                q += 1
        parent[k] = root
    # Labels 1.. in order of each component's first pixel (its root: a parent always comes
    # before its child, so one look-up per pixel finds the root); 0 is the background.
    labels = np.empty(n, np.int32)
    n_labels = 1
    for k in range(n):
        r = parent[parent[k]]
        parent[k] = r
        if r == k:
            labels[k] = n_labels
            n_labels += 1
        else:
            labels[k] = labels[r]
    # Moments as hos.moments.blob_moments computes them, summed in the same (raster) order:
    # area, centroid, then central second moments about the centroid (eq. 13).
    area = np.zeros(n_labels)
    sx = np.zeros(n_labels)
    sy = np.zeros(n_labels)
    srate = np.zeros(n_labels)
    for k in range(n):
        lab = labels[k]
        area[lab] += 1.0
        sx[lab] += xs[k]
        sy[lab] += ys[k]
        if rate.size:
            srate[lab] += rate[index[k]]
    inv = np.empty(n_labels)
    x0 = np.empty(n_labels)
    y0 = np.empty(n_labels)
    inv[0] = np.inf
    x0[0] = np.nan
    y0[0] = np.nan
    for lab in range(1, n_labels):
        inv[lab] = 1.0 / area[lab]
        x0[lab] = sx[lab] * inv[lab]
        y0[lab] = sy[lab] * inv[lab]
    # Second moments and ellipses of the blobs that the size rule can accept only (most blobs
    # are specks of a pixel or two); the others get NaN.
    sized = (area >= min_area) & (area <= max_area)
    s20 = np.zeros(n_labels)
    s11 = np.zeros(n_labels)
    s02 = np.zeros(n_labels)
    for k in range(n):
        lab = labels[k]
        if not sized[lab]:
            continue
        dx = xs[k] - x0[lab]
        dy = ys[k] - y0[lab]
        s20[lab] += dx * dx
        s11[lab] += dx * dy
        s02[lab] += dy * dy
    # Ellipse of each blob, eqs. 14-17, as hos.moments.moments_from_central.
    m20 = np.full(n_labels, np.nan)
    m11 = np.full(n_labels, np.nan)
    m02 = np.full(n_labels, np.nan)
    theta = np.full(n_labels, np.nan)
    a = np.full(n_labels, np.nan)
    b = np.full(n_labels, np.nan)
    for lab in range(1, n_labels):
        if not sized[lab]:
            continue
        m20[lab] = s20[lab] * inv[lab] + pixel_var
        m11[lab] = s11[lab] * inv[lab]
        m02[lab] = s02[lab] * inv[lab] + pixel_var
        theta[lab] = np.mod(0.5 * np.arctan2(2.0 * m11[lab], m20[lab] - m02[lab]), np.pi)
        half_trace = 0.5 * (m20[lab] + m02[lab])
        root = np.sqrt((0.5 * (m20[lab] - m02[lab])) ** 2 + m11[lab] * m11[lab])
        a[lab] = 2.0 * np.sqrt(half_trace + root)
        b[lab] = 2.0 * np.sqrt(max(half_trace - root, 0.0))
    return labels, n_labels, area, x0, y0, m20, m11, m02, theta, a, b, srate


def label_sparse(
    index: np.ndarray,
    shape: tuple[int, int],
    rate: np.ndarray | None = None,
    *,
    min_area: float = 0.0,
    max_area: float = np.inf,
) -> tuple:
    """8-connected components, moments and ellipses of a sparse candidate set, in one pass.

    Parameters
    ----------
    index : (N,) intp, ascending flat indices of the candidate pixels of an image of ``shape``
    rate : (H * W,) float32, optional; its sum over each blob is returned
    min_area, max_area : second moments and ellipses are computed only for the blobs whose area
        is in this range (the size rule's); the others get NaN

    Returns
    -------
    pixel_labels (N,) int32 (1..n_labels-1, in order of each blob's first pixel),
    n_labels (including 0), then (n_labels,) float64: area, x0, y0, m20, m11, m02 (eq. 13, with
    the pixel's own 1/12), theta, a, b (eqs. 14-17) as :func:`hos.moments.blob_moments`, and the
    sum of ``rate`` over the blob.
    """
    empty = np.zeros(0, np.float32)
    index = np.ascontiguousarray(index, dtype=np.intp)
    return _label_sparse(
        index,
        shape[1],
        empty if rate is None else rate,
        _PIXEL_VAR,
        float(min_area),
        float(max_area),
    )


#: The kernels' entry points in two groups of about equal compile time (9.4 and 9.0 s on the
#: 2-core test machine), so that :func:`compile_in_parallel` can build them on two cores.
WARM_UP_GROUPS = (
    ("photometric_candidates", "grown_along_lines", "fit_mixture"),
    ("label_sparse", "global_translation"),
)


def warm_up(group: int | None = None) -> float:
    """Compile every kernel now, or load it from numba's on-disk cache; the seconds it took.

    The first call of a kernel in a process compiles it (a few seconds each, once per install:
    the machine code is then cached) or loads it (about 0.3 s for the first, a few ms for the
    others). The arguments have the types the detector passes, so the same compiled code is used.
    ``group`` (an index into :data:`WARM_UP_GROUPS`) limits it to those kernels.
    """
    if group is None:
        names = {name for names in WARM_UP_GROUPS for name in names}
    elif group in range(len(WARM_UP_GROUPS)):
        names = set(WARM_UP_GROUPS[group])
    else:
        raise ValueError(f"unknown kernel group {group!r}; expected 0 to {len(WARM_UP_GROUPS) - 1}")
    if not ENABLED:
        return 0.0
    from ._jit_mixture import fit_mixture_jit
    from ._jit_motion import global_translation_jit

    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    shape = (30, 40)
    gray = rng.integers(0, 256, shape, dtype=np.uint8)
    fg = np.where(gray > 128, 255, 0).astype(np.uint8)
    index = np.flatnonzero(fg)
    if "photometric_candidates" in names:
        photometric_candidates(gray, fg, gray // 2, c=3)
    if "label_sparse" in names:
        label_sparse(index, shape, np.zeros(gray.size, np.float32), min_area=4.0, max_area=50.0)
        label_sparse(index, shape, None, min_area=4.0, max_area=50.0)
    if "grown_along_lines" in names:
        diff = gray.astype(np.int16) - 128
        lines = np.zeros((2, 3, 2), np.int32)
        grown_along_lines(index, diff, np.full(shape, 9.0, np.float32), lines, c=3)
    if "fit_mixture" in names:
        theta = np.arange(180) * (np.pi / 180)
        fit_mixture_jit(1.0 + 10.0 * np.exp(-0.5 * ((theta - 1.2) / 0.1) ** 2))
    if "global_translation" in names:
        small = rng.random(shape, dtype=np.float32) * 255
        global_translation_jit(small, np.roll(small, 1, axis=1))
    return time.perf_counter() - t0


def compile_in_parallel() -> float:
    """Fill numba's on-disk cache with every kernel, one group per process; the seconds it took.

    ``make install`` calls this so that no run pays the compilation: 19-21 s on one core, about
    12 s on two. Each group is built in a fresh (spawned) process, which writes its machine code
    to the cache and exits; this process loads nothing.
    """
    if not ENABLED:
        return 0.0
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    t0 = time.perf_counter()
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(len(WARM_UP_GROUPS), mp_context=context) as pool:
        list(pool.map(warm_up, range(len(WARM_UP_GROUPS))))
    return time.perf_counter() - t0
