"""Layered atmosphere: sky brightness and attenuation/emission along in-scene paths.

The atmosphere is a stack of horizontal cells (flat within the scene, spherical shells for the
sky) of uniform power attenuation (extinction) coefficient alpha [Np/m], single-scattering albedo
omega, asymmetry parameter g and physical temperature T [K]. Brightness temperatures are
Rayleigh-Jeans brightness temperatures throughout (Murakowski 2014 eq. 1.1, PHYSICS.md): a
non-scattering cell emits T (1 - exp(-tau)). Planck radiance would read about h f / 2k lower
(0.8 K at 35 GHz, 2.3 K at 95 GHz) for the same atmosphere.

Per cell, at the cell's midpoint height:

* gases: oxygen and water vapour, ITU-R P.676 Annex 1 line by line, on the P.835 reference
  profile of `Atmosphere.profile` (`pmmw.atmosphere.itu`); they absorb only (omega = 0);
* fog and cloud slabs (`AtmosphereLayer`): liquid water, P.840 at the cell's temperature; the droplets are
  Rayleigh scatterers (omega < 1e-3 at 95 GHz), counted as absorbing only (omega = 0);
* rain slabs: P.838 extinction for an unpolarized wave (mean of H and V), or a power law
  A = a R^b [dB/km] with coefficients given for the frequency (`AtmosphereLayer.power_law`: Murakowski 2014
  Table 3.5's, Olsen et al. 1978 at 20 C), of which the Mie fraction omega (about 0.37 at 35 GHz
  and 0.50 at 95 GHz for 10 mm/h) is scattering, with the asymmetry parameter g of the drop
  distribution (-0.03 and 0.27), both tabulated from Mie theory
  (`itu.rain_single_scattering_albedo`, `itu.rain_asymmetry_parameter`). The power law sets the
  total only: its scattering part is the same fraction omega of it, its g the same.

Scattering (`scattering_source`). Rain scatters about half of what it removes from a ray, and
the same amount of radiation from other directions is scattered into the ray: the source
function of a cell is ``S(mu) = (1 - omega) T + omega (1/2) int P(mu, mu') I(mu') dmu'``, mu the
cosine of the propagation direction to the upward vertical. The diffuse field I is taken from
the delta-Eddington solution of the plane-parallel atmosphere (Eddington's ``I = I0 + I1 mu``
with the forward peak f = g^2 of the phase function scaled out: Joseph, Wiscombe & Weinman 1976;
the Eddington entry of the two-stream family of Meador & Weaver 1980), exact per cell of constant
properties and solved for all cells at once as one banded linear system (continuity of I0 and I1
at every cell edge, as Toon et al. 1989 do; Marshak 1947 boundary conditions: a blackbody ground
at ``ground_temperature`` below, the cosmic background above). For an I linear in mu only the
first two Legendre moments of the phase function
count, so the source is exactly ``S(mu) = (1 - omega) T + omega (<I0> + g mu <I1>)`` with the
true omega and g (the single-scattering correction of the TMS method, Nakajima & Tanaka 1988),
<> the average over the cell; it is `source` + `source_mu` mu. Every ray then keeps the formal
solution below with the true extinction (P.838's attenuation) and this source. Scattering cells
are split to at most `TAU_MAX_SCATTERING` vertical optical depth (up to `MAX_SPLIT` parts, which
covers 50 mm/h at 95 GHz) so that the cell average stands for the source within a cell.

Accuracy. An isothermal atmosphere between boundaries at its own temperature gives I0 = T,
I1 = 0 and reads T exactly (the equilibrium the thesis's fully emitting rain assumed). Against
Chandrasekhar's exact emissivity of a semi-infinite isotropic scatterer, sqrt(1 - omega)
H(mu, omega) (Chandrasekhar 1960 ch. V; Kirchhoff: 1 minus its plane albedo), this scheme errs
by at most 0.7 % (omega = 0.3), 1.3 % (0.5) and 3.5 % (0.9) over mu = 0.05-1, nearly all of it
the Eddington closure's own. Against a 32-stream discrete-ordinates solution with the full
(Henyey-Greenstein) phase function, a rain-like slab of 4 optical depths at 285 K under the 3 K
background reads at most 0.93 K too warm (omega 0.5, g 0.3, as 10 mm/h at 95 GHz; 2.6 K without
the g mu term) and 0.21 K (omega 0.37, g -0.03, as at 35 GHz); see
`tests/atmosphere/test_atmosphere_scattering.py`.
For rain (omega <= 0.56) the error is about 1 % of the contrast between the rain and what lies
beyond it: at most ~3 K for an opaque rain under a cold sky, 1 K or less in the thesis's rain
scene. Not modelled:
polarization by scattering (oblate drops make rain's emission slightly polarized, a few kelvin
at low elevations): Tv = Th; the ground's reflection (the two-stream ground is a blackbody at
`ground_temperature`); horizontal inhomogeneity (a rain cell of finite extent); and the scene's
own objects, which do not feed back into the atmosphere's radiation field. Without rain
(omega = 0 everywhere) the source is T and every result is bit for bit the non-scattering one.

Sky (`AtmosphereModel.sky_temperature`): the recurrence of Murakowski 2014 sec. 2.2.7,
``T_{j+1} = T_j exp(-alpha_j d_j) + S_j (1 - exp(-alpha_j d_j))`` from the cosmic background
down, written as the equivalent sum over cells. d_j is the length of the ray in spherical shell j
for a ray leaving the observer at elevation el over a spherical earth, bent by refraction per
Bouguer's rule ``n r cos(el) = const`` (refractivity from ITU-R P.453); S_j is the source for
the ray's mean direction in the shell, mu_j = -(shell thickness)/d_j. Tabulated once per observer
height over elevation and interpolated. Tv = Th: the horizontally stratified atmosphere of
spherical drops emits and scatters unpolarized light in this model.

In-scene paths (`AtmosphereModel.path`): straight segments through flat horizontal cells, exact
for piecewise-constant alpha and S: a segment from height z0 to z1 of length L spends
``overlap_j L / |z1 - z0|`` in cell j, and its radiation travels toward z0 with
mu = (z0 - z1) / L.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from pmmw.arrays import FloatArray
from pmmw.atmosphere import itu
from pmmw.atmosphere.itu import NP_M_PER_DB_KM, PROFILES
from pmmw.jit import inline, njit

if TYPE_CHECKING:  # scipy.interpolate is imported where it is used: ~0.3 s a command need not pay
    from scipy.interpolate import CubicSpline


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
SKY_ELEVATIONS = 0.5 * np.pi * np.linspace(0.0, 1.0, N_SKY_TABLE) ** 2  # [rad]
SKY_ELEVATIONS.setflags(write=False)
HORIZONTAL_SLOPE = 1e-9  # |z1 - z0| / L below which a segment counts as horizontal
# largest vertical optical depth of a scattering cell: its mean source then stands for the source
# anywhere in it (the two-stream field varies on a scale 1/k >~ 1 optical depth)
TAU_MAX_SCATTERING = 0.05
MAX_SPLIT = 20  # but a grid cell is cut into at most this many (heavy rain: 10 m in 200 m cells)
OMEGA_MAX = 1.0 - 1e-6  # the two-stream eigenvalue k vanishes for conservative scattering

LAYER_KINDS = ("fog", "cloud", "rain")


@dataclass(frozen=True)
class AtmosphereLayer:
    """A weather slab between two heights above the ground.

    Attributes
    ----------
    kind : str
        "fog" or "cloud" (liquid water droplets, P.840) or "rain" (P.838, or `power_law`).
    base, top : float
        Heights of the slab above the ground [m], 0 <= base < top.
    liquid_water : float
        Liquid water content of fog or cloud [kg/m^3] (1 g/m^3 = 1e-3 kg/m^3).
    rain_rate : float
        Rain rate [mm/h].
    power_law : tuple of float or None
        Rain only: ``(a, b)`` of the specific attenuation A = a R^b [dB/km] (a in
        (dB/km)/(mm/h)^b, b dimensionless) at the frequency the model is built for, in place of
        ITU-R P.838; None: P.838.
    scattering : bool
        Rain only: the drops scatter their Mie single-scattering albedo's share of the extinction
        (default); False: all of it is absorbed, as Murakowski 2014 sec. 3.3.1 modelled rain.
    """

    kind: str
    base: float
    top: float
    liquid_water: float = 0.0
    rain_rate: float = 0.0
    power_law: tuple[float, float] | None = None
    scattering: bool = True

    def __post_init__(self) -> None:
        if self.kind not in LAYER_KINDS:
            raise ValueError(f"unknown weather layer kind {self.kind!r}; known: {', '.join(LAYER_KINDS)}")
        if not (0.0 <= self.base < self.top):
            raise ValueError(f"{self.kind} layer: need 0 <= base < top, got base {self.base} m, top {self.top} m")
        if self.liquid_water < 0.0 or self.rain_rate < 0.0:
            raise ValueError(f"{self.kind} layer: liquid_water and rain_rate must be >= 0")
        if self.kind == "rain" and self.liquid_water:
            raise ValueError("rain layer: give rain_rate [mm/h], not liquid_water")
        if self.kind != "rain" and self.rain_rate:
            raise ValueError(f"{self.kind} layer: give liquid_water [kg/m^3], not rain_rate")
        if self.power_law is not None:
            if self.kind != "rain":
                raise ValueError(f"{self.kind} layer: a power law is for rain only")
            a, b = self.power_law
            if not (math.isfinite(a) and a > 0.0 and math.isfinite(b) and b > 0.0):
                raise ValueError(f"rain layer: power law A = a R^b needs finite a > 0 and b > 0, got a {a}, b {b}")


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
    layers : tuple of AtmosphereLayer
        Fog, cloud and rain slabs; where they overlap their attenuations add.
    ground_altitude : float
        Altitude above sea level of the scene's z = 0 [m].
    """

    profile: str = "standard"
    ground_temperature: float | None = None
    humidity: float | None = None
    layers: tuple[AtmosphereLayer, ...] = ()
    ground_altitude: float = 0.0

    def __post_init__(self) -> None:
        if self.profile not in PROFILES:
            raise ValueError(f"unknown atmosphere profile {self.profile!r}; known: {', '.join(PROFILES)}")
        object.__setattr__(self, "layers", tuple(self.layers))
        if not all(isinstance(layer, AtmosphereLayer) for layer in self.layers):
            raise TypeError("Atmosphere.layers must hold AtmosphereLayer records")
        if not (-500.0 <= self.ground_altitude < itu.TROPOPAUSE_HEIGHT[self.profile]):
            raise ValueError(
                f"ground_altitude {self.ground_altitude} m outside [-500 m, tropopause "
                f"{itu.TROPOPAUSE_HEIGHT[self.profile]:g} m) of profile {self.profile!r}"
            )
        if self.ground_temperature is not None and not self.ground_temperature > 0.0:
            raise ValueError(f"ground_temperature must be > 0 K, got {self.ground_temperature}")
        if self.humidity is not None and not self.humidity >= 0.0:
            raise ValueError(f"humidity must be >= 0 kg/m^3, got {self.humidity}")


