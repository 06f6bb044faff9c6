"""Rough and bumped surfaces in the renderer.

References: energy conservation (isothermal enclosures read their temperature; a rough lossless
dielectric reflects plus transmits 1), `pmmw.reflectance.monte_carlo` (the renderer's surface code,
`pmmw.surface`, driven forward from the source side over an infinite plane: these comparisons
check the renderer's backward, reciprocal use of it through its wavefront, media stack, geometry,
intersector and sky, not the surface physics, which tests/reflectance/test_brdf.py checks against the analytic
model and SCATMECH), the Optics Express 2016 copper number, and the flat-surface Fresnel closed form
as the exponent grows.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmmw import reflectance as B
from pmmw.physics import roughness as R
from pmmw.scene.bump import BumpMap, gaussian_surface
from pmmw.trace.job import RenderSettings
from tests.scenes import UniformSky, box, hollow_box, looking_down_at, make_job, material, render, sphere

F95 = 95e9
COPPER_EPS = (0.23 + 3.46j) ** 2
MODELS = {
    "ggx": R.GGX(0.4),
    "ashikhmin_shirley": R.AshikhminShirley(5.0, 40.0, orientation_deg=30.0),
    "blinn_phong": R.BlinnPhong(10.0),
    "beckmann": R.Beckmann(alpha_x=0.2, alpha_y=0.5),
    "blender_gloss": R.BlenderGloss(0.6),
}


def _room(t, model, bump=None):
    """An isothermal closed room with rough walls, a rough metal sphere, a rough coated sphere, a
    rough lossless-ish plastic box and a rough opaque box."""
    return [
        (hollow_box([-5, -5, -3], [5, 5, 3], 0.3), material(eps=5.5 + 0.5j, temperature=t, roughness=model, bump=bump)),
        (sphere([1.0, 2.0, 0.0], 0.8), material(kind="metal", temperature=t, roughness=model)),
        (
            sphere([-1.2, 2.5, 0.3], 0.7),
            material(eps=5.9 + 9.4j, temperature=t, coating=[(1.61 + 0.121j, 0.8e-3, t)], roughness=model),
        ),
        (box([-0.6, 1.0, -1.5], [0.6, 1.8, -0.5]), material(eps=2.26 + 0.0013j, temperature=t, roughness=model)),
        (
            box([1.5, 0.5, -2.0], [2.5, 1.5, -1.0]),
            material(kind="opaque", eps=3.0 + 0.2j, temperature=t, roughness=model),
        ),
    ]


def _room_camera():
    from pmmw.scene.camera import Camera

    return Camera.look_at([0.0, -4.0, 0.5], [0.0, 2.0, 0.0], [0, 0, 1], np.radians(70), (24, 18))


@pytest.mark.parametrize("name", list(MODELS))
def test_isothermal_room_with_rough_surfaces_reads_its_temperature(name):
    """Every facet event keeps or splits the power by R + T + A = 1 about the facet, masked
    children re-hit, nothing is discarded: every pixel reads T exactly (rounding, 1e-6 K) with
    random facets, for every model (deterministic splitting: with stochastic branches a path's
    s and p weights are 1 only on average, smooth or rough)."""
    t = 300.0
    settings = RenderSettings(spp=2, max_depth=6, threshold=1e-3, termination="temperature", tile=12)
    img = render(make_job(_room(t, MODELS[name]), _room_camera(), UniformSky(0.0, 0.0), F95, settings))
    for ch in ("Ex2", "Ey2"):
        assert np.max(np.abs(img[ch] - t)) < 1e-6, ch
    for ch in ("Q", "U", "V"):
        assert np.max(np.abs(img[ch])) < 1e-6, ch


def test_isothermal_room_with_bumps_reads_its_temperature():
    bump = BumpMap(gaussian_surface(0.02, 0.1, 2.0, seed=3), 2.0)
    assert bump.rms_slope > 0.2  # slopes steep enough that some rays meet the back of a bump
    settings = RenderSettings(spp=2, max_depth=6, threshold=1e-3, termination="temperature", tile=12)
    img = render(make_job(_room(300.0, MODELS["ggx"], bump), _room_camera(), UniformSky(0.0, 0.0), F95, settings))
    assert np.max(np.abs(img["I"] - 600.0)) < 1e-6  # I = Ex2 + Ey2


def _plane(theta_deg, mat, spp, seed=1, sky=1.0):
    """One pixel looking at a wide flat top face at incidence theta; sky at `sky` K."""
    settings = RenderSettings(spp=spp, max_depth=30, threshold=1e-4, termination="roulette", seed=seed, tile=1)
    job = make_job(
        [(box([-500, -500, -50], [500, 500, 0]), mat)],
        looking_down_at(theta_deg, height=2.0),
        UniformSky(sky, sky),
        F95,
        settings,
    )
    return render(job)


@pytest.mark.parametrize("theta", [20.0, 60.0])
def test_rough_copper_reflectance_matches_the_brdf_monte_carlo(theta):
    """Sky 1 K, copper 0 K: each polarization of the pixel reads the directional-hemispherical
    reflectance (reciprocity) that `pmmw brdf` integrates over the hemisphere for that incident
    polarization (h = s = image x here). 20000 samples: a binomial-like standard error
    sqrt(R(1-R)/N) <= 0.002 for the render and 0.001 for 1e5 brdf paths; tolerance 0.008 (3.5
    sigma combined)."""
    model = R.AshikhminShirley(15.0, 15.0)
    img = _plane(theta, material(eps=COPPER_EPS, temperature=0.0, roughness=model), spp=20_000)
    res = {}
    for name, stokes in (("Ex2", (1, 1, 0, 0)), ("Ey2", (1, -1, 0, 0))):
        stack = B.Stack(layers=(B.StackLayer(eps=COPPER_EPS, roughness=model),))
        s = B.run_brdf(stack=stack, incidence=theta, stokes=stokes, samples=100_000, seed=7, plots=False)
        res[name] = s.summary["methods"]["mc"]["total_reflectance"]
        assert float(img[name][0, 0]) == pytest.approx(res[name], abs=8e-3), name
    if theta == 60.0:  # s and p differ by far more than the tolerance there: polarization is carried
        assert res["Ex2"] - res["Ey2"] > 0.03


def test_seed_001_copper_in_a_scene():
    """Seed 001's copper (ex = ey = 15, 40 degrees): the scene's unpolarized reflectance is our
    0.9266 (docs/brdf.md; the seed reports 0.8692, see there why), within 0.006 (20000 samples,
    standard error ~0.002 per polarization)."""
    img = _plane(40.0, material(eps=COPPER_EPS, temperature=0.0, roughness=R.AshikhminShirley(15, 15)), spp=20_000)
    assert float(img["I"][0, 0]) / 2 == pytest.approx(0.9266, abs=6e-3)  # I = Ex2 + Ey2


@pytest.mark.parametrize("theta", [0.0, 50.0, 80.0])
def test_rough_lossless_dielectric_reflects_plus_transmits_one(theta):
    """Sky 1 K over a lossless rough dielectric whose inside ends on a 0 K blackbody floor: the
    pixel reads R; with the floor at 1 K it reads R + T = 1; R agrees with the brdf
    Monte Carlo's total reflectance (same tolerance reasoning as for copper)."""
    model = R.GGX(0.5)
    eps = 2.25 + 0j

    def scene(t_floor):
        slab = (box([-500, -500, -5], [500, 500, 0]), material(eps=eps, temperature=0.0, roughness=model))
        floor = (box([-499, -499, -6], [499, 499, -4]), material(kind="blackbody", temperature=t_floor))
        settings = RenderSettings(spp=4000, max_depth=40, threshold=1e-4, seed=3, tile=1)
        return render(make_job([slab, floor], looking_down_at(theta, height=2.0), UniformSky(1.0, 1.0), F95, settings))

    both = scene(1.0)
    # Russian roulette below the 1e-4 weight threshold is unbiased, not exact path by path: the
    # residue is ~ threshold x (fraction of paths reaching it) / sqrt(spp) << 1e-5
    assert abs(float(both["I"][0, 0]) - 2.0) < 1e-5  # I = Ex2 + Ey2
    refl = float(scene(0.0)["I"][0, 0]) / 2
    s = B.run_brdf(
        stack=B.Stack(layers=(B.StackLayer(eps=eps, roughness=model),)),
        incidence=theta,
        samples=100_000,
        seed=2,
        plots=False,
    ).summary["methods"]["mc"]
    assert refl == pytest.approx(s["total_reflectance"], abs=0.012)


