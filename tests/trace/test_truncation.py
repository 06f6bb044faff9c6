"""Paths ended at ``render.max_depth``: measured per pixel, bounded, and reported per region.

The references here share no code with the accounting they check: a mirror whose depth-1 image
is known in closed form, a deeper render of the same scene (deterministic splitting, so the two
renders differ only by what the cut-off replaced), and seed-to-seed scatter for the standard
errors.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from pmmw.imaging.imager import blur, blur_adjoint, psf_kernel
from pmmw.physics.jones import stokes_images
from pmmw.pipeline import region_stats
from pmmw.trace.integrator import Integrator
from pmmw.trace.intersect import make_intersector
from pmmw.trace.job import RenderSettings
from pmmw.trace.pool import assemble
from tests.scenes import UniformSky, box, looking_down_at, make_job, material, sphere

F95 = 95e9


def _image(job):
    integ = Integrator(job, make_intersector(job.vertices, job.faces))
    return assemble(job, [integ.render_tile(t) for t in job.tiles()])


def _mirror_job(max_depth):
    plate = (box([-50, -50, -1], [50, 50, 0]), material(kind="metal", temperature=290.0))
    settings = RenderSettings(spp=1, max_depth=max_depth, threshold=0.0, termination="temperature")
    return make_job([plate], looking_down_at(45.0, width=2, height_px=2), UniformSky(10.0, 290.0), F95, settings)


def test_a_mirror_cut_at_depth_one_is_fully_truncated_and_bounded():
    """Metal at 290 K under a 10 K sky: at max_depth 1 the reflected path ends on the metal's
    290 K with all of its power (fraction 1); the bound is max(290 - 10, 290 - 290) = 280 K, the
    exact error, since the next segment sees the 10 K sky. At depth 2 nothing is cut."""
    cut = _image(_mirror_job(1))
    full = _image(_mirror_job(2))
    np.testing.assert_allclose(stokes_images(cut.mean)["Ex2"], 290.0, atol=1e-9)
    np.testing.assert_allclose(stokes_images(full.mean)["Ex2"], 10.0, atol=1e-9)
    np.testing.assert_allclose(cut.truncated[..., 0], 1.0, atol=1e-12)
    np.testing.assert_allclose(cut.truncated[..., 1], 280.0, atol=1e-9)
    np.testing.assert_array_equal(full.truncated, 0.0)


def _cluttered_job(max_depth):
    """Non-isothermal clutter with long reflection chains: a lossless sphere inside a metal
    trough over a lossy ground, under a cold sky."""
    objects = [
        (box([-3, -3, -1], [3, 3, 0]), material(eps=3.0 + 0.3j, temperature=300.0)),
        (box([-1.2, -1.2, 0], [-1.0, 1.2, 1.0]), material(kind="metal", temperature=250.0)),
        (box([1.0, -1.2, 0], [1.2, 1.2, 1.0]), material(kind="metal", temperature=250.0)),
        (sphere([0.0, 0.0, 0.5], 0.4), material(eps=2.2 + 0j, temperature=320.0)),
    ]
    from pmmw.scene.camera import Camera

    cam = Camera.look_at([0.3, -2.5, 2.0], [0.0, 0.0, 0.4], [0, 0, 1], np.radians(60), (24, 24))
    settings = RenderSettings(spp=1, max_depth=max_depth, threshold=1e-9, termination="temperature", tile=24)
    return make_job(objects, cam, UniformSky(5.0, 290.0), F95, settings)


def test_the_bound_covers_what_a_deeper_render_changes():
    """Deterministic splitting with a vanishing threshold: the depth-3 image differs from the
    depth-48 one only where the cut-off replaced a path, and never by more than the per-pixel
    bound (both polarizations; 1e-6 K of rounding plus the deep render's own bound, < 0.2 K).
    The test can fail: the cut moves pixels by kelvins and the bound is tight to within a few
    times. (Depth 24 is not enough for the reference: a ray between the two parallel metal walls
    keeps 15 % of a pixel's power for 30 reflections before it climbs out.)"""
    shallow, deep = _image(_cluttered_job(3)), _image(_cluttered_job(48))
    diff = np.abs(shallow.mean[..., :2] - deep.mean[..., :2]).max(axis=-1)
    bound = shallow.truncated[..., 1]
    assert diff.max() > 1.0  # the cut matters in this scene
    assert deep.truncated[..., 1].max() < 0.2
    assert np.all(diff <= bound + deep.truncated[..., 1] + 1e-6)
    moved = diff > 1e-3
    assert np.median(bound[moved] / diff[moved]) < 20.0  # a bound, but not a vacuous one


def test_blur_adjoint_is_the_transpose_of_blur():
    """<blur(x), y> = <x, blur_adjoint(y)> for random images, also when the kernel is wider than
    the image (mirrored padding repeats). The Airy kernel is mirror-symmetric, so this is the
    self-adjoint shortcut (`blur_adjoint` is `blur`, diagonal in the DCT-II basis): rounding of two
    DCT blurs, 1e-10 relative. The general path: the next test."""
    rng = np.random.default_rng(3)
    for shape, kernel in (
        ((17, 23), psf_kernel(2e-3, 2 * np.pi * 95e9 / 3e8, 0.6)),
        ((9, 6), psf_kernel(1e-3, 2 * np.pi * 35e9 / 3e8, 0.3)),
    ):
        assert kernel.shape[0] > 2 * min(shape) or shape == (17, 23)
        x, y = rng.normal(size=shape), rng.normal(size=shape)
        lhs, rhs = np.sum(blur(x, kernel) * y), np.sum(x * blur_adjoint(y, kernel))
        assert abs(lhs - rhs) <= 1e-10 * np.sum(np.abs(x)) * np.sum(np.abs(y))


def test_blur_adjoint_of_an_asymmetric_kernel_folds_the_margin_back():
    """The general adjoint (padded FFT convolution with the flipped kernel, the padded margin folded
    back onto the pixels it was copied from), live for the off-axis beams of `FieldPSF.kernel_at`:
    <blur(x), y> = <x, blur_adjoint(y)> for an off-axis beam (theta = 0.5 rad, phi = 0.7 rad:
    elongated along a diagonal, not mirror-symmetric, though point-symmetric) and a random kernel
    off centre (no symmetry at all, so the flip matters), each also wider than its image.

    Tolerance 1e-12 of S = sum|x| sum|y| max|k|: every term x_i A_ij y_j of either sum is at most
    |x_i| |y_j| times the few taps folded onto one pixel pair, and float64 FFT convolutions round
    to about eps log2(n) = 2e-15 of that; 1e-12 leaves a factor of 100 over several taps. Controls:
    `self_adjoint` is False for both kernels (the general path is the one taken), and the adjoint
    without the fold (the flipped kernel's `blur`) misses the identity by far more than the
    tolerance."""
    from pmmw.imaging.antenna import Aperture, off_axis_kernel
    from pmmw.imaging.imager import self_adjoint

    rng = np.random.default_rng(8)
    beam = off_axis_kernel(2e-3, 2 * np.pi * 95e9 / 3e8, 0.3, Aperture(), theta=0.5, phi=0.7, max_radius=40)
    shifted = np.zeros((15, 15))
    shifted[:, 3:] = rng.random((15, 12))  # off centre by 1.5 px on average, random taps
    assert beam.shape == (81, 81)
    for shape, kernel in (((17, 23), beam), ((9, 6), beam), ((17, 23), shifted), ((5, 4), shifted)):
        assert not self_adjoint(kernel, shape)
        x, y = rng.normal(size=shape), rng.normal(size=shape)
        s = np.sum(np.abs(x)) * np.sum(np.abs(y)) * np.max(np.abs(kernel))
        lhs, rhs = np.sum(blur(x, kernel) * y), np.sum(x * blur_adjoint(y, kernel))
        assert abs(lhs - rhs) <= 1e-12 * s, (shape, kernel.shape)
        unfolded = np.sum(x * blur(y, kernel[::-1, ::-1]))
        assert abs(lhs - unfolded) > 1e-6 * s, (shape, kernel.shape)


def _roulette_room(seed):
    """An isothermal room at 300 K with a coarse roulette threshold: every pixel's expectation
    is 300 K and the Monte Carlo noise is about 1.7 K per sample (test_render_physics)."""
    room = [
        (box([-5, -5, -0.1], [5, 5, 0]), material(eps=3.0 + 0.5j, temperature=300.0)),
        (box([-5, -5, 3.0], [5, 5, 3.1]), material(kind="metal", temperature=300.0)),
        (box([-5, 4.9, 0], [5, 5, 3]), material(kind="metal", temperature=300.0)),
        (sphere([0, 1.0, 1.0], 0.7), material(eps=2.5 + 0.01j, temperature=300.0)),
    ]
    from pmmw.scene.camera import Camera

    cam = Camera.look_at([0.0, -4.0, 1.5], [0.0, 2.0, 0.8], [0, 0, 1], np.radians(60), (32, 32))
    settings = RenderSettings(spp=4, max_depth=40, threshold=0.05, termination="roulette", tile=32, seed=seed)
    return make_job(room, cam, UniformSky(300.0, 300.0), F95, settings)


def test_region_standard_errors_predict_the_scatter_over_seeds():
    """The report's standard error of a region mean and of a contrast, through a PSF, against
    the scatter of the same figures over 12 seeds. With 12 seeds the sample standard deviation
    is within a factor 0.55-1.45 of the truth with probability > 99 %; the predicted error is
    averaged over the seeds."""
    from pmmw.config.schema import Region

    regions = {"a": Region(box=[4, 4, 14, 14]), "b": Region(box=[18, 10, 28, 26])}
    kernel = psf_kernel(np.radians(60) / 32, 2 * np.pi * 95e9 / 3e8, 0.02)
    assert kernel.shape[0] > 3
    scn = SimpleNamespace(
        output=SimpleNamespace(regions=regions),
        imager=SimpleNamespace(noise=0.0),
        render=SimpleNamespace(max_depth=40, termination="roulette"),
    )
    means, se_mean = _predicted_and_observed_scatter(_roulette_room, scn, kernel)
    assert abs(np.mean(means) - 300.0) < 4.0 * np.mean(se_mean) / np.sqrt(12)


def _predicted_and_observed_scatter(make, scn, kernel):
    """Render ``make(seed)`` for 12 seeds; assert that the scatter of region a's mean and of the
    contrast a - b (Ex2, sensor image) is 0.55-1.45 times the mean reported standard error.
    Returns a's means and standard errors."""
    means, contrasts, se_mean, se_con = [], [], [], []
    for seed in range(1, 13):
        job = make(seed)
        img = _image(job)
        sensor = {c: blur(v, kernel) for c, v in stokes_images(img.mean).items()}
        st = region_stats(scn, job.camera, sensor, img, kernel)
        means.append(st["means"]["a"]["Ex2"])
        contrasts.append(st["contrasts"]["a - b"]["Ex2"]["K"])
        se_mean.append(st["stderr"]["a"]["Ex2"])
        se_con.append(st["contrasts"]["a - b"]["Ex2"]["stderr_K"])
    for observed, predicted in (
        (np.std(means, ddof=1), np.mean(se_mean)),
        (np.std(contrasts, ddof=1), np.mean(se_con)),
    ):
        assert 0.55 < observed / predicted < 1.45, (observed, predicted)
    return means, se_mean


def test_one_sample_per_pixel_gives_no_standard_error():
    job = _mirror_job(2)
    img = _image(job)
    from pmmw.config.schema import Region

    scn = SimpleNamespace(
        output=SimpleNamespace(regions={"a": Region(box=[0, 0, 2, 2])}),
        imager=SimpleNamespace(noise=1.0),
        render=SimpleNamespace(max_depth=2, termination="temperature"),
    )
    st = region_stats(scn, job.camera, stokes_images(img.mean), img, None)
    assert st["stderr"]["a"]["Ex2"] is None
    assert st["truncation"]["a"]["bound_K"] == pytest.approx(0.0)


def _checkerboard(seed, spp):
    """Metal squares (mirroring a 10 K sky) and blackbody squares (300 K) of 0.23 m, seen from
    4 m straight down with the image turned 30 degrees to them: every square's edges cross
    pixels at slant, so most of the variance is the pixels' partial coverage, where the
    low-discrepancy sub-pixel samples beat independent ones."""
    from pmmw.scene.camera import Camera

    objects, n, a = [], 12, 0.23
    for i in range(n):
        for j in range(n):
            lo = [(i - n / 2) * a, (j - n / 2) * a, -0.1]
            spec = (
                material(kind="metal", temperature=300.0)
                if (i + j) % 2
                else material(kind="blackbody", temperature=300.0)
            )
            objects.append((box(lo, [lo[0] + a, lo[1] + a, 0.0]), spec))
    up = [np.sin(np.radians(30.0)), np.cos(np.radians(30.0)), 0.0]
    cam = Camera.look_at([0.0, 0.0, 4.0], [0.0, 0.0, 0.0], up, np.radians(30.0), (32, 32))
    settings = RenderSettings(spp=spp, max_depth=4, threshold=1e-3, tile=32, seed=seed)
    return make_job(objects, cam, UniformSky(10.0, 300.0), F95, settings)


def test_region_standard_errors_hold_for_low_discrepancy_samples_at_edges():
    """Where partial pixel coverage dominates, the spread of single samples overstates the error
    of the low-discrepancy pixel means (1.6x here at 8 spp, more at higher spp); the report's
    estimate (from the two independently rotated replicates of each pixel) predicts the scatter
    of a region mean and a contrast over 12 seeds within 0.55-1.45 (the sampling range of a
    12-seed standard deviation at > 99 %)."""
    from pmmw.config.schema import Region

    regions = {"a": Region(box=[2, 2, 16, 16]), "b": Region(box=[16, 14, 30, 30])}
    kernel = psf_kernel(np.radians(30) / 32, 2 * np.pi * 95e9 / 3e8, 0.05)
    scn = SimpleNamespace(
        output=SimpleNamespace(regions=regions),
        imager=SimpleNamespace(noise=0.0),
        render=SimpleNamespace(max_depth=4, termination="roulette"),
    )
    _predicted_and_observed_scatter(lambda seed: _checkerboard(seed, 8), scn, kernel)


def test_the_rain_sky_stays_within_the_range_the_truncation_bound_assumes():
    """A path ended early can at most be wrong by the gap to the hottest or coldest brightness the
    sky can show. With scattering rain the source depends on direction (source -+ |source_mu|),
    so the range must cover every elevation and observer height, not only the cells' mean
    sources; checked on 10 mm/h rain under a cloud at 95 GHz (the SAR rain weather) over a 250 K
    ground, colder than the air, which the scattering solution sees."""
    from pmmw.atmosphere.model import Atmosphere, AtmosphereLayer, AtmosphereModel
    from pmmw.scene.sky import AtmosphereSky

    atm = Atmosphere(
        profile="standard",
        layers=(
            AtmosphereLayer("rain", 0.0, 1500.0, rain_rate=10.0),
            AtmosphereLayer("cloud", 1000.0, 2000.0, liquid_water=1.3e-3),
        ),
    )
    model = AtmosphereModel(atm, 95e9, ground_temperature=250.0)
    assert np.abs(model.source_mu).max() > 1.0  # the direction term is there to be covered
    sky = AtmosphereSky(model, 250.0)
    lo, hi = sky.temperature_range()
    el = np.radians(np.linspace(0.0, 90.0, 91))
    for h in (0.0, 750.0, 1500.0, 3000.0):
        t = model.sky_temperature(el, height=h)
        assert lo <= t.min() and t.max() <= hi, (h, t.min(), t.max(), lo, hi)


def test_the_rain_two_stream_ground_is_the_skys_ground():
    """The scene's sky puts `sky.ground_temperature` below the horizon; the scattering solution of
    the same atmosphere stands on the same ground."""
    from pmmw.pipeline import atmosphere_model, resolve

    res = resolve(
        "configs/sar_cessna_95ghz.yaml",
        [
            "sky.ground_temperature=260 K",
            "atmosphere.layers=[{kind: rain, base: 0 m, top: 1500 m, rain_rate: 10 mm/h}]",
        ],
    )
    assert atmosphere_model(res.scenario, 95e9).ground_temperature == pytest.approx(260.0)
