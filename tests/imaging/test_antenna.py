"""The antenna's beam (`pmmw.imaging.antenna`) against closed forms and published tables."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.special import j0, j1, jv

from pmmw.imaging.antenna import Aperture, antenna_kernel, beam_report, gaussian_feed_spillover
from pmmw.imaging.imager import blur, psf_kernel

U = np.linspace(0.01, 30.0, 3001)


def test_uniform_aperture_is_the_airy_pattern():
    # F(u) = J1(u)/u: the quadrature is exact to rounding for this smooth integrand (1e-9)
    ap = Aperture()
    assert ap.power(U) == pytest.approx((2 * j1(U) / U) ** 2, abs=1e-9)
    s = ap.beam_shape()
    # HPBW 1.029 lambda/D (u_half = 1.6163, Born & Wolf 1999 sec. 8.5.2): printed to 4 digits
    assert s["hpbw_u"] / np.pi == pytest.approx(1.029, abs=5e-4)
    # first sidelobe -17.57 dB (printed to 0.01 dB) at u = 5.1356
    assert s["first_sidelobe_dB"] == pytest.approx(-17.57, abs=0.005)
    # first null at u = 3.8317 (table step 0.0025); Airy encircled energy 0.838 there (3 digits)
    assert s["first_null_u"] == pytest.approx(3.8317, abs=0.003)
    assert ap.encircled_energy(3.8317)[0] == pytest.approx(0.838, abs=5e-4)
    # and Rayleigh's closed form 1 - J0^2 - J1^2 along u (trapezoid on a 0.0025 grid: 1e-5)
    uu = np.array([1.0, 3.8317, 7.0156, 12.0])
    assert ap.encircled_energy(uu) == pytest.approx(1 - j0(uu) ** 2 - j1(uu) ** 2, abs=1e-5)
    assert ap.taper_efficiency() == pytest.approx(1.0, abs=1e-12)


def test_the_uniform_aperture_s_closed_form_is_its_quadrature():
    """`Aperture.field` takes the uniform aperture's closed form J1(u) / u; the Hankel quadrature
    it takes for every other aperture, run for a blockage of 1e-9 (its central hole removes
    1e-18 / 2 of the integral), gives the same field to rounding: 1e-12 (the quadrature of this
    smooth integrand is exact to rounding, as above). The control: a 1 % blockage changes the
    field by more."""
    u = np.concatenate([[0.0, 1e-9], U])
    closed = Aperture().field(u)
    assert closed[0] == 0.5 and closed[1:] == pytest.approx(j1(u[1:]) / u[1:], rel=1e-14)
    assert Aperture(blockage=1e-9).field(u) == pytest.approx(closed, abs=1e-12)
    assert np.abs(Aperture(blockage=0.1).field(u) - closed).max() > 1e-3


def test_parabolic_taper_matches_its_closed_form_and_silver_table():
    # f = 1 - rho^2 (no pedestal): F(u) = 2 J2(u) / u^2, normalized 8 J2(u) / u^2
    ap = Aperture("parabolic", edge_taper_db=400.0)
    assert ap.power(U) == pytest.approx((8 * jv(2, U) / U**2) ** 2, abs=1e-9)
    s = ap.beam_shape()
    # The width against the closed form's own half-power point, found by scipy's root finder on
    # scipy's Bessel function (no pmmw code): 72.7476 lambda/D deg; 1e-3 deg is far above the
    # root's precision and far below any change of the transform that matters
    from scipy.optimize import brentq

    u_half = brentq(lambda u: (8 * jv(2, u) / u**2) ** 2 - 0.5, 0.5, 4.0)
    assert np.degrees(s["hpbw_u"] / np.pi) == pytest.approx(np.degrees(2 * u_half / np.pi), abs=1e-3)
    # Silver 1949, ch. 6, the table of the (1 - r^2)^p illuminations, p = 1: HPBW 72.8 lambda/D deg,
    # first sidelobe 24.6 dB down, gain factor 0.75; printed to 0.1 deg and 0.1 dB. A finding, not a pass: the exact width 72.748 deg
    # rounds to 72.7, so the 1949 table is 0.05 deg high (its own arithmetic); it is checked at one
    # unit of its last digit, and the exact root above is the check of pmmw's width
    assert np.degrees(s["hpbw_u"] / np.pi) == pytest.approx(72.8, abs=0.1)
    assert s["first_sidelobe_dB"] == pytest.approx(-24.6, abs=0.05)
    assert ap.taper_efficiency() == pytest.approx(0.75, abs=1e-12)


def test_parabolic_on_pedestal_is_the_sum_of_its_parts():
    # f = C + (1 - C)(1 - rho^2): F = C J1(u)/u + (1 - C) 2 J2(u)/u^2 (linearity of the transform)
    te = 10.0
    c = 10 ** (-te / 20)
    f = c * j1(U) / U + (1 - c) * 2 * jv(2, U) / U**2
    f0 = c / 2 + (1 - c) / 4
    ap = Aperture("parabolic", edge_taper_db=te)
    assert ap.power(U) == pytest.approx((f / f0) ** 2, abs=1e-9)
    # a tapered beam is wider with lower sidelobes than the uniform one, less than the full taper
    s, s0, s1 = ap.beam_shape(), Aperture().beam_shape(), Aperture("parabolic", edge_taper_db=400.0).beam_shape()
    assert s0["hpbw_u"] < s["hpbw_u"] < s1["hpbw_u"]
    assert s0["first_sidelobe_dB"] > s["first_sidelobe_dB"] > s1["first_sidelobe_dB"]


def test_blockage_raises_the_first_sidelobe_as_the_annulus_closed_form():
    # annulus b < rho < 1: F(u) = J1(u)/u - b^2 J1(b u)/(b u); F(0) = (1 - b^2) / 2
    b = 0.2
    f = j1(U) / U - b**2 * j1(b * U) / (b * U)
    ap = Aperture(blockage=b)
    assert ap.power(U) == pytest.approx((f / ((1 - b * b) / 2)) ** 2, abs=1e-9)
    closed = 10 * np.log10(np.max(((f / ((1 - b * b) / 2)) ** 2)[(U > 4.0) & (U < 7.0)]))
    s = ap.beam_shape()
    assert s["first_sidelobe_dB"] == pytest.approx(closed, abs=0.01)  # table step: 0.01 dB
    assert s["first_sidelobe_dB"] > -17.57 + 1.0  # the rise (control: the unblocked aperture's level)
    assert ap.taper_efficiency() == pytest.approx(1 - b * b, abs=1e-12)


def test_gaussian_feed_spillover_is_the_power_outside_the_rim():
    # a Gaussian beam exp(-2 r^2 / w^2) in power with its edge taper T_e at r = a: the fraction of
    # its power outside a, by quadrature (1e-9), equals 10^(-T_e/10) (Goldsmith 1998)
    te = 12.0
    w = np.sqrt(2.0 / (te / 10 * np.log(10)))  # a = 1: exp(-2/w^2) = 10^(-Te/10)
    r = np.linspace(0, 12, 240001)  # the rim r = 1 on the grid
    p = np.exp(-2 * r**2 / w**2) * r
    outside = np.trapezoid(p[r >= 1.0], r[r >= 1.0]) / np.trapezoid(p, r)
    assert gaussian_feed_spillover(te) == pytest.approx(outside, rel=1e-6)
    g = Aperture("gaussian", edge_taper_db=te).beam_shape()
    assert g["hpbw_u"] > Aperture().beam_shape()["hpbw_u"] and g["first_sidelobe_dB"] < -17.57


def test_uniform_antenna_kernel_is_the_airy_kernel():
    # the table's linear interpolation (step 0.01 in u) against the closed-form Airy: 1e-4 of the peak
    for pitch in (0.5e-3, 3e-3):
        k_airy = psf_kernel(pitch, 2 * np.pi / 3.2e-3, 0.5)
        k_ant = antenna_kernel(pitch, 2 * np.pi / 3.2e-3, 0.5, Aperture())
        assert k_ant.shape == k_airy.shape
        assert np.max(np.abs(k_ant - k_airy)) < 1e-4 * k_airy.max()


def test_nyquist_sampling_is_reported():
    lam, d = 3.2e-3, 0.5  # Nyquist pitch lambda / 2D = 3.2 mrad
    k0 = 2 * np.pi / lam
    assert "under-sampled" in beam_report(Aperture(), k0, d, 4e-3)["sampling"]
    assert "under-sampled" not in beam_report(Aperture(), k0, d, 3e-3)["sampling"]  # control


def test_spillover_in_the_energy_budget_and_the_image():
    ap = Aperture("gaussian", edge_taper_db=10.0, spillover=0.1, spillover_temperature=290.0)
    rep = beam_report(ap, 2 * np.pi / 3.2e-3, 0.5, 1e-3)
    eb = rep["energy_budget"]
    assert eb["main_beam"] + eb["sidelobes"] + eb["spillover"] == pytest.approx(1.0, abs=1e-12)
    assert rep["main_beam_efficiency"] < 0.9


def test_renders_without_an_antenna_block_keep_their_image():
    # pipeline.imager_model without imager.antenna or receiver: the Airy blur and scalar noise of before
    from pmmw import pipeline

    rng = np.random.default_rng(0)
    ideal = {c: rng.uniform(50, 300, (16, 16)) for c in ("Ex2", "Ey2", "U", "V")}
    im = SimpleNamespace(aperture_diameter=0.3, noise=4.0, antenna=None, receiver=None, resolution=(16, 16))
    scn = SimpleNamespace(imager=im, render=SimpleNamespace(seed=7))
    job = SimpleNamespace(camera=SimpleNamespace(pixel_angle=2e-3), k0=2 * np.pi / 3.2e-3)
    sensor, kernel = pipeline.imager_model(scn, job, ideal)
    k = psf_kernel(2e-3, job.k0, 0.3)
    noise = np.random.Generator(np.random.PCG64(np.random.SeedSequence([7, 0x5EED])))
    want = {c: blur(ideal[c], k) + noise.normal(0.0, 4.0, (16, 16)) for c in ("Ex2", "Ey2", "U", "V")}
    assert np.array_equal(sensor["Ex2"], want["Ex2"]) and np.array_equal(sensor["V"], want["V"])
    assert np.array_equal(kernel, k)


def test_adaptive_sampling_sizes_its_target_by_the_kernel_the_imager_blurs_with(tmp_path):
    """`make_job`'s error footprint is the one of the kernel the imager model uses
    (`pipeline.imager_kernel`): with a tapered antenna the antenna's kernel, not the uniform Airy
    one it used before; the control: without an antenna the Airy kernel's, and the two differ."""
    from pmmw.imaging.imager import error_footprint, psf_kernel
    from pmmw.pipeline import imager_kernel, make_job, resolve

    cfg = Path(__file__).resolve().parents[2] / "configs" / "cwd_outdoor_95ghz.yaml"
    base = ["imager.resolution=[16, 12]", "render.target_error=1 K"]
    tapered = base + ["imager.antenna={illumination: parabolic, edge_taper: 10 dB}"]
    res = resolve(cfg, tapered)
    f = res.scenario.frequencies[0]
    job = make_job(res, f)
    kern = imager_kernel(res.scenario, job.camera.pixel_angle, job.k0)
    assert job.settings.error_footprint == pytest.approx(error_footprint(kern), rel=1e-12)
    plain = make_job(resolve(cfg, base), f)
    airy = psf_kernel(plain.camera.pixel_angle, plain.k0, resolve(cfg, base).scenario.imager.aperture_diameter)
    assert plain.settings.error_footprint == pytest.approx(error_footprint(airy), rel=1e-12)
    assert abs(job.settings.error_footprint - plain.settings.error_footprint) > 1e-3 * plain.settings.error_footprint


def test_the_airy_kernel_is_computed_once_and_each_caller_gets_its_own():
    """`psf_kernel` caches its work: the same arguments give equal kernels, and changing one
    caller's array leaves the next caller's alone."""
    from pmmw.imaging.imager import psf_kernel

    a = psf_kernel(1e-3, 2e3, 0.5)
    b = psf_kernel(1e-3, 2e3, 0.5)
    np.testing.assert_array_equal(a, b)
    a[:] = 0.0
    assert psf_kernel(1e-3, 2e3, 0.5).sum() == pytest.approx(1.0, abs=1e-12)
