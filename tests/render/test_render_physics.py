"""Renders of simple scenes against references that share no code with the renderer.

Closed-form Fresnel (written here), the Brewster angle, an isothermal enclosure, and the `tmm`
package for coated surfaces. The scenes use a vanishing field of view so every pixel sees the
same incidence angle.
"""

import numpy as np
import pytest
import tmm

from pmmw.trace.job import RenderSettings
from tests.scenes import (
    UniformSky,
    box,
    hollow_box,
    looking_down_at,
    make_job,
    material,
    render,
    sphere,
)

F35 = 35e9
F95 = 95e9
C0 = 299_792_458.0


def fresnel_closed_form(eps, theta):
    """Textbook power reflectances of a half-space from vacuum (Born & Wolf), independent of pmmw."""
    c = np.cos(theta)
    root = np.sqrt(eps - np.sin(theta) ** 2 + 0j)
    rs = (c - root) / (c + root)
    rp = (eps * c - root) / (eps * c + root)
    return abs(rs) ** 2, abs(rp) ** 2


def ground(eps, temperature, depth=20.0, size=2000.0):
    return (box([-size / 2, -size / 2, -depth], [size / 2, size / 2, 0.0]), material(eps=eps, temperature=temperature))


@pytest.mark.parametrize("theta", [0, 10, 30, 45, 60, 75, 85])
def test_lossy_half_space_matches_fresnel(theta):
    """Ex2 = (1-Rs)T + Rs Tsky, Ey2 = (1-Rp)T + Rp Tsky within 0.1 K.

    Sand at 35 GHz (eps 3.9+0.56j) is so lossy that nothing comes back out of a 20 m deep ground
    (exp(-2 k0 Im(n) 20 m) ~ 1e-900), so the closed form is exact and 0.1 K only covers float32
    geometry (the hit angle is exact to ~1e-7 rad, a ~1e-5 K effect).
    """
    eps, t_ground, t_sky = 3.9 + 0.56j, 300.0, 40.0
    job = make_job([ground(eps, t_ground)], looking_down_at(theta), UniformSky(t_sky, 290.0), F35)
    img = render(job)
    rs, rp = fresnel_closed_form(eps, np.radians(theta))
    np.testing.assert_allclose(img["Ex2"], (1 - rs) * t_ground + rs * t_sky, atol=0.1)
    np.testing.assert_allclose(img["Ey2"], (1 - rp) * t_ground + rp * t_sky, atol=0.1)
    # no circular polarization from a single reflection; U vanishes in the s/p-aligned imager basis
    np.testing.assert_allclose(img["U"], 0.0, atol=0.1)
    np.testing.assert_allclose(img["V"], 0.0, atol=0.1)


def test_brewster_angle_reflects_no_p():
    """A lossless dielectric at the Brewster angle: Ey2 sees no sky at all.

    Rays transmitted into the lossless ground are absorbed by a blackbody nested inside it (an
    index-matched absorber), so Ey2 = Rp Tsky + (1 - Rp) Tbb. At Brewster Rp = 0 exactly, so
    Ey2 = Tbb to float32 geometry precision (1e-3 K); 5 degrees off Brewster Rp > 0 is visible.
    """
    eps, t_bb, t_sky = 2.25, 300.0, 0.0
    lossless = (box([-1000, -1000, -50], [1000, 1000, 0]), material(eps=eps, temperature=300.0))
    absorber = (box([-900, -900, -40], [900, 900, -1]), material(kind="blackbody", temperature=t_bb))
    brewster = np.degrees(np.arctan(np.sqrt(eps)))
    img = render(make_job([lossless, absorber], looking_down_at(brewster), UniformSky(t_sky, 290.0), F35))
    np.testing.assert_allclose(img["Ey2"], t_bb, atol=1e-3)
    rs, _ = fresnel_closed_form(eps, np.radians(brewster))
    np.testing.assert_allclose(img["Ex2"], (1 - rs) * t_bb, atol=1e-3)
    off = render(make_job([lossless, absorber], looking_down_at(brewster - 5), UniformSky(t_sky, 290.0), F35))
    _, rp = fresnel_closed_form(eps, np.radians(brewster - 5))
    assert rp > 1e-3
    np.testing.assert_allclose(off["Ey2"], (1 - rp) * t_bb, atol=1e-3)


