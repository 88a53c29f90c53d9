"""The HOS rain/snow detector (Bossu, Hautière & Tarel, IJCV 2011), pure: arrays in, results out.

Read in order: ``background`` -> ``blobs`` -> ``moments`` -> ``histogram`` -> ``mixture`` ->
``smoothing`` -> ``ptype`` -> ``pipeline``. ``render`` draws synthetic rain for tests,
benchmarks and the demo.
"""

from .histogram import hog_histogram, hos_histogram
from .mixture import fit_mixture, gof_distance, mixture_bin_mass
from .moments import BlobMoments, blob_moments, orientation_uncertainty
from .params import (
    DecisionParams,
    DetectorParams,
    HistogramParams,
    MixtureParams,
    RobustnessParams,
    SegmentationParams,
)
from .pipeline import HosDetector, classify_blobs
from .ptype import PrecipitationTypeVote, PtypeParams
from .result import BlobClass, FrameResult, MixtureFit, State
from .smoothing import ParameterSmoother

__all__ = [
    "BlobClass",
    "BlobMoments",
    "DecisionParams",
    "DetectorParams",
    "FrameResult",
    "HistogramParams",
    "HosDetector",
    "MixtureFit",
    "MixtureParams",
    "ParameterSmoother",
    "PrecipitationTypeVote",
    "PtypeParams",
    "RobustnessParams",
    "SegmentationParams",
    "State",
    "blob_moments",
    "classify_blobs",
    "fit_mixture",
    "gof_distance",
    "hog_histogram",
    "hos_histogram",
    "mixture_bin_mass",
    "orientation_uncertainty",
]
