"""Imagers high up in the layered atmosphere: what their rays that miss every mesh see.

A ray going down that misses every face meets the sky model's ground (a blackbody at
``sky.ground_temperature`` on z = 0) through the air between its height and the ground; a ray
going up sees the sky from the imager's own height. References: the model's own radiative
transfer, Murakowski 2014 sec. 2.2.7's recurrence through its cells, written out here from the
ground up (independent of the renderer's cell walk), and `AtmosphereModel.sky_temperature`.
"""

import dataclasses

import numpy as np
import pytest

from pmmw.atmosphere.model import Atmosphere, AtmosphereModel
from pmmw.scene.camera import Camera
from pmmw.scene.sky import AtmosphereSky
from pmmw.trace.job import RenderSettings
from tests.scenes import box, make_job, material, render

T_GROUND = 290.0  # [K] the sky model's ground and the ground mesh (a blackbody) alike
GROUND = box([-5e3, -5e3, -10.0], [5e3, 5e3, 0.0])  # a 10 km square whose top is z = 0
FREQUENCIES = (35e9, 60e9, 95e9)  # a window, the oxygen band (opaque from 100 km), a window
_MODELS = {}


def _model(f):
    if f not in _MODELS:
        _MODELS[f] = AtmosphereModel(Atmosphere(), f, ground_temperature=T_GROUND)
    return _MODELS[f]


def _pixel(model, position, direction):
    """The one pixel (Ex2, Ey2) [K] of a pinhole imager at ``position`` [m] looking along
    ``direction`` (a 0.001-degree field: one direction) over the ground square, with the layered
    atmosphere and its sky, as `pipeline.make_job` sets them up; and the job."""
    position, direction = np.asarray(position, float), np.asarray(direction, float)
    cam = Camera.look_at(position, position + 1e3 * direction, [1.0, 0.0, 0.0], np.radians(1e-3), (1, 1))
    job = make_job(
        [(GROUND, material(kind="blackbody", temperature=T_GROUND))],
        cam,
        AtmosphereSky(model, T_GROUND),
        model.frequency,
        RenderSettings(spp=1, max_depth=4, threshold=1e-9, termination="temperature"),
    )
    job = dataclasses.replace(job, atmosphere=model)
    img = render(job)
    return float(img["Ex2"][0, 0]), float(img["Ey2"][0, 0]), job


def _upwelling(model, height, cos_nadir):
    """Brightness [K] at ``height`` [m] looking down at ``cos_nadir`` from the vertical onto a
    blackbody ground at T_GROUND: Murakowski 2014 sec. 2.2.7's recurrence
    ``T_{j+1} = T_j exp(-tau_j) + S_j (1 - exp(-tau_j))`` from the ground up through the model's
    flat cells (edges, extinction, source for radiation travelling up at mu = cos_nadir) along
    the straight slant path, tau_j = alpha_j dz_j / cos_nadir; no air above the model's top."""
    top = min(height, model.top)
    dz = np.clip(np.minimum(model.edges[1:], top) - model.edges[:-1], 0.0, None)
    t = T_GROUND
    for alpha, s, s_mu, d in zip(model.alpha, model.source, model.source_mu, dz):
        tau = alpha * d / cos_nadir
        t = t * np.exp(-tau) + (s + s_mu * cos_nadir) * -np.expm1(-tau)
    return t


@pytest.mark.parametrize("f", FREQUENCIES, ids=[f"{f / 1e9:g}GHz" for f in FREQUENCIES])
def test_a_high_imager_sees_the_ground_model_through_the_air_where_it_misses_every_mesh(f):
    """Imager 100 km up (the model's top), at nadir and 30 and 70 degrees off it: a ray that
    misses the ground square reads the upwelling brightness over the blackbody ground model from
    the model's own recurrence (`_upwelling`), and a ray that hits the square (a blackbody at the
    same temperature, on the same plane) reads the same: the two paths must agree.

    Tolerance: ``render.atmosphere_tolerance`` (0.01 K), the error the renderer allows itself on
    in-scene air paths (`integrator.atmosphere_skip_length`); its cell walk is otherwise exact
    for the cells (the model docstring; the tabulated column under the imager holds 1e-9 K), so
    nothing else separates the pixels from the reference. The old code read the bare 290 K for
    every miss: 1.4 K too warm at 35 GHz, 3.1 K at 95 GHz and 72 K at 60 GHz, where the air
    hides the ground (checked below, so that the comparison can fail)."""
    model = _model(f)
    h = 100e3
    for off_nadir in (0.0, 30.0, 70.0):
        th = np.radians(off_nadir)
        d = np.array([0.0, np.sin(th), -np.cos(th)])
        far = 20e3 if off_nadir == 0.0 else 0.0  # the nadir miss: beside the square
        miss_x, miss_y, job = _pixel(model, [far, 0.0, h], d)
        hit_x, hit_y, _ = _pixel(model, [0.0, -h * np.tan(th), h], d)
        tol = job.settings.atmosphere_tolerance
        assert tol == 0.01
        want = _upwelling(model, h, np.cos(th))
        for got in (miss_x, miss_y, hit_x, hit_y):
            assert abs(got - want) <= tol, (off_nadir, got, want)
        assert abs(miss_x - hit_x) <= tol and abs(miss_y - hit_y) <= tol
        assert abs(want - T_GROUND) > 1.0  # the air shows: the bare ground (the old 290 K) fails
    if f == 60e9:
        assert _upwelling(model, h, 1.0) < T_GROUND - 50.0  # opaque: the upper air's emission


