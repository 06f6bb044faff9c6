"""The detection criterion as a probability (Kay 1998, eq. 4.14) and the matched filter in
pixel-dependent noise, each against a Monte Carlo of itself."""

import numpy as np
import pytest
from scipy.stats import norm

from pmmw.imaging import detection


def _binomial_tolerance(p, n, z=5.0):
    """z standard errors of a fraction p of n trials (5: a correct model fails once in ~3.5e6)."""
    return z * np.sqrt(p * (1 - p) / n) + 1.0 / n


def _trials(signal, sigma_map, n, rng):
    """The matched filter's statistic sum(s x / sigma^2) / sqrt(sum(s^2 / sigma^2)) over n noise
    images, with and without the signal: standard normal without it."""
    w = signal / sigma_map**2
    scale = np.sqrt(np.sum(signal**2 / sigma_map**2))
    noise = rng.standard_normal((n,) + signal.shape) * sigma_map
    t0 = np.einsum("nij,ij->n", noise, w) / scale
    t1 = np.einsum("nij,ij->n", noise + signal, w) / scale
    return t0, t1


@pytest.mark.parametrize("dt,expect", [(1.0, True), (0.3, False)])
def test_pd_matches_a_monte_carlo_of_the_matched_filter(dt, expect):
    rng = np.random.default_rng(11)
    mask = np.zeros((12, 12), bool)
    mask[4:8, 4:8] = True  # 16 px
    sigma = 0.8
    s = dt * mask.astype(float)
    snr = detection.region_snr(dt, mask, None, sigma)  # 1.0 x 4 / 0.8 = 5; 0.3 x 4 / 0.8 = 1.5
    pfa = 1e-2
    n = 40000
    t0, t1 = _trials(s, np.full(s.shape, sigma), n, rng)
    thr = norm.isf(pfa)
    pd_mc, pfa_mc = np.mean(t1 > thr), np.mean(t0 > thr)
    pd = detection.probability_of_detection(snr, pfa)
    assert pfa_mc == pytest.approx(pfa, abs=_binomial_tolerance(pfa, n))
    assert pd_mc == pytest.approx(pd, abs=_binomial_tolerance(pd, n))
    # the criterion: SNR 5 detected; the control (SNR 1.5) is not, and its Pd is low
    assert detection.detectable(snr) is expect
    assert (pd > 0.9) is expect


def test_rose_threshold_as_probabilities():
    # Q(5) = 2.8665e-7 (tables of the normal tail); at that Pfa, SNR 5 is an even chance
    assert detection.probability_of_detection(5.0, norm.sf(5.0)) == pytest.approx(0.5, abs=1e-12)
    assert detection.required_snr(0.5, norm.sf(5.0)) == pytest.approx(5.0, abs=1e-9)
    # Pfa 1e-3, Pd 0.9: Q^-1(1e-3) - Q^-1(0.9) = 3.0902 + 1.2816 = 4.3717 (printed normal quantiles, 4 decimals)
    assert detection.required_snr(0.9, 1e-3) == pytest.approx(4.3717, abs=1e-4)


def test_effective_sigma_is_the_whitened_matched_filter():
    # noise that differs per pixel (a receiver's): the SNR from effective_sigma equals the spread of
    # the prewhitened matched filter's output, measured over many noise images
    rng = np.random.default_rng(3)
    mask = np.zeros((10, 10), bool)
    mask[3:7, 2:8] = True
    sigma_map = np.where(np.arange(10)[None, :] < 5, 0.5, 2.0) * np.ones((10, 10))
    dt = 0.7
    s = dt * mask.astype(float)
    eff = detection.effective_sigma(mask, None, sigma_map)
    snr = detection.region_snr(dt, mask, None, eff)
    n = 20000
    t0, t1 = _trials(s, sigma_map, n, rng)
    # the mean separation of the two distributions (unit variance) is the SNR; its standard error
    # sqrt(2/n) = 0.01, 5 of them
    assert np.mean(t1) - np.mean(t0) == pytest.approx(snr, abs=5 * np.sqrt(2.0 / n))
    # uniform noise: effective sigma is that sigma (exact)
    assert detection.effective_sigma(mask, None, np.full((10, 10), 1.3)) == pytest.approx(1.3, rel=1e-12)
    # control: the mean sigma over the footprint would misstate the SNR by more than the error
    naive = detection.region_snr(dt, mask, None, float(sigma_map[mask].mean()))
    assert abs(naive - snr) > 10 * np.sqrt(2.0 / n)


