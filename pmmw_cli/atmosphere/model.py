"""Layered atmosphere: sky brightness and attenuation/emission along in-scene paths.

The atmosphere is a stack of horizontal cells (flat within the scene, spherical shells for the
sky) of uniform power attenuation coefficient alpha [Np/m] and emission (source) temperature S
[K]. Brightness temperatures are Rayleigh-Jeans brightness temperatures throughout (seed 000
eq. 1.1, PHYSICS.md): a cell of physical temperature T emits T (1 - exp(-tau)). Planck radiance
would read about h f / 2k lower (0.8 K at 35 GHz, 2.3 K at 95 GHz) for the same atmosphere.

Per cell, at the cell's midpoint height:

* gases: oxygen and water vapour, ITU-R P.676 Annex 1 line by line, on the P.835 reference
  profile of `Atmosphere.profile` (`pmmw_cli.atmosphere.itu`);
* fog and cloud slabs (`Layer`): liquid water, P.840 at the cell's temperature;
* rain slabs: P.838 extinction for an unpolarized wave (mean of H and V). Rain scatters strongly
  and only the absorbed part 1 - omega of its extinction is emitted (Mie albedo omega, about 0.37
  at 35 GHz and 0.50 at 95 GHz for 10 mm/h): S = T alpha_abs / alpha_ext. Radiation scattered
  into a path is neglected, so rain looks colder than it is and an isothermal enclosure full of
  rain does not read its temperature.

Sky (`AtmosphereModel.sky_temperature`): the recurrence of seed 000 sec. 2.2.7,
``T_{j+1} = T_j exp(-alpha_j d_j) + S_j (1 - exp(-alpha_j d_j))`` from the cosmic background
down, written as the equivalent sum over cells. d_j is the length of the ray in spherical shell j
for a ray leaving the observer at elevation el over a spherical earth, bent by refraction per
Bouguer's rule ``n r cos(el) = const`` (refractivity from ITU-R P.453). Tabulated once per
observer height over elevation and interpolated. Tv = Th: a horizontally stratified atmosphere
without scattering emits unpolarized light.

In-scene paths (`AtmosphereModel.path`): straight segments through flat horizontal cells, exact
for piecewise-constant alpha and S: a segment from height z0 to z1 of length L spends
``overlap_j L / |z1 - z0|`` in cell j.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pmmw_cli.atmosphere import itu
from pmmw_cli.atmosphere.itu import NP_M_PER_DB_KM, PROFILES

T_CMB = 2.725  # cosmic microwave background [K]
R_EARTH = 6371.0e3  # mean earth radius [m]

DZ_GROUND = 10.0  # default thickness of the lowest cell [m]
DZ_GROWTH = 1.1  # ratio of successive cell thicknesses above the ground
DZ_MAX_TROPOSPHERE = 200.0  # largest cell below DZ_SPLIT_HEIGHT [m] (water-vapour scale 2 km)
DZ_MAX_ALOFT = 1000.0  # largest cell above it [m] (oxygen scale height ~7 km)
DZ_SPLIT_HEIGHT = 20.0e3  # [m]

F_MIN, F_MAX = 1e9, 1e12  # validity of P.676 Annex 1, P.838, P.840 [Hz]
# elevations in a sky table, el = (pi/2) u^2 with u uniform: dense at the horizon
N_SKY_TABLE = 1025
HORIZONTAL_SLOPE = 1e-9  # |z1 - z0| / L below which a segment counts as horizontal

LAYER_KINDS = ("fog", "cloud", "rain")


@dataclass(frozen=True)
class Layer:
    """A weather slab between two heights above the ground.

    Attributes
    ----------
    kind : str
        "fog" or "cloud" (liquid water droplets, P.840) or "rain" (P.838).
    base, top : float
        Heights of the slab above the ground [m], 0 <= base < top.
    liquid_water : float
        Liquid water content of fog or cloud [kg/m^3] (1 g/m^3 = 1e-3 kg/m^3).
    rain_rate : float
        Rain rate [mm/h].
    """

    kind: str
    base: float
    top: float
    liquid_water: float = 0.0
    rain_rate: float = 0.0

    def __post_init__(self):
        if self.kind not in LAYER_KINDS:
            raise ValueError(
                f"unknown weather layer kind {self.kind!r}; known: {', '.join(LAYER_KINDS)}"
            )
        if not (0.0 <= self.base < self.top):
            raise ValueError(
                f"{self.kind} layer: need 0 <= base < top, got base {self.base} m, top {self.top} m"
            )
        if self.liquid_water < 0.0 or self.rain_rate < 0.0:
            raise ValueError(f"{self.kind} layer: liquid_water and rain_rate must be >= 0")
        if self.kind == "rain" and self.liquid_water:
            raise ValueError("rain layer: give rain_rate [mm/h], not liquid_water")
        if self.kind != "rain" and self.rain_rate:
            raise ValueError(f"{self.kind} layer: give liquid_water [kg/m^3], not rain_rate")


@dataclass(frozen=True)
class Atmosphere:
    """A reference atmosphere, its ground-level overrides, and weather slabs.

    Attributes
    ----------
    profile : str
        ITU-R P.835 reference profile, one of `PROFILES`; "standard" is the mean annual global
        reference atmosphere.
    ground_temperature : float or None
        Air temperature at the scene's ground [K]. The profile's temperature is shifted by the
        difference at the ground, the shift tapering linearly to zero at the profile's tropopause
        (`itu.TROPOPAUSE_HEIGHT`) so the stratosphere is untouched.
    humidity : float or None
        Water-vapour density at the scene's ground [kg/m^3] (7.5 g/m^3 = 7.5e-3 kg/m^3); the whole
        water-vapour profile is scaled by it. Not checked against saturation.
    layers : tuple of Layer
        Fog, cloud and rain slabs; where they overlap their attenuations add.
    ground_altitude : float
        Altitude above sea level of the scene's z = 0 [m].
    """

    profile: str = "standard"
    ground_temperature: float | None = None
    humidity: float | None = None
    layers: tuple[Layer, ...] = ()
    ground_altitude: float = 0.0

    def __post_init__(self):
        if self.profile not in PROFILES:
            raise ValueError(
                f"unknown atmosphere profile {self.profile!r}; known: {', '.join(PROFILES)}"
            )
        object.__setattr__(self, "layers", tuple(self.layers))
        if not all(isinstance(layer, Layer) for layer in self.layers):
            raise TypeError("Atmosphere.layers must hold Layer records")
        if not (-500.0 <= self.ground_altitude < itu.TROPOPAUSE_HEIGHT[self.profile]):
            raise ValueError(
                f"ground_altitude {self.ground_altitude} m outside [-500 m, tropopause "
                f"{itu.TROPOPAUSE_HEIGHT[self.profile]:g} m) of profile {self.profile!r}"
            )
        if self.ground_temperature is not None and not self.ground_temperature > 0.0:
            raise ValueError(f"ground_temperature must be > 0 K, got {self.ground_temperature}")
        if self.humidity is not None and not self.humidity >= 0.0:
            raise ValueError(f"humidity must be >= 0 kg/m^3, got {self.humidity}")


def atmosphere_profile(atm: Atmosphere, z):
    """Temperature, pressure and water vapour at heights z above the scene's ground.

    Parameters
    ----------
    atm : Atmosphere
    z : array_like
        Heights above the ground [m].

    Returns
    -------
    T, p, rho : ndarray
        Temperature [K], total pressure [Pa], water-vapour density [kg/m^3], shaped like z.
    """
    h_ground = atm.ground_altitude
    h = np.minimum(h_ground + np.asarray(z, dtype=np.float64), itu.PROFILE_TOP)
    T, p, rho = itu.reference_atmosphere(atm.profile, h)
    if atm.ground_temperature is not None or atm.humidity is not None:
        T0, _, rho0 = itu.reference_atmosphere(atm.profile, h_ground)
        if atm.ground_temperature is not None:
            h_trop = itu.TROPOPAUSE_HEIGHT[atm.profile]
            taper = np.clip((h_trop - h) / (h_trop - h_ground), 0.0, 1.0)
            T = T + (atm.ground_temperature - T0) * taper
        if atm.humidity is not None:
            rho = rho * (atm.humidity / rho0)
    return T, p, rho


def vertical_grid(top: float, dz: float = DZ_GROUND, breaks=()) -> np.ndarray:
    """Cell edges [m] from 0 to top: dz at the ground, growing by DZ_GROWTH up to the caps.

    Every height in ``breaks`` strictly inside (0, top) becomes an edge exactly; grid edges
    closer than a third of the local spacing to one are dropped (no sliver cells).
    """
    edges = [0.0]
    step = dz
    while edges[-1] < top:
        edges.append(min(edges[-1] + step, top))
        cap = DZ_MAX_TROPOSPHERE if edges[-1] < DZ_SPLIT_HEIGHT else DZ_MAX_ALOFT
        step = min(step * DZ_GROWTH, max(cap, dz))
    edges = np.array(edges)
    b = np.unique([x for x in breaks if 0.0 < x < top])
    if b.size:
        spacing = np.gradient(edges)
        near = np.abs(edges[:, None] - b[None, :]).min(axis=1) < spacing / 3.0
        near[[0, -1]] = False
        edges = np.union1d(edges[~near], b)
    return edges


def layered_sky_temperature(
    edges,
    alpha,
    source,
    elevation,
    *,
    observer_height=0.0,
    earth_radius=R_EARTH,
    refractive_index=None,
    background=T_CMB,
):
    """Brightness temperature [K] seen looking up through a stack of cells (seed 000 sec. 2.2.7).

    Parameters
    ----------
    edges : ndarray, shape (K+1,)
        Cell edges, heights above the ground [m], increasing.
    alpha : ndarray, shape (K,)
        Power attenuation coefficient of each cell [Np/m].
    source : ndarray, shape (K,)
        Emission temperature of each cell [K].
    elevation : array_like, shape (M,)
        Elevation of the ray at the observer [rad], >= 0.
    observer_height : float
        Height of the observer above the ground [m]; cells below it do not count.
    earth_radius : float
        [m]; ``np.inf`` gives the flat-earth air mass 1/sin(el).
    refractive_index : ndarray, shape (K,), optional
        Refractive index of each cell; rays bend per Bouguer's rule n r cos(el) = const (spherical
        earth only). None: straight rays.
    background : float
        Brightness temperature above the top cell [K].

    Returns
    -------
    ndarray, shape (M,)
        float64.
    """
    edges = np.asarray(edges, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    el = np.clip(np.atleast_1d(np.asarray(elevation, dtype=np.float64)), 0.0, np.pi / 2)[:, None]
    z_lo = np.maximum(edges[:-1], observer_height)[None, :]
    z_hi = np.maximum(edges[1:], observer_height)[None, :]
    if np.isinf(earth_radius):
        d = (z_hi - z_lo) / np.maximum(np.sin(el), 1e-12)
    else:
        r_obs = earth_radius + observer_height
        c = r_obs * np.cos(el)  # impact parameter of the ray at the observer
        if refractive_index is not None:
            n = np.asarray(refractive_index, dtype=np.float64)
            i_obs = min(
                max(np.searchsorted(edges, observer_height, side="right") - 1, 0), n.size - 1
            )
            b = c * (n[i_obs] / n)[None, :]  # Bouguer: n_j r cos(el_j) = n_obs r_obs cos(el)
        else:
            b = c
        r_lo, r_hi = earth_radius + z_lo, earth_radius + z_hi
        # a straight line of impact parameter b covers sqrt(r^2 - b^2) from its tangent point
        d = np.sqrt(np.maximum((r_hi - b) * (r_hi + b), 0.0)) - np.sqrt(
            np.maximum((r_lo - b) * (r_lo + b), 0.0)
        )
    tau = alpha[None, :] * d
    tau_before = np.cumsum(tau, axis=1) - tau  # optical depth between the observer and cell j
    emitted = (np.asarray(source)[None, :] * -np.expm1(-tau) * np.exp(-tau_before)).sum(axis=1)
    return emitted + background * np.exp(-tau.sum(axis=1))


class AtmosphereModel:
    """An `Atmosphere` at one frequency: cells, sky table, path attenuation and emission.

    Parameters
    ----------
    atm : Atmosphere
    frequency : float
        [Hz].
    top : float
        Height of the top of the model above the ground [m] (capped at the 100 km the P.835
        profiles reach).
    dz : float, optional
        Thickness of the lowest cell [m] (default `DZ_GROUND`); cells grow upward from it.

    Attributes
    ----------
    edges : ndarray, shape (K+1,)
        Cell edges, heights above the ground [m]; every weather-layer base and top is one.
    temperature : ndarray, shape (K,)
        Physical temperature of each cell [K].
    alpha : ndarray, shape (K,)
        Power attenuation (extinction) coefficient [Np/m].
    alpha_absorption : ndarray, shape (K,)
        Its absorbing part [Np/m] (all of it but the scattering part of rain).
    source : ndarray, shape (K,)
        Emission temperature T alpha_absorption / alpha [K].
    depth : ndarray, shape (K+1,)
        Vertical optical depth from the ground to each edge [Np].
    """

    def __init__(
        self, atm: Atmosphere, frequency: float, *, top: float = 100e3, dz: float | None = None
    ):
        if not (F_MIN <= frequency <= F_MAX):
            raise ValueError(
                f"frequency {frequency:g} Hz outside the 1-1000 GHz of the ITU-R models"
            )
        if dz is not None and not dz > 0.0:
            raise ValueError(f"dz must be > 0 m, got {dz}")
        self.atmosphere = atm
        self.frequency = float(frequency)
        top = min(float(top), itu.PROFILE_TOP - atm.ground_altitude)
        breaks = [h for layer in atm.layers for h in (layer.base, layer.top)]
        self.edges = vertical_grid(top, DZ_GROUND if dz is None else float(dz), breaks)
        zm = 0.5 * (self.edges[:-1] + self.edges[1:])
        T, p, rho = atmosphere_profile(atm, zm)
        e = itu.water_vapour_pressure(rho, T)
        f = self.frequency
        alpha_gas = itu.gas_specific_attenuation_db_km(f, p - e, rho, T) * NP_M_PER_DB_KM
        alpha_abs = alpha_gas.copy()
        alpha_ext = alpha_gas.copy()
        for layer in atm.layers:
            inside = (zm > layer.base) & (zm < layer.top)
            if layer.kind == "rain":
                a = itu.rain_specific_attenuation_db_km(layer.rain_rate, f) * NP_M_PER_DB_KM
                alpha_ext[inside] += a
                alpha_abs[inside] += a * itu.rain_absorption_fraction(f, layer.rain_rate)
            else:
                a = itu.liquid_water_kl(f, T[inside]) * (layer.liquid_water * 1e3) * NP_M_PER_DB_KM
                alpha_ext[inside] += a
                alpha_abs[inside] += a
        self.temperature = T
        self.alpha = alpha_ext
        self.alpha_absorption = alpha_abs
        self.source = np.where(
            alpha_ext > 0.0, T * alpha_abs / np.where(alpha_ext > 0.0, alpha_ext, 1.0), T
        )
        self.refractive_index = 1.0 + 1e-6 * itu.refractivity(p, rho, T)
        self.depth = np.concatenate([[0.0], np.cumsum(alpha_ext * np.diff(self.edges))])
        self._sky_tables: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    @property
    def top(self) -> float:
        """Top of the model above the ground [m]."""
        return float(self.edges[-1])

    def _cell(self, z) -> np.ndarray:
        i = np.searchsorted(self.edges, z, side="right") - 1
        return np.clip(i, 0, self.alpha.size - 1)

    def specific_attenuation_db_km(self, z=0.0):
        """Total specific attenuation at height z above the ground [dB/km] (float for scalar z)."""
        a = self.alpha[self._cell(z)] / NP_M_PER_DB_KM
        return float(a) if np.ndim(a) == 0 else a

    def zenith_opacity(self) -> float:
        """Optical depth of the whole model from the ground to its top, straight up [Np]."""
        return float(self.depth[-1])

    def sky_table(self, height: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(elevation [rad], T [K]) table of the sky seen from `height` [m]; built once, cached."""
        key = float(np.clip(height, 0.0, self.top))
        if key not in self._sky_tables:
            el = 0.5 * np.pi * np.linspace(0.0, 1.0, N_SKY_TABLE) ** 2
            T = layered_sky_temperature(
                self.edges,
                self.alpha,
                self.source,
                el,
                observer_height=key,
                refractive_index=self.refractive_index,
            )
            self._sky_tables[key] = (el, T)
        return self._sky_tables[key]

    def sky_temperature(self, elevation, height: float = 0.0) -> np.ndarray:
        """Sky brightness temperature Tv = Th [K] for rays leaving at these elevations.

        Earth curvature and refraction included; interpolated in a table computed once per
        observer height.

        Parameters
        ----------
        elevation : array_like
            Elevation above the horizon [rad]; values below 0 are read as 0 (below the horizon
            the renderer sees the ground, not the sky).
        height : float
            Observer height above the ground [m] (the sky from an aircraft lacks the air below).

        Returns
        -------
        ndarray
            float64, shaped like `elevation`.
        """
        el, T = self.sky_table(height)
        return np.interp(np.clip(elevation, 0.0, 0.5 * np.pi), el, T)

    def _tau(self, z0, z1, length):
        """Optical depth of straight segments [Np] from the cumulative depth (exact, no loop)."""
        dz = z1 - z0
        horizontal = np.abs(dz) <= HORIZONTAL_SLOPE * length
        slope_tau = np.abs(
            np.interp(z1, self.edges, self.depth) - np.interp(z0, self.edges, self.depth)
        ) * (length / np.where(horizontal, 1.0, np.abs(dz)))
        flat_tau = self.alpha[self._cell(0.5 * (z0 + z1))] * length
        return np.where(horizontal, flat_tau, slope_tau)

    def _segments(self, z0, z1, length):
        z0, z1, length = np.broadcast_arrays(
            np.asarray(z0, dtype=np.float64),
            np.asarray(z1, dtype=np.float64),
            np.asarray(length, dtype=np.float64),
        )
        shape = z0.shape
        z0 = np.clip(z0.ravel(), 0.0, self.top)
        z1 = np.clip(z1.ravel(), 0.0, self.top)
        return shape, z0, z1, length.ravel()

    def path(self, z0, z1, length) -> tuple[np.ndarray, np.ndarray]:
        """Transmittance and own emission of straight segments, seen by an observer at the z0 end.

        Parameters
        ----------
        z0 : array_like, shape (N,)
            Height of the observer's end above the ground [m].
        z1 : array_like, shape (N,)
            Height of the far end [m].
        length : array_like, shape (N,)
            Segment length [m] (>= |z1 - z0|).

        Returns
        -------
        transmittance : ndarray, shape (N,)
            exp(-tau), power.
        emission : ndarray, shape (N,)
            sum_j S_j (1 - exp(-tau_j)) exp(-tau between the observer and cell j) [K]; the
            brightness at the observer is ``emission + transmittance * T_far``.
        """
        shape, z0, z1, L = self._segments(z0, z1, length)
        trans = np.ones_like(z0)
        emission = np.zeros_like(z0)
        dz = z1 - z0
        horizontal = np.abs(dz) <= HORIZONTAL_SLOPE * L

        h = np.flatnonzero(horizontal)
        j = self._cell(0.5 * (z0[h] + z1[h]))
        tau = self.alpha[j] * L[h]
        trans[h] = np.exp(-tau)
        emission[h] = self.source[j] * -np.expm1(-tau)

        # sloped segments: walk the cells from the observer outward, dropping finished segments
        s = np.flatnonzero(~horizontal)
        up = dz[s] > 0.0
        e = self.edges
        last = self.alpha.size - 1
        i_start = np.where(
            up,
            np.searchsorted(e, z0[s], side="right") - 1,
            np.searchsorted(e, z0[s], side="left") - 1,
        ).clip(0, last)
        i_end = np.where(
            up,
            np.searchsorted(e, z1[s], side="left") - 1,
            np.searchsorted(e, z1[s], side="right") - 1,
        ).clip(0, last)
        j = i_start
        step = np.where(up, 1, -1)
        left = np.abs(i_end - i_start) + 1  # cells still to cross
        # vertical optical depth at the segment's ends; the cells' own are self.depth
        d_lo = np.interp(np.minimum(z0[s], z1[s]), e, self.depth)
        d_hi = np.interp(np.maximum(z0[s], z1[s]), e, self.depth)
        stretch = L[s] / np.abs(dz[s])
        t = np.ones(s.size)
        em = np.zeros(s.size)
        while s.size:
            tau_v = np.minimum(self.depth[j + 1], d_hi) - np.maximum(self.depth[j], d_lo)
            x = np.expm1(-np.maximum(tau_v, 0.0) * stretch)  # exp(-tau) - 1
            em -= self.source[j] * x * t
            t *= 1.0 + x
            left -= 1
            done = left == 0
            if done.any():
                trans[s[done]] = t[done]
                emission[s[done]] = em[done]
                keep = ~done
                s, j, step, left, d_lo, d_hi, stretch, t, em = (
                    a[keep] for a in (s, j, step, left, d_lo, d_hi, stretch, t, em)
                )
            j = j + step
        return trans.reshape(shape), emission.reshape(shape)

    def extremes(self, z_lo: float, z_hi: float) -> tuple[float, float, float]:
        """Largest extinction and range of source temperatures of the cells between two heights.

        Every cell a straight segment between heights z_lo <= z <= z_hi [m] can cross is included
        (one more below, for segments ending exactly on a cell edge), so the result bounds `path`.

        Returns
        -------
        alpha_max : float
            [Np/m].
        source_min, source_max : float
            [K].
        """
        i0 = max(int(self._cell(np.clip(z_lo, 0.0, self.top))) - 1, 0)
        i1 = int(self._cell(np.clip(z_hi, 0.0, self.top)))
        sl = slice(i0, max(i1, i0) + 1)
        return float(self.alpha[sl].max()), float(self.source[sl].min()), float(self.source[sl].max())

    def path_loss_db(self, z0, z1, length) -> np.ndarray:
        """Attenuation of straight segments, 10 log10(1/transmittance) [dB]; arguments as `path`."""
        shape, z0, z1, L = self._segments(z0, z1, length)
        return (self._tau(z0, z1, L) * (10.0 / np.log(10.0))).reshape(shape)
