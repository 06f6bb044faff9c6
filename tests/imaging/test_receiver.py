"""The receiver's noise (`pmmw.imaging.receiver`) against the radiometer equation's closed
forms (Ulaby & Long 2014, ch. 7) and the pixel noise of `apply_imager` against its formula."""

import numpy as np
import pytest
from scipy.stats import chi2

from pmmw.imaging.imager import apply_imager
from pmmw.imaging.receiver import Receiver, dwell_time, noise_temperature, radiometer_sigma


def test_total_power_radiometer_equation():
    # T_sys / sqrt(B tau): 300 K + 500 K over 1e10 Hz x 1e-3 s = 1e7 -> 800 / 3162.28 = 0.25298 K;
    # exact arithmetic: only float rounding (1e-12 relative)
    assert radiometer_sigma(300.0, 500.0, 1e10, 1e-3) == pytest.approx(800.0 / np.sqrt(1e7), rel=1e-12)


def test_dicke_balanced_is_twice_total_power_and_ignores_gain():
    # balanced Dicke: 2 T_sys / sqrt(B tau), whatever dG/G (the reference cancels it)
    tp = radiometer_sigma(300.0, 500.0, 1e10, 1e-3)
    assert radiometer_sigma(300.0, 500.0, 1e10, 1e-3, mode="dicke") == pytest.approx(2.0 * tp, rel=1e-12)
    assert radiometer_sigma(300.0, 500.0, 1e10, 1e-3, mode="dicke", gain_fluctuation=1e-2) == pytest.approx(
        2.0 * tp, rel=1e-12
    )


def test_unbalanced_dicke_keeps_a_gain_term_in_the_imbalance():
    # T_A 100 K, T_ref 300 K, T_rec 500 K, B tau 1e7, dG/G 1e-3:
    # sqrt((2 600^2 + 2 800^2) / 1e7 + 1e-6 200^2) = sqrt(0.2 + 0.04) = 0.48990 K (hand arithmetic)
    s = radiometer_sigma(100.0, 500.0, 1e10, 1e-3, mode="dicke", gain_fluctuation=1e-3, t_ref=300.0)
    assert s == pytest.approx(np.sqrt(0.24), rel=1e-12)


def test_gain_fluctuation_term_of_total_power():
    # T_sys sqrt(1/(B tau) + (dG/G)^2): 800 K x sqrt(1e-7 + 1e-6) = 800 sqrt(1.1e-6) = 0.83905 K
    s = radiometer_sigma(300.0, 500.0, 1e10, 1e-3, gain_fluctuation=1e-3)
    assert s == pytest.approx(800.0 * np.sqrt(1.1e-6), rel=1e-12)


def test_noise_figure_and_dwell_time():
    # F = 3.0103 dB is a factor 2: T_rec = 290 K (T0 (F - 1)); 10 Hz x 1000 pixels -> 100 us
    assert noise_temperature(10 * np.log10(2.0)) == pytest.approx(290.0, rel=1e-12)
    assert dwell_time(10.0, 1000) == pytest.approx(1e-4, rel=1e-12)


def _sample_std_bounds(n, sigma, p=1e-6):
    """Two-sided bounds on the sample std of n independent normals of std sigma: (n-1) s^2 /
    sigma^2 is chi-square with n-1 degrees of freedom; p the chance a correct model fails."""
    lo, hi = chi2.ppf([p / 2, 1 - p / 2], n - 1)
    return sigma * np.sqrt(lo / (n - 1)), sigma * np.sqrt(hi / (n - 1))


def test_pixel_noise_of_a_constant_image_is_the_radiometer_sigma():
    rx = Receiver(t_rec=500.0, bandwidth=2e9, tau=1e-4)
    shape = (200, 200)
    ideal = {"Ex2": np.full(shape, 300.0), "Ey2": np.full(shape, 300.0), "U": np.zeros(shape), "V": np.zeros(shape)}
    maps = {}
    out = apply_imager(
        ideal, pixel_angle=1e-3, k0=1.0, aperture_diameter=0.0, noise=0.0, seed=3, receiver=rx, noise_maps=maps
    )
    want = 800.0 / np.sqrt(2e9 * 1e-4)  # 1.7889 K
    lo, hi = _sample_std_bounds(out["Ex2"].size, want)
    assert lo < np.std(out["Ex2"] - 300.0, ddof=1) < hi
    # I = Ex2 + Ey2 of independent noises: sqrt(2) sigma
    lo, hi = _sample_std_bounds(out["I"].size, np.sqrt(2.0) * want)
    assert lo < np.std(out["I"] - 600.0, ddof=1) < hi
    assert maps["Ex2"] == pytest.approx(np.full(shape, want), rel=1e-12)


def test_hot_pixels_are_noisier_than_cold_ones():
    rx = Receiver(t_rec=100.0, bandwidth=2e9, tau=1e-4)
    shape = (100, 200)
    t = np.where(np.arange(200)[None, :] < 100, 40.0, 310.0) * np.ones(shape)  # cold sky | warm body
    ideal = {"Ex2": t, "Ey2": t, "U": np.zeros(shape), "V": np.zeros(shape)}
    out = apply_imager(ideal, pixel_angle=1e-3, k0=1.0, aperture_diameter=0.0, noise=0.0, seed=5, receiver=rx)
    cold, hot = (out["Ex2"] - t)[:, :100], (out["Ex2"] - t)[:, 100:]
    for part, t_a in ((cold, 40.0), (hot, 310.0)):
        lo, hi = _sample_std_bounds(part.size, (t_a + 100.0) / np.sqrt(2e5))
        assert lo < np.std(part, ddof=1) < hi
    # control: the two halves' spreads differ beyond their sampling error (140 K vs 410 K systems)
    assert np.std(hot) > 2.5 * np.std(cold)


def test_scalar_noise_path_is_unchanged():
    # `imager.noise` alone draws exactly the numbers it drew before receivers existed
    shape = (8, 8)
    ideal = {c: np.full(shape, 100.0) for c in ("Ex2", "Ey2", "U", "V")}
    out = apply_imager(ideal, pixel_angle=1e-3, k0=1.0, aperture_diameter=0.0, noise=4.0, seed=1)
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([1, 0x5EED])))
    assert np.array_equal(out["Ex2"], 100.0 + rng.normal(0.0, 4.0, shape))
