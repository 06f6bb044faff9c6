"""Numerical stress of whole renders: scale, degenerate geometry, and random scenes.

Invariants (no reference code needed): every pixel is finite; with the thesis's termination on the
last object's temperature every pixel is a convex combination of the scene's temperatures, so
Ex2 and Ey2 lie within [min T, max T]; |U|, |V| <= I; nothing self-intersects at km scale.
"""

import numpy as np
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pmmw.scene.camera import Camera
from pmmw.trace.job import RenderSettings
from tests.scenes import UniformSky, box, looking_down_at, make_job, material, render, sphere

F95 = 95e9


def _check_range(img, t_lo, t_hi, slack=1e-6):
    for c in ("Ex2", "Ey2", "I", "Q", "U", "V"):
        assert np.all(np.isfinite(img[c])), c
    for c in ("Ex2", "Ey2"):
        assert img[c].min() >= t_lo - slack and img[c].max() <= t_hi + slack, (c, img[c].min(), img[c].max())
    assert np.all(np.hypot(img["U"], img["V"]) <= img["I"] + slack)


def test_km_scale_scene_with_mm_coating_does_not_self_intersect():
    """A 4 km ground with a 0.8 mm coating seen from 1 km away at grazing-ish angles.

    If reflected rays re-hit the surface they left (float32 at 1e3 m has 6e-5 m spacing), the
    image would show spurious second hits; with the offsets it must equal the closed-form
    coated half-space seen from 1 m (same angle), to 0.01 K.
    """
    eps_c, eps_s = 1.61 + 0.121j, 5.9 + 9.4j
    ground = box([-2000, -2000, -30], [2000, 2000, 0])
    spec = material(eps=eps_s, temperature=310.0, coating=[(eps_c, 0.8e-3, 300.0)])
    sky = UniformSky(40.0, 290.0)
    far = Camera.look_at(
        [500, -900, 1000 * np.cos(np.radians(70))],
        [500, -900 + 1000 * np.sin(np.radians(70)), 0],
        [0, 0, 1],
        np.radians(0.001),
        (1, 1),
    )
    near = looking_down_at(70)
    img_far = render(make_job([(ground, spec)], far, sky, F95))
    img_near = render(make_job([(ground, spec)], near, sky, F95))
    for c in ("Ex2", "Ey2"):
        np.testing.assert_allclose(img_far[c], img_near[c], atol=0.01)


def test_degenerate_duplicate_and_inside_out_geometry_stays_finite_and_in_range():
    """Zero-area and duplicated triangles, an inside-out box and an open sheet: no NaN, no crash,
    temperatures inside the scene's range (termination on the last object's temperature)."""
    verts = np.array([[0, 3, 0], [1, 3, 0], [2, 3, 0], [0, 3, 1]], float)
    degenerate = trimesh.Trimesh(verts, [[0, 1, 2], [0, 1, 3], [0, 1, 3]], process=False)  # collinear + duplicate
    inside_out = box([-1, 4, -1], [1, 6, 1])
    inside_out.invert()
    sheet = trimesh.Trimesh([[-3, 8, -3], [3, 8, -3], [3, 8, 3], [-3, 8, 3]], [[0, 1, 2], [0, 2, 3]], process=False)
    objs = [
        (degenerate, material(eps=3 + 1j, temperature=250.0)),
        (inside_out, material(eps=2.5 + 0.1j, temperature=280.0)),
        (sheet, material(eps=4 + 0.5j, temperature=300.0)),
        (box([-50, -50, -5], [50, 50, -3]), material(eps=5.5 + 0.5j, temperature=260.0)),
    ]
    cam = Camera.look_at([0, 0, 0.5], [0, 6, 0], [0, 0, 1], np.radians(60), (32, 24))
    settings = RenderSettings(spp=2, max_depth=8, threshold=1e-4, termination="temperature", tile=16)
    img = render(make_job(objs, cam, UniformSky(20.0, 200.0), F95, settings))
    _check_range(img, 20.0, 300.0)


