"""The layered atmosphere inside renders (issue 3): sky through a mirror, paths through fog."""

import numpy as np
import trimesh

from pmmw_cli.atmosphere.model import Atmosphere, AtmosphereModel, Layer
from pmmw_cli.scene.camera import Camera
from pmmw_cli.scene.sky import AtmosphereSky
from pmmw_cli.trace.job import RenderSettings
from tests.scenes import box, make_job, material, render

F95 = 95e9


def _job(objects, cam, atm_model):
    job = make_job(objects, cam, AtmosphereSky(atm_model, 290.0), F95,
                   RenderSettings(spp=1, max_depth=4, threshold=1e-9, termination="temperature"))
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
    foggy = AtmosphereModel(Atmosphere(layers=(Layer("fog", 0.0, 600.0, liquid_water=0.3e-3),)), F95)
    for model in (clear, foggy):
        img = render(_job([target], cam, model))
        trans, emission = model.path(np.array([2.0]), np.array([2.0]), np.array([300.0]))
        np.testing.assert_allclose(img["Ex2"], emission[0] + trans[0] * 300.0, atol=0.02)
    extra_db = foggy.path_loss_db(2.0, 2.0, 300.0) - clear.path_loss_db(2.0, 2.0, 300.0)
    np.testing.assert_allclose(extra_db, 0.3 * 0.3 * 4.1, rtol=0.05)