def rain_power_law_db_km(rain_rate_mm_h: npt.ArrayLike, a: float, b: float) -> FloatArray:
    """Rain specific attenuation A = a R^b [dB/km] (Murakowski 2014 sec. 3.3.4, Table 3.5).

    Parameters
    ----------
    rain_rate_mm_h : array_like
        Rain rate R [mm/h].
    a : float
        [(dB/km)/(mm/h)^b]: the attenuation at 1 mm/h.
    b : float
        Exponent [-].
    """
    return a * np.asarray(rain_rate_mm_h, dtype=np.float64) ** b


def atmosphere_profile(atm: Atmosphere, z: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
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


def vertical_grid(top: float, dz: float = DZ_GROUND, breaks: Iterable[float] = ()) -> FloatArray:
    """Cell edges [m] from 0 to top: dz at the ground, growing by DZ_GROWTH up to the caps.

    Every height in ``breaks`` strictly inside (0, top) becomes an edge exactly; grid edges
    closer than a third of the local spacing to one are dropped (no sliver cells).
    """
    grid = [0.0]
    step = dz
    while grid[-1] < top:
        grid.append(min(grid[-1] + step, top))
        cap = DZ_MAX_TROPOSPHERE if grid[-1] < DZ_SPLIT_HEIGHT else DZ_MAX_ALOFT
        step = min(step * DZ_GROWTH, max(cap, dz))
    edges = np.array(grid)
    b = np.unique([x for x in breaks if 0.0 < x < top])
    if b.size:
        spacing = np.gradient(edges)
        near = np.abs(edges[:, None] - b[None, :]).min(axis=1) < spacing / 3.0
        near[[0, -1]] = False
        edges = np.union1d(edges[~near], b)
    return edges


def scattering_source(
    dtau: FloatArray,
    omega: FloatArray,
    g: FloatArray,
    T: FloatArray,
    *,
    ground_temperature: float,
    top_temperature: float = T_CMB,
) -> tuple[FloatArray, FloatArray]:
    """Source function of each cell from the delta-Eddington field of a plane-parallel stack.

    The diffuse field ``I(s, mu) = I0(s) + I1(s) mu`` (mu: cosine of the propagation direction to
    the upward vertical) of the delta-scaled problem (Joseph, Wiscombe & Weinman 1976: f = g^2,
    omega' = (1 - f) omega / (1 - omega f), g' = (g - f) / (1 - f), dtau' = (1 - omega f) dtau)
    obeys, in a cell of constant properties with s its scaled optical height,
    ``dI0/ds = -(1 - omega' g') I1`` and ``dI1/ds = -3 (1 - omega') (I0 - T)`` (the first two
    moments of the transfer equation), whence, with k^2 = 3 (1 - omega') (1 - omega' g'),
    ``I0 = T + a exp(-k s) + b exp(-k (dtau' - s))`` and
    ``I1 = r (a exp(-k s) - b exp(-k (dtau' - s)))``, r = k / (1 - omega' g'): neither
    exponential exceeds 1. I0 and I1 are continuous at every cell edge; Marshak's conditions fix
    the hemispheric fluxes entering the stack, ``I0 + 2/3 I1 = ground_temperature`` at the
    bottom (a blackbody ground) and ``I0 - 2/3 I1 = top_temperature`` at the top. That is one
    linear system with five bands in the 2K coefficients (a_j, b_j).

    Parameters
    ----------
    dtau : ndarray, shape (K,)
        Vertical optical depth of each cell, extinction, ground first [Np].
    omega : ndarray, shape (K,)
        Single-scattering albedo [-] (capped at `OMEGA_MAX`).
    g : ndarray, shape (K,)
        Asymmetry parameter of the scattering [-], in (-1, 1).
    T : ndarray, shape (K,)
        Physical temperature [K].
    ground_temperature : float
        Temperature of the blackbody below the stack [K].
    top_temperature : float
        Isotropic brightness incident from above the stack [K].

    Returns
    -------
    source : ndarray, shape (K,)
        ``(1 - omega) T + omega <I0>`` [K], <> the mean over the cell.
    source_mu : ndarray, shape (K,)
        ``omega g <I1>`` [K]: radiation travelling in direction mu has the source
        ``source + source_mu mu`` (only the first two Legendre moments of the phase function act
        on a field linear in mu).
    """
    dtau, omega, g, T = (np.asarray(a, dtype=np.float64) for a in (dtau, omega, g, T))
    w = np.minimum(omega, OMEGA_MAX)
    f = g * g
    w_s = (1.0 - f) * w / (1.0 - w * f)
    g_s = (g - f) / (1.0 - f)
    x = np.sqrt(3.0 * (1.0 - w_s) * (1.0 - w_s * g_s)) * (1.0 - w * f) * dtau  # k dtau'
    r = np.sqrt(3.0 * (1.0 - w_s) / (1.0 - w_s * g_s))
    E = np.exp(-x)
    K = T.size
    n = 2 * K
    ab = np.zeros((5, n))  # ab[2 + i - j, j] = A[i, j]

    def put(rows: int | npt.NDArray[np.intp], cols: int | npt.NDArray[np.intp], values: npt.ArrayLike) -> None:
        ab[2 + rows - cols, cols] = values

    c = 2.0 / 3.0
    rhs = np.zeros(n)
    # bottom: upward flux I0 + 2/3 I1 = ground, at s = 0 of cell 0
    put(0, 0, 1.0 + c * r[0])
    put(0, 1, E[0] * (1.0 - c * r[0]))
    rhs[0] = ground_temperature - T[0]
    # edges between cell j and j + 1: I0 and I1 continuous
    j = np.arange(K - 1)
    i0, i1 = 2 * j + 1, 2 * j + 2
    put(i0, 2 * j, E[j])
    put(i0, 2 * j + 1, 1.0)
    put(i0, 2 * j + 2, -1.0)
    put(i0, 2 * j + 3, -E[j + 1])
    rhs[i0] = T[j + 1] - T[j]
    put(i1, 2 * j, r[j] * E[j])
    put(i1, 2 * j + 1, -r[j])
    put(i1, 2 * j + 2, -r[j + 1])
    put(i1, 2 * j + 3, r[j + 1] * E[j + 1])
    # top: downward flux I0 - 2/3 I1 = top_temperature, at s = dtau' of cell K - 1
    put(n - 1, n - 2, E[-1] * (1.0 - c * r[-1]))
    put(n - 1, n - 1, 1.0 + c * r[-1])
    rhs[n - 1] = top_temperature - T[-1]
    from scipy.linalg import solve_banded

    coef = solve_banded((2, 2), ab, rhs)
    a, b = coef[0::2], coef[1::2]
    mean = np.ones(K)  # cell mean of exp(-k s), = that of exp(-k (dtau' - s))
    thick = x > 1e-12
    mean[thick] = -np.expm1(-x[thick]) / x[thick]
    source = (1.0 - omega) * T + omega * (T + (a + b) * mean)
    source_mu = omega * g * r * (a - b) * mean
    return source, source_mu


def layered_sky_temperature(
    edges: npt.ArrayLike,
    alpha: npt.ArrayLike,
    source: npt.ArrayLike,
    elevation: npt.ArrayLike,
    *,
    observer_height: float = 0.0,
    earth_radius: float = R_EARTH,
    refractive_index: npt.ArrayLike | None = None,
    background: float = T_CMB,
    source_mu: npt.ArrayLike | None = None,
) -> FloatArray:
    """Brightness temperature [K] looking up through a stack of cells (Murakowski 2014 sec. 2.2.7).

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
    source_mu : ndarray, shape (K,), optional
        Direction-dependent part of the source (`scattering_source`): a ray crossing cell j at
        mean direction mu_j = -(cell thickness) / d_j (downward, toward the observer) has the
        source ``source_j + source_mu_j mu_j``. None: isotropic sources.

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
            i_obs = min(max(int(np.searchsorted(edges, observer_height, side="right")) - 1, 0), n.size - 1)
            b = c * (n[i_obs] / n)[None, :]  # Bouguer: n_j r cos(el_j) = n_obs r_obs cos(el)
        else:
            b = c
        r_lo, r_hi = earth_radius + z_lo, earth_radius + z_hi
        # a straight line of impact parameter b covers sqrt(r^2 - b^2) from its tangent point
        d = np.sqrt(np.maximum((r_hi - b) * (r_hi + b), 0.0)) - np.sqrt(np.maximum((r_lo - b) * (r_lo + b), 0.0))
    tau = alpha[None, :] * d
    tau_before = np.cumsum(tau, axis=1) - tau  # optical depth between the observer and cell j
    src = np.asarray(source, dtype=np.float64)[None, :]
    if source_mu is not None:
        crossed = d > 0.0
        mu = -(z_hi - z_lo) / np.where(crossed, d, 1.0)
        src = src + np.asarray(source_mu, dtype=np.float64)[None, :] * np.where(crossed, mu, 0.0)
    emitted = (src * -np.expm1(-tau) * np.exp(-tau_before)).sum(axis=1)
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
    ground_temperature : float, optional
        Temperature of the blackbody ground under the scattering solution [K] (default: the air
        temperature at the ground); only rain (omega > 0) sees it.

    Attributes
    ----------
    edges : ndarray, shape (K+1,)
        Cell edges, heights above the ground [m]; every weather-layer base and top is one, and
        rain is cut into cells of at most `TAU_MAX_SCATTERING` vertical optical depth (at most
        `MAX_SPLIT` parts of a grid cell).
    temperature : ndarray, shape (K,)
        Physical temperature of each cell [K].
    alpha : ndarray, shape (K,)
        Power attenuation (extinction) coefficient [Np/m].
    alpha_absorption : ndarray, shape (K,)
        Its absorbing part [Np/m] (all of it but the scattering part of rain).
    omega : ndarray, shape (K,)
        Single-scattering albedo (alpha - alpha_absorption) / alpha [-].
    asymmetry : ndarray, shape (K,)
        Asymmetry parameter of the scattering [-] (0 where nothing scatters).
    source, source_mu : ndarray, shape (K,)
        Source function [K] for radiation travelling at mu (cosine to the upward vertical):
        ``source + source_mu mu`` (`scattering_source`); without scattering source = temperature
        and source_mu = 0.
    depth : ndarray, shape (K+1,)
        Vertical optical depth from the ground to each edge [Np].
    """

    def __init__(
        self,
        atm: Atmosphere,
        frequency: float,
        *,
        top: float = 100e3,
        dz: float | None = None,
        ground_temperature: float | None = None,
    ) -> None:
        if not (F_MIN <= frequency <= F_MAX):
            raise ValueError(f"frequency {frequency:g} Hz outside the 1-1000 GHz of the ITU-R models")
        if dz is not None and not dz > 0.0:
            raise ValueError(f"dz must be > 0 m, got {dz}")
        if ground_temperature is not None and not ground_temperature > 0.0:
            raise ValueError(f"ground_temperature must be > 0 K, got {ground_temperature}")
        self.atmosphere = atm
        self.frequency = float(frequency)
        top = min(float(top), itu.PROFILE_TOP - atm.ground_altitude)
        breaks = [h for layer in atm.layers for h in (layer.base, layer.top)]
        edges = vertical_grid(top, DZ_GROUND if dz is None else float(dz), breaks)
        cells = self._cells(edges)
        # optically thick scattering cells are cut into equal parts (their mean source must stand
        # for the source anywhere in them); the optics are evaluated again at the new midpoints
        tau = cells[3] * np.diff(edges)
        parts = np.where(cells[4] > 0.0, np.ceil(tau / TAU_MAX_SCATTERING), 1.0)
        parts = np.minimum(parts, MAX_SPLIT).astype(int)
        if np.any(parts > 1):
            edges = np.concatenate(
                [np.linspace(lo, hi, m, endpoint=False) for lo, hi, m in zip(edges[:-1], edges[1:], parts, strict=True)]
                + [edges[-1:]]
            )
            cells = self._cells(edges)
        T, p, rho, alpha_ext, alpha_sca, alpha_sca_g = cells
        self.edges = edges
        self.temperature = T
        self.alpha = alpha_ext
        self.alpha_absorption = alpha_ext - alpha_sca
        scatters = alpha_sca > 0.0
        self.omega = np.where(scatters, alpha_sca / np.where(scatters, alpha_ext, 1.0), 0.0)
        self.asymmetry = np.where(scatters, alpha_sca_g / np.where(scatters, alpha_sca, 1.0), 0.0)
        self.refractive_index = 1.0 + 1e-6 * itu.refractivity(p, rho, T)
        self.depth = np.concatenate([[0.0], np.cumsum(alpha_ext * np.diff(self.edges))])
        if ground_temperature is None:
            ground_temperature = float(atmosphere_profile(atm, 0.0)[0])
        self.ground_temperature = float(ground_temperature)
        if scatters.any():
            self.source, self.source_mu = scattering_source(
                np.diff(self.depth),
                self.omega,
                self.asymmetry,
                T,
                ground_temperature=self.ground_temperature,
            )
        else:
            self.source, self.source_mu = T.copy(), np.zeros_like(T)
        self._sky_tables: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def _cells(self, edges):
        """Optics at the midpoints of cells with these edges [m].

        Returns T [K], p [Pa], rho [kg/m^3], extinction, scattering and scattering x asymmetry
        [Np/m], each shape (K,).
        """
        atm, f = self.atmosphere, self.frequency
        zm = 0.5 * (edges[:-1] + edges[1:])
        T, p, rho = atmosphere_profile(atm, zm)
        e = itu.water_vapour_pressure(rho, T)
        alpha_ext = itu.gas_specific_attenuation_db_km(f, p - e, rho, T) * NP_M_PER_DB_KM
        alpha_sca = np.zeros_like(alpha_ext)
        alpha_sca_g = np.zeros_like(alpha_ext)
        for layer in atm.layers:
            inside = (zm > layer.base) & (zm < layer.top)
            if layer.kind == "rain":
                if layer.power_law is None:
                    a = itu.rain_specific_attenuation_db_km(layer.rain_rate, f) * NP_M_PER_DB_KM
                else:
                    a = rain_power_law_db_km(layer.rain_rate, *layer.power_law) * NP_M_PER_DB_KM
                a_sca = a * itu.rain_single_scattering_albedo(f, layer.rain_rate) if layer.scattering else 0.0
                alpha_ext[inside] += a
                alpha_sca[inside] += a_sca
                alpha_sca_g[inside] += a_sca * itu.rain_asymmetry_parameter(f, layer.rain_rate)
            else:  # Rayleigh droplets: absorption only
                a = itu.liquid_water_kl(f, T[inside]) * (layer.liquid_water * 1e3) * NP_M_PER_DB_KM
                alpha_ext[inside] += a
        return T, p, rho, alpha_ext, alpha_sca, alpha_sca_g

    @property
    def top(self) -> float:
        """Top of the model above the ground [m]."""
        return float(self.edges[-1])

    def _cell(self, z: npt.ArrayLike) -> npt.NDArray[np.intp]:
        i = np.searchsorted(self.edges, z, side="right") - 1
        return np.clip(i, 0, self.alpha.size - 1)

    def specific_attenuation_db_km(self, z: npt.ArrayLike = 0.0) -> float | FloatArray:
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
            el = SKY_ELEVATIONS
            T = layered_sky_temperature(
                self.edges,
                self.alpha,
                self.source,
                el,
                observer_height=key,
                refractive_index=self.refractive_index,
                source_mu=self.source_mu,
            )
            self._sky_tables[key] = (el, T)
        return self._sky_tables[key]

    def sky_temperature(self, elevation: npt.ArrayLike, height: float = 0.0) -> FloatArray:
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
        slope_tau = np.abs(np.interp(z1, self.edges, self.depth) - np.interp(z0, self.edges, self.depth)) * (
            length / np.where(horizontal, 1.0, np.abs(dz))
        )
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

    def path(self, z0: npt.ArrayLike, z1: npt.ArrayLike, length: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
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
            sum_j S_j (1 - exp(-tau_j)) exp(-tau between the observer and cell j) [K], S_j the
            source of cell j for radiation travelling toward the observer,
            ``source_j + source_mu_j (z0 - z1) / L``; the brightness at the observer is
            ``emission + transmittance * T_far``.
        """
        shape, z0, z1, L = self._segments(z0, z1, length)
        trans, emission = np.empty_like(z0), np.empty_like(z0)
        self.walk(np.ascontiguousarray(z0), np.ascontiguousarray(z1), np.ascontiguousarray(L), trans, emission)
        return trans.reshape(shape), emission.reshape(shape)

    def walk(self, z0: FloatArray, z1: FloatArray, length: FloatArray, trans: FloatArray, emission: FloatArray) -> None:
        """`path` in place, for the renderer's segments (`pmmw.trace.kernels.ambient_segments`):
        ``z0``, ``z1`` already within 0..`top`, every argument a contiguous float64 array of
        shape (N,); a segment of length 0 gives transmittance 1 and no emission."""
        _path_loop(
            z0,
            z1,
            length,
            self.edges,
            self.alpha,
            self.depth,
            self.source,
            self.source_mu,
            bool(np.any(self.source_mu)),
            trans,
            emission,
        )

    def column(
        self, z_top: float, z_bottom: float, s_lo: float, s_hi: float, tolerance: float = 1e-9
    ) -> _Column | None:
        """The column between two heights as seen from its top along every slope in a range, for
        `walk_below`: its own emission against the stretch s = L / |dz| [-], a cubic spline on a
        uniform grid fine enough to be within ``tolerance`` [K] of the cell walk at every
        midpoint (16 nodes, doubled up to 4096), its transmittance exp(-tau s) in closed form.
        None where no such grid exists or the range is empty.

        An imager's rays all start at its height and end below the scene's top, so each of their
        first segments crosses this column in full: `walk_below` walks only the part below it.
        """
        z_top, z_bottom = min(float(z_top), self.top), max(float(z_bottom), 0.0)
        s_lo, s_hi = max(float(s_lo), 1.0), min(float(s_hi), 0.5 / HORIZONTAL_SLOPE)
        if not (z_top > z_bottom and s_hi >= s_lo):
            return None
        tau = float(np.interp(z_top, self.edges, self.depth) - np.interp(z_bottom, self.edges, self.depth))
        if s_hi - s_lo < 1e-12 * s_hi:  # one slope: a range to interpolate in all the same
            s_lo, s_hi = s_lo * (1.0 - 1e-9), s_hi * (1.0 + 1e-9)
        from scipy.interpolate import CubicSpline

        n = 16
        while n <= 4096:
            s = np.linspace(s_lo, s_hi, 2 * n - 1)  # the nodes, and the midpoints between them
            _, em = self.path(np.full(s.size, z_top), np.full(s.size, z_bottom), (z_top - z_bottom) * s)
            spline = CubicSpline(s[::2], em[::2])
            if np.abs(spline(s[1::2]) - em[1::2]).max() <= tolerance:
                return _Column(z_top, z_bottom, tau, s_lo, s_hi, spline)
            n *= 2
        return None

    def walk_below(
        self,
        column: _Column,
        z0: FloatArray,
        z1: FloatArray,
        length: FloatArray,
        trans: FloatArray,
        emission: FloatArray,
    ) -> None:
        """`walk` of segments some of which cross ``column`` (`column`) in full: those that start
        at its top, end at or below its bottom and lie in its range of slopes walk only their
        part below it, with the column's transmittance and tabulated emission ahead of it
        (``emission = E_col + T_col * E_below``, ``trans = T_col * T_below``); the others walk
        in full."""
        with np.errstate(divide="ignore", invalid="ignore"):
            s = length / (z0 - z1)
        use = (length > 0.0) & (z0 == column.z_top) & (z1 <= column.z_bottom) & (s >= column.s_lo) & (s <= column.s_hi)
        rest = np.flatnonzero(~use)
        if rest.size:
            tr, em = np.empty(rest.size), np.empty(rest.size)
            self.walk(z0[rest], z1[rest], length[rest], tr, em)
            trans[rest], emission[rest] = tr, em
        rows = np.flatnonzero(use)
        if rows.size:
            s, below = s[rows], z1[rows]
            tr, em = np.empty(rows.size), np.empty(rows.size)
            self.walk(np.full(rows.size, column.z_bottom), below, (column.z_bottom - below) * s, tr, em)
            t_col = np.exp(-column.tau * s)
            trans[rows] = t_col * tr
            emission[rows] = column.emission(s) + t_col * em

    def extremes(self, z_lo: float, z_hi: float) -> tuple[float, float, float]:
        """Largest extinction and range of source temperatures of the cells between two heights.

        The range covers every direction: ``source -+ |source_mu|``.

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
        spread = np.abs(self.source_mu[sl])
        return (
            float(self.alpha[sl].max()),
            float((self.source[sl] - spread).min()),
            float((self.source[sl] + spread).max()),
        )

    def path_loss_db(self, z0: npt.ArrayLike, z1: npt.ArrayLike, length: npt.ArrayLike) -> FloatArray:
        """Attenuation of straight segments, 10 log10(1/transmittance) [dB]; arguments as `path`."""
        shape, z0, z1, L = self._segments(z0, z1, length)
        return (self._tau(z0, z1, L) * (10.0 / np.log(10.0))).reshape(shape)


@dataclass(frozen=True)
class _Column:
    """`AtmosphereModel.column`: heights [m], vertical optical depth between them, the range of
    stretches and the column's emission [K] as a function of the stretch."""

    z_top: float
    z_bottom: float
    tau: float
    s_lo: float
    s_hi: float
    emission: CubicSpline


@inline()
def _depth_in(z, k, edges, depth):
    """Cumulative vertical optical depth at height z inside cell k (edges[k] <= z <= edges[k+1]),
    linear between the cell's edges as `numpy.interp` (which numba runs as an array routine, at
    a third of the whole walk's cost)."""
    return depth[k] + (depth[k + 1] - depth[k]) * ((z - edges[k]) / (edges[k + 1] - edges[k]))


@njit()
def _path_loop(z0, z1, length, edges, alpha, depth, source, source_mu, with_mu, trans, emission):
    """`AtmosphereModel.path` per segment, compiled: a horizontal segment stays in one cell; a
    sloped one walks the cells from the observer outward, optical depths from the cumulative
    vertical depth stretched by L / |dz|, each cell's source seen through the cells before it."""
    last = alpha.size - 1
    for i in range(z0.shape[0]):
        a, b, L = z0[i], z1[i], length[i]
        if L == 0.0:  # (the renderer's rays that stay out of the atmosphere this bounce)
            trans[i], emission[i] = 1.0, 0.0
            continue
        dz = b - a
        if abs(dz) <= HORIZONTAL_SLOPE * L:
            j = min(max(np.searchsorted(edges, 0.5 * (a + b), side="right") - 1, 0), last)
            tau = alpha[j] * L
            trans[i] = math.exp(-tau)
            emission[i] = source[j] * -math.expm1(-tau)
            continue
        if dz > 0.0:
            j, end = np.searchsorted(edges, a, side="right") - 1, np.searchsorted(edges, b, side="left") - 1
        else:
            j, end = np.searchsorted(edges, a, side="left") - 1, np.searchsorted(edges, b, side="right") - 1
        j, end = min(max(j, 0), last), min(max(end, 0), last)
        # vertical optical depth at the segment's ends, linear within the cell each end lies in
        # (the cells' own are `depth`); j and end are those cells
        lo, hi = (j, end) if dz > 0.0 else (end, j)
        d_lo = _depth_in(min(a, b), lo, edges, depth)
        d_hi = _depth_in(max(a, b), hi, edges, depth)
        stretch = L / abs(dz)
        mu = -dz / L  # direction of the radiation, toward the observer (only rain's source depends on it)
        # the transmittance from the observer to the far edge of each cell in turn, from the
        # vertical depth between them (one exp per cell, no product of the cells' own: about
        # twice as fast as expm1 per cell, the same to 1e-13 K); the cell emits its source times
        # what it takes off that transmittance
        t, em = 1.0, 0.0
        up = dz > 0.0  # the observer at d_lo, each cell's far edge its top; else at d_hi, its bottom
        d_obs, step = (d_lo, 1) if up else (d_hi, -1)
        for _ in range(abs(end - j) + 1):
            far = min(depth[j + 1], d_hi) if up else max(depth[j], d_lo)
            t_far = math.exp(-max((far - d_obs) * step, 0.0) * stretch)
            em += (source[j] + source_mu[j] * mu if with_mu else source[j]) * (t - t_far)
            t = t_far
            j += step
        trans[i], emission[i] = t, em
