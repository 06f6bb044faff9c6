"""Sky brightness temperature for rays that leave the scene.

Models are chosen by ``sky.model`` through `SKY_MODELS`:

* ``uniform``: one temperature in every direction above the horizon, unpolarized.
* ``slab``: a single isothermal atmospheric slab of zenith opacity tau [Np] at temperature
  T_atm over the cosmic background, flat-earth air mass 1/sin(el):
  ``T(el) = T_atm (1 - exp(-tau / sin el)) + T_cmb exp(-tau / sin el)``, unpolarized. The default
  until the layered atmosphere lands. Without a given opacity, tau comes from a clear-sky table
  (US standard atmosphere zenith temperatures of about 18.5 K at 35 GHz and 46 K at 95 GHz).
* ``atmosphere``: the layered atmosphere's radiative transfer (default when the scenario has a
  layered atmosphere), see `AtmosphereSky`.
* ``texture``: a user's equirectangular EXR with ``Tv``, ``Th`` channels [K]
  (`pmmw.scene.sky_texture`), polarized in the sky basis of `pmmw.physics.jones`.

Below the horizon (el < 0) rays see ``sky.ground_temperature``, unless a texture covers it; with
the ``atmosphere`` sky, through the layered atmosphere between the ray's height and the ground
(`AtmosphereSky.ground_through_air`). Temperatures are Rayleigh-Jeans brightness temperatures [K].
"""

from __future__ import annotations

import math

import numpy as np

from pmmw.atmosphere.model import SKY_ELEVATIONS
from pmmw.errors import warn
from pmmw.jit import njit

T_CMB = 2.725  # cosmic microwave background [K]
T_SLAB_DEFAULT = 275.0  # mean radiating temperature of the lower troposphere [K]

# Clear-sky zenith opacity [Np] at window frequencies [Hz], derived from the zenith brightness
# temperatures quoted in PHYSICS.md (US standard atmosphere: 18.5 K at 35 GHz, 46 K at 95 GHz)
# with T_atm = 275 K; log-linear in frequency in between. The layered model replaces this.
_TAU_TABLE_F = np.array([35e9, 95e9])
_TAU_TABLE = -np.log((T_SLAB_DEFAULT - np.array([18.5, 46.0])) / (T_SLAB_DEFAULT - T_CMB))


def default_zenith_opacity(f: float) -> float:
    """Clear-sky zenith opacity [Np] at frequency f [Hz] for the slab model."""
    if not (_TAU_TABLE_F[0] <= f <= _TAU_TABLE_F[-1]):
        warn(
            f"slab sky: no clear-sky opacity tabulated at {f / 1e9:g} GHz (35-95 GHz known); "
            "extrapolating: give sky.zenith_opacity for a better sky"
        )
    x = (np.log(f) - np.log(_TAU_TABLE_F[0])) / (np.log(_TAU_TABLE_F[1]) - np.log(_TAU_TABLE_F[0]))
    return float(np.exp(np.log(_TAU_TABLE[0]) + x * (np.log(_TAU_TABLE[1]) - np.log(_TAU_TABLE[0]))))


class UniformSky:
    """Unpolarized sky of one brightness temperature [K] above the horizon."""

    unpolarized = True

    def __init__(self, temperature: float, ground_temperature: float):
        self.temperature = float(temperature)
        self.ground_temperature = float(ground_temperature)

    def brightness(self, directions, heights=None):
        """(Tv, Th) [K], each shape (n,), for unit directions (n, 3) leaving the scene from
        heights (n,) [m] above the ground (used by the atmosphere model only)."""
        t = np.where(directions[:, 2] >= 0.0, self.temperature, self.ground_temperature)
        return t, t

    def temperature_range(self) -> tuple[float, float]:
        """Lowest and highest brightness [K] any direction can show."""
        return min(self.temperature, self.ground_temperature), max(self.temperature, self.ground_temperature)


