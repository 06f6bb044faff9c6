"""The layered atmosphere inside renders: sky through a mirror, paths through fog."""

import numpy as np
import trimesh

from pmmw.atmosphere.model import Atmosphere, AtmosphereLayer, AtmosphereModel
from pmmw.scene.camera import Camera
from pmmw.scene.sky import AtmosphereSky
from pmmw.trace.job import RenderSettings
from tests.scenes import box, make_job, material, render

F95 = 95e9


def _job(objects, cam, atm_model):
    job = make_job(
        objects,
        cam,
        AtmosphereSky(atm_model, 290.0),
        F95,
        RenderSettings(spp=1, max_depth=4, threshold=1e-9, termination="temperature"),
    )
    import dataclasses

    return dataclasses.replace(job, atmosphere=atm_model)


def test_metal_mirror_at_45_degrees_shows_the_zenith_sky_through_the_air():
    """Camera at 1.5 m, 45-degree metal plate 20 m away: the pixel reads the zenith sky seen from
    the plate's height, attenuated by 20 m of ground air, plus those 20 m' own emission. The
    expectation is composed from the model's path and sky table directly (integration check);
    the zenith value itself is checked against PHYSICS.md (~46 K at 95 GHz, US standard) within
    the profile difference (the P.835 mean global reference is moister: 40-60 K)."""
    model = AtmosphereModel(Atmosphere(), F95)
    plate = box([-1, -0.01, -1], [1, 0.01, 1])
    plate.apply_transform(trimesh.transformations.rotation_matrix(np.radians(-45), [1, 0, 0]))
    plate.apply_translation([0, 20, 1.5])
    cam = Camera.look_at([0, 0, 1.5], [0, 20, 1.5], [0, 0, 1], np.radians(0.2), (2, 2))
    img = render(_job([(plate, material(kind="metal", temperature=300.0))], cam, model))
    trans, emission = model.path(np.array([1.5]), np.array([1.5]), np.array([19.99]))
    zenith = model.sky_temperature(np.pi / 2, height=0.0)
    expected = emission[0] + trans[0] * zenith
    np.testing.assert_allclose(img["Ex2"], expected, atol=0.05)
    np.testing.assert_allclose(img["Ey2"], expected, atol=0.05)
    assert 35.0 < zenith < 65.0


def test_fog_adds_the_liquid_water_attenuation_along_a_horizontal_path():
    """A 300 K blackbody 300 m away at 2 m height, seen through clear air and through 0.3 g/m3 of
    fog (0-600 m): the extra loss is the liquid-water specific attenuation x 0.3 km. PHYSICS.md:
    K_l(95 GHz) = 4.08 dB/km per g/m3 at 15 C (4.60 at 0 C); the fog sits at the profile's
    ~14 C near the ground, so 0.3 x 0.3 x 4.1 ~ 0.37 dB, within 5 %. The rendered brightness
    must equal emission + transmittance x 300 K from the model (0.02 K)."""
    target = (box([-50, 300, -10], [50, 301, 50]), material(kind="blackbody", temperature=300.0))
    cam = Camera.look_at([0, 0, 2.0], [0, 300, 2.0], [0, 0, 1], np.radians(0.1), (1, 1))
    clear = AtmosphereModel(Atmosphere(), F95)
    foggy = AtmosphereModel(Atmosphere(layers=(AtmosphereLayer("fog", 0.0, 600.0, liquid_water=0.3e-3),)), F95)
    for model in (clear, foggy):
        img = render(_job([target], cam, model))
        trans, emission = model.path(np.array([2.0]), np.array([2.0]), np.array([300.0]))
        np.testing.assert_allclose(img["Ex2"], emission[0] + trans[0] * 300.0, atol=0.02)
    extra_db = foggy.path_loss_db(2.0, 2.0, 300.0) - clear.path_loss_db(2.0, 2.0, 300.0)
    np.testing.assert_allclose(extra_db, 0.3 * 0.3 * 4.1, rtol=0.05)