def _room(temperature=300.0):
    """An isothermal closed room: lossy walls, a metal sphere, a coated lossy sphere, a plastic box."""
    t = temperature
    return [
        (hollow_box([-5, -5, -3], [5, 5, 3], 0.3), material(eps=5.5 + 0.5j, temperature=t)),
        (sphere([1.0, 2.0, 0.0], 0.8), material(kind="metal", temperature=t)),
        (sphere([-1.2, 2.5, 0.3], 0.7), material(eps=5.9 + 9.4j, temperature=t, coating=[(1.61 + 0.121j, 0.8e-3, t)])),
        (box([-0.6, 1.0, -1.5], [0.6, 1.8, -0.5]), material(eps=2.26 + 0.0013j, temperature=t)),
        (box([1.5, 0.5, -2.0], [2.5, 1.5, -1.0]), material(kind="opaque", eps=3.0 + 0.2j, temperature=t)),
    ]


def _room_camera():
    from pmmw.scene.camera import Camera

    return Camera.look_at([0.0, -4.0, 0.5], [0.0, 2.0, 0.0], [0, 0, 1], np.radians(70), (48, 36))


def test_isothermal_enclosure_reads_its_temperature():
    """Energy conservation: every pixel reads T in Ex2 and Ey2, Q, U, V vanish.

    With deterministic splitting and the thesis's depth/threshold termination on the last object's
    temperature, every event's weights add to exactly 1 (PHYSICS.md), so the tolerance is
    rounding only (1e-6 K), whatever the materials. The sky (0 K) must never be seen.
    """
    t = 300.0
    settings = RenderSettings(spp=2, max_depth=6, threshold=1e-3, termination="temperature", tile=16)
    job = make_job(_room(t), _room_camera(), UniformSky(0.0, 0.0), F95, settings)
    img = render(job)
    for c in ("Ex2", "Ey2"):
        np.testing.assert_allclose(img[c], t, atol=1e-6)
    for c in ("Q", "U", "V"):
        np.testing.assert_allclose(img[c], 0.0, atol=1e-6)


@pytest.mark.parametrize("strategy", ["stochastic", "hybrid"])
def test_isothermal_enclosure_with_branch_choice_keeps_each_paths_power(strategy):
    """With one branch followed per interaction, the branch is drawn by the power it would carry
    (the path's Jones columns times R and T), and the chosen child is rescaled to all of the
    power the interaction did not absorb: per path, deposited plus carried power is conserved.
    So the total (Ex2 + Ey2) / 2 of every pixel reads T to rounding (1e-6 K), as with splitting;
    Ex2 alone is only unbiased (a polarized path moves power between the rows) and is checked
    statistically (5 standard errors of the pixel mean). Drawn by the unpolarized R and T
    alone (the rule before), 42 % of the pixels missed T, by up to 243 K at 2 spp."""
    t = 300.0
    settings = RenderSettings(
        spp=2, max_depth=6, threshold=1e-3, termination="temperature", tile=16, strategy=strategy, split_depth=1
    )
    img = render(make_job(_room(t), _room_camera(), UniformSky(0.0, 0.0), F95, settings))
    np.testing.assert_allclose(0.5 * (img["Ex2"] + img["Ey2"]), t, rtol=0, atol=1e-6)
    for c in ("Ex2", "Ey2"):
        assert abs(img[c].mean() - t) < 5.0 * img[c].std() / np.sqrt(img[c].size) + 1e-6