def test_an_imager_above_the_top_of_the_atmosphere_sees_only_the_air_below_it():
    """Imager 500 km up, above the model's 100 km top, at nadir and 30 degrees off it, at 95 GHz
    (zenith opacity ~0.3 Np: a wrong path length shows): hits and misses read the upwelling
    brightness at the top (`_upwelling`; the P.835 profiles end there, no air above). The old
    code walked the whole 500 km segment's length between the top and the ground (five times the
    air on a hit) and read 290 K on a miss. Tolerance as above, ``render.atmosphere_tolerance``."""
    model = _model(95e9)
    h = 500e3
    assert model.top == 100e3
    for off_nadir in (0.0, 30.0):
        th = np.radians(off_nadir)
        d = np.array([0.0, np.sin(th), -np.cos(th)])
        far = 20e3 if off_nadir == 0.0 else 0.0
        miss_x, _, job = _pixel(model, [far, 0.0, h], d)
        hit_x, _, _ = _pixel(model, [0.0, -h * np.tan(th), h], d)
        want = _upwelling(model, h, np.cos(th))
        assert want == _upwelling(model, 100e3, np.cos(th))
        for got in (miss_x, hit_x):
            assert abs(got - want) <= job.settings.atmosphere_tolerance, (off_nadir, got, want)


def test_an_upward_looking_imager_at_altitude_sees_the_sky_from_its_own_height():
    """Imager 10 km up looking at the zenith and at 30 degrees elevation, and 10.2 km up (between
    the sky's 250 m table levels): the pixel reads `AtmosphereModel.sky_temperature` at the
    imager's height, colder than the sky from the ground by more than 10 K (at 60 GHz the
    ground's sky is the warm lower air; at 35 and 95 GHz the air below 10 km holds nearly all the
    water vapour). Tolerance 1e-9 K: the renderer reads the same table of the model with the
    same linear interpolation in elevation, so only rounding separates them. The old code read
    the 10 km table from 10.2 km (0.05-1.3 K warmer: the 200 m of air between)."""
    for f in FREQUENCIES:
        model = _model(f)
        for h in (10e3, 10.2e3):
            for el in (np.pi / 2, np.radians(30.0)):
                d = np.array([0.0, np.cos(el), np.sin(el)])
                got_x, got_y, _ = _pixel(model, [0.0, 0.0, h], d)
                want = float(model.sky_temperature(el, height=h))
                assert abs(got_x - want) <= 1e-9 and abs(got_y - want) <= 1e-9, (f, h, el, got_x, want)
                assert want < float(model.sky_temperature(el, height=0.0)) - 10.0


def test_a_near_ground_imager_misses_meet_the_same_air_as_its_hits():
    """An imager 100 m up, within the sky's lowest 250 m level (`AtmosphereSky.HEIGHT_STEP`):
    looking up at 0.5 rad it reads the sky from the ground (`AtmosphereModel.sky_temperature` at
    height 0; 1e-9 K, the same table); looking down 80 degrees off nadir, past the ground square
    (a miss) and onto it (a hit), both read the air in front of the ground (`_upwelling`, within
    ``render.atmosphere_tolerance``), not the bare ground model: a height threshold below which
    misses skipped the air made a ray at 249 m and one at 251 m disagree."""
    model = _model(95e9)
    up, _, _ = _pixel(model, [0.0, 0.0, 100.0], [0.0, np.cos(0.5), np.sin(0.5)])
    assert abs(up - float(model.sky_temperature(0.5, height=0.0))) <= 1e-9
    th = np.radians(80.0)
    d = np.array([0.0, np.sin(th), -np.cos(th)])
    want = _upwelling(model, 100.0, np.cos(th))
    assert abs(want - T_GROUND) > 0.1  # the air matters: the control the bare ground fails
    miss, _, job = _pixel(model, [0.0, 6e3, 100.0], d)
    hit, _, _ = _pixel(model, [0.0, -100.0 * np.tan(th), 100.0], d)
    for got in (miss, hit):
        assert abs(got - want) <= job.settings.atmosphere_tolerance, (got, want)