def _count_segments(model):
    """Wrap model.walk (the renderer's call, `kernels.ambient_segments`) to count the segments it
    evaluates (those of nonzero length); returns the running count (a list)."""
    count, orig = [0], model.walk

    def walk(z0, z1, length, trans, emission):
        count[0] += int(np.count_nonzero(length))
        return orig(z0, z1, length, trans, emission)

    model.walk = walk
    return count


def test_short_segments_skip_the_atmosphere_within_the_stated_bound():
    """A 0.4 m closed room in 1 g/m3 fog (every segment shorter than its 0.69 m diagonal) with
    walls at 250 K and 320 K, so that skipping the air changes the image. With
    render.atmosphere_tolerance set so that the skip length is 1.1 x the diagonal, no segment is
    evaluated, and every pixel's Ex2, Ey2 stays within the tolerance of the full render
    (`atmosphere_skip_length`: the bound is exact with termination: temperature, which this
    render uses, so the comparison is deterministic). The images must differ (the skip was taken).
    Observed: 0.016 K against the 0.12 K bound (the bound takes the worst temperature contrast and
    every segment at full weight)."""
    from pmmw.scene.sky import UniformSky
    from pmmw.trace.integrator import atmosphere_skip_length
    from tests.scenes import hollow_box

    model = AtmosphereModel(Atmosphere(layers=(AtmosphereLayer("fog", 0.0, 600.0, liquid_water=1e-3),)), F95)
    room = hollow_box([-0.2, -0.2, 0.8], [0.2, 0.2, 1.2], 0.02)
    block = box([-0.1, 0.05, 0.8], [0.1, 0.15, 0.95])
    cam = Camera.look_at([0, -0.1, 1.1], [0, 0.18, 0.9], [0, 0, 1], np.radians(80), (12, 12))
    objects = [(room, material(eps=3 + 0.5j, temperature=250.0)), (block, material(eps=5 + 2j, temperature=320.0))]
    import dataclasses

    base = make_job(
        objects,
        cam,
        UniformSky(290.0, 290.0),
        F95,
        RenderSettings(spp=2, max_depth=4, threshold=1e-4, termination="temperature"),
    )
    base = dataclasses.replace(base, atmosphere=model)
    diagonal = np.sqrt(3) * 0.4
    unit = atmosphere_skip_length(
        dataclasses.replace(base, settings=dataclasses.replace(base.settings, atmosphere_tolerance=1.0))
    )
    tol = 1.1 * diagonal / unit
    count = _count_segments(model)
    images = {}
    for t in (0.0, tol):
        job = dataclasses.replace(base, settings=dataclasses.replace(base.settings, atmosphere_tolerance=t))
        count[0] = 0
        images[t] = render(job)
        if t:
            assert atmosphere_skip_length(job) > diagonal
            assert count[0] == 0
        else:
            assert count[0] > 0
    for c in ("Ex2", "Ey2"):
        diff = np.abs(images[tol][c] - images[0.0][c])
        assert diff.max() <= tol
        assert diff.max() > 1e-6


def test_long_segments_are_not_skipped():
    """The 300 m fog path of the test above, with the default tolerance (0.01 K): the skip length
    is centimetres, so every segment is evaluated and the image is identical, bit for bit, to the
    one rendered with the skip switched off."""
    import dataclasses

    target = (box([-50, 300, -10], [50, 301, 50]), material(kind="blackbody", temperature=300.0))
    ground = (box([-50, 0, -1], [50, 300, 0]), material(eps=3 + 0.3j, temperature=290.0))
    cam = Camera.look_at([0, 0, 2.0], [0, 300, 1.0], [0, 0, 1], np.radians(2), (4, 4))
    model = AtmosphereModel(Atmosphere(layers=(AtmosphereLayer("fog", 0.0, 600.0, liquid_water=0.3e-3),)), F95)
    job = _job([target, ground], cam, model)
    assert job.settings.atmosphere_tolerance == 0.01
    count = _count_segments(model)
    on = render(job)
    n_on = count[0]
    count[0] = 0
    off = render(dataclasses.replace(job, settings=dataclasses.replace(job.settings, atmosphere_tolerance=0.0)))
    assert n_on == count[0] > 0
    for c in on:
        np.testing.assert_array_equal(on[c], off[c])