def test_isothermal_enclosure_with_russian_roulette_is_unbiased():
    """With Russian roulette the expectation is still T; each roulette event adds noise.

    A statistical test: the mean over the 1728 pixels must be within 5 standard errors of T (the
    standard error estimated from the pixels themselves; a false alarm has probability ~6e-7),
    and the per-pixel noise at this coarse threshold (0.05) stays below 3 K (measured ~1.7 K).
    """
    t = 300.0
    settings = RenderSettings(spp=16, max_depth=12, threshold=0.05, termination="roulette", tile=16)
    img = render(make_job(_room(t), _room_camera(), UniformSky(0.0, 0.0), F95, settings))
    for c in ("Ex2", "Ey2"):
        std = img[c].std()
        assert 0.0 < std < 3.0
        assert abs(img[c].mean() - t) < 5.0 * std / np.sqrt(img[c].size)


def _tmm_rt_absorb(pol, eps_layers, d_layers, theta, lam):
    n_list = [1.0] + [np.sqrt(e + 0j) for e in eps_layers]
    d_list = [np.inf] + list(d_layers) + [np.inf]
    res = tmm.coh_tmm(pol, n_list, d_list, theta, lam)
    absorb = tmm.absorp_in_each_layer(res)
    return res["R"], res["T"], absorb


@pytest.mark.parametrize("theta", [0, 20, 40, 60, 80])
def test_coated_half_space_matches_tmm(theta):
    """0.8 mm denim on dry skin at 95 GHz, coating emitting at its own temperature.

    Ex2 = Rs Tsky + A_denim,s T_denim + T_s T_skin with Rs, A, T from `tmm` (independent transfer
    matrix code). Skin absorbs everything that enters a 20 m deep body. Tolerance 0.02 K: both
    codes are double precision; the remaining difference is float32 geometry.
    """
    eps_denim, eps_skin = 1.61 + 0.121j, 5.9 + 9.4j
    t_denim, t_skin, t_sky = 300.0, 310.0, 40.0
    lam = C0 / F95
    body = (
        box([-500, -500, -20], [500, 500, 0]),
        material(eps=eps_skin, temperature=t_skin, coating=[(eps_denim, 0.8e-3, t_denim)]),
    )
    img = render(make_job([body], looking_down_at(theta), UniformSky(t_sky, 290.0), F95))
    th = np.radians(theta)
    for pol, chan in (("s", "Ex2"), ("p", "Ey2")):
        r, tr, absorb = _tmm_rt_absorb(pol, [eps_denim, eps_skin], [0.8e-3], th, lam)
        a_denim = absorb[1]
        expected = r * t_sky + a_denim * t_denim + (1 - r - a_denim) * t_skin
        np.testing.assert_allclose(img[chan], expected, atol=0.02)


def test_thick_water_coating_equals_water_half_space():
    """A 50 mm water coating (|exp(2i beta)| ~ 1e-220) renders as the water half-space.

    The coating absorbs everything that enters it, so Ex2 = (1-Rs) T + Rs Tsky for water alone;
    tolerance 1e-6 K: the substrate's contribution is ~1e-200 of T.
    """
    eps_water = 6.65 + 9.4j
    t, t_sky = 300.0, 40.0
    body = (
        box([-500, -500, -20], [500, 500, 0]),
        material(eps=5.5 + 0.5j, temperature=t, coating=[(eps_water, 50e-3, t)]),
    )
    img = render(make_job([body], looking_down_at(30), UniformSky(t_sky, 290.0), F95))
    rs, rp = fresnel_closed_form(eps_water, np.radians(30))
    np.testing.assert_allclose(img["Ex2"], (1 - rs) * t + rs * t_sky, atol=1e-3)
    np.testing.assert_allclose(img["Ey2"], (1 - rp) * t + rp * t_sky, atol=1e-3)


def test_metal_mirror_at_45_degrees_sees_the_sky_overhead():
    """A 45-degree metal plate reflects the zenith: Ex2 = Ey2 = Tsky(zenith)."""
    from pmmw.scene.camera import Camera
    from pmmw.scene.sky import SlabSky

    plate = box([-1, -0.01, -1], [1, 0.01, 1])
    plate.apply_transform(__import__("trimesh").transformations.rotation_matrix(np.radians(-45), [1, 0, 0]))
    plate.apply_translation([0, 10, 1.5])
    cam = Camera.look_at([0, 0, 1.5], [0, 10, 1.5], [0, 0, 1], np.radians(0.5), (4, 4))
    sky = SlabSky(275.0, 0.06, 290.0)
    img = render(make_job([(plate, material(kind="metal", temperature=300.0))], cam, sky, F35))
    zenith = sky.zenith_angle_temperature(np.pi / 2)
    np.testing.assert_allclose(img["Ex2"], zenith, atol=0.05)
    np.testing.assert_allclose(img["Ey2"], zenith, atol=0.05)