class SlabSky:
    """Isothermal slab of zenith opacity ``tau`` [Np] at ``temperature`` [K] over the CMB."""

    unpolarized = True

    def __init__(self, temperature: float, tau: float, ground_temperature: float):
        self.temperature = float(temperature)
        self.tau = float(tau)
        self.ground_temperature = float(ground_temperature)

    def zenith_angle_temperature(self, elevation):
        """Sky temperature [K] at elevation angles [rad] >= 0."""
        sin_el = np.sin(np.asarray(elevation, float))
        with np.errstate(divide="ignore"):
            trans = np.exp(-self.tau / np.maximum(sin_el, 0.0))
        return self.temperature * (1.0 - trans) + T_CMB * trans

    def brightness(self, directions, heights=None):
        sin_el = np.clip(directions[:, 2], -1.0, 1.0)
        with np.errstate(divide="ignore", over="ignore"):
            trans = np.where(sin_el > 0.0, np.exp(-self.tau / np.where(sin_el > 0.0, sin_el, 1.0)), 0.0)
        t = self.temperature * (1.0 - trans) + T_CMB * trans
        t = np.where(sin_el >= 0.0, t, self.ground_temperature)
        return t, t

    def temperature_range(self) -> tuple[float, float]:
        """Lowest and highest brightness [K] any direction can show."""
        ts = (self.temperature, T_CMB, self.ground_temperature)
        return min(ts), max(ts)


class TextureSky:
    """A user's polarized sky map (`pmmw.scene.sky_texture.SkyTexture`)."""

    unpolarized = False

    def __init__(self, texture):
        self.texture = texture

    def brightness(self, directions, heights=None):
        return self.texture.sample(directions)

    def temperature_range(self) -> tuple[float, float]:
        """Lowest and highest brightness [K] of the map (interpolation stays within them)."""
        tx = self.texture
        return float(min(tx.tv.min(), tx.th.min())), float(max(tx.tv.max(), tx.th.max()))