_EPS = st.builds(
    complex,
    st.floats(1.0, 1e4),
    st.one_of(st.just(0.0), st.floats(1e-6, 1e4)),
)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    eps_a=_EPS,
    eps_b=_EPS,
    eps_c=_EPS,
    t=st.lists(st.floats(1.0, 400.0), min_size=4, max_size=4),
    kind=st.sampled_from(["dielectric", "metal", "opaque", "blackbody", "thin"]),
    coat_d=st.one_of(st.just(0.0), st.floats(1e-6, 0.2)),
    theta=st.floats(0.0, 89.9),
)
def test_random_scenes_render_within_the_range_of_their_temperatures(eps_a, eps_b, eps_c, t, kind, coat_d, theta):
    """Hypothesis: nested and coated objects of random permittivity (|eps| 1..1e4, loss 0..1e4),
    random kinds, coatings 0..0.2 m, any view angle: every pixel finite and within [min T, max T]."""
    ground = (
        box([-100, -100, -20], [100, 100, 0]),
        material(eps=eps_a, temperature=t[0], coating=[(eps_c, coat_d, t[1])] if coat_d > 0 else []),
    )
    inner = (box([-90, -90, -15], [90, 90, -1]), material(eps=eps_b, temperature=t[2]))
    spec = material(kind=kind, eps=eps_b, temperature=t[3], thickness=1e-3 if kind == "thin" else None)
    ball = (sphere([0, 0.3, 0.3], 0.25, subdivisions=2), spec)
    cam = looking_down_at(theta, width=6, height_px=4, fov_deg=40)
    settings = RenderSettings(spp=1, max_depth=6, threshold=1e-4, termination="temperature", tile=8)
    img = render(make_job([ground, inner, ball], cam, UniformSky(t[1] * 0.5, t[0]), F95, settings))
    temps = list(t) + [t[1] * 0.5]
    _check_range(img, min(temps), max(temps), slack=1e-6 * max(temps))


_ROUGH = st.one_of(
    st.none(),
    st.builds(lambda a: {"model": "ggx", "alpha": a}, st.floats(1e-3, 3.0)),
    st.builds(lambda e, f: {"model": "ashikhmin_shirley", "ex": e, "ey": f}, st.floats(0.0, 1e4), st.floats(0.0, 1e4)),
    st.builds(lambda m: {"model": "blinn_phong", "m": m}, st.floats(0.0, 1e6)),
    st.builds(lambda a: {"model": "beckmann", "alpha": a}, st.floats(1e-3, 2.0)),
    st.builds(lambda g: {"model": "blender_gloss", "gloss": g}, st.floats(0.0, 1.0)),
)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])  # 13-51 s at 60
@given(
    eps_a=_EPS,
    eps_b=_EPS,
    eps_c=_EPS,
    t=st.lists(st.floats(1.0, 400.0), min_size=4, max_size=4),
    kind=st.sampled_from(["dielectric", "metal", "opaque", "blackbody"]),
    rough_a=_ROUGH,
    rough_b=_ROUGH,
    rough_c=_ROUGH,
    coat_d=st.one_of(st.just(0.0), st.floats(1e-6, 0.2)),
    bump_slope=st.one_of(st.just(0.0), st.floats(0.01, 3.0)),
    theta=st.floats(0.0, 89.9),
)
def test_random_rough_scenes_render_within_the_range_of_their_temperatures(
    eps_a, eps_b, eps_c, t, kind, rough_a, rough_b, rough_c, coat_d, bump_slope, theta
):
    """Hypothesis: the same nested scenes with random roughness models and parameters (from
    mirror-like to extreme), rough coating layers, and bump maps up to slope 3 (steeper than
    the view): every pixel finite and within [min T, max T]."""
    from pmmw.scene.bump import BumpMap, gaussian_surface

    bump = None
    if bump_slope > 0:
        bump = BumpMap(gaussian_surface(bump_slope * 0.05 / np.sqrt(2), 0.05, 1.0, seed=2), 1.0)
    coat = [(eps_c, coat_d, t[1], rough_c)] if coat_d > 0 else []
    ground = (
        box([-100, -100, -20], [100, 100, 0]),
        material(eps=eps_a, temperature=t[0], coating=coat, roughness=rough_a, bump=bump),
    )
    inner = (box([-90, -90, -15], [90, 90, -1]), material(eps=eps_b, temperature=t[2], roughness=rough_b))
    ball = (
        sphere([0, 0.3, 0.3], 0.25, subdivisions=2),
        material(kind=kind, eps=eps_b, temperature=t[3], roughness=rough_a, coating=coat),
    )
    cam = looking_down_at(theta, width=6, height_px=4, fov_deg=40)
    settings = RenderSettings(spp=2, max_depth=6, threshold=1e-4, termination="temperature", tile=8)
    img = render(make_job([ground, inner, ball], cam, UniformSky(t[1] * 0.5, t[0]), F95, settings))
    temps = list(t) + [t[1] * 0.5]
    _check_range(img, min(temps), max(temps), slack=1e-6 * max(temps))