def test_interpenetrating_objects_of_equal_permittivity_act_as_one_medium():
    """Medium stack (Murakowski 2014 sec. 2.2.9): two slightly interpenetrating lossless blocks of the same
    permittivity but different ids show no interface between them, so a ray crosses them as one
    block. Reference: the same scene with one block spanning both. A blackbody under the blocks
    makes the transmitted path visible. Tolerance 1e-3 K: entering the second block is an
    (index-matched, r = 0) interaction that counts towards max_depth, so the deepest internal
    bounces end on the depth cut-off one step earlier (measured 3e-4 K)."""
    eps = 2.25 + 0j
    bb = (box([-50, -50, -20], [50, 50, -2.0]), material(kind="blackbody", temperature=300.0))
    upper = (box([-40, -40, -1.0], [40, 40, 0.0]), material(eps=eps, temperature=300.0))
    lower = (box([-40, -40, -1.999], [40, 40, -0.999]), material(eps=eps, temperature=300.0))
    one = (box([-40, -40, -1.999], [40, 40, 0.0]), material(eps=eps, temperature=300.0))
    sky = UniformSky(20.0, 290.0)
    settings = RenderSettings(spp=1, max_depth=12, threshold=1e-9, termination="temperature")
    cam = looking_down_at(35)
    two = render(make_job([bb, upper, lower], cam, sky, F35, settings))
    single = render(make_job([bb, one], cam, sky, F35, settings))
    for c in ("Ex2", "Ey2"):
        np.testing.assert_allclose(two[c], single[c], atol=1e-3)
        assert 20.5 < two[c][0, 0] < 299.5  # both the sky and the absorber are seen


@pytest.mark.parametrize("roll_deg", [0.0, 30.0, 45.0])
def test_polarized_sky_texture_in_the_imager_basis(tmp_path, roll_deg):
    """A sky with Th != Tv seen directly, with the camera rolled about its axis.

    Independent expectation from the definition of the sky basis (PRODUCT.md: sky polarized in the
    basis of the global Z axis): h = unit(Z x k), v = k x h with k the propagation direction, and
    Ex2 = Th (h.x)^2 + Tv (v.x)^2, Ey2 = Th (h.y)^2 + Tv (v.y)^2, U = 2 (Th (h.x)(h.y) + Tv (v.x)(v.y))
    for the imager's x, y (eq. 2.14, 2.15 with incoherent h and v components). V = 0.
    Tolerance 1e-3 K: the texture is uniform in each channel, so only rounding remains.
    """
    from pmmw.scene.camera import Camera
    from pmmw.scene.sky import TextureSky
    from pmmw.scene.sky_texture import SkyTexture

    th_val, tv_val = 40.0, 120.0
    sky = TextureSky(SkyTexture(np.full((90, 180), tv_val), np.full((90, 180), th_val)))
    el = np.radians(30.0)
    k_view = np.array([0.0, np.cos(el), np.sin(el)])
    right = np.array([1.0, 0.0, 0.0])
    up0 = np.cross(right, k_view)
    r = np.radians(roll_deg)
    up = np.cos(r) * up0 + np.sin(r) * right
    cam = Camera.look_at([0, 0, 0], k_view, up, np.radians(0.01), (1, 1))
    far = (box([1000, 1000, -1001], [1001, 1001, -1000]), material(kind="blackbody"))  # never seen
    img = render(make_job([far], cam, sky, F35))
    k = -k_view
    h = np.cross([0, 0, 1.0], k)
    h /= np.linalg.norm(h)
    v = np.cross(k, h)
    hx, hy, vx, vy = h @ cam.x, h @ cam.y, v @ cam.x, v @ cam.y
    np.testing.assert_allclose(img["Ex2"], th_val * hx**2 + tv_val * vx**2, atol=1e-3)
    np.testing.assert_allclose(img["Ey2"], th_val * hy**2 + tv_val * vy**2, atol=1e-3)
    np.testing.assert_allclose(img["U"], 2 * (th_val * hx * hy + tv_val * vx * vy), atol=1e-3)
    np.testing.assert_allclose(img["V"], 0.0, atol=1e-9)
    if roll_deg == 45.0:
        assert abs(img["U"][0, 0]) > 79.0  # |Th - Tv| = 80 K all in U