class AtmosphereSky:
    """The layered atmosphere's own sky (`pmmw.atmosphere.model.AtmosphereModel`).

    Unpolarized (a horizontally stratified atmosphere; rain scatters, in the delta-Eddington
    approximation of `pmmw.atmosphere.model.scattering_source`, without polarizing), with earth
    curvature.
    Rays leave the scene from various heights; the sky above a ray is taken from a table for the
    nearest of `HEIGHT_STEP`-spaced observer heights below it (cached per height), so an aircraft
    sees only the air above it; rays that leave from exactly a height given to `observe` (a
    pinhole imager's: every camera ray starts there) read a table of that height. Below the
    horizon: the ground, a blackbody at ``ground_temperature`` at z = 0, seen through the air
    between the ray's height and the ground (`ground_through_air`): from an imager high up, the
    atmosphere's own emission, not the bare ground; from any height, so that a ray that misses
    every mesh reads what one that hits a blackbody ground mesh reads. Rays that leave within the
    lowest level (below `HEIGHT_STEP`) read the sky from the ground above the horizon (the air
    below them counted twice: at most 250 m of it).
    """

    unpolarized = True
    HEIGHT_STEP = 250.0  # [m]

    def __init__(self, model, ground_temperature: float):
        self.model = model
        self.ground_temperature = float(ground_temperature)
        # the tables built so far, as `_sky_lookup` reads them: level k's row of T (-1: none yet)
        self._row = np.full(int((model.top - 1.0) // self.HEIGHT_STEP) + 1, -1, np.int64)
        self._tables = np.empty((0, SKY_ELEVATIONS.size))
        # the heights given to `observe` and their rows of T
        self._exact_h, self._exact_row = np.empty(0), np.empty(0, np.int64)

    def zenith_angle_temperature(self, elevation, height: float = 0.0):
        return self.model.sky_temperature(elevation, height=height)

    def brightness(self, directions, heights=None):
        """(Tv, Th) [K], the same array, shape (n,), for unit directions (n, 3) leaving the scene
        at heights (n,) [m] above the ground (None: at the ground): above the horizon the sky
        table of the ray's level (or of its `observe` height), below it `ground_through_air`
        (at the ground itself: ``ground_temperature``)."""
        dz = np.ascontiguousarray(directions[:, 2], dtype=np.float64)
        heights = np.zeros(dz.shape) if heights is None else np.ascontiguousarray(heights, dtype=np.float64)
        t = np.empty(dz.shape)
        while (
            missing := _sky_lookup(
                dz,
                heights,
                self.HEIGHT_STEP,
                self.model.top - 1.0,
                self._row,
                SKY_ELEVATIONS,
                self._tables,
                self.ground_temperature,
                self._exact_h,
                self._exact_row,
                t,
            )
        ) >= 0.0:
            self._add(missing)
        down = np.flatnonzero((dz < 0.0) & (heights > 0.0))
        if down.size:
            t[down] = self.ground_through_air(dz[down], heights[down])
        return t, t

    def ground_through_air(self, dz, heights):
        """The ground below the horizon seen from ``heights`` (n,) [m] along rays going down,
        direction z-components ``dz`` (n,) < 0: ``emission + transmittance * ground_temperature``
        [K], shape (n,), the air's along the slant path from the ray's height (at most the model's
        top: no air above it) down to z = 0 (`AtmosphereModel.walk`, exact for its cells: the
        recurrence of Murakowski 2014 sec. 2.2.7 from the ground up).

        Flat cells, as every path in the scene takes (`AtmosphereModel.path`): a ray that misses a
        ground mesh reads what one that hits a blackbody mesh at ``ground_temperature`` on z = 0
        reads. Not modelled: the earth's curvature below the horizon (from a height h, rays less
        than about sqrt(2 h / R_earth) below it, 3.2 degrees at 10 km and 10 degrees at 100 km,
        would pass over the earth's limb and see the sky beyond; here they meet the flat ground
        through a long slant path of air), and the ground's reflection (a blackbody)."""
        z0 = np.minimum(heights, self.model.top)
        trans, emission = np.empty(z0.shape), np.empty(z0.shape)
        self.model.walk(z0, np.zeros(z0.shape), z0 / -dz, trans, emission)
        return emission + trans * self.ground_temperature

    def observe(self, height: float):
        """Build the table of the sky seen from exactly ``height`` [m] (`AtmosphereModel.sky_table`)
        for the rays that leave from there: a pinhole imager's, which would otherwise read the
        table of their level, up to `HEIGHT_STEP` lower (from 10.25 km at 60 GHz, 1.5 K too warm at
        30 degrees elevation, 2.6 K at the horizon). Heights on a level need none; nor do imagers
        within the lowest level (below `HEIGHT_STEP`): they read the ground's table, as every ray
        there does (near-ground scenes keep their images)."""
        height = float(height)
        if not height >= self.HEIGHT_STEP or height in self._exact_h or self.level(height) == height:
            return
        _, temperature = self.model.sky_table(height)
        self._tables = np.vstack([self._tables, temperature])
        self._exact_h = np.append(self._exact_h, height)
        self._exact_row = np.append(self._exact_row, self._tables.shape[0] - 1)

    def level(self, heights):
        """The observer heights [m] whose tables serve rays leaving at ``heights`` (the
        `HEIGHT_STEP` level at or below each)."""
        return np.floor(np.clip(heights, 0.0, self.model.top - 1.0) / self.HEIGHT_STEP) * self.HEIGHT_STEP

    def _add(self, height: float):
        """The table of the level at ``height`` [m] (`AtmosphereModel.sky_table`), for `_sky_lookup`."""
        k = int(round(height / self.HEIGHT_STEP))
        if self._row[k] >= 0:
            return
        _, temperature = self.model.sky_table(k * self.HEIGHT_STEP)  # at the points SKY_ELEVATIONS
        self._tables = np.vstack([self._tables, temperature])
        self._row[k] = self._tables.shape[0] - 1

    def prepare(self, z_lo: float, z_hi: float, most: int = 8):
        """Build the tables (about 20 ms each) that rays leaving between heights ``z_lo`` and
        ``z_hi`` [m] use: all their levels, or the lowest and highest when there are more than
        ``most``. Done once before the worker processes fork, so that each does not build them
        again; any other level is still built when a ray needs it."""
        levels = np.unique(self.level(np.array([z_lo, z_hi])))
        if levels.size and (levels[-1] - levels[0]) / self.HEIGHT_STEP < most:
            levels = np.arange(levels[0], levels[-1] + 0.5 * self.HEIGHT_STEP, self.HEIGHT_STEP)
        for h in levels:
            self._add(float(h))

    def temperature_range(self) -> tuple[float, float]:
        """Lowest and highest brightness [K]: the sky is a mix of the cells' sources (in every
        direction: ``source -+ |source_mu|``) and the CMB."""
        _, lo, hi = self.model.extremes(0.0, self.model.top)
        ts = (lo, hi, T_CMB, self.ground_temperature)
        return min(ts), max(ts)


@njit()
def _sky_lookup(dz, heights, step, h_max, row, el_grid, tables, ground, exact_h, exact_row, out):
    """`AtmosphereSky.brightness` of rays with direction z-components ``dz`` leaving at
    ``heights`` [m], into ``out`` [K]: below the horizon ``ground``, above it the table of the
    ray's level (``floor(min(max(height, 0), h_max) / step)``, its row of ``tables`` given by
    ``row``), or where the height is one of ``exact_h`` [m] that height's row ``exact_row``,
    linear in elevation between the table's points ``el_grid`` [rad] as
    `numpy.interp` (the points are (pi / 2) (k / (N - 1))^2, so the interval is found from the
    square root, not searched). Returns the height [m] of the first level met that has no table
    yet (for the caller to build and call again), -1 when every ray was served."""
    last = el_grid.shape[0] - 1
    scale = last / math.sqrt(el_grid[last])
    for i in range(dz.shape[0]):
        el = math.asin(min(max(dz[i], -1.0), 1.0))
        if el < 0.0:
            out[i] = ground
            continue
        r = -1
        for e in range(exact_h.shape[0]):
            if heights[i] == exact_h[e]:
                r = exact_row[e]
        if r < 0:
            level = math.floor(min(max(heights[i], 0.0), h_max) / step)
            r = row[int(level)]
            if r < 0:
                return level * step
        k = min(int(math.sqrt(el) * scale), last - 1)
        while k > 0 and el < el_grid[k]:  # (rounding of the square root)
            k -= 1
        while k < last - 1 and el >= el_grid[k + 1]:
            k += 1
        x0, x1 = el_grid[k], el_grid[k + 1]
        y0 = tables[r, k]
        out[i] = tables[r, last] if el >= x1 else y0 + (tables[r, k + 1] - y0) * ((el - x0) / (x1 - x0))
    return -1.0


def _make_uniform(cfg, f, atmosphere_model=None):
    return UniformSky(cfg.temperature, cfg.ground_temperature)


def _make_slab(cfg, f, atmosphere_model=None):
    tau = cfg.zenith_opacity if cfg.zenith_opacity is not None else default_zenith_opacity(f)
    temp = cfg.temperature if cfg.temperature is not None else T_SLAB_DEFAULT
    return SlabSky(temp, tau, cfg.ground_temperature)


def _make_atmosphere(cfg, f, atmosphere_model=None):
    if atmosphere_model is None:
        raise ValueError("the atmosphere sky needs the scene's atmosphere model")
    return AtmosphereSky(atmosphere_model, cfg.ground_temperature)


def _make_texture(cfg, f, atmosphere_model=None):
    from pmmw.scene.sky_texture import SkyTexture

    return TextureSky(SkyTexture.load(cfg.file, key="sky.file"))


#: sky.model -> factory(sky config, frequency [Hz]) -> sky object with ``brightness(dirs)``.
SKY_MODELS = {"atmosphere": _make_atmosphere, "uniform": _make_uniform, "slab": _make_slab, "texture": _make_texture}


def make_sky(cfg, f: float, atmosphere_model=None):
    """Build the sky for one frequency [Hz] from the scenario's ``sky`` record."""
    return SKY_MODELS[cfg.model](cfg, f, atmosphere_model=atmosphere_model)