def test_detection_limit_of_a_range_sweep():
    # SNR falling with range as 100 / r (a closed form): SNR 5 at r = 20 exactly; swept 5, 10, 15, 25
    xs = [5.0, 10.0, 15.0, 25.0]
    lim = detection.detection_limit(xs, [100 / x for x in xs], [0.1] * 4)
    assert lim["kind"] == "limit" and lim["falls_with_x"]
    assert (lim["detected_x"], lim["missed_x"]) == (15.0, 25.0)
    # linear interpolation of 1/r between 15 and 25 misses 20 by at most the bracket; the stated error
    # (half the bracket, with the MC's in quadrature) must cover the true crossing
    assert abs(lim["crossing_x"] - 20.0) <= lim["error"]
    assert lim["spacing_error"] == pytest.approx(5.0)
    # the MC share: 0.1 SNR over the slope (6.667 - 4) / 10 = 0.2667 per m -> 0.375 m
    assert lim["mc_error"] == pytest.approx(0.1 / ((100 / 15 - 4) / 10), rel=1e-12)


def test_detection_limit_of_an_aperture_sweep_and_its_controls():
    # SNR growing with aperture: the smallest aperture detected
    lim = detection.detection_limit([0.3, 0.6, 0.9, 1.2], [2.0, 4.0, 6.0, 8.0])
    assert lim["kind"] == "limit" and not lim["falls_with_x"]
    assert (lim["detected_x"], lim["missed_x"]) == (0.9, 0.6)
    assert lim["crossing_x"] == pytest.approx(0.75, abs=1e-12)
    # controls: a target below the criterion everywhere is never detected; above it, always
    assert detection.detection_limit([1.0, 2.0, 3.0], [4.9, 3.0, 1.0])["kind"] == "none"
    assert detection.detection_limit([1.0, 2.0, 3.0], [9.0, 7.0, 5.0])["kind"] == "all"


def test_gaussian_tails_are_scipy_stats_to_the_bit():
    # tolerance: none (array_equal): the same special functions scipy.stats.norm calls, so a
    # report's probabilities of detection stay the same numbers; edges (0, 1, 0.5, inf, nan) included
    import numpy as np
    from scipy.stats import norm

    from pmmw.imaging import detection

    x = np.array([-np.inf, -40.0, -5.0, -0.3, 0.0, 1e-9, 2.5, 5.0, 38.0, np.inf, np.nan])
    q = np.array([0.0, 1e-300, 1e-12, 2.9e-7, 1e-3, 0.3, 0.5, 0.97, 1.0 - 1e-16, 1.0, np.nan])
    assert np.array_equal(detection._tail(x), norm.sf(x), equal_nan=True)
    assert np.array_equal(detection._tail_inverse(q), norm.isf(q), equal_nan=True)
    snr = np.linspace(0.0, 12.0, 49)
    for pfa in (1e-3, 2.9e-7, 0.2):
        assert np.array_equal(detection.probability_of_detection(snr, pfa), norm.sf(norm.isf(pfa) - snr))
        assert detection.required_snr(0.9, pfa) == float(norm.isf(pfa) - norm.isf(0.9))
    # control: the tail of -x is another function, so the comparison can fail
    assert not np.array_equal(detection._tail(-x[1:-1]), norm.sf(x[1:-1]))