@pytest.mark.parametrize("strategy", ["stochastic", "hybrid"])
def test_branch_choice_strategies_are_unbiased(strategy):
    """Stochastic branch choice (and the hybrid) converge to the closed form of the half-space.

    A lossless dielectric half-space with a nested blackbody (as the Brewster test) at 50 deg:
    Ex2 = Rs Tsky + (1 - Rs) Tbb exactly. 64 samples on 8x8 pixels = 4096 independent paths of
    weight 1/(P or 1-P): the image mean must lie within 5 standard errors (estimated from the
    samples) of the closed form.
    """
    from pmmw.scene.camera import Camera

    eps, t_bb, t_sky = 2.25, 300.0, 20.0
    lossless = (box([-1000, -1000, -50], [1000, 1000, 0]), material(eps=eps, temperature=300.0))
    absorber = (box([-900, -900, -40], [900, 900, -1]), material(kind="blackbody", temperature=t_bb))
    theta = 50.0
    base = looking_down_at(theta)
    cam = Camera(base.position, base.x, base.y, base.k, np.radians(0.01), 8, 8)
    settings = RenderSettings(
        spp=64, max_depth=8, threshold=1e-9, termination="temperature", strategy=strategy, split_depth=1, tile=8
    )
    job = make_job([lossless, absorber], cam, UniformSky(t_sky, 290.0), F35, settings)
    from pmmw.trace.integrator import Integrator
    from pmmw.trace.intersect import make_intersector

    res = Integrator(job, make_intersector(job.vertices, job.faces)).render_tile(job.tiles()[0])
    rs, rp = fresnel_closed_form(eps, np.radians(theta))
    for c, r in ((0, rs), (1, rp)):
        expected = r * t_sky + (1 - r) * t_bb
        est = res.mean[..., c].mean()
        se = np.sqrt((res.stderr[..., c] ** 2).mean() / res.mean[..., c].size)
        assert se > 0.0  # the choice does add noise
        assert abs(est - expected) < 5 * se + 1e-9


def test_adaptive_sampling_reaches_the_target_error():
    """render.target_error: pixels stop at min_spp where they converge (smooth ground) and get
    more samples only where needed; every pixel that stopped early meets the target."""

    settings = RenderSettings(
        spp=64, max_depth=6, threshold=0.05, termination="roulette", target_error=0.5, min_spp=4, tile=16
    )
    job = make_job(_room(300.0), _room_camera(), UniformSky(0.0, 0.0), F95, settings)
    from pmmw.trace.integrator import Integrator
    from pmmw.trace.intersect import make_intersector

    integ = Integrator(job, make_intersector(job.vertices, job.faces))
    results = [integ.render_tile(t) for t in job.tiles()]
    samples = np.concatenate([r.samples.ravel() for r in results])
    err = np.concatenate([np.max(r.stderr[..., :2], axis=-1).ravel() for r in results])
    assert samples.min() == 4 and samples.max() == 64  # both ends are used
    assert np.all(err[samples < 64] <= 0.5)
    assert samples.mean() < 64