def test_rough_converges_to_smooth():
    """Blinn-Phong m = 1e6 (facets within ~0.1 degree): the pixel equals the flat Fresnel pixel to
    1e-3 K-per-K (one sample is enough: the lobe is a mirror)."""
    smooth = _plane(50.0, material(eps=COPPER_EPS, temperature=0.0), spp=1)
    rough = _plane(50.0, material(eps=COPPER_EPS, temperature=0.0, roughness=R.BlinnPhong(1e6)), spp=64)
    for ch in ("Ex2", "Ey2"):
        assert float(rough[ch][0, 0]) == pytest.approx(float(smooth[ch][0, 0]), abs=1e-3)


def test_smooth_scenes_never_touch_the_roughness_code(monkeypatch):
    """'Smooth costs nothing': with no rough or bumped material the facet code is never called."""
    from pmmw.surface import surfaces

    def boom(*a, **k):
        raise AssertionError("roughness code called for a smooth scene")

    monkeypatch.setattr(surfaces.Surfaces, "_facets", boom)
    monkeypatch.setattr(surfaces.Surfaces, "_bumped", boom)
    img = _plane(30.0, material(eps=3.0 + 0.1j, temperature=300.0), spp=4)
    assert np.isfinite(img["I"]).all()


def test_bump_tilts_the_normal_like_a_tilted_plane():
    """A constant-slope bump (h = a x, periodic saw cut out of the sampled region) equals the
    geometric plane tilted by atan(a): the Fresnel angle changes accordingly (closed form)."""
    a = 0.2
    n = 64
    size = 4.0
    x = (np.arange(n) + 0.0) * size / n
    h = np.tile(a * ((x + size / 2) % size), (n, 1))  # ramp along u = x, wrap-around jump at x = 2 m
    bump = BumpMap(h, size)
    th = 40.0
    eps = 3.0 + 0.1j  # lossy: what enters the 50 m deep box never comes back (exp(-115/m x 50 m))
    img = _plane(th, material(eps=eps, temperature=0.0, bump=bump), spp=1)
    # the camera looks along +y (looking_down_at), so a slope along x tilts the normal sideways
    n_t = np.array([-a, 0.0, 1.0]) / math.hypot(a, 1.0)
    d = np.array([0.0, math.sin(math.radians(th)), -math.cos(math.radians(th))])
    cos_i = -float(d @ n_t)
    root = np.sqrt(eps - (1 - cos_i**2))
    rs = (cos_i - root) / (cos_i + root)
    rp = (eps * cos_i - root) / (eps * cos_i + root)
    unpol = (abs(rs) ** 2 + abs(rp) ** 2) / 2
    assert float(img["I"][0, 0]) / 2 == pytest.approx(unpol, abs=1e-6)


