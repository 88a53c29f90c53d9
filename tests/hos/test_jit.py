"""The compiled kernels (hos._jit) against their numpy/OpenCV references."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from drivers.simulator import Scene, SceneParams, StreakParams
from hos import HosDetector, _jit
from hos.background import mask_to_index, photometric_rule
from hos.blobs import CandidateRate, blob_mean_rate, find_blobs, find_blobs_sparse
from tests.conftest import run_python

REPO = Path(__file__).resolve().parents[2]
needs_jit = pytest.mark.skipif(not _jit.ENABLED, reason=f"no JIT: {_jit.why_disabled()}")


def _canonical(index: np.ndarray, pixel_labels: np.ndarray) -> np.ndarray:
    """Each pixel's component named by the component's first pixel: label-numbering free."""
    first = {}
    out = np.empty(index.size, np.int64)
    for k, (p, lab) in enumerate(zip(index.tolist(), pixel_labels.tolist(), strict=True)):
        out[k] = first.setdefault(lab, p)
    return out


@needs_jit
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_photometric_candidates_equal_the_opencv_rule(seed):
    rng = np.random.default_rng(seed)
    h, w = 37, 53  # not a multiple of 8 pixels: the tail after the last whole word is checked
    gray = rng.integers(0, 256, (h, w), dtype=np.uint8)
    fg = np.where(rng.random((h, w)) < 0.3, 255, 0).astype(np.uint8)
    background = (rng.random((h, w)) * 260.0 - 2.0).clip(0, 255).astype(np.float32)
    background[0, :5] = 254.6  # saturating threshold: 255 + c caps at 255
    gray[0, :5] = 255
    background = cv2.convertScaleAbs(background)
    reference = mask_to_index(photometric_rule(gray, background, fg, c=3))
    index, n_fg = _jit.photometric_candidates(gray, fg, background, c=3)
    np.testing.assert_array_equal(index, reference)
    assert n_fg == np.count_nonzero(fg)
    assert index.size > 0


def _assert_same_blobs(mask: np.ndarray) -> None:
    ref = find_blobs(mask)
    index = mask_to_index(mask)
    got = find_blobs_sparse(index, mask.shape, compiled=True)
    np.testing.assert_array_equal(got.index, ref.index)
    np.testing.assert_array_equal(
        _canonical(got.index, got.pixel_labels), _canonical(ref.index, ref.pixel_labels)
    )
    assert got.n_labels == ref.n_labels
    # the same blobs, once each side's labels are put in the order of their first pixels
    order_got, order_ref = _by_first_pixel(got), _by_first_pixel(ref)
    for name in ("area", "x0", "y0", "m20", "m11", "m02", "theta", "a", "b"):
        np.testing.assert_allclose(
            getattr(got.moments, name)[order_got],
            getattr(ref.moments, name)[order_ref],
            rtol=1e-12,
            atol=1e-12,
        )


def _by_first_pixel(blobs) -> np.ndarray:
    """Labels 1.. sorted by the flat index of their first pixel."""
    first = np.full(blobs.n_labels, np.iinfo(np.int64).max)
    np.minimum.at(first, blobs.pixel_labels, blobs.index)
    return np.argsort(first[1:], kind="stable") + 1


@needs_jit
@settings(max_examples=150, deadline=None)
@given(
    arrays(
        np.uint8,
        st.tuples(st.integers(1, 14), st.integers(1, 14)),
        elements=st.sampled_from([0, 0, 255]),
    )
)
def test_sparse_labelling_finds_the_components_opencv_finds(mask):
    """Any mask, including blobs touching the image's edges (a row's end is not the next row)."""
    _assert_same_blobs(mask)


@needs_jit
def test_sparse_labelling_on_a_rendered_rain_layer():
    scene = Scene(640, 360, seed=4, params=SceneParams(rain=StreakParams(mu_deg=70)))
    mask = np.zeros((360, 640), np.uint8)
    for i in range(3):
        mask |= scene.frame(i)[1].mask.astype(np.uint8) * 255
    _assert_same_blobs(mask)


@needs_jit
def test_moments_only_for_blobs_the_size_rule_can_accept():
    mask = np.zeros((20, 30), np.uint8)
    mask[2, 2] = 255  # 1 px
    mask[5:12, 10] = 255  # 7 px
    got = find_blobs_sparse(mask_to_index(mask), mask.shape, min_area=4, max_area=50)
    area = got.moments.area
    small, streak = (1, 2) if area[1] == 1 else (2, 1)
    assert np.isnan(got.moments.theta[small])
    assert got.moments.theta[streak] == pytest.approx(np.pi / 2)


def test_candidate_rate_is_the_running_mean_of_the_mask():
    """The sparse, rescaled rate equals cv2.accumulateWeighted on the dense mask."""
    rng = np.random.default_rng(5)
    shape = (23, 31)
    rate = CandidateRate(shape, tau=7)
    dense = np.zeros(shape, np.float32)
    for n in range(1, 400):  # long enough for several renormalisations at tau 7
        mask = (rng.random(shape) < 0.2).astype(np.uint8)
        rate.update(np.flatnonzero(mask), mask.mean())
        cv2.accumulateWeighted(mask, dense, max(1.0 / n, 1.0 / 7))
    np.testing.assert_allclose(rate.values(), dense, atol=2e-5)


@pytest.mark.parametrize("compiled", [False, True])
def test_blob_mean_rate_reads_the_rate_before_the_update(compiled):
    shape = (10, 10)
    rate = CandidateRate(shape, tau=10)
    mask = np.zeros(shape, np.uint8)
    mask[2:8, 4] = 255
    index = mask_to_index(mask)
    rate.update(index, 0.06)  # first frame: the rate is the mask
    blobs = find_blobs_sparse(index, shape, rate=rate, compiled=compiled)
    assert blob_mean_rate(blobs, rate)[1] == pytest.approx(1.0)


@needs_jit
def test_the_detector_decides_the_same_with_and_without_the_kernels():
    params = SceneParams(cars=2, rain=StreakParams(mu_deg=70), schedule=[0] * 70 + [1] * 60)
    scene = Scene(640, 360, seed=2, params=params)
    fast, reference = HosDetector(compiled=True), HosDetector(compiled=False)
    assert fast.compiled and not reference.compiled
    n_rain = 0
    for i in range(130):
        gray = scene.frame(i)[0]
        a, b = fast.process(gray, i / 25), reference.process(gray, i / 25)
        assert (a.rain, a.state, a.n_blobs, a.n_rain_blobs) == (
            b.rain,
            b.state,
            b.n_blobs,
            b.n_rain_blobs,
        )
        np.testing.assert_allclose(a.histogram, b.histogram, rtol=1e-9, atol=1e-9)
        assert a.R == pytest.approx(b.R, rel=1e-6, abs=1e-6)
        np.testing.assert_array_equal(a.label_image() > 0, b.label_image() > 0)
        n_rain += a.rain
    assert n_rain > 40


def test_hos_jit_0_turns_the_kernels_off():
    code = (
        "from hos import _jit, HosDetector; import numpy as np;"
        "d = HosDetector(); z = np.zeros((36, 64), np.uint8);"
        "r = [d.process(z, i / 25) for i in range(3)];"
        "print(_jit.ENABLED, d.compiled, _jit.why_disabled())"
    )
    assert run_python(code, HOS_JIT="0").split() == ["False", "False", "HOS_JIT=0"]


@needs_jit
def test_warm_up_compiles_every_kernel_the_detector_calls():
    """After warm_up(), a detector's first frames compile nothing new (same argument types)."""
    from hos._jit_mixture import _fit
    from hos._jit_motion import _fit_translation

    kernels = (_jit._photometric_candidates, _jit._label_sparse, _fit, _fit_translation)
    _jit.warm_up()
    before = [len(k.signatures) for k in kernels]
    assert all(before)
    params = SceneParams(rain=StreakParams(mu_deg=70), schedule=[0] * 62 + [1])
    scene = Scene(320, 180, seed=1, params=params)
    det = HosDetector(compiled=True)
    for i in range(70):
        det.process(scene.frame(i)[0], i / 25)
    assert [len(k.signatures) for k in kernels] == before


