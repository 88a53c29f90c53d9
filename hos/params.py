"""Parameters of the detector: frozen dataclasses whose defaults are the paper's values.

Every number of Bossu, Hautière & Tarel (IJCV 2011) that the method needs is here, with the
section or equation it comes from. Parameters that go beyond the paper (robustness, see
``docs/method.md``) say so. All angles are radians inside the code; the user-facing JSON and the
config use degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any, Literal

from .ptype import PtypeParams

__all__ = [
    "ANGLE_PARAMETERS",
    "DecisionParams",
    "DetectorParams",
    "HistogramParams",
    "MixtureParams",
    "RobustnessParams",
    "SegmentationParams",
]


def _check(ok: bool, key: str, what: str) -> None:
    if not ok:
        raise ValueError(f"{key}: {what}")


@dataclass(frozen=True)
class SegmentationParams:
    """Candidate streak pixels and blobs (paper section 2)."""

    #: ``"mog"``: mixture-of-Gaussians background subtraction (eqs. 3-6) + photometric rule
    #: (eq. 8). ``"framediff"``: the rule of eq. 32, ``I_n - I_{n-1} >= c`` and
    #: ``I_n - I_{n+1} >= c``, with one frame of delay.
    method: Literal["mog", "framediff"] = "mog"
    #: MoG memory in frames; the decay factor of eq. 6 is ``gamma_1 = 1 / history``.
    mog_history: int = 500
    #: Number of Gaussians per pixel (K of eq. 3).
    mog_mixtures: int = 3
    #: D of section 2.2: a pixel further than D standard deviations from every background
    #: component is foreground. OpenCV's MOG2 takes D squared as ``varThreshold``.
    mog_d: float = 3.0
    #: T of eq. 5, minimum prior probability of observing a background pixel.
    mog_background_ratio: float = 0.9
    #: c of eqs. 8 and 32 (grey levels): rain is brighter than what it occludes.
    photometric_c: float = 3.0
    #: Size rule (section 2.4): blob areas in pixels at ``size_reference_height`` rows, scaled
    #: to the frame's height so that one setting serves every resolution (below).
    min_area: int = 4
    #: 120, not the published reimplementation's 50 (beyond the paper): a soft lens spreads a
    #: flake or a streak over more pixels than the sharp camera the bound was set for; at 270
    #: rows and 1.2 px of blur, half the flakes were over 50's bound (docs/method.md,
    #: departure 38).
    max_area: int = 120
    size_reference_height: int = 480
    #: How ``min_area`` scales. ``"area"``: with the height squared, as ``max_area`` does; at
    #: 1080 rows it rejects every blob of fewer than 21 pixels. ``"length"`` (beyond the
    #: paper): with the height, since a streak is a pixel or two wide at any resolution and
    #: its area grows as its length: faint short streaks at 720 and 1080 rows are seen, and so
    #: are more fragments of swaying foliage and of a shaken view. With ``min_area_px`` they
    #: agree at 240 rows and below and at 360; "length" asks 3 pixels at 270 rows (2 with
    #: "area"), 6 at 720 (9) and 9 at 1080 (21). ``"still"`` (the default): the lower of the
    #: two while the camera stands still, the area law while it is shaken (an offset of
    #: ``robustness.shaken_px`` or more within ``motion_window_frames``) (docs/method.md,
    #: departure 15). ``"lower"`` (an option, departure 47): the lower of the two whether the
    #: camera is shaken or not; it sees drizzle under a camera in the wind at 720 and 1080
    #: rows, and said clear weather under a cloud's shade through a soft lens was rain.
    min_area_scaling: Literal["length", "area", "still", "lower"] = "still"
    #: How ``max_area`` scales with the frame: "streak" (default), the larger of the area law
    #: and the length law, or "area", the paper's bound scaled with the frame's area. A
    #: streak is about a pixel wide at any resolution, so its area grows with the height
    #: only: below the reference height the area law rejected the long streaks of a 240-row
    #: frame (12.5 pixels at most; "streak" allows 25). Above it both laws give the area's
    #: (docs/method.md, departure 16).
    max_area_scaling: Literal["streak", "area"] = "streak"
    #: Beyond the paper: whatever the resolution, a blob of fewer pixels has no orientation to
    #: vote with (one pixel's second moments are isotropic; two give 0, 45 or 90 degrees).
    #: 0 keeps the scaled ``min_area`` alone.
    min_area_px: int = 2
    #: Beyond the paper: a blob larger than the scaled ``max_area``, up to ``thin_factor``
    #: times it, is still streak-sized when it is thin: its area over its length (the length
    #: from its moments, sqrt(3) a, eq. 15) at most ``thin_width`` pixels. A drop near the
    #: camera, or seen through a long exposure (night), draws a streak longer than the area
    #: bound allows (50 pixels at 480 rows: a streak 1.5 pixels wide and 33 long), while
    #: what the bound is for (vehicles, pedestrians, merged streaks) is wide. 1: the area
    #: bound alone (docs/method.md, departure 25).
    thin_factor: float = 4.0
    thin_width: float = 2.5
    #: Learning rate of the running background image used by the photometric rule.
    background_rate: float = 0.02
    #: Beyond the paper (departure 36): a streak completed along its line. A pixel that eq. 8
    #: keeps (``photometric_c`` brighter than the background) but that MOG2 left in the
    #: background joins the candidates when the mean of the frame's difference from the
    #: background along a line of ``line_length`` pixels through it, at the best of
    #: ``line_orientations`` orientations, is at least ``max(photometric_c, line_k *
    #: noise / sqrt(line_length))``, the noise being the local standard deviation of that
    #: difference (its mean absolute value times sqrt(pi / 2) over ``line_window`` pixels
    #: square), and when it touches a candidate through such pixels: a faint streak's pixels,
    #: under MOG2's per-pixel threshold, integrated along the streak. 9 (the default since
    #: departure 40): more faint rain seen (the real motorway in heavy rain 63 -> 88 % of its
    #: frames with ``moved_edge_px = 2``, which keeps the slivers of edges it would grow from
    #: voting); 0: off, eq. 8 alone, and cheaper (the detector alone took 1.45-1.64 times as
    #: long with it on, on two real clips; docs/method.md, departures 36, 40).
    line_length: int = 9
    line_orientations: int = 12
    line_k: float = 6.0
    line_window: int = 31
    #: Each pixel's difference counts toward a line's sum up to ``line_cap`` times the
    #: line's per-pixel threshold, so that the line must be met along its length, not by one
    #: bright blob on it (a snowflake lengthening itself). 0: no cap (the rule as first
    #: tried, which cost snow in the wind its detection). Used only with ``line_length``.
    line_cap: float = 1.5

    def __post_init__(self) -> None:
        _check(self.method in ("mog", "framediff"), "method", 'must be "mog" or "framediff"')
        _check(self.mog_history >= 1, "mog_history", "must be >= 1")
        _check(1 <= self.mog_mixtures <= 8, "mog_mixtures", "must be in 1..8")
        _check(self.mog_d > 0, "mog_d", "must be > 0")
        _check(0 < self.mog_background_ratio <= 1, "mog_background_ratio", "must be in (0, 1]")
        _check(0 <= self.photometric_c < 255, "photometric_c", "must be in [0, 255)")
        _check(
            self.line_length == 0 or self.line_length >= 3,
            "line_length",
            "must be 0 (off) or >= 3",
        )
        _check(self.line_orientations >= 2, "line_orientations", "must be >= 2")
        _check(self.line_k >= 0, "line_k", "must be >= 0")
        _check(self.line_window >= 3, "line_window", "must be >= 3")
        _check(self.line_cap == 0 or self.line_cap >= 1, "line_cap", "must be 0 (no cap) or >= 1")
        _check(1 <= self.min_area <= self.max_area, "min_area", "must be >= 1 and <= max_area")
        _check(self.size_reference_height >= 1, "size_reference_height", "must be >= 1")
        _check(
            self.min_area_scaling in ("length", "area", "still", "lower"),
            "min_area_scaling",
            'must be "length", "area", "still" or "lower"',
        )
        _check(
            self.max_area_scaling in ("streak", "area"),
            "max_area_scaling",
            'must be "streak" or "area"',
        )
        _check(0 <= self.min_area_px <= self.max_area, "min_area_px", "must be in [0, max_area]")
        _check(self.thin_factor >= 1, "thin_factor", "must be >= 1")
        _check(self.thin_width > 0, "thin_width", "must be > 0")
        _check(0 < self.background_rate <= 1, "background_rate", "must be in (0, 1]")


@dataclass(frozen=True)
class HistogramParams:
    """The HOS (section 3, eqs. 13-20)."""

    bins: int = 180
    #: dm of eq. 19, the uncertainty of a second-order moment (px^2). The paper chose it "in
    #: simulation"; ours is chosen the same way: 0.4 smooths the HOS of a few hundred streaks
    #: enough for the goodness-of-fit test while widening the fitted sigma by under 6 % for
    #: streaks of 5 px and more (docs/method.md).
    dm: float = 0.4
    #: Clamp of the per-blob orientation uncertainty (eq. 19 diverges for round blobs).
    dtheta_min: float = math.radians(0.5)
    dtheta_max: float = math.radians(90.0)
    #: dG of eq. 11 for the gradient (HOG) variant, in grey levels.
    dg: float = 8.0

    def __post_init__(self) -> None:
        _check(8 <= self.bins <= 3600, "bins", "must be in 8..3600")
        _check(self.dm > 0, "dm", "must be > 0")
        _check(0 < self.dtheta_min < self.dtheta_max, "dtheta_min", "must be > 0 and < dtheta_max")
        _check(self.dg > 0, "dg", "must be > 0")


@dataclass(frozen=True)
class MixtureParams:
    """EM for the Gaussian-uniform mixture (section 4, eqs. 23-26)."""

    max_iter: int = 100
    #: Convergence: largest change of Pi (fraction) or of mu, sigma (radians) between steps.
    tol: float = 1e-4
    #: Goodness-of-fit threshold Dc of eq. 26 (paper: 0.06).
    gof_dc: float = 0.06
    #: Beyond the paper: D of eq. 26 is a Kolmogorov-Smirnov distance, whose sampling noise
    #: alone exceeds 0.06 with fewer than ~500 blobs. The threshold used is
    #: ``max(gof_dc, gof_ks_c / sqrt(n_eff))``, n_eff the effective number of weighted votes
    #: (1.36: the 5 % critical value). Set ``gof_ks_c = 0`` for the paper's fixed threshold.
    gof_ks_c: float = 1.36

    def __post_init__(self) -> None:
        _check(self.max_iter >= 2, "max_iter", "must be >= 2")
        _check(self.tol > 0, "tol", "must be > 0")
        _check(0 < self.gof_dc <= 1, "gof_dc", "must be in (0, 1]")
        _check(self.sigma_min > 0, "sigma_min", "must be > 0")
        _check(self.gof_ks_c >= 0, "gof_ks_c", "must be >= 0")

    #: Floor on sigma so that EM cannot collapse onto one bin.
    sigma_min: float = math.radians(1.0)


@dataclass(frozen=True)
class DecisionParams:
    """Kalman smoothing of (Pi, mu, sigma) and the decision (section 5)."""

    #: Variance of the process noise and of the measurement noise (paper: 0.01 and 0.1).
    process_var: float = 0.01
    measurement_var: float = 0.1
    #: Threshold on the smoothed surface of the Gaussian (paper: 0.35).
    pi_rain: float = 0.35
    #: Beyond the paper: the decision switches off at ``pi_rain - hysteresis`` so that the
    #: verdict does not flicker around the threshold.
    hysteresis: float = 0.05
    #: Beyond the paper: a new verdict is reported once the threshold test has agreed with it
    #: for this many consecutive frames: a few to start (a one-frame blip is not rain), more to
    #: stop (rain tapering off must not flicker the state on and off).
    dwell_on_frames: int = 3
    dwell_off_frames: int = 5
    #: Beyond the paper: a frame without a valid fit is evidence of *no* rain. It updates Pi
    #: with a measurement of 0 and this (larger) variance, so that the state decays instead of
    #: freezing at its last value (the weakness noted in section 5).
    miss_measurement_var: float = 0.6
    #: Beyond the paper: a fit needs at least this many blobs to be a measurement at all.
    min_blobs: int = 12
    #: Beyond the paper: a frame with fewer than ``min_blobs`` streak-sized blobs measures Pi
    #: as 0 with this variance (sure evidence: rain that stops leaves no blob behind); 0 gives
    #: it ``miss_measurement_var`` like any other frame without a valid fit.
    empty_measurement_var: float = 0.1
    #: Beyond the paper: a frame with fewer voting blobs than this share of their running
    #: mean over ``collapse_frames`` frames measures Pi as 0 with ``empty_measurement_var``:
    #: the shower has stopped, whatever the few blobs left fit (compression and noise
    #: blobs, pooled, fit narrow Gaussians at Pi 0.3-0.6). 0: never.
    collapse_ratio: float = 0.1
    collapse_frames: int = 10
    #: Beyond the paper: a voting population that the next frame shows again is not rain. A
    #: drop is seen once, so of a frame's voting blobs only chance finds one again a little
    #: way off (``robustness.found_again_radius``) in the next frame (2-11 % in rain); the
    #: leaves of a crown stirred by a gust stay where they were stirred (36-43 % over a
    #: tree-lined road seen by a soft camera). While the running mean of that share over
    #: ``flicker_frames`` frames exceeds ``flicker_share``, no fit is a measurement of rain.
    #: Found again lower down (a flake falling) does not count. 0: never, nor without the
    #: found-again rule (``robustness.found_again_radius = 0``) (docs/method.md, departure 29).
    flicker_share: float = 0.25
    flicker_frames: int = 10
    #: Beyond the paper: while the verdict is rain, a frame with fewer than ``min_blobs``
    #: blobs is not taken as sure evidence (``empty_measurement_var``) if it has at least this
    #: share of the voting blobs of the recent frames (their running mean over
    #: ``collapse_frames``): faint rain at a low resolution leaves 9-19 blobs a frame, so a
    #: third of its frames have fewer than ``min_blobs``; rain that stops leaves far fewer
    #: than half. 0: every such frame is sure evidence (before this rule).
    empty_ratio: float = 0.5
    #: Beyond the paper: precipitation seen by its fall (hos/fall.py): the small blobs of
    #: consecutive frames paired within ``fall_radius`` pixels (at ``size_reference_height``
    #: rows, scaled with the height, at least 8), those displaced down the vertical counted
    #: against those displaced as far up, over ``fall_frames`` judged frames; a z of at least
    #: ``fall_z`` is precipitation, of the type snow, whatever the HOS says (round flakes and
    #: specks, which the HOS cannot orient). 0: never. Dry scenes (docs/method.md, 22): 4.8
    #: at most.
    fall_z: float = 8.0
    fall_frames: int = 25
    fall_radius: float = 9.0
    #: Beyond the paper (docs/method.md, departure 43): the type remembers the fall. Within
    #: the type's vote window (``window_frames``) of a frame seen falling, a frame whose fall
    #: z on the type's meter is at least this share of ``fall_z`` (above every rain frame of
    #: the tuning split: 3.33 at most) votes snow, and is remembered in turn: a fall that
    #: weakens under the verdict's threshold is still no rain's. 0: the fall votes only while
    #: its verdict is on (before departure 43).
    fall_type_hold: float = 0.5
    #: Beyond the paper (docs/method.md, departure 37): while a cloud's shade is corrected,
    #: the small blobs in the blocks where the frame's local level is still off the
    #: background's by eq. 8's c or more (departure 32's medians), or next to them, do not
    #: start precipitation by their fall: a shade's edge sweeping a plain sky leaves pieces
    #: along it that move with it, down where it slopes. Outside the cells eq. 8 re-levels,
    #: they still tell snow from rain once precipitation is seen. False: every small blob
    #: is paired.
    fall_light: bool = True
    #: Beyond the paper: a frame with fewer than ``min_blobs`` blobs is fitted with the HOS of
    #: the frames before it added, up to this many frames in all, until ``min_blobs`` are
    #: reached; the fit's variance is multiplied by the frames pooled. 1: never.
    pool_frames: int = 4
    #: ... and such a pooled fit counts only if its Gaussian is this narrow: the outlines of
    #: a few pedestrians make a broad near-vertical population from frame to frame (31-35
    #: degrees at 320x240), a few streaks a narrow one.
    pool_sigma_max: float = math.radians(20.0)
    #: ... and only if its blobs lie in at least this share of distinct cells
    #: (``robustness.traffic_cell``): streaks land somewhere new in every frame; the parts of
    #: a pedestrian or a light's reflection in a wet road, seen again and again, do not.
    pool_places: float = 0.75
    #: Beyond the paper: a fit of one frame whose Gaussian is wider than ``spread_sigma``
    #: (snow, or nothing at all) counts only if its blobs are spread over the view: they
    #: occupy at least ``spread_places`` times as many cells of a ``spread_grid`` x
    #: ``spread_grid`` grid over the region of interest as the same number of blobs dropped at
    #: random would. Flakes fall everywhere; the fragments of a tree's foliage swaying in the
    #: wind sit in its crown. 0: never.
    spread_sigma: float = math.radians(20.0)
    spread_places: float = 0.5
    spread_grid: int = 4
    #: Beyond the paper: the limits on sigma (``sigma_max``, ``pool_sigma_max``,
    #: ``spread_sigma``) apply to the streaks' own spread, the width of their voting kernels
    #: (eq. 19) taken out of the fitted sigma; False: to the fitted sigma, as before.
    kernel_corrected: bool = True
    #: Beyond the paper: a fit from fewer blobs is a noisier measurement. Its variance is
    #: ``measurement_var * max(1, measurement_blobs / n_eff)``, n_eff the effective number of
    #: blobs of the HOS (their weights' (sum w)^2 / sum w^2); 0 keeps the paper's constant.
    measurement_blobs: float = 100.0
    #: Beyond the paper: a second track of rain, made of the last frame's voting blobs that
    #: pass the paper's eq. 32 (at least this share of a blob's pixels ``photometric_c``
    #: brighter than in the frame before and in the frame after: a drop is there for one
    #: frame only). It has its own pool and Kalman filter, with ``transient_blobs`` as its
    #: ``measurement_blobs``; rain is said when either track says it (docs/method.md,
    #: departure 45). A rain test only: slow snow fails it, and stays with the first track.
    #: 0: no second track.
    transient_share: float = 0.5
    transient_blobs: float = 30.0
    #: ... and only blobs of at least this many pixels vote in it: a drop of sensor noise
    #: passes eq. 32 too, and a blob of 2 pixels has one of four orientations
    transient_min_area: int = 3
    #: ... and its width rules (``sigma_min``, ``sigma_max``, ``spread_sigma``) read the
    #: median width of its last this many fits: a fit of some 30 drops reads its width a
    #: few degrees off, and one such fit must not turn clutter into rain
    transient_width_frames: int = 5
    #: ... and the blobs the light rule left out (departure 31) are tested in it too
    transient_lit: bool = True
    #: ... and a drop's pixel must have been at rest before it came (within ``photometric_c``
    #: from the frame before that one): a flickering light passes eq. 32 too
    transient_rest: bool = True
    #: Beyond the paper: a fitted Gaussian wider than this is not a streak population.
    sigma_max: float = math.radians(36.0)
    #: Beyond the paper: nor is one narrower than this (the fitted sigma, voting kernels
    #: included). The HOS's bins are a degree wide: a Gaussian under two of them is one
    #: orientation repeated, parallel structure (lights mirrored in a wet road, a railing's
    #: bars), where rain's orientations spread over more (perspective, turbulence, and each
    #: short streak's own uncertainty, eq. 19). 0: no lower limit.
    sigma_min: float = math.radians(2.0)
    #: ... unless one frame alone gives it this many blobs (its Pi times the frame's
    #: effective number of blobs): rain seen through a telephoto lens in a steady wind, or
    #: drawn at one orientation, is many streaks in one frame, where the parallel structures
    #: the limit is for are a few blobs pooled over frames (docs/method.md, departure 25).
    #: 0: the limit always holds.
    sigma_min_blobs: float = 24.0
    #: Beyond the paper: precipitation falls. A streak population whose mean orientation is
    #: further than ``max_tilt`` from the camera's vertical (``vertical``, 90 degrees for an
    #: upright camera; set it for a rolled one) is traffic, lane markings or vanishing lines.
    vertical: float = math.radians(90.0)
    max_tilt: float = math.radians(60.0)
    #: S_b of section 6: a blob is rain when P(rain|theta)/P(noise|theta) > S_b (paper: 0.6).
    s_b: float = 0.6

    def __post_init__(self) -> None:
        _check(self.process_var > 0, "process_var", "must be > 0")
        _check(self.measurement_var > 0, "measurement_var", "must be > 0")
        _check(0 < self.pi_rain < 1, "pi_rain", "must be in (0, 1)")
        _check(0 <= self.hysteresis < self.pi_rain, "hysteresis", "must be in [0, pi_rain)")
        _check(self.dwell_on_frames >= 1, "dwell_on_frames", "must be >= 1")
        _check(self.dwell_off_frames >= 1, "dwell_off_frames", "must be >= 1")
        _check(self.miss_measurement_var > 0, "miss_measurement_var", "must be > 0")
        _check(self.empty_measurement_var >= 0, "empty_measurement_var", "must be >= 0")
        _check(0 <= self.collapse_ratio < 1, "collapse_ratio", "must be in [0, 1)")
        _check(0 <= self.empty_ratio <= 1, "empty_ratio", "must be in [0, 1]")
        _check(self.fall_z >= 0, "fall_z", "must be >= 0")
        _check(self.fall_frames >= 1, "fall_frames", "must be >= 1")
        _check(self.fall_radius > 0, "fall_radius", "must be > 0")
        _check(0 <= self.fall_type_hold <= 1, "fall_type_hold", "must be in [0, 1]")
        _check(self.collapse_frames >= 1, "collapse_frames", "must be >= 1")
        _check(0 <= self.flicker_share <= 1, "flicker_share", "must be in [0, 1]")
        _check(self.flicker_frames >= 1, "flicker_frames", "must be >= 1")
        _check(self.pool_frames >= 1, "pool_frames", "must be >= 1")
        _check(0 <= self.pool_places <= 1, "pool_places", "must be in [0, 1]")
        _check(0 <= self.spread_places <= 1, "spread_places", "must be in [0, 1]")
        _check(self.spread_grid >= 1, "spread_grid", "must be >= 1")
        _check(self.min_blobs >= 1, "min_blobs", "must be >= 1")
        _check(self.measurement_blobs >= 0, "measurement_blobs", "must be >= 0")
        _check(self.sigma_max > 0, "sigma_max", "must be > 0")
        _check(0 <= self.sigma_min < self.sigma_max, "sigma_min", "must be in [0, sigma_max)")
        _check(self.sigma_min_blobs >= 0, "sigma_min_blobs", "must be >= 0")
        _check(0 <= self.transient_share <= 1, "transient_share", "must be in [0, 1]")
        _check(self.transient_blobs > 0, "transient_blobs", "must be > 0")
        _check(self.transient_min_area >= 1, "transient_min_area", "must be >= 1")
        _check(self.transient_width_frames >= 1, "transient_width_frames", "must be >= 1")
        _check(0 < self.max_tilt <= math.pi / 2, "max_tilt", "must be in (0, 90] degrees")
        _check(self.s_b > 0, "s_b", "must be > 0")


@dataclass(frozen=True)
class RobustnessParams:
    """Beyond the paper: what keeps clear weather clear on a real roadside camera.

    See ``docs/method.md`` for why each of these exists.
    """

    #: Frames of warm-up during which the background model is learnt and no verdict is given.
    warmup_frames: int = 60
    #: Time constant (frames) of the per-pixel candidate rate used to find structural noise:
    #: rain lands at random places, edges of a shaking camera or swaying leaves recur in place.
    persistence_frames: int = 100
    #: A blob whose pixels are candidates more often than ``max(persistence_floor,
    #: persistence_ratio * global candidate rate)`` is structural noise, not rain.
    persistence_floor: float = 0.03
    persistence_ratio: float = 2.5
    #: With ``persistence_local_ratio`` > 0 (departure 28, not the default), a blob is
    #: structure only if its pixels are also candidates more often than that many times the
    #: candidate rate of the part of the view around it (a box of ``persistence_local_px``
    #: pixels at ``segmentation.size_reference_height`` rows, scaled with the height). An edge
    #: recurs on its own line and hardly beside it; rain seen only in one part of the view (a
    #: lamp's pool of light at night) falls as often everywhere in that part, and compared
    #: with the whole view alone is taken for structure when it is dense there. 2 sees such
    #: rain, but on real views with the benchmark's rain drawn over them it let the clutter
    #: of busy parts vote too (drizzle over a motorway 86 -> 76 % of frames seen): 0, the
    #: whole view only, stays the default (docs/method.md, departure 28).
    persistence_local_ratio: float = 0.0
    persistence_local_px: float = 32.0
    #: Camera offset from its learnt position (pixels at full resolution), measured on an image
    #: reduced to about 240 px wide against a reference that learns over ``reference_frames``
    #: (as fast as the background model while that relearns a view), leaving out what moved
    #: in the last frame. With ``stabilise``, a frame offset by up to ``motion_frame_px`` is
    #: translated back before the background model sees it (a camera in the wind: a typical
    #: sway of a pixel peaks at 2-3 px); a frame offset by more carries no rain evidence: its
    #: edges are in the foreground.
    reference_frames: int = 100
    #: How the camera offset is fitted (departure 27). Two linearised fits of the optical
    #: flow constraint can be made against the reference: on the gradients of the mean of the
    #: reference and the frame (symmetric; the only fit before departure 27), or on the
    #: reference's alone (Lucas-Kanade's template, as in the inverse compositional form).
    #: Each reads motion that is not there in its own way: the symmetric fit follows texture
    #: that only the frame shows (flakes falling together over a plain view, where they are
    #: the only texture: a camera being re-aimed), the template fit magnifies texture that the
    #: reference holds only faintly (a trail at a tenth of the frame's contrast reads ten times
    #: its move). Neither shrinks a real offset: on a shifted view both are right to about
    #: 0.1 px. ``"shorter"`` (the default) makes both and keeps the shorter offset (the second
    #: only when the first is not zero); ``"reference"`` or ``"mean"``: that fit alone.
    motion_gradient: Literal["shorter", "reference", "mean"] = "shorter"
    #: Beyond the paper: an offset is the camera's only if it explains the frame (departure
    #: 33). The view is cut in 3 x 3 parts; in each holding enough of the reference's most
    #: textured quarter (what moves often in place left out), the frame moved back by the
    #: offset must match the reference with a median absolute difference at most
    #: ``motion_explained`` times that of the frame as it is; the offset stands if it does so
    #: in at least half of those parts, else it reads 0 (an offset under half a pixel of that
    #: reduced image stands unchecked: too small to tell). A camera being re-aimed is told by
    #: its frame-to-frame steps adding up to more than ``motion_far_px`` over 5 frames; that
    #: sum is checked the same way, against the frame 5 back. Measured over the whole textured
    #: quarter on the tuning split, that ratio is 0.4-0.8 in the wind and 0.7-1.05 while
    #: re-aimed or knocked; where heavy rain over a faint view pulled the fit by 1-5 px it
    #: was 1.4-2.3 (real fog with a swing, the benchmark's rain drawn over it). 0: never
    #: checked.
    motion_explained: float = 1.2
    #: Beyond the paper (departure 42): a frame whose mean grey level (exposure corrected,
    #: plus one) is more than this many times the motion reference's, or less than its
    #: inverse, is lit otherwise than the view the reference learnt (a lightning flash, the
    #: dark between flashes): no offset is read from it (0), nor a step from the frame
    #: before lit otherwise. 0: always read.
    motion_light_ratio: float = 1.5
    #: ... and (departure 44) the reference does not learn from such a frame: a light that
    #: lasts this many frames in a row is the view's, and the reference takes the frame as
    #: it is; after a step between two frames lit otherwise (a flash), no step is read for
    #: as many frames (the clouds a flash lights move, not the camera). 0: the reference
    #: learns from every frame and the steps are read at once (departure 42 alone).
    motion_light_frames: int = 25
    #: Beyond the paper: what moves often in place (a tree's crown in the wind, a flag, a
    #: busy lane) takes no part in the camera-offset fit either. A reduced pixel in the
    #: background model's foreground on more than ``max(mover_rate, mover_ratio * median)`` of
    #: the frames (a running mean over ``mover_frames`` frames) is left out; not when that is
    #: most of the image (a camera being moved, heavy rain everywhere). 0: never.
    mover_rate: float = 0.15
    mover_ratio: float = 3.0
    mover_frames: int = 50
    stabilise: bool = True
    #: Smaller offsets are left alone: resampling a compressed frame costs more than it saves.
    stabilise_min_px: float = 0.25
    #: The frame is translated back by whole pixels (the offset rounded), which moves a
    #: one-pixel streak without spreading it; the fraction left (up to half a pixel) moves
    #: eq. 8's background instead, and the estimate's own error is held out by the 3x3
    #: neighbourhood rule (``shaken_px``). True: the frame is translated by the offset's
    #: fraction too (bilinear), which halves a thin streak's contrast at half a pixel.
    stabilise_subpixel: bool = False
    motion_frame_px: float = 2.5
    #: A frame offset by more than this is a camera being moved (knocked, re-aimed), not the
    #: wind: ``unstable`` at once.
    motion_far_px: float = 3.0
    #: A camera further than ``motion_frame_px`` off its place, and still there (its offset
    #: changing by less than ``stabilise_min_px`` a frame) for this many frames, was knocked
    #: or re-aimed: its new view is learnt at once (as after a scene change). 0: never (the
    #: reference drifts over to the new view in about ``reference_frames`` frames).
    rest_frames: int = 10
    #: A camera seen off its place by at least this much in the last ``motion_window_frames``
    #: frames is compared, pixel by pixel, with the brightest background of each 3x3
    #: neighbourhood (``hos.background.neighbourhood_background``): its edges, up to a pixel
    #: off, are not candidates. 0: never.
    shaken_px: float = 0.1
    #: Fraction of recent frames that moved above which the camera is declared ``unstable``.
    motion_unstable_fraction: float = 0.3
    motion_window_frames: int = 25
    #: Beyond the paper: the camera's offset is also fitted on an image this many times smaller
    #: than the reduced one, and refined from there when that finds a longer shift than the
    #: linearised fit reaches (a knock of several pixels; docs/method.md, departure 35). 1 or
    #: 0: never.
    motion_coarse: int = 4
    #: Beyond the paper: frames after the camera was last off its place by more than
    #: ``motion_frame_px`` (or unstable) that are judged but carry no evidence either way
    #: (held): a camera drifting back and forth across the limit leaves the edges of its view
    #: half-learnt in the frames between (docs/method.md, departure 34). 0: none.
    settle_frames: int = 10
    #: Exposure compensation: a global gain change larger than this is undone before the
    #: background model sees it. 1 % of a mid-grey scene is under eq. 8's c; at 3 % an
    #: exposure ramp (auto-exposure easing over a second) kept the frame up to 3 % off the
    #: background, 4-5 grey levels, and every flat pixel's noise became a candidate.
    gain_tolerance: float = 0.01
    #: Beyond the paper: a change of light over part of the view (the shade of a passing
    #: cloud) is undone cell by cell before the background model sees it, the way the global
    #: gain is (``hos/shade.py``; docs/method.md, departure 31). The view is cut into
    #: ``shade_cells`` cells across; a cell's gain is kept when the log ratios of its pixels
    #: deviate from their median by at most ``shade_coherence`` times it (light multiplies
    #: every pixel alike; an object does not) and it is more than ``gain_tolerance``, or,
    #: where no shade is under way, more than ``shade_onset`` (a cloud's shade takes a fifth
    #: of the light or more; rain's veil and a truck's spray change a cell by a few per
    #: cent). 0: off.
    shade_cells: int = 16
    shade_coherence: float = 0.8
    shade_onset: float = 0.05
    #: Beyond the paper (departure 32): while a shade is corrected, eq. 8 compares each pixel
    #: with the background raised or lowered by the local level of the frame's difference to
    #: it (the median over 5 x 5 blocks of the reduced image's pixels), so that what the
    #: cells' correction misses of a shade (its edge inside a cell) leaves the candidates,
    #: and a streak, a column of blocks at most, stays. False: eq. 8 as before.
    shade_relevel: bool = True
    #: The camera cannot see rain when the region of interest is dark: when ``dark_share``
    #: of it (its brightest part: the reduced image's grey levels at the ``1 - dark_share``
    #: quantile) is under ``dark_level``. A lamp-lit street at night, mean grey 10, still
    #: shows the rain in its light; a view with nothing lit does not (docs/method.md,
    #: departure 26). ``dark_share = 1``: the whole view must be that dark, 0: the mean grey
    #: level is compared (as before departure 26).
    dark_level: float = 20.0
    dark_share: float = 0.1
    #: Beyond the paper: a blob whose pixels changed by less than this mean (grey levels) from
    #: frame to frame over the last ``stale_frames`` frames is a copy (a video encoder's
    #: skipped blocks keep a streak for frames after the drop has gone) and does not vote; a
    #: frame identical to the previous one carries no new evidence and holds the state.
    #: 0: never.
    stale_level: float = 1.0
    stale_frames: int = 2
    #: Fraction of the region of interest in the foreground above which the scene has changed
    #: (lights, a wiper, a moved camera); the background is relearnt quickly.
    scene_change_fraction: float = 0.35
    #: Beyond the paper (section 7): in heavy rain streaks overlap and merge into blobs that the
    #: size rule rejects; R is corrected by the candidate area those merged blobs carry.
    merge_correction: bool = True
    merge_max_factor: float = 20.0
    #: Beyond the paper: blobs where foreground bodies (vehicles, pedestrians, spray) are now,
    #: or pass often, are left out of the HOS (``hos/traffic.py``). The foreground is eroded
    #: by a square of ``traffic_width`` pixels (streaks vanish) and cut into cells of
    #: ``traffic_cell`` pixels (both at ``size_reference_height`` rows); a cell more than
    #: ``traffic_density`` full is dense. Cells dense (or next to one) more often than
    #: ``max(traffic_rate, traffic_ratio * median cell)`` (a mean over the frames seen, then
    #: over ``traffic_frames``), and dense at least ``traffic_hits`` times, are traffic; with
    #: ``traffic_now`` so are the frame's own bodies (2 x 2 dense cells). Both are grown by a
    #: cell, and by ``traffic_below`` cells downward (lights mirrored in a wet road).
    #: ``traffic = false``: the paper's HOS of every blob.
    traffic: bool = True
    traffic_cell: int = 8
    traffic_width: int = 3
    traffic_density: float = 0.5
    traffic_frames: int = 1500
    traffic_rate: float = 0.02
    traffic_ratio: float = 3.0
    traffic_now: bool = True
    traffic_hits: float = 5.0
    traffic_below: int = 2
    #: ... and no lane is learnt where a cloud's shade is being corrected (the cells eq. 8
    #: re-levels, departure 32, ``shade_relevel``): a shade's edge, a band of foreground
    #: sweeping the view, is no vehicle's lane, and the cells it crossed became lanes that
    #: hid the rain from the HOS for minutes after (docs/method.md, departure 46). The
    #: frame's own bodies there still count. False: every dense cell is learnt, as before.
    traffic_shade: bool = True
    #: Beyond the paper: a streak-sized blob found again in the next judged frame, moved by
    #: more than nothing and less than ``found_again_radius`` pixels (at
    #: ``size_reference_height`` rows), is not a new drop (a drop falls at least its streak's
    #: length between frames) and takes no part in the HOS (``hos/again.py``): foliage and
    #: hedges flickering with the sway, fragments creeping along a lane. Not while the blobs
    #: found again fall, by ``found_again_fall_z`` standard deviations over
    #: ``found_again_frames`` frames (slow snow), for those found lower down (the flakes);
    #: ``found_again_fall_lower = False``: for every blob then, as before departure 41 (what
    #: a gust bends down sways beside and above too). 0: the paper's HOS of every blob.
    found_again_radius: float = 3.0
    found_again_frames: int = 25
    found_again_fall_z: float = 8.0
    found_again_fall_lower: bool = True
    #: Beyond the paper: a streak-sized blob whose brightening over the background is what an
    #: edge of the background under it, moved across its length by up to this many pixels,
    #: would give takes no part in the HOS (``hos.blobs.moved_edge``): the slivers that a
    #: camera's vibration, too small or too brief for the motion estimate, cuts along every
    #: pole, post and rail, all oriented alike (docs/method.md, departure 30), and the
    #: flicker a codec leaves along such edges, which the line rule (departure 36) would
    #: complete into streaks: 2 pixels since departure 40 (1 before). 0: off.
    moved_edge_px: float = 2.0

    def __post_init__(self) -> None:
        _check(self.warmup_frames >= 0, "warmup_frames", "must be >= 0")
        _check(self.persistence_frames >= 1, "persistence_frames", "must be >= 1")
        _check(0 < self.persistence_floor <= 1, "persistence_floor", "must be in (0, 1]")
        _check(self.persistence_ratio > 0, "persistence_ratio", "must be > 0")
        _check(self.persistence_local_ratio >= 0, "persistence_local_ratio", "must be >= 0")
        _check(self.persistence_local_px > 0, "persistence_local_px", "must be > 0")
        _check(self.reference_frames >= 1, "reference_frames", "must be >= 1")
        _check(self.motion_explained >= 0, "motion_explained", "must be >= 0")
        _check(
            self.motion_light_ratio == 0 or self.motion_light_ratio > 1,
            "motion_light_ratio",
            "must be 0 or > 1",
        )
        _check(self.motion_light_frames >= 0, "motion_light_frames", "must be >= 0")
        _check(
            self.motion_gradient in ("shorter", "reference", "mean"),
            "motion_gradient",
            'must be "shorter", "reference" or "mean"',
        )
        _check(self.mover_rate >= 0, "mover_rate", "must be >= 0")
        _check(self.mover_ratio >= 0, "mover_ratio", "must be >= 0")
        _check(self.mover_frames >= 1, "mover_frames", "must be >= 1")
        _check(self.motion_frame_px > 0, "motion_frame_px", "must be > 0")
        _check(self.stabilise_min_px >= 0, "stabilise_min_px", "must be >= 0")
        _check(self.motion_far_px > 0, "motion_far_px", "must be > 0")
        _check(self.stale_level >= 0, "stale_level", "must be >= 0")
        _check(self.stale_frames >= 1, "stale_frames", "must be >= 1")
        _check(self.shaken_px >= 0, "shaken_px", "must be >= 0")
        _check(self.rest_frames >= 0, "rest_frames", "must be >= 0")
        _check(0 < self.motion_unstable_fraction <= 1, "motion_unstable_fraction", "in (0, 1]")
        _check(self.motion_window_frames >= 1, "motion_window_frames", "must be >= 1")
        _check(self.settle_frames >= 0, "settle_frames", "must be >= 0")
        _check(self.motion_coarse >= 0, "motion_coarse", "must be >= 0")
        _check(self.gain_tolerance > 0, "gain_tolerance", "must be > 0")
        _check(self.shade_cells >= 0, "shade_cells", "must be >= 0")
        _check(self.shade_coherence > 0, "shade_coherence", "must be > 0")
        _check(self.shade_onset >= 0, "shade_onset", "must be >= 0")
        _check(0 <= self.dark_level < 255, "dark_level", "must be in [0, 255)")
        _check(0 <= self.dark_share <= 1, "dark_share", "must be in [0, 1]")
        _check(0 < self.scene_change_fraction <= 1, "scene_change_fraction", "in (0, 1]")
        _check(self.merge_max_factor >= 1, "merge_max_factor", "must be >= 1")
        _check(self.traffic_cell >= 1, "traffic_cell", "must be >= 1")
        _check(self.traffic_width >= 1, "traffic_width", "must be >= 1")
        _check(0 < self.traffic_density < 1, "traffic_density", "must be in (0, 1)")
        _check(self.traffic_frames >= 1, "traffic_frames", "must be >= 1")
        _check(0 <= self.traffic_rate < 1, "traffic_rate", "must be in [0, 1)")
        _check(self.traffic_ratio >= 0, "traffic_ratio", "must be >= 0")
        _check(self.traffic_hits >= 0, "traffic_hits", "must be >= 0")
        _check(self.traffic_below >= 0, "traffic_below", "must be >= 0")
        _check(self.found_again_radius >= 0, "found_again_radius", "must be >= 0")
        _check(self.found_again_frames >= 1, "found_again_frames", "must be >= 1")
        _check(self.found_again_fall_z >= 0, "found_again_fall_z", "must be >= 0")
        _check(self.moved_edge_px >= 0, "moved_edge_px", "must be >= 0")


#: The parameters that are angles (radians in the code): a configuration may give each in
#: degrees with its name and ``_deg``. No other key takes ``_deg``.
ANGLE_PARAMETERS = frozenset(
    {
        "dtheta_min",
        "dtheta_max",
        "sigma_min",
        "pool_sigma_max",
        "spread_sigma",
        "sigma_max",
        "vertical",
        "max_tilt",
        "sigma_rain",
        "sigma_snow",
    }
)


@dataclass(frozen=True)
class DetectorParams:
    """All detector parameters, grouped as the paper's sections are."""

    segmentation: SegmentationParams = field(default_factory=SegmentationParams)
    histogram: HistogramParams = field(default_factory=HistogramParams)
    mixture: MixtureParams = field(default_factory=MixtureParams)
    decision: DecisionParams = field(default_factory=DecisionParams)
    robustness: RobustnessParams = field(default_factory=RobustnessParams)
    #: Beyond the paper: rain or snow from the streaks' shape (hos/ptype.py).
    precipitation_type: PtypeParams = field(default_factory=PtypeParams)

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None) -> DetectorParams:
        """Build from ``{"segmentation": {...}, ...}``; angles given in degrees where the key
        ends in ``_deg`` (:data:`ANGLE_PARAMETERS` only: ``across_rain_deg`` is a mistake, not
        26 degrees). Unknown keys raise ``ValueError`` naming the key."""
        if not data:
            return cls()
        groups = {f.name: f for f in fields(cls)}
        built: dict[str, Any] = {}
        for group, values in data.items():
            if group not in groups:
                raise ValueError(f"detector.{group}: unknown parameter group")
            default = getattr(cls(), group)
            known = {f.name for f in fields(default)}
            kwargs: dict[str, Any] = {}
            for key, value in (values or {}).items():
                name = key[:-4] if key.endswith("_deg") else key
                if name not in known:
                    raise ValueError(f"detector.{group}.{key}: unknown parameter")
                if key.endswith("_deg") and name not in ANGLE_PARAMETERS:
                    raise ValueError(
                        f"detector.{group}.{key}: {name} is not an angle; give it without _deg"
                    )
                kwargs[name] = math.radians(value) if key.endswith("_deg") else value
            try:
                built[group] = replace(default, **kwargs)
            except ValueError as err:
                raise ValueError(f"detector.{group}.{err}") from None
        return cls(**built)