def test_sky_tables_built_before_the_workers_fork_are_those_the_rays_use():
    """`AtmosphereSky.prepare` (called once in the parent by `integrator.prime`) builds the tables
    of the height levels between the scene's lowest and highest point, and the lowest and highest
    only when they are many; brightness reads them unchanged."""
    model = AtmosphereModel(Atmosphere(), F95)
    sky = AtmosphereSky(model, 290.0)
    sky.prepare(0.3, 620.0)
    assert sorted(model._sky_tables) == [0.0, 250.0, 500.0]
    wide = AtmosphereModel(Atmosphere(), F95)
    AtmosphereSky(wide, 290.0).prepare(10.0, 9000.0)
    assert sorted(wide._sky_tables) == [0.0, 9000.0]
    d = np.array([[0.0, 0.6, 0.8], [0.0, 0.0, 1.0]])
    fresh = AtmosphereSky(AtmosphereModel(Atmosphere(), F95), 290.0)
    for h in (0.3, 260.0, 619.0):
        np.testing.assert_array_equal(sky.brightness(d, np.full(2, h))[0], fresh.brightness(d, np.full(2, h))[0])
    assert sorted(model._sky_tables) == [0.0, 250.0, 500.0]  # nothing built again


def test_sky_lookup_reads_the_tables_as_numpy_interp_at_every_height_and_elevation():
    """The compiled lookup (`sky._sky_lookup`: the table interval from the square root of the
    elevation) against `AtmosphereModel.sky_temperature` (numpy.interp in the same tables), over
    random directions and heights on four levels, with the horizon, the zenith, a point exactly
    on a table node and rays below the horizon (the ground through the air from the ray's height:
    `AtmosphereSky.ground_through_air`; the bare ground from at or below z = 0). Tolerance 1e-9 K: the
    two interpolate the same two points and differ only in rounding (~1e-13 K)."""
    from pmmw.atmosphere.model import SKY_ELEVATIONS

    model = AtmosphereModel(Atmosphere(layers=(AtmosphereLayer("fog", 0.0, 600.0, liquid_water=0.3e-3),)), F95)
    sky = AtmosphereSky(model, 281.5)
    rng = np.random.default_rng(7)
    n = 20000
    el = np.concatenate(
        [rng.uniform(-0.3, np.pi / 2, n), rng.uniform(0.0, 0.02, n), [0.0, np.pi / 2, SKY_ELEVATIONS[300], -1e-9]]
    )
    az = rng.uniform(0.0, 2.0 * np.pi, el.size)
    d = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    heights = rng.uniform(-5.0, 1000.0, el.size)
    got, same = sky.brightness(d, heights)
    assert got is same
    el_d = np.arcsin(d[:, 2])
    want = np.full(el.size, 281.5)
    for h in (0.0, 250.0, 500.0, 750.0):
        sel = (el_d >= 0.0) & (np.floor(np.clip(heights, 0.0, None) / 250.0) * 250.0 == h)
        assert sel.sum() > 1000
        want[sel] = model.sky_temperature(el_d[sel], height=h)
    # below the horizon: the ground through the air down from the ray's height (model.path), from
    # any height above the ground; at or below it (heights down to -5 m) the bare ground
    down = (el_d < 0.0) & (heights > 0.0)
    trans, emission = model.path(heights[down], 0.0, heights[down] / -d[down, 2])
    want[down] = emission + trans * 281.5
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    assert np.all(got[(el_d < 0.0) & ~down] == 281.5) and ((el_d < 0.0) & ~down).sum() > 10
    assert down.sum() > 1000 and ((el_d < 0.0) & (heights > 0.0) & (heights < 250.0)).sum() > 500
    assert sorted(model._sky_tables) == [0.0, 250.0, 500.0, 750.0]


