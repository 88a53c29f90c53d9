"""What the detector returns for one frame."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["BlobClass", "FrameResult", "MixtureFit", "State", "json_angle_deg", "json_float"]


class State:
    """Why the camera can or cannot judge (the ``state`` field of the JSON contract)."""

    OK = "ok"
    WARMING_UP = "warming_up"
    UNSTABLE = "unstable"  # the camera moves (wind, vibration): edges would look like rain
    DARK = "dark"  # too little light to see streaks
    SCENE_CHANGE = "scene_change"  # most of the image changed at once; relearning the background


class BlobClass:
    """Class of each connected component of the candidate mask (``FrameResult.blob_class``)."""

    NONE = 0  # label 0 is the background
    RAIN = 1  # drawn green in the overlay
    NOISE = 2  # a streak-sized blob whose orientation is not the rain's: red
    SIZE = 3  # rejected by the size rule: blue
    STRUCTURE = 4  # recurs in place (edges, foliage), or found again a little way off: purple
    TRAFFIC = 5  # streak-sized, but where vehicles, pedestrians or spray are or pass: orange


@dataclass(frozen=True)
class MixtureFit:
    """The Gaussian-uniform mixture of eq. 23 fitted to one HOS, or why it could not be.

    A failed fit is a value, not an exception: ``ok`` is False and ``reason`` says why.
    Angles in radians, ``mu`` in [0, pi).
    """

    ok: bool
    pi: float = math.nan
    mu: float = math.nan
    sigma: float = math.nan
    gof_d: float = math.nan
    gof_ok: bool = False
    iterations: int = 0
    reason: str = ""


@dataclass
class FrameResult:
    """Everything the detector knows about one frame.

    The scalar fields map one-to-one onto the ``weatherd detect --jsonl`` contract through
    :meth:`to_json`. The arrays are for drawing and for rain-pixel evaluation; they are views of
    the detector's working buffers, valid until the next call to ``process``.
    """

    frame: int
    t_s: float
    rain: bool
    state: str
    fit: MixtureFit
    pi_smoothed: float
    mu_smoothed: float
    sigma_smoothed: float
    S: float
    R: float
    n_blobs: int
    n_rain_blobs: int
    #: (bins,) float64, the HOS of eq. 20 before normalisation (its sum is S), of this frame
    #: alone; a frame with few blobs is fitted on it summed with the frames before it
    #: (``decision.pool_frames``), so ``fit`` may describe more than this histogram.
    histogram: np.ndarray = field(repr=False)
    #: Beyond the paper: "rain", "snow" or "unknown" (hos/ptype.py), voted over recent frames;
    #: "unknown" whenever ``rain`` is false.
    precipitation_type: str = "unknown"
    #: The rain blobs' shape behind the vote (hos.ptype.StreakShape), for diagnostics.
    streak_shape: Any = field(default=None, repr=False)
    #: Diagnostics beyond the contract.
    motion_px: float = 0.0
    gain: float = 1.0
    brightness: float = 0.0
    candidate_fraction: float = 0.0
    n_structural_blobs: int = 0
    n_traffic_blobs: int = 0
    #: Beyond the paper (hos/again.py): streak-sized blobs found again a little way off since
    #: the last frame, not new drops, left out of the HOS (not counted in the two above).
    n_found_again_blobs: int = 0
    #: Beyond the paper (hos/fall.py): the evidence that what the small blobs show falls (z,
    #: in standard deviations over ``decision.fall_frames`` frames), and how far it falls,
    #: pixels a frame (NaN unless it is seen falling).
    fall_z: float = 0.0
    fall_px: float = math.nan
    #: Beyond the paper (hos/again.py): the running share of the rain blobs that the next
    #: frame showed again, beyond chance (``decision.flicker_share``: above it, leaves stirred
    #: by gusts, not rain; departure 29).
    flicker_share: float = 0.0
    #: Beyond the paper (departure 45): the second track's smoothed Pi, of the last frame's
    #: voting blobs that passed the paper's eq. 32 against this frame (a drop is brighter
    #: than the frames before and after it), and how many of them voted. ``rain`` is said
    #: when either track says it, so it may be true while ``pi_smoothed`` is low. NaN when
    #: the second track is off.
    drops_pi_smoothed: float = math.nan
    n_drop_blobs: int = 0
    #: (H, W) int32 labels of the candidate mask and (n_labels,) uint8 class of each label.
    #: ``labels`` may be None when the labels are kept sparse, as the candidate pixels' flat
    #: indices ``pixel_index`` (N,) and their labels ``pixel_labels`` (N,): see label_image().
    labels: np.ndarray | None = field(default=None, repr=False)
    blob_class: np.ndarray | None = field(default=None, repr=False)
    pixel_index: np.ndarray | None = field(default=None, repr=False)
    pixel_labels: np.ndarray | None = field(default=None, repr=False)
    image_shape: tuple[int, int] | None = field(default=None, repr=False)

    def label_image(self) -> np.ndarray | None:
        """(H, W) int32 labels of the candidate pixels (0 elsewhere), or None if not kept."""
        if self.labels is not None:
            return self.labels
        if self.pixel_index is None or self.pixel_labels is None or self.image_shape is None:
            return None
        out = np.zeros(self.image_shape, np.int32)
        out.reshape(-1)[self.pixel_index] = self.pixel_labels
        return out

    def to_json(self) -> dict[str, Any]:
        """The per-frame JSON object of the ``weatherd detect --jsonl`` contract."""
        fit = self.fit
        has_fit = fit.ok
        return {
            "frame": int(self.frame),
            "t_s": round(float(self.t_s), 6),
            "rain": bool(self.rain),
            "state": self.state,
            "pi": json_float(fit.pi) if has_fit else None,
            "mu_deg": json_angle_deg(fit.mu) if has_fit else None,
            "sigma_deg": json_angle_deg(fit.sigma) if has_fit else None,
            "gof_d": json_float(fit.gof_d) if has_fit else None,
            "gof_ok": bool(fit.gof_ok) if has_fit else None,
            "pi_smoothed": json_float(self.pi_smoothed),
            "mu_smoothed_deg": json_angle_deg(self.mu_smoothed),
            "sigma_smoothed_deg": json_angle_deg(self.sigma_smoothed),
            "S": json_float(self.S),
            "R": json_float(self.R),
            "n_blobs": int(self.n_blobs),
            "n_rain_blobs": int(self.n_rain_blobs),
            "precipitation_type": self.precipitation_type,
            "motion_px": json_float(self.motion_px),
            "gain": json_float(self.gain),
            "brightness": json_float(self.brightness),
            "n_structural_blobs": int(self.n_structural_blobs),
            "n_traffic_blobs": int(self.n_traffic_blobs),
            "n_found_again_blobs": int(self.n_found_again_blobs),
            "fall_z": json_float(self.fall_z),
            "fall_px": json_float(self.fall_px),
            "flicker_share": json_float(self.flicker_share),
            "drops_pi_smoothed": json_float(self.drops_pi_smoothed),
            "n_drop_blobs": int(self.n_drop_blobs),
        }


def json_float(x: float) -> float | None:
    """A float for JSON: rounded to 6 decimals, None when not finite."""
    x = float(x)
    return round(x, 6) if math.isfinite(x) else None


def json_angle_deg(x: float) -> float | None:
    """An angle in radians for JSON: degrees in [0, 180), 4 decimals, None when not finite."""
    x = float(x)
    return round(math.degrees(x) % 180.0, 4) if math.isfinite(x) else None