# ---------------------------------------------------------------------------------------------
# rough coating layers: the Optics Express 2016 walk through layers in the renderer
# ---------------------------------------------------------------------------------------------


def _layered_room(t):
    """Isothermal room whose objects carry rough coating layers of their own: rough paint over
    rough metal, a rough lossy layer with a coherent film over a rough plastic box (rays also
    leave it from inside through the layers), a rough layer over an opaque body and a rough
    layer over smooth walls."""
    paint = (1.61 + 0.121j, 0.8e-3, t, R.GGX(0.3))
    return [
        (
            hollow_box([-5, -5, -3], [5, 5, 3], 0.3),
            material(eps=5.5 + 0.5j, temperature=t, coating=[(2.0 + 0.05j, 2e-3, t, R.BlinnPhong(20))]),
        ),
        (sphere([1.0, 2.0, 0.0], 0.8), material(kind="metal", temperature=t, coating=[paint], roughness=R.GGX(0.2))),
        (
            box([-0.6, 1.0, -1.5], [0.6, 1.8, -0.5]),
            material(
                eps=2.26 + 0.0013j,
                temperature=t,
                roughness=R.Beckmann(0.3),
                coating=[(1.5 + 0.01j, 0.3e-3, t), (3.0 + 0.02j, 4e-3, t, R.GGX(0.5)), (1.8 + 0.0j, 0.5e-3, t)],
            ),
        ),
        (
            box([1.5, 0.5, -2.0], [2.5, 1.5, -1.0]),
            material(kind="opaque", eps=3.0 + 0.2j, temperature=t, coating=[(2.5 + 0.1j, 1e-3, t, R.GGX(0.4))]),
        ),
    ]