def test_a_tabulated_column_gives_the_cell_walk_of_every_segment():
    """`AtmosphereModel.column` + `walk_below` against `walk` (the cell walk itself): segments from
    3 km down to the lowest 10 m over the slopes of a 10-degree imager looking straight down
    (SAR), those ending exactly at the column's bottom, and segments it must leave to the walk
    (starting elsewhere, ending above the bottom, sloped beyond the table, of length 0). The
    table promises 1e-9 K at its midpoints; every segment is held to that, and transmittances to
    rounding (1e-14 relative: closed form). In fog the column needs a finer grid, and still
    holds."""
    rng = np.random.default_rng(5)
    for atm in (
        Atmosphere(humidity=0.004),
        Atmosphere(layers=[AtmosphereLayer(kind="fog", base=0.0, top=600.0, liquid_water=1e-3)]),
    ):
        model = AtmosphereModel(atm, F95)
        col = model.column(3000.0, 10.0, 1.0, 1.008)
        assert col is not None
        n = 4000
        z1 = rng.uniform(0.0, 10.0, n)
        s = rng.uniform(1.0, 1.008, n)
        z0 = np.full(n, 3000.0)
        z1[:50] = 10.0  # exactly the bottom
        z0[50:100] = 2999.0  # not from the top
        z1[100:150] = rng.uniform(10.001, 50.0, 50)  # ending above the bottom
        s[150:200] = rng.uniform(1.2, 2.0, 50)  # beyond the table's slopes
        length = (z0 - z1) * s
        length[200:250] = 0.0
        want_t, want_e, got_t, got_e = (np.empty(n) for _ in range(4))
        model.walk(z0, z1, length, want_t, want_e)
        model.walk_below(col, z0, z1, length, got_t, got_e)
        np.testing.assert_allclose(got_e, want_e, rtol=0, atol=1e-9)
        np.testing.assert_allclose(got_t, want_t, rtol=1e-14, atol=0)
        assert want_e.max() > 5.0  # the column emits: a test that can fail


def test_an_imager_high_above_the_scene_reads_the_same_image_with_the_tabulated_column():
    """The SAR scene (imager 3 km up, 37 atmosphere cells above the aircraft) with its first
    segments through the tabulated column and with every cell walked: the same rays, and images
    within 1e-9 K in every pixel. Landing's imager, 70 m up, and any thin lens walk in full."""
    from pathlib import Path

    from pmmw import pipeline
    from pmmw.trace.integrator import Integrator, camera_column
    from pmmw.trace.intersect import make_intersector

    configs = Path(__file__).resolve().parents[2] / "configs"
    res = pipeline.resolve(
        configs / "sar_cessna_95ghz.yaml", ["imager.resolution=[24, 24]", "render.spp=4", "render.target_error=null"]
    )
    job = pipeline.make_job(res, res.scenario.frequencies[0])
    isect = make_intersector(job.vertices, job.faces)
    fast = Integrator(job, isect)
    assert fast.column is not None
    slow = Integrator(job, isect)
    slow.column = None
    a, b = ([integ.render_tile(t) for t in job.tiles()] for integ in (fast, slow))
    for x, y in zip(a, b):
        assert x.rays == y.rays
        np.testing.assert_allclose(x.mean, y.mean, rtol=0, atol=1e-9)
    lens = pipeline.resolve(configs / "sar_cessna_95ghz.yaml", ["imager.focus_distance=3000 m"])
    assert camera_column(pipeline.make_job(lens, lens.scenario.frequencies[0])) is None
    landing = pipeline.resolve(configs / "landing_95ghz.yaml")
    assert camera_column(pipeline.make_job(landing, landing.scenario.frequencies[0])) is None