def _clip_area(poly, x0, y0, x1, y1):
    """Area of a convex polygon (list of (x, y)) clipped to a box (Sutherland-Hodgman)."""
    for axis, bound, keep_above in ((0, x0, True), (0, x1, False), (1, y0, True), (1, y1, False)):
        out = []
        for i, p in enumerate(poly):
            q = poly[i - 1]
            p_in = (p[axis] >= bound) if keep_above else (p[axis] <= bound)
            q_in = (q[axis] >= bound) if keep_above else (q[axis] <= bound)
            if p_in != q_in:
                s = (bound - q[axis]) / (p[axis] - q[axis])
                out.append((q[0] + s * (p[0] - q[0]), q[1] + s * (p[1] - q[1])))
            if p_in:
                out.append(p)
        poly = out
        if not poly:
            return 0.0
    return 0.5 * abs(sum(poly[i - 1][0] * p[1] - p[0] * poly[i - 1][1] for i, p in enumerate(poly)))


def test_adaptive_sampling_per_psf_footprint_meets_the_target_after_the_blur():
    """render.target_error with a blurring imager: pixels stop at target / sqrt(sum psf^2)
    (`error_footprint`, 5.3 for this PSF of ~4.5 pixels FWHM), so the sensor image (blurred) meets
    the target with fewer samples than the per-pixel rule, which stops at the target itself.

    Scene with an exact answer: a 300 K blackbody square tilted 25 degrees, face-on 10 m away,
    on a 280 K sky; a pixel's truth is 280 K + 20 K x the exact fraction of its area the square
    covers (polygon clipping in pixel coordinates). Only edge pixels have noise. Tolerance: the
    blurred RMS error must be at most the target (the rule bounds every pixel's blurred error by
    it up to how well a few samples estimate sigma; observed 0.07 K for 0.4 K: the R2 sub-pixel
    sequence converges faster than the 1/sqrt(N) the estimate assumes), and the footprint rule
    must add under half the samples the per-pixel rule adds after the first pass (observed 1080
    against 2760)."""
    from pmmw.imaging.imager import blur, error_footprint, psf_kernel
    from pmmw.scene.camera import Camera
    from pmmw.trace.integrator import Integrator
    from pmmw.trace.intersect import make_intersector
    from pmmw.trace.pool import assemble

    n, side, dist, rot = 32, 3.0, 10.0, np.radians(25.0)
    plate = box([-side / 2, dist, -side / 2], [side / 2, dist + 0.01, side / 2])
    c, s = np.cos(rot), np.sin(rot)
    plate.apply_transform(np.array([[c, 0, -s, 0], [0, 1, 0, 0], [s, 0, c, 0], [0, 0, 0, 1.0]]))
    cam = Camera.look_at([0, 0, 0], [0, dist, 0], [0, 0, 1], np.radians(30), (n, n))
    kern = psf_kernel(cam.pixel_angle, 2 * np.pi * F95 / 299_792_458.0, 0.06)
    footprint = error_footprint(kern)
    assert 4.0 < footprint < 7.0

    half = np.tan(cam.fov / 2)
    corners = [(c * x - s * z, s * x + c * z) for x, z in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    poly = [
        ((xa * side / 2 / dist / half + 1) * n / 2, (n - za * side / 2 / dist * n / half) / 2) for xa, za in corners
    ]
    cover = np.array([[_clip_area(poly, i, j, i + 1, j + 1) for i in range(n)] for j in range(n)])
    truth = blur(280.0 + 20.0 * cover, kern)

    target = 0.4
    samples, errors = {}, {}
    for rule, f in (("pixel", 1.0), ("footprint", footprint)):
        st = RenderSettings(
            spp=64,
            max_depth=2,
            threshold=1e-3,
            termination="temperature",
            target_error=target,
            min_spp=4,
            tile=16,
            error_footprint=f,
        )
        job = make_job([(plate, material(kind="blackbody", temperature=300.0))], cam, UniformSky(280.0, 280.0), F95, st)
        integ = Integrator(job, make_intersector(job.vertices, job.faces))
        img = assemble(job, [integ.render_tile(t) for t in job.tiles()])
        samples[rule] = int(img.samples.sum())
        errors[rule] = max(np.sqrt(np.mean((blur(img.mean[..., ch], kern) - truth) ** 2)) for ch in (0, 1))
    assert errors["footprint"] <= target
    first = 4 * n * n  # every pixel's first pass
    assert samples["footprint"] - first < 0.5 * (samples["pixel"] - first)