def test_isothermal_room_with_rough_coating_layers_reads_its_temperature():
    """The walk through rough layers keeps or splits power at every facet event and emits what
    the layers, films and bodies absorb: every pixel reads T to 1e-6 K."""
    t = 300.0
    settings = RenderSettings(spp=2, max_depth=6, threshold=1e-3, termination="temperature", tile=12)
    img = render(make_job(_layered_room(t), _room_camera(), UniformSky(0.0, 0.0), F95, settings))
    for ch in ("Ex2", "Ey2"):
        assert np.max(np.abs(img[ch] - t)) < 1e-6, ch


@pytest.mark.parametrize("substrate", ["metal", "lossy"])
def test_rough_layer_over_a_substrate_matches_the_brdf_monte_carlo(substrate):
    """A 2 mm rough lossy layer (GGX 0.3) over rough metal (GGX 0.2) or over a lossy dielectric:
    the pixel (sky 1 K, everything else 0 K) reads the directional-hemispherical reflectance of
    `pmmw brdf`'s layered Monte Carlo (Optics Express 2016: the layer absorbs along each path's length) per
    polarization. 20000 samples each side, standard errors <= 0.003: tolerance 0.012."""
    layer_eps, d = 2.25 + 0.05j, 2e-3
    if substrate == "metal":
        mat = material(kind="metal", temperature=0.0, roughness=R.GGX(0.2), coating=[(layer_eps, d, 0.0, R.GGX(0.3))])
        bottom = B.StackLayer(eps=0j, metal=True, roughness=R.GGX(0.2))
    else:
        mat = material(eps=6.0 + 2.0j, temperature=0.0, roughness=R.GGX(0.2), coating=[(layer_eps, d, 0.0, R.GGX(0.3))])
        bottom = B.StackLayer(eps=6.0 + 2.0j, roughness=R.GGX(0.2))
    stack = B.Stack(layers=(B.StackLayer(eps=layer_eps, roughness=R.GGX(0.3), thickness=d), bottom), frequency=F95)
    img = _plane(50.0, mat, spp=20_000)
    for name, stokes in (("Ex2", (1, 1, 0, 0)), ("Ey2", (1, -1, 0, 0))):
        s = B.run_brdf(stack=stack, incidence=50.0, stokes=stokes, samples=20_000, seed=4, plots=False)
        ref = s.summary["methods"]["mc"]["total_reflectance"]
        assert float(img[name][0, 0]) == pytest.approx(ref, abs=0.012), name


def test_bump_texture_file_gives_its_slopes(tmp_path):
    """A height texture (here an EXR ramp written with pmmw's writer) tiled over `size`: the
    central-difference slope equals height x (ramp step) / (pixel size) away from the wrap
    (exact for a linear ramp, to float32 rounding of the stored values)."""
    from pmmw.io.exr import write_exr
    from pmmw.scene.bump import make_bump

    n = 32
    ramp = np.tile(np.arange(n, dtype=np.float32) / n, (n, 1))
    write_exr(tmp_path / "ramp.exr", {"Y": ramp}, {})
    bump = make_bump(
        {"texture": "ramp.exr", "height": "4 mm", "size": "0.5 m"},
        file=tmp_path / "scene.yaml",
        key="materials.sand.bump",
    )
    slope = 4e-3 * (1.0 / n) / (0.5 / n)  # height x value step per pixel / pixel size = 0.008
    assert np.allclose(bump.gu[:, 2:-2], slope, rtol=1e-6)
    assert np.allclose(bump.gv, 0.0, atol=1e-12)
    n_up = bump.perturb(np.array([[0.2, 0.1, 0.0]]), np.array([[0.0, 0.0, 1.0]]))
    assert n_up[0] == pytest.approx(np.array([-slope, 0.0, 1.0]) / math.hypot(slope, 1.0), abs=1e-9)