_SIGNATURES = (
    "import numba, hos._jit as j, hos._jit_mixture as m, hos._jit_motion as t;"
    "ks = {f'{mod.__name__}.{n}': sorted(map(str, k.signatures)) for mod in (j, m, t)"
    " for n, k in vars(mod).items() if isinstance(k, numba.core.registry.CPUDispatcher)};"
    "print(sorted((n, s) for n, s in ks.items() if s))"
)


@needs_jit
def test_the_install_s_two_kernel_groups_are_every_kernel_warm_up_loads():
    """``make install`` compiles the kernels in two groups, one per core: together they must
    be every kernel that warm_up() compiles (else the first run compiles the rest)."""
    every = run_python("import hos._jit as j; j.warm_up();" + _SIGNATURES)
    groups = run_python(
        "import hos._jit as j; [j.warm_up(g) for g in range(len(j.WARM_UP_GROUPS))];" + _SIGNATURES
    )
    assert groups == every
    # the five entry points (the other kernels are compiled into them)
    assert every.count("'hos._jit") == 5, every


@needs_jit
def test_compile_in_parallel_runs_the_groups_in_child_processes():
    code = "import hos._jit as j; s = j.compile_in_parallel(); print(s > 0);" + _SIGNATURES
    loaded_here, kernels = run_python(code).splitlines()
    assert loaded_here == "True"
    assert kernels == "[]"  # the children compiled (or loaded) them, not this process


def test_an_unknown_kernel_group_is_refused():
    with pytest.raises(ValueError, match="unknown kernel group 2"):
        _jit.warm_up(2)