def test_bump_tilts_walls_and_both_orientations_alike():
    """On a wall (normal along x: u = y, v = z) a ramp h = a u tilts the normal to
    unit(n - a e_y) (closed form); the face's other orientation sees the same bump, so its
    normal is exactly the mirror image; a normal on a diagonal (a tie of the dominant axis) takes
    the first axis."""
    a, n_pts, size = 0.3, 64, 4.0
    u = np.arange(n_pts) * size / n_pts
    bump = BumpMap(np.tile(a * ((u + size / 2) % size), (n_pts, 1)), size)  # ramp along columns (u)
    pos = np.array([[0.0, 0.1, 0.2], [0.0, 0.1, 0.2]])
    out = bump.perturb(pos, np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]))
    expect = np.array([1.0, -a, 0.0]) / math.hypot(1.0, a)
    np.testing.assert_allclose(out[0], expect, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out[1], -expect, rtol=0, atol=1e-12)
    diag = np.array([[1.0, 1.0, 0.0]]) / math.sqrt(2.0)  # x dominant (first of the tie): u = y
    t_u = np.array([0.0, 1.0, 0.0]) - diag[0, 1] * diag[0]
    expect = diag[0] - a * t_u
    np.testing.assert_allclose(bump.perturb(pos[:1], diag)[0], expect / np.linalg.norm(expect), rtol=0, atol=1e-12)


def test_rough_cinderblocks_config_resolves_its_rough_bumpy_sand():
    """The shipped rough variant of the thesis's cinderblock scene: `pmmw validate` reports the
    sand's GGX roughness and its Gaussian bump map (RMS slope sqrt(2) 2 cm / 25 cm = 0.113, one
    realization over 16 x 16 correlation lengths: 10 %)."""
    from pathlib import Path

    from pmmw.pipeline import resolve, validate

    path = Path(__file__).resolve().parents[2] / "configs/cinderblocks_rough_35ghz.yaml"
    sand = validate(path)["media"]["35 GHz"]["desert_sand"]
    assert sand["roughness"].startswith("GGX(") and sand["bump"].startswith("BumpMap(gaussian")
    bump = resolve(path).db.get("desert_sand").bump
    assert bump.rms_slope == pytest.approx(math.sqrt(2) * 0.02 / 0.25, rel=0.1)


def test_nearly_smooth_rough_layer_is_the_incoherent_slab_closed_form():
    """A 2 mm lossless layer with a nearly smooth rough top (Blinn-Phong m = 1e6: facets within
    ~0.1 degree) over a lossy half-space is an incoherent slab; per polarization the walk must sum
    the multiple reflections to R = R01 + (1 - R01)^2 R12 / (1 - R01 R12) (textbook Fresnel here,
    lossless layer: R10 = R01, T = 1 - R). Tolerance 1e-4: the facets' tilt changes the Fresnel
    angles by ~1e-3 rad (second order in R: ~1e-6) and paths below 1e-7 of weight end at 0 K
    (observed 2e-6)."""
    eps_l, eps_s, th = 2.25 + 0j, 6.0 + 2.0j, 30.0
    mat = material(eps=eps_s, temperature=0.0, coating=[(eps_l, 2e-3, 0.0, R.BlinnPhong(1e6))])
    settings = RenderSettings(spp=64, max_depth=60, threshold=1e-7, termination="temperature", seed=1, tile=1)
    img = render(
        make_job(
            [(box([-500, -500, -50], [500, 500, 0]), mat)],
            looking_down_at(th, height=2.0),
            UniformSky(1.0, 1.0),
            F95,
            settings,
        )
    )

    def fresnel(e1, e2, sin1):
        c1 = np.sqrt(1 - sin1**2 + 0j)
        c2 = np.sqrt(1 - (e1 / e2) * sin1**2 + 0j)
        n1, n2 = np.sqrt(e1), np.sqrt(e2)
        rs = (n1 * c1 - n2 * c2) / (n1 * c1 + n2 * c2)
        rp = (n2 * c1 - n1 * c2) / (n2 * c1 + n1 * c2)
        return abs(rs) ** 2, abs(rp) ** 2

    sin0 = math.sin(math.radians(th))
    r01 = fresnel(1.0, eps_l, sin0)
    r12 = fresnel(eps_l, eps_s, sin0 / math.sqrt(eps_l.real))
    for ch, a, b in (("Ex2", r01[0], r12[0]), ("Ey2", r01[1], r12[1])):
        expected = a + (1 - a) ** 2 * b / (1 - a * b)
        assert float(img[ch][0, 0]) == pytest.approx(expected, abs=1e-4), ch
