"""Microfacet roughness models: normal distributions, Smith masking, exact visible-normal sampling.

Pure numerics, vectorized over rays (float64). Chosen by ``model:`` through `REGISTRY` and built
from a YAML record by `make_model`. Polarization is not handled here: a sampled microfacet normal
``m`` simply replaces the macro normal in the smooth-interface code, whose convention is stated in
`pmmw.physics.jones`.

Models
------
Every distribution ``D(m)`` is normalized over projected area, ``int D(m) (m.n) dw_m = 1``
[1/sr], and every masking function is Smith's for that distribution,
``G1(w) = (w.n) / A(w)`` with the projected area ``A(w) = int (w.m)+ D(m) dw_m`` (which is also
the Stryjewski et al. 2009 eq. 7 ensemble average: ``P(k) = <n.h> (n.k) / <h.k>+``).

``ashikhmin_shirley`` (``ex``, ``ey`` >= 0, ``orientation_deg``)
    ``D = sqrt((ex+2)(ey+2))/(2 pi) cos^(ex cos^2 phi + ey sin^2 phi) theta`` (Optics Express 2016 eq. 9; the
    extracted ``(ex+2)(ey+2)/2 pi`` lost its square root). phi is measured from the tangent
    rotated by ``orientation_deg`` about n. ``A`` is exact for ``ex == ey`` (closed form below);
    for ``ex != ey`` it is the isotropic form at the exponent ``e*`` with
    ``1/(e*+2) = cos^2 phi/(ex+2) + sin^2 phi/(ey+2)``, times a correction tabulated once per
    pair (ex, ey) from the exact one-dimensional integral (`_ASProjectedArea`, 0.2 s): the
    interpolation error is below 1e-5 of A for ex/ey = 2; it grows with the anisotropy, within
    a few degrees of grazing only: 4e-4 for ex/ey = 100, 1.5e-3 for ex = 0, ey = 50, several
    percent for ex/ey = 1e5. (Masking errors change the shape of the multiple-scattering part,
    never the energy balance: see "How the renderer uses this".)
``blinn_phong`` (``m`` >= 0)
    Stryjewski et al. 2009 eq. 3, ``rho(h) = (m+1)/(2 pi) cos^m`` per solid angle, i.e. ``D = (m+2)/(2 pi)
    cos^m`` per projected area: the isotropic Ashikhmin-Shirley surface ``ex = ey = m``.
    Stryjewski et al. 2009 eq. 18-23 expand ``<k.h>+`` in factorials and fail for large m; here (Smith's
    integral over the marginal slope density ``(1+q^2)^-(m+3)/2``)::

        A(theta) = cos(theta) (1 - I_x((m+2)/2, 1/2) / 2) + K sin^(m+2)(theta),
        K = (m+2) B(1/2, (m+3)/2) / (2 pi (m+1)),   x = sin^2(theta)

    with the regularized incomplete beta function I and K from ``betaln``: no factorial, no
    overflow, no cancellation, finite and accurate from m = 0 to 1e6 and beyond
    (`blinn_phong_mean_cos` gives Stryjewski et al. 2009's ``<k.h>+ = (m+1)/(m+2) A``).
``ggx`` (``alpha`` or ``alpha_x``, ``alpha_y`` > 0, ``orientation_deg``)
    Trowbridge-Reitz; what most renderers ship (Blender, Mitsuba, pbrt, Unreal):
    ``A(w) = (w.z + sqrt(w.z^2 + alpha_w^2 (1 - w.z^2))) / 2``.
``beckmann`` (same parameters)
    ``D = exp(-tan^2 theta (cos^2 phi/ax^2 + sin^2 phi/ay^2)) / (pi ax ay cos^4 theta)``;
    ``A(w) = w.z (1 + erf a)/2 + alpha_w sin(theta) exp(-a^2) / (2 sqrt pi)``, ``a = cot theta / alpha_w``.
``blender_gloss`` (``gloss`` in [0, 1])
    Murakowski 2014 sec. 2.2.6, Blender's glossy perturbation kept literally for the thesis's scenes:
    ``m = unit(n + r (x cos phi + y sin phi))``, ``r = sqrt(1 - b^(2L))``, ``L = (1 - g)^3``, b and
    phi uniform. It is not a microfacet distribution with a visibility law: every ray gets a
    normal from that recipe (no masking, ``G1 = 1`` above the horizon, 0 below). The only change:
    a facet drawn facing away from ``wo`` (possible beyond 45 degrees) is replaced by its mirror
    image ``unit(n - r (...))``, which has the same probability and faces ``wo``.

Sampling
--------
`sample_normals` draws ``m`` from the distribution of visible normals
``D_wo(m) = (wo.m)+ D(m) / A(wo)`` *exactly* for every microfacet model, so the returned weight
is 1: GGX by the spherical-cap construction (Dupuy and Benyoub 2023: ``m`` is the half
vector between ``wo`` and a uniform direction on a cap, in the space where the surface is
stretched to ``alpha = 1``), which holds for ``wo`` on either side of the macro surface;
Ashikhmin-Shirley, Blinn-Phong and Beckmann by rejection from GGX visible normals of a matched
roughness. In slope space the ratio of the two distributions is bounded (the GGX tails are the
heavier), so accepting a GGX visible normal with probability ``D(m) / (K D_GGX(m))`` gives the
target exactly (the factor ``(wo.m)+`` cancels). Acceptance is 0.68-1.0 at normal incidence
(``K`` minimized over the GGX width once per model) and about 0.4 at 89 degrees.
A ray whose acceptance probability ``A(wo) / (K A_GGX(wo))`` is below 1e-4, or that is still
rejected after 65536 candidates (only a masked ray re-hitting a smooth surface from well below
its horizon, where hardly any facet faces it), takes one proposal with the importance weight
``D_wo(m) / D_wo^GGX(m)`` instead of 1: unbiased, and rare (none in 1e6 copper paths here). The
extra uniforms for rejection rounds are a hash of the bits of ``(u1, u2)`` (splitmix64), so ``m``
is a deterministic function of ``(u1, u2)``: runs stay reproducible tile by tile. The
Optics Express 2016 sampling formula (normals from ``D cos``, no visibility) is `sample_dcos`, used for
quadratures.

How the renderer uses this
--------------------------
At a hit on a rough interface, for each ray (trace direction ``d``, ``wo = -d``), with the macro
normal ``n`` facing the ray's side (``wo.n > 0`` for a ray arriving through a medium; ``< 0`` is
allowed, see step 4) and a tangent ``t`` (the anisotropy axis before ``orientation_deg``; for a
mesh without texture coordinates any field consistent over the surface, e.g. world X projected
onto the face, Y where that degenerates; isotropic models ignore it):

1. ``m, w = model.sample_normals(n, t, wo, u1, u2)``. Multiply the ray's power by ``w`` (its
   Jones matrix by ``sqrt(w)``). ``w`` is the importance weight ``D_wo(m) / p(m)`` of the draw:
   1.0 for the built-in models (exact visible-normal sampling) except in the rare rejection
   fallback above; its expectation is 1 for every model, so power is conserved on average and,
   with weight 1, exactly per ray. Where ``w > 0``, ``wo.m > 0``. ``w == 0`` means no facet
   faces ``wo`` (degenerate input): end the ray there as absorbed, i.e. emit its power at the
   surface temperature, so that energy is still accounted for.
2. Do with ``m`` exactly what the smooth code does with ``n``: ``cos1 = wo.m``; the local basis
   ``s = unit(m x k)``, ``p = k x s`` (`pmmw.physics.jones`); ``fresnel.interface(eps1, eps2,
   cos1)`` or ``multilayer.stack(..., cos1, ...)`` for a coated facet; the reflected direction
   ``d - 2 (d.m) m`` and the refracted one about ``m``; the absorbed ``A = 1 - R - T`` emitted at
   the surface (or coating) temperature; reflected and transmitted children split or chosen as
   for smooth surfaces.
3. Each child, with direction ``d_c`` in the medium on side X, where ``n_X`` is the macro normal
   pointing into that medium (``n`` for the reflected child, ``-n`` for the transmitted one),
   *leaves* the surface with probability ``P = model.masking(n_X, t, d_c)``: Smith's ``G1``,
   which is 0 when ``d_c.n_X <= 0`` (the child points back into the surface: the "wrong side").
   Draw ``u < P`` (weight unchanged) or split into weights ``P`` and ``1 - P`` (amplitudes
   ``sqrt``).
4. A child that does not leave hits the same interface again at the same point, from side X:
   process it at once as an interaction with the same face (no intersection test, no offset of
   the origin; the renderer lets it cross one wavelength of the side's medium first, absorbing
   ``1 - exp(-alpha lambda)`` there: all of it inside copper, nothing inside clear plastic,
   which is what `pmmw.reflectance` does with its absorbing and transparent half-spaces), with
   ``wo = -d_c`` and macro
   normal ``n_X``; its media are those of side X (a transmitted child re-hits from inside: the
   face's "leaving" case, with the medium stack it already has). For a masked child
   ``wo.n_X < 0``; `sample_normals` handles that (it draws a facet facing ``wo``). A chain of
   re-hits ends with probability 1; after ``MAX_REHITS`` re-hits in a row, end the child by
   emitting its remaining power at the surface temperature (as if absorbed there).

Energy: every step either keeps the ray's power (masking, re-hits, weight 1) or splits it by
Fresnel's ``R + T + A = 1`` about the facet, with ``A`` emitted at the surface. Nothing is
discarded, so a non-absorbing rough surface reflects plus transmits exactly 1, path by path, and
an isothermal enclosure with rough walls still reads its temperature in every pixel with zero
variance, whether masking is drawn or split (`pmmw.reflectance` runs this exact estimator: its
tests check R + T = 1 to 1e-12 and R = 1 for a rough perfect conductor). The
expected result is the multiple-scattering BSDF of the Smith microsurface with uncorrelated
masking (random walk on the microsurface): its first-order term is the classic
``f = F(wo.m) D(m) G1(wi) G1(wo) / (4 |wi.n| |wo.n|)`` for reflection (`shadowing` returns that
``G1 G1``) and Walter et al.'s (2007) transmission term with the same ``G1 G1``; higher orders
return the energy that single-scattering models lose. A smooth surface (no ``roughness:``) never
calls this module.

References: Optics Express 2016 (Ashikhmin-Shirley microfacets over layers, eq. 9); Stryjewski et al. 2009 (polarized
Ashikhmin model, eq. 3-7, 18-23); Murakowski 2014 sec. 2.2.6 (Blender gloss); B. G. Smith (1967);
Walter et al., EGSR 2007; Heitz, JCGT 3(2) 2014 and Heitz et al., SIGGRAPH 2016 (random walk);
Dupuy and Benyoub, HPG 2023 (spherical caps).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from pmmw.arrays import FloatArray
from pmmw.errors import UserError, UserErrors
from pmmw.jit import inline, njit
from pmmw.physics.vec import NORM_UNDERFLOW, cross, dot, unit

__all__ = [
    "GGX",
    "MAX_REHITS",
    "PARAMETERS",
    "REGISTRY",
    "AshikhminShirley",
    "Beckmann",
    "BlenderGloss",
    "BlinnPhong",
    "MicrofacetModel",
    "ashikhmin_pair",
    "blinn_phong_mean_cos",
    "local_frame",
    "make_model",
    "torrance_sparrow",
]

#: Re-hits of one child in a row after which the integrator ends it (emits its power at the
#: surface temperature). Each re-hit leaves with Smith's G1 of a direction that is usually far
#: from grazing: the mean chain is short, and no chain in the tests comes near 64.
MAX_REHITS = 64

# Rejection sampling (`_Microfacet._rejection_vndf`): rays whose acceptance probability is below
# _MIN_ACCEPT, or still rejected after _MAX_ROUNDS, take one weighted proposal instead. Expected
# rounds are 1 to 5 for rays arriving from above the macro surface.
_MIN_ACCEPT = 1e-4
_MAX_ROUNDS = 1 << 16
_BATCH = 8192  # candidates per numpy call once few rays remain
_TINY = 1e-300
_SQRT_PI = math.sqrt(math.pi)


@runtime_checkable
class MicrofacetModel(Protocol):
    """What the integrator and `pmmw brdf` need from a roughness model (see the module docstring)."""

    name: str

    def sample_normals(
        self, n_macro: FloatArray, tangent: FloatArray | None, wo: FloatArray, u1: FloatArray, u2: FloatArray
    ) -> tuple[FloatArray, FloatArray]: ...

    def shadowing(
        self, n_macro: FloatArray, m: FloatArray, wi: FloatArray, wo: FloatArray, tangent: FloatArray | None = None
    ) -> FloatArray: ...

    def masking(self, n_macro: FloatArray, tangent: FloatArray | None, w: FloatArray) -> FloatArray: ...

    def pdf(self, n_macro: FloatArray, tangent: FloatArray | None, wo: FloatArray, m: FloatArray) -> FloatArray: ...

    # `pmmw brdf --method analytic`'s quadratures (`pmmw.reflectance.analytic_model`)
    def D(self, n_macro: FloatArray, tangent: FloatArray | None, m: FloatArray) -> FloatArray: ...

    def projected_area(self, n_macro: FloatArray, tangent: FloatArray | None, w: FloatArray) -> FloatArray: ...

    def sample_dcos(
        self, n_macro: FloatArray, tangent: FloatArray | None, u1: FloatArray, u2: FloatArray
    ) -> tuple[FloatArray, FloatArray]: ...


# ----------------------------------------------------------------------------------------------
# Frames and small vector helpers
# ----------------------------------------------------------------------------------------------


def local_frame(
    n_macro: npt.ArrayLike, tangent: npt.ArrayLike, orientation: float = 0.0
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Orthonormal frame (x, y, z = n) with x the tangent rotated by ``orientation`` about n.

    Parameters
    ----------
    n_macro : ndarray, shape (N, 3), float64
        Unit macro normals.
    tangent : ndarray, shape (N, 3) or (3,), float64
        Anisotropy direction; its component along n is removed. Where it is (nearly) parallel
        to n, any perpendicular direction is used (only isotropic results are then meaningful).
    orientation : float
        Rotation of the anisotropy axes about n [rad].

    Returns
    -------
    x, y, z : ndarray, shape (N, 3), float64
    """
    z = np.asarray(n_macro, dtype=np.float64)
    t = np.broadcast_to(np.asarray(tangent, dtype=np.float64), z.shape)
    x = t - dot(t, z)[:, None] * z
    norm = np.linalg.norm(x, axis=1)
    bad = norm < 1e-9
    if np.any(bad):
        # any perpendicular: cross with the axis least aligned with n
        zb = z[bad]
        axis = np.zeros_like(zb)
        axis[np.arange(zb.shape[0]), np.argmin(np.abs(zb), axis=1)] = 1.0
        x[bad] = np.cross(axis, zb)
        norm = np.linalg.norm(x, axis=1)
    x = x / norm[:, None]
    y = cross(z, x)
    if orientation:
        c, s = math.cos(orientation), math.sin(orientation)
        x, y = c * x + s * y, -s * x + c * y
    return x, y, z


def _to_local(v, frame):
    x, y, z = frame
    if x.ndim == 1:
        return v @ np.stack([x, y, z], axis=1)
    return np.stack([dot(v, x), dot(v, y), dot(v, z)], axis=1)


def _to_world(v, frame):
    x, y, z = frame
    if x.ndim == 1:
        return v @ np.stack([x, y, z], axis=0)
    return v[:, 0:1] * x + v[:, 1:2] * y + v[:, 2:3] * z


# ----------------------------------------------------------------------------------------------
# Deterministic extra uniforms for rejection rounds
# ----------------------------------------------------------------------------------------------

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


def _splitmix64(x):
    x = x + _GOLDEN
    z = x
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return x, z ^ (z >> np.uint64(31))


def _hash_uniforms(u1, u2, round_no, count):
    """``count`` uniforms in [0, 1) per ray, a deterministic function of (u1, u2, round_no);
    ``round_no`` is an int or an int array of the rays' shape."""
    a = np.ascontiguousarray(u1, dtype=np.float64).view(np.uint64)
    b = np.ascontiguousarray(u2, dtype=np.float64).view(np.uint64)
    salt = np.broadcast_to(np.asarray(round_no, dtype=np.uint64), a.shape) * _MIX2  # array product: wraps
    state = a ^ ((b << np.uint64(29)) | (b >> np.uint64(35))) ^ salt
    state, _ = _splitmix64(state)
    out = []
    for _ in range(count):
        state, z = _splitmix64(state)
        out.append((z >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0))
    return out


# ----------------------------------------------------------------------------------------------
# Shared numerics in the local frame (z = macro normal)
# ----------------------------------------------------------------------------------------------


def _ggx_vndf_local(wo, ax, ay, u1, u2):
    """GGX visible normals by spherical caps (Dupuy and Benyoub 2023), any ``wo`` with |wo.z| < 1.

    In the stretched space (alpha = 1, D uniform over the upper hemisphere) the visible normals
    of ``v`` are the half vectors between ``v`` and directions uniform on the cap z >= -v.z.
    """
    v = unit(np.stack([ax * wo[:, 0], ay * wo[:, 1], wo[:, 2]], axis=1))
    phi = 2.0 * np.pi * u1
    z = (1.0 - u2) * (1.0 + v[:, 2]) - v[:, 2]
    sin_t = np.sqrt(np.clip(1.0 - z * z, 0.0, 1.0))
    h = np.stack([sin_t * np.cos(phi) + v[:, 0], sin_t * np.sin(phi) + v[:, 1], z + v[:, 2]], axis=1)
    m = unit(np.stack([ax * h[:, 0], ay * h[:, 1], np.maximum(h[:, 2], 0.0)], axis=1))
    degenerate = ~np.any(m != 0.0, axis=1)  # c = -v exactly (measure zero)
    if np.any(degenerate):
        m[degenerate] = (0.0, 0.0, 1.0)
    return m


def _slopes2(m, ax=1.0, ay=1.0):
    """``(m.x/ax)^2 + (m.y/ay)^2`` over ``m.z^2``: squared stretched slope (inf at m.z == 0)."""
    num = (m[:, 0] / ax) ** 2 + (m[:, 1] / ay) ** 2
    mz2 = m[:, 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(mz2 > 0.0, num / np.where(mz2 > 0.0, mz2, 1.0), np.inf)


def _directional_alpha2(w, ax, ay):
    """``alpha^2`` of an anisotropic GGX/Beckmann surface along the azimuth of local ``w``."""
    r2 = w[:, 0] ** 2 + w[:, 1] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        c2 = np.where(r2 > 0.0, w[:, 0] ** 2 / np.where(r2 > 0.0, r2, 1.0), 1.0)
    return ax * ax * c2 + ay * ay * (1.0 - c2)


def _ggx_d(m, ax, ay):
    """GGX distribution for local normals (0 at and below the horizon)."""
    cz = m[:, 2]
    t = _slopes2(m, ax, ay)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        val = 1.0 / (np.pi * ax * ay * cz**4 * (1.0 + t) ** 2)
    return np.where(cz > 0.0, np.nan_to_num(val, nan=0.0, posinf=0.0), 0.0)


def _ggx_a_up(c, s2, alpha2):
    """GGX projected area for w.z = c >= 0, sin^2 = s2, directional alpha^2."""
    return 0.5 * (c + np.sqrt(c * c + alpha2 * s2))


def _beckmann_a_up(c, s2, alpha2):
    """Beckmann projected area for c >= 0 (Smith, closed form)."""
    from scipy import special  # where used: not imported before a render's first ray

    sa = np.sqrt(alpha2 * s2)  # alpha sin(theta)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(sa > 0.0, c / np.where(sa > 0.0, sa, 1.0), np.inf)
        tail = np.where(sa > 0.0, sa * np.exp(-np.minimum(a * a, 745.0)) / (2.0 * _SQRT_PI), 0.0)
    return c * 0.5 * (1.0 + special.erf(a)) + tail


def _phong_a_up(e, c, s2):
    """Isotropic Ashikhmin-Shirley / Blinn-Phong projected area for c = cos(theta) >= 0.

    ``A = c (1 - I_x((e+2)/2, 1/2)/2) + K sin^(e+2)(theta)``, ``x = sin^2(theta)`` (module
    docstring); e may be an array.
    """
    from scipy import special

    e = np.asarray(e, dtype=np.float64)
    ib = special.betainc(0.5 * (e + 2.0), 0.5, np.clip(s2, 0.0, 1.0))
    log_k = np.log(e + 2.0) + special.betaln(0.5, 0.5 * (e + 3.0)) - np.log(2.0 * np.pi * (e + 1.0))
    with np.errstate(divide="ignore"):
        tail = np.exp(log_k + 0.5 * (e + 2.0) * np.log(s2))
    return c * (1.0 - 0.5 * ib) + tail


def _area_any(a_up_fn, w):
    """Projected area for any direction: ``A(w) = A(-w) + w.z`` gives the lower hemisphere."""
    flip = w[:, 2] < 0.0
    wu = w.copy()
    wu[flip, 2] = -wu[flip, 2]
    return a_up_fn(wu) + np.where(flip, w[:, 2], 0.0)


# ----------------------------------------------------------------------------------------------
# GGX and Beckmann per ray, compiled (the renderer's facet draw and masking test)
# ----------------------------------------------------------------------------------------------
# The same arithmetic as `local_frame`, `_ggx_vndf_local` and the projected areas above, written
# per ray in one pass (numba, cached on disk): these run once per rough interaction and re-hit.
# tests/physics/test_roughness.py checks them against the array code to rounding.

_jit = njit()


_inline = inline()

# compiled model codes (`smith_g1`); other models are evaluated by their array code
NOT_ROUGH, GGX_CODE, BECKMANN_CODE, OTHER_CODE = 0, 1, 2, 3


@_inline
def _frame1(z0, z1, z2, t0, t1, t2, orientation):
    """`local_frame` of one ray: x and y as two 3-tuples (z is the normal)."""
    tn = t0 * z0 + t1 * z1 + t2 * z2
    x0, x1, x2 = t0 - tn * z0, t1 - tn * z1, t2 - tn * z2
    norm = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    if norm < 1e-9:  # any perpendicular: the axis least aligned with n, crossed with n
        a0, a1, a2 = abs(z0), abs(z1), abs(z2)
        if a0 <= a1 and a0 <= a2:
            x0, x1, x2 = 0.0, -z2, z1
        elif a1 <= a2:
            x0, x1, x2 = z2, 0.0, -z0
        else:
            x0, x1, x2 = -z1, z0, 0.0
        norm = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    x0, x1, x2 = x0 / norm, x1 / norm, x2 / norm
    y0, y1, y2 = z1 * x2 - z2 * x1, z2 * x0 - z0 * x2, z0 * x1 - z1 * x0
    if orientation != 0.0:
        co, so = math.cos(orientation), math.sin(orientation)
        x0, x1, x2, y0, y1, y2 = (
            co * x0 + so * y0,
            co * x1 + so * y1,
            co * x2 + so * y2,
            -so * x0 + co * y0,
            -so * x1 + co * y1,
            -so * x2 + co * y2,
        )
    return (x0, x1, x2), (y0, y1, y2)


@_inline
def smith_g1(n, t, w, code, ax, ay, orientation):
    """Smith masking ``G1(w) = w.z / A(w)`` of one ray (3-tuples n, t, w: macro normal, tangent,
    direction) for GGX (``code`` `GGX_CODE`) or Beckmann, as `_Microfacet.masking` with
    `_ggx_a_up` / `_beckmann_a_up`; 0 below the macro surface."""
    c = w[0] * n[0] + w[1] * n[1] + w[2] * n[2]
    if not c > 0.0:
        return 0.0
    x, y = _frame1(n[0], n[1], n[2], t[0], t[1], t[2], orientation)
    wx = w[0] * x[0] + w[1] * x[1] + w[2] * x[2]
    wy = w[0] * y[0] + w[1] * y[1] + w[2] * y[2]
    r2 = wx * wx + wy * wy
    c2 = wx * wx / r2 if r2 > 0.0 else 1.0
    alpha2 = ax * ax * c2 + ay * ay * (1.0 - c2)
    if code == BECKMANN_CODE:
        sa = math.sqrt(alpha2 * r2)
        if sa > 0.0:
            a = c / sa
            area = c * 0.5 * (1.0 + math.erf(a)) + sa * math.exp(-min(a * a, 745.0)) / (2.0 * _SQRT_PI)
        else:
            area = c
    else:
        area = 0.5 * (c + math.sqrt(c * c + alpha2 * r2))
    return min(max(c / area, 0.0), 1.0)


@_inline
def ggx_draw1(n, t, wo, u1, u2, ax, ay, orientation):
    """`GGX.sample_normals` of one ray (3-tuples n, t, wo: macro normal, tangent, direction
    toward the viewer): the spherical-cap draw (`_ggx_vndf_local`) in the ray's `local_frame`.
    Returns the facet normal's three components and the draw's weight (1, or 0 where the facet
    faces away from wo: measure zero)."""
    x, y = _frame1(n[0], n[1], n[2], t[0], t[1], t[2], orientation)
    wx = wo[0] * x[0] + wo[1] * x[1] + wo[2] * x[2]
    wy = wo[0] * y[0] + wo[1] * y[1] + wo[2] * y[2]
    wz = wo[0] * n[0] + wo[1] * n[1] + wo[2] * n[2]
    vx, vy, vz = ax * wx, ay * wy, wz
    nv = math.sqrt(vx * vx + vy * vy + vz * vz)
    if nv > 0.0:
        vx, vy, vz = vx / nv, vy / nv, vz / nv
    phi = 2.0 * math.pi * u1
    zc = (1.0 - u2) * (1.0 + vz) - vz
    sin_t = math.sqrt(min(max(1.0 - zc * zc, 0.0), 1.0))
    mx, my, mz = ax * (sin_t * math.cos(phi) + vx), ay * (sin_t * math.sin(phi) + vy), max(zc + vz, 0.0)
    nm = math.sqrt(mx * mx + my * my + mz * mz)
    if nm < NORM_UNDERFLOW:  # the squares underflow: scaled first, as `vec.unit` does
        big = max(abs(mx), abs(my), abs(mz))
        if big > 0.0:
            mx, my, mz = mx / big, my / big, mz / big
            nm = math.sqrt(mx * mx + my * my + mz * mz)
    if nm <= 0.0:  # c = -v exactly (measure zero)
        mx, my, mz = 0.0, 0.0, 1.0
    else:
        mx, my, mz = mx / nm, my / nm, mz / nm
    w = 1.0 if mx * wx + my * wy + mz * wz > 0.0 else 0.0
    return (mx * x[0] + my * y[0] + mz * n[0], mx * x[1] + my * y[1] + mz * n[1], mx * x[2] + my * y[2] + mz * n[2], w)


@_jit
def _ggx_sample_rows(n, t, wo, u1, u2, ax, ay, orientation, m_out, w_out):
    """`ggx_draw1` of arrays of rays, shape (N, 3) and (N,), filled in ``m_out`` and ``w_out``."""
    for i in range(n.shape[0]):
        m_out[i, 0], m_out[i, 1], m_out[i, 2], w_out[i] = ggx_draw1(
            (n[i, 0], n[i, 1], n[i, 2]),
            (t[i, 0], t[i, 1], t[i, 2]),
            (wo[i, 0], wo[i, 1], wo[i, 2]),
            u1[i],
            u2[i],
            ax,
            ay,
            orientation,
        )


@_jit
def _smith_masking_rows(n, t, w, code, ax, ay, orientation, out):
    """`smith_g1` of arrays of rays, shape (N, 3) -> ``out`` (N,)."""
    for i in range(n.shape[0]):
        out[i] = smith_g1(
            (n[i, 0], n[i, 1], n[i, 2]),
            (t[i, 0], t[i, 1], t[i, 2]),
            (w[i, 0], w[i, 1], w[i, 2]),
            code,
            ax,
            ay,
            orientation,
        )


def _rows(n_macro, tangent, v):
    """Per-ray (N, 3) float64 arrays of macro normals and tangents (broadcast from (3,)) for
    the compiled routines, with ``v`` (N, 3) setting N; tangent None: world X."""
    v = np.ascontiguousarray(v, dtype=np.float64)

    def rows(a):  # writable and contiguous: the array types `kernels.warm` compiles for
        a = np.asarray(a, dtype=np.float64)
        return np.ascontiguousarray(a if a.shape == v.shape else np.broadcast_to(a, v.shape))

    return rows(n_macro), rows(np.array([1.0, 0.0, 0.0]) if tangent is None else tangent), v


# ----------------------------------------------------------------------------------------------
# Models
# ----------------------------------------------------------------------------------------------


class _Microfacet:
    """Common world-frame interface; subclasses supply local-frame numerics."""

    name = "microfacet"
    anisotropic = False
    code = OTHER_CODE  # masking by the array code (`smith_g1` covers GGX and Beckmann)

    def __init__(self, orientation_deg: float = 0.0) -> None:
        self.orientation = math.radians(float(orientation_deg))

    # -- local-frame hooks ----------------------------------------------------------------
    def _d_local(self, m):  # pragma: no cover - abstract
        raise NotImplementedError

    def _a_up_local(self, w):  # pragma: no cover - abstract
        raise NotImplementedError

    def _vndf_local(self, wo, u1, u2):  # pragma: no cover - abstract
        raise NotImplementedError

    def _dcos_local(self, u1, u2):  # pragma: no cover - abstract
        raise NotImplementedError

    # -- frame ------------------------------------------------------------------------------
    def _frame(self, n_macro, tangent):
        n_macro = np.asarray(n_macro, dtype=np.float64)
        if tangent is None:
            if self.anisotropic:
                raise ValueError(f"{self.name}: an anisotropic model needs the tangent")
            tangent = np.array([1.0, 0.0, 0.0])
        if n_macro.ndim == 1:  # one macro frame for all rays: build it once
            x, y, z = local_frame(
                n_macro[None, :], np.asarray(tangent, dtype=np.float64).reshape(1, 3), self.orientation
            )
            return x[0], y[0], z[0]
        return local_frame(n_macro, tangent, self.orientation)

    # -- public API (world frame) --------------------------------------------------------------
    def D(self, n_macro: FloatArray, tangent: FloatArray | None, m: FloatArray) -> FloatArray:
        """Normal distribution ``D(m)`` [1/sr], normalized as ``int D (m.n) dw = 1``.

        Parameters
        ----------
        n_macro, tangent : ndarray, shape (N, 3) or (3,), float64
            Unit macro normal and anisotropy tangent (one pair for all rays when (3,)).
        m : ndarray, shape (N, 3), float64
            Unit microfacet normals.

        Returns
        -------
        ndarray, shape (N,), float64 (0 where m.n <= 0)
        """
        frame = self._frame(n_macro, tangent)
        return self._d_local(_to_local(np.asarray(m, dtype=np.float64), frame))

    def projected_area(self, n_macro: FloatArray, tangent: FloatArray | None, w: FloatArray) -> FloatArray:
        """``A(w) = int (w.m)+ D(m) dw_m`` [-] for any unit ``w`` (also below the horizon).

        ``A(n) = 1``; ``A(w) - A(-w) = w.n``; Smith's masking is ``G1 = (w.n)/A(w)``.
        """
        frame = self._frame(n_macro, tangent)
        return _area_any(self._a_up_local, _to_local(np.asarray(w, dtype=np.float64), frame))

    def masking(self, n_macro: FloatArray, tangent: FloatArray | None, w: FloatArray) -> FloatArray:
        """Smith masking ``G1(w) = max(w.n, 0) / A(w)`` in [0, 1]: the probability that a ray
        leaving the surface along ``w`` (unit, shape (N, 3)) is not blocked by the microsurface;
        0 for directions on the wrong side of the macro surface."""
        frame = self._frame(n_macro, tangent)
        wl = _to_local(np.asarray(w, dtype=np.float64), frame)
        up = wl[:, 2] > 0.0
        out = np.zeros(wl.shape[0])
        if np.any(up):
            a = self._a_up_local(wl[up])
            out[up] = np.clip(wl[up, 2] / a, 0.0, 1.0)
        return out

    def shadowing(
        self, n_macro: FloatArray, m: FloatArray, wi: FloatArray, wo: FloatArray, tangent: FloatArray | None = None
    ) -> FloatArray:
        """Bidirectional shadowing-masking ``G2`` of the estimator: ``G1(wi) G1(wo)`` where both
        see the facet (``wi.m > 0`` and ``wo.m > 0``), else 0. Shapes (N, 3) -> (N,), in [0, 1]."""
        m = np.asarray(m, dtype=np.float64)
        g = self.masking(n_macro, tangent, wi) * self.masking(n_macro, tangent, wo)
        return np.where((dot(np.asarray(wi, float), m) > 0.0) & (dot(np.asarray(wo, float), m) > 0.0), g, 0.0)

    def pdf(self, n_macro: FloatArray, tangent: FloatArray | None, wo: FloatArray, m: FloatArray) -> FloatArray:
        """Density of `sample_normals`, the visible normals ``D_wo(m) = (wo.m)+ D(m)/A(wo)``
        [1/sr of m]."""
        frame = self._frame(n_macro, tangent)
        wl = _to_local(np.asarray(wo, dtype=np.float64), frame)
        ml = _to_local(np.asarray(m, dtype=np.float64), frame)
        a = _area_any(self._a_up_local, wl)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(a > 0.0, np.maximum(dot(wl, ml), 0.0) * self._d_local(ml) / np.where(a > 0.0, a, 1.0), 0.0)

    def sample_normals(
        self, n_macro: FloatArray, tangent: FloatArray | None, wo: FloatArray, u1: FloatArray, u2: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Draw microfacet normals visible from ``wo`` (exact; weight 1 but in the rare fallback).

        Parameters
        ----------
        n_macro : ndarray, shape (N, 3) or (3,), float64
            Unit macro normal on the side of the ray (one for all rays when (3,)).
        tangent : ndarray, shape (N, 3) or (3,), float64
            Anisotropy direction (perpendicular to n_macro; the orientation parameter rotates it).
        wo : ndarray, shape (N, 3), float64
            Unit direction toward where the ray comes from (``-d``). Usually ``wo.n > 0``; a ray
            masked by the microsurface re-hits it with ``wo.n < 0`` (module docstring, step 4).
        u1, u2 : ndarray, shape (N,), float64
            Uniforms in [0, 1).

        Returns
        -------
        m : ndarray, shape (N, 3), float64
            Unit microfacet normals distributed as ``D_wo(m)`` (`pdf`), with ``wo.m > 0``
            wherever the weight is > 0.
        weight : ndarray, shape (N,), float64
            Importance weight ``D_wo(m) / p(m)`` >= 0, finite, mean 1: 1.0 except for the rare
            weighted fallback of rejection sampling (module docstring, "Sampling"), 0.0 where no facet
            faces ``wo`` at all (``wo`` pointing straight into the surface from below, which
            the masking rule never produces).
        """
        frame = self._frame(n_macro, tangent)
        wl = _to_local(np.asarray(wo, dtype=np.float64), frame)
        u1 = np.asarray(u1, dtype=np.float64)
        u2 = np.asarray(u2, dtype=np.float64)
        ml, weight = self._vndf_local(wl, u1, u2)
        return _to_world(ml, frame), np.where(dot(ml, wl) > 0.0, weight, 0.0)

    def sample_dcos(
        self, n_macro: FloatArray, tangent: FloatArray | None, u1: FloatArray, u2: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Normals drawn from ``D(m) (m.n)`` (Optics Express 2016's sampling formula generalized), with
        that density [1/sr]; no visibility. Used for quadratures (`pmmw brdf --method analytic`)."""
        frame = self._frame(n_macro, tangent)
        ml = self._dcos_local(np.asarray(u1, dtype=np.float64), np.asarray(u2, dtype=np.float64))
        return _to_world(ml, frame), self._d_local(ml) * ml[:, 2]

    # -- rejection from GGX visible normals ----------------------------------------------------
    def _rejection_vndf(self, wo, u1, u2, ax, ay, log_accept, bound):
        """Exact visible normals by rejection from GGX(ax, ay) visible normals; weights.

        ``bound`` is K, the sup of D / D_GGX: a ray from ``wo`` is accepted with probability
        ``A(wo) / (K A_GGX(wo))``. Rays whose acceptance is below `_MIN_ACCEPT` (a masked ray
        re-hitting a smooth surface from well below its horizon, where hardly any facet faces
        it: the masking that sends rays there has a comparably tiny probability), or that are
        still rejected after `_MAX_ROUNDS`, take one fresh proposal with the importance weight
        ``D_wo(m) / D_wo^GGX(m)``, which keeps the estimator unbiased.
        """
        n = wo.shape[0]
        m = np.empty((n, 3))
        weight = np.ones(n)

        def area_ggx(w):
            return _area_any(
                lambda v: _ggx_a_up(v[:, 2], v[:, 0] ** 2 + v[:, 1] ** 2, _directional_alpha2(v, ax, ay)), w
            )

        def weighted(idx, v1, v2):
            cand = _ggx_vndf_local(wo[idx], ax, ay, v1, v2)
            a_t = _area_any(self._a_up_local, wo[idx])
            d_g = _ggx_d(cand, ax, ay)
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                w = self._d_local(cand) * area_ggx(wo[idx]) / (d_g * a_t)
            m[idx] = cand
            weight[idx] = np.where(np.isfinite(w) & (a_t > 0.0) & (d_g > 0.0), w, 0.0)

        pending = np.ones(n, dtype=bool)
        below = np.nonzero(wo[:, 2] < 0.0)[0]
        if below.size:
            with np.errstate(divide="ignore", invalid="ignore"):  # 0/0 at grazing: NaN is hopeless below
                p_acc = _area_any(self._a_up_local, wo[below]) / (bound * area_ggx(wo[below]))
            hopeless = below[~(p_acc >= _MIN_ACCEPT)]
            if hopeless.size:
                weighted(hopeless, u1[hopeless], u2[hopeless])
                pending[hopeless] = False
        idx = np.nonzero(pending)[0]
        cand = _ggx_vndf_local(wo[idx], ax, ay, u1[idx], u2[idx])
        (v,) = _hash_uniforms(u1[idx], u2[idx], 0, 1)
        ok = np.log(np.maximum(v, _TINY)) < log_accept(cand)
        m[idx[ok]] = cand[ok]
        pending[idx[ok]] = False
        # Candidate r >= 1 of a ray uses the uniforms hashed with salt r. When few rays remain,
        # several candidates per ray are tried at once and the first accepted one (lowest r) is
        # kept: the same sample as trying them one by one, in far fewer numpy calls.
        rnd = 1
        while rnd < _MAX_ROUNDS and np.any(pending):
            idx = np.nonzero(pending)[0]
            batch = int(min(_MAX_ROUNDS - rnd, max(1, _BATCH // idx.size)))
            rep = np.repeat(idx, batch)
            salt = rnd + np.tile(np.arange(batch, dtype=np.int64), idx.size)
            v1, v2, v3 = _hash_uniforms(u1[rep], u2[rep], salt, 3)
            cand = _ggx_vndf_local(wo[rep], ax, ay, v1, v2)
            ok = (np.log(np.maximum(v3, _TINY)) < log_accept(cand)).reshape(idx.size, batch)
            hit = ok.any(axis=1)
            first = np.argmax(ok, axis=1)
            m[idx[hit]] = cand.reshape(idx.size, batch, 3)[hit, first[hit]]
            pending[idx[hit]] = False
            rnd += batch
        if np.any(pending):
            idx = np.nonzero(pending)[0]
            v1, v2 = _hash_uniforms(u1[idx], u2[idx], _MAX_ROUNDS, 2)
            weighted(idx, v1, v2)
        return m, weight

    def __repr__(self) -> str:
        params = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({params})"

    def params(self) -> dict[str, float]:
        return {}


class _ASProjectedArea:
    """Exact projected area of an anisotropic Ashikhmin-Shirley surface, tabulated as a
    correction to the isotropic closed form at the effective exponent (module docstring).

    ``A(w) = N int_0^2pi J(e(phi), cos th_w, sin th_w cos(phi - phi_w)) dphi`` with the inner
    integral ``J(e, a, b) = int_0^pi/2 cos^e t (a cos t + b sin t)+ sin t dt`` in closed form
    (incomplete beta) and Gauss-Legendre in azimuth on the pieces where ``b`` has one sign.
    """

    _N_COS = 129
    _N_PHI = 49
    _N_QUAD = 48

    def __init__(self, ex: float, ey: float) -> None:
        self.ex, self.ey = float(ex), float(ey)
        t = np.linspace(0.0, 1.0, self._N_COS)
        self.cos_nodes = np.sin(0.5 * np.pi * t) ** 2  # dense near grazing (cos -> 0)
        self.phi_nodes = np.linspace(0.0, 0.5 * np.pi, self._N_PHI)
        c, p = np.meshgrid(self.cos_nodes, self.phi_nodes, indexing="ij")
        c, p = c.ravel(), p.ravel()
        s2 = 1.0 - c * c
        exact = self.exact(c, p)
        approx = _phong_a_up(self.effective_exponent(np.cos(p) ** 2, np.sin(p) ** 2), c, s2)
        self.ratio = (exact / approx).reshape(self._N_COS, self._N_PHI)

    def effective_exponent(self, cos2: FloatArray, sin2: FloatArray) -> FloatArray:
        """``1/(e+2) = cos^2 phi/(ex+2) + sin^2 phi/(ey+2)`` (exact along the axes when ex == ey)."""
        return 1.0 / (cos2 / (self.ex + 2.0) + sin2 / (self.ey + 2.0)) - 2.0

    def exact(self, c: FloatArray, phi_w: FloatArray) -> FloatArray:
        """Exact A for cos(theta_w) = c >= 0 and azimuth phi_w, arrays of one shape (slow).

        The azimuth integral runs over ``psi`` with ``tan(phi) = k tan(psi)``,
        ``k = sqrt((ex+2)/(ey+2))`` (the sampling map of Optics Express 2016 with +2): then
        ``dphi = (e(phi)+2)/sqrt((ex+2)(ey+2)) dpsi`` cancels the ``1/(e+2)`` peak of J where
        the exponent is small, and Gauss-Legendre converges to 1e-6 with 48 nodes per piece
        even for ex/ey = 1e5.
        """
        from scipy import special

        x, wq = np.polynomial.legendre.leggauss(self._N_QUAD)
        s = np.sqrt(np.clip(1.0 - c * c, 0.0, 1.0))
        root = math.sqrt((self.ex + 2.0) * (self.ey + 2.0))
        k = math.sqrt((self.ex + 2.0) / (self.ey + 2.0))
        total = np.zeros_like(c)
        for lo in (-0.5 * np.pi, 0.5 * np.pi):  # b >= 0 on the first piece, b <= 0 on the second
            p0 = phi_w + lo
            q0 = np.arctan2(np.sin(p0) / k, np.cos(p0))
            q0 = q0 + 2.0 * np.pi * np.round((p0 - q0) / (2.0 * np.pi))  # the branch of p0
            psi = q0[:, None] + 0.5 * np.pi * (x[None, :] + 1.0)
            phi = np.arctan2(k * np.sin(psi), np.cos(psi))
            e = self.ex * np.cos(phi) ** 2 + self.ey * np.sin(phi) ** 2
            a = c[:, None]
            b = s[:, None] * np.cos(phi - phi_w[:, None])
            half_b = 0.5 * np.exp(special.betaln(1.5, 0.5 * (e + 1.0)))
            if lo < 0.0:
                j = a / (e + 2.0) + np.maximum(b, 0.0) * half_b
            else:
                bb = np.maximum(-b, 0.0)
                r2 = a * a + bb * bb
                with np.errstate(divide="ignore", invalid="ignore"):
                    cos2c = np.where(r2 > 0.0, bb * bb / np.where(r2 > 0.0, r2, 1.0), 0.0)  # cos^2 theta_c
                sin2c = 1.0 - cos2c
                with np.errstate(divide="ignore"):
                    pow_c = np.exp(0.5 * (e + 2.0) * np.log(cos2c))
                j = a * (1.0 - pow_c) / (e + 2.0) - bb * half_b * special.betainc(1.5, 0.5 * (e + 1.0), sin2c)
                j = np.maximum(j, 0.0)
            dphi = (e + 2.0) / root
            total += (j * dphi * (0.5 * np.pi) * wq[None, :]).sum(axis=1)
        return root / (2.0 * math.pi) * total

    def __call__(self, w: FloatArray) -> FloatArray:
        """A for local directions with w.z >= 0, shape (N, 3)."""
        c = w[:, 2]
        r2 = w[:, 0] ** 2 + w[:, 1] ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            cos2 = np.where(r2 > 0.0, w[:, 0] ** 2 / np.where(r2 > 0.0, r2, 1.0), 1.0)
        sin2 = 1.0 - cos2
        approx = _phong_a_up(self.effective_exponent(cos2, sin2), c, r2)
        # bilinear interpolation of the correction in (cos theta, phi folded into [0, pi/2])
        phi = np.arctan2(np.abs(w[:, 1]), np.abs(w[:, 0]))
        ic = np.clip(np.searchsorted(self.cos_nodes, c) - 1, 0, self._N_COS - 2)
        c0, c1 = self.cos_nodes[ic], self.cos_nodes[ic + 1]
        tc = np.clip((c - c0) / (c1 - c0), 0.0, 1.0)
        dphi = self.phi_nodes[1] - self.phi_nodes[0]
        ip = np.clip((phi / dphi).astype(np.int64), 0, self._N_PHI - 2)
        tp = np.clip(phi / dphi - ip, 0.0, 1.0)
        r = self.ratio
        corr = (
            (1 - tc) * (1 - tp) * r[ic, ip]
            + tc * (1 - tp) * r[ic + 1, ip]
            + (1 - tc) * tp * r[ic, ip + 1]
            + tc * tp * r[ic + 1, ip + 1]
        )
        return approx * corr


@functools.lru_cache(maxsize=64)
def _area_table(ex, ey):
    return _ASProjectedArea(ex, ey)


class AshikhminShirley(_Microfacet):
    """Anisotropic Ashikhmin-Shirley distribution (Optics Express 2016 eq. 9), exponents ``ex``, ``ey`` >= 0."""

    name = "ashikhmin_shirley"

    def __init__(self, ex: float, ey: float, orientation_deg: float = 0.0) -> None:
        super().__init__(orientation_deg)
        self.ex, self.ey = float(ex), float(ey)
        if not (self.ex >= 0.0 and self.ey >= 0.0 and math.isfinite(self.ex) and math.isfinite(self.ey)):
            raise ValueError(f"exponents must be finite and >= 0, got ex={ex!r}, ey={ey!r}")
        self.anisotropic = self.ex != self.ey
        self._log_norm = 0.5 * (math.log(self.ex + 2.0) + math.log(self.ey + 2.0)) - math.log(2.0 * math.pi)
        self._area_table = _area_table(self.ex, self.ey) if self.anisotropic else None
        self._setup_proposal()

    def params(self) -> dict[str, float]:
        return {"ex": self.ex, "ey": self.ey, "orientation_deg": math.degrees(self.orientation)}

    def _setup_proposal(self):
        # GGX proposal with 1/alpha_x^2 = (ex+4)/gamma, 1/alpha_y^2 = (ey+4)/gamma: along every
        # azimuth its slope density is the isotropic GGX of alpha^2 = gamma/(e(phi)+4), so the
        # ratio D_AS/D_GGX = C h(t, e(phi)), h = (1 + t (e+4)/gamma)^2 (1+t)^-(e+4)/2, whose sup
        # over t is 1 for gamma >= 4 and h*(e) at t = (4-gamma)/e otherwise; h* decreases with e,
        # so the bound is at the smaller exponent. gamma is chosen to minimize the bound.
        emin = min(self.ex, self.ey)
        best: tuple[float, float, float] | None = None
        for gamma in np.linspace(1.0, 4.0, 301):
            log_h = self._log_hstar(emin, gamma)
            log_k = (
                self._log_norm
                + math.log(math.pi)
                + math.log(gamma)
                - 0.5 * (math.log(self.ex + 4.0) + math.log(self.ey + 4.0))
                + log_h
            )
            if best is None or log_k < best[0]:
                best = (log_k, gamma, log_h)
        assert best is not None  # the loop runs 301 times
        _, self._gamma, self._log_hsup = best
        self._ax = math.sqrt(self._gamma / (self.ex + 4.0))
        self._ay = math.sqrt(self._gamma / (self.ey + 4.0))
        self.proposal_bound = math.exp(best[0])  # K: acceptance at normal incidence is 1/K

    @staticmethod
    def _log_hstar(e, gamma):
        if gamma >= 4.0:
            return 0.0
        if e < 1e-9:  # the e -> 0 limit; h* decreases with e, so this only raises the bound
            return 2.0 * math.log(4.0 / gamma)
        return 2.0 * math.log1p((4.0 - gamma) * (e + 4.0) / (gamma * e)) - 0.5 * (e + 4.0) * math.log1p(
            (4.0 - gamma) / e
        )

    def _exponent(self, v):
        """e(phi) of Optics Express 2016 eq. 9 for local vectors (any length); ex where v is along z."""
        r2 = v[:, 0] ** 2 + v[:, 1] ** 2
        if not self.anisotropic:
            return np.full(v.shape[0], self.ex)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(
                r2 > 0.0, (self.ex * v[:, 0] ** 2 + self.ey * v[:, 1] ** 2) / np.where(r2 > 0.0, r2, 1.0), self.ex
            )

    def _d_local(self, m):
        cz = m[:, 2]
        e = self._exponent(m)
        with np.errstate(divide="ignore"):
            log_c = np.log(np.maximum(cz, 0.0))
        # e = 0 and cz = 0: cos^0 = 1 on the horizon (measure zero); keep it finite
        val = np.exp(self._log_norm + np.where(e > 0.0, e * log_c, 0.0))
        return np.where(cz > 0.0, val, 0.0)

    def _a_up_local(self, w):
        if self._area_table is not None:
            return self._area_table(w)
        s2 = w[:, 0] ** 2 + w[:, 1] ** 2
        return _phong_a_up(self.ex, w[:, 2], s2)

    def _log_accept(self, m):
        e = self._exponent(m)
        t = _slopes2(m)
        g = self._gamma
        big = t > 1e150
        tt = np.where(big, 1.0, t)
        small_form = 2.0 * np.log1p(tt * (e + 4.0) / g) - 0.5 * (e + 4.0) * np.log1p(tt)
        with np.errstate(divide="ignore", invalid="ignore"):
            lt = np.log(np.where(big, t, 1.0))
            # t -> inf: 2 log(t (e+4)/g) - (e+4)/2 log t (-inf for e > 0)
            big_form = 2.0 * (lt + np.log((e + 4.0) / g)) - 0.5 * (e + 4.0) * lt
        return np.where(big, big_form, small_form) - self._log_hsup

    def _vndf_local(self, wo, u1, u2):
        if self.ex == 0.0 and self.ey == 0.0:  # D = 1/pi is GGX with alpha = 1
            return _ggx_vndf_local(wo, 1.0, 1.0, u1, u2), np.ones(wo.shape[0])
        return self._rejection_vndf(wo, u1, u2, self._ax, self._ay, self._log_accept, self.proposal_bound)

    def _dcos_local(self, u1, u2):
        # azimuth density 1/(e(phi)+2): tan phi = sqrt((ex+2)/(ey+2)) tan(pi u/2) per quadrant
        # (Optics Express 2016's formula with +2 for the cosine weight), cos theta = u2^(1/(e+2))
        q = np.floor(4.0 * u1)
        frac = 4.0 * u1 - q
        base = np.arctan(math.sqrt((self.ex + 2.0) / (self.ey + 2.0)) * np.tan(0.5 * np.pi * frac))
        phi = np.select([q == 0, q == 1, q == 2], [base, np.pi - base, np.pi + base], 2.0 * np.pi - base)
        e = self.ex * np.cos(phi) ** 2 + self.ey * np.sin(phi) ** 2
        cz = np.exp(np.log(np.maximum(u2, _TINY)) / (e + 2.0))
        sz = np.sqrt(np.clip(1.0 - cz * cz, 0.0, 1.0))
        return np.stack([sz * np.cos(phi), sz * np.sin(phi), cz], axis=1)


class BlinnPhong(AshikhminShirley):
    """Blinn-Phong distribution of Stryjewski et al. 2009 eq. 3 with exponent ``m`` >= 0 (isotropic:
    ``ashikhmin_shirley`` with ex = ey = m; 0 to 1e6 and beyond)."""

    name = "blinn_phong"

    def __init__(self, m: float) -> None:
        super().__init__(m, m, 0.0)
        self.m = float(m)

    def params(self) -> dict[str, float]:
        return {"m": self.m}

    def mean_cos(self, cos_theta: npt.ArrayLike) -> FloatArray:
        """Stryjewski et al. 2009 eq. 18: ``<k.h>+`` over ``rho(h) = (m+1)/(2 pi) cos^m`` (`blinn_phong_mean_cos`)."""
        return blinn_phong_mean_cos(self.m, cos_theta)


def blinn_phong_mean_cos(m: npt.ArrayLike, cos_theta: npt.ArrayLike) -> FloatArray:
    """Stryjewski et al. 2009 eq. 18, ``<k.h>+ = int rho(h) (k.h)+ dw_h`` with ``rho = (m+1)/(2 pi) cos^m``.

    Stable replacement of Stryjewski et al. 2009 eq. 19-23 (module docstring): ``(m+1)/(m+2) A(theta)``.

    Parameters
    ----------
    m : float or ndarray
        Blinn-Phong exponent, >= 0 (0 to 1e6 and beyond).
    cos_theta : float or ndarray
        Cosine of the angle between k and the macro normal, in [-1, 1].

    Returns
    -------
    ndarray, float64
        Finite, in [0, 1]; ``(m+1)/(m+2)`` at ``cos_theta = 1``.
    """
    m = np.asarray(m, dtype=np.float64)
    c = np.asarray(cos_theta, dtype=np.float64)
    m, c = np.broadcast_arrays(m, c)
    ca = np.abs(c)
    s2 = np.clip((1.0 - ca) * (1.0 + ca), 0.0, 1.0)
    a = _phong_a_up(m, ca, s2) + np.minimum(c, 0.0)
    return (m + 1.0) / (m + 2.0) * a


class GGX(_Microfacet):
    """GGX / Trowbridge-Reitz distribution (Walter et al. 2007; as in Blender, Mitsuba and pbrt),
    roughness ``alpha`` (or ``alpha_x``, ``alpha_y``) > 0."""

    name = "ggx"
    code = GGX_CODE  # compiled masking (`smith_g1`)

    def __init__(
        self,
        alpha: float | None = None,
        alpha_x: float | None = None,
        alpha_y: float | None = None,
        orientation_deg: float = 0.0,
    ) -> None:
        super().__init__(orientation_deg)
        if alpha is not None:
            alpha_x = alpha_y = alpha
        if alpha_x is None or alpha_y is None:
            raise ValueError("give alpha, or both alpha_x and alpha_y")
        self.ax, self.ay = float(alpha_x), float(alpha_y)
        if not (self.ax > 0.0 and self.ay > 0.0 and math.isfinite(self.ax) and math.isfinite(self.ay)):
            raise ValueError(f"alpha must be finite and > 0, got {alpha_x!r}, {alpha_y!r}")
        self.anisotropic = self.ax != self.ay

    def params(self) -> dict[str, float]:
        if self.anisotropic:
            return {"alpha_x": self.ax, "alpha_y": self.ay, "orientation_deg": math.degrees(self.orientation)}
        return {"alpha": self.ax}

    def _alpha2(self, w):
        return _directional_alpha2(w, self.ax, self.ay), w[:, 0] ** 2 + w[:, 1] ** 2

    def _d_local(self, m):
        return _ggx_d(m, self.ax, self.ay)

    def _a_up_local(self, w):
        alpha2, s2 = self._alpha2(w)
        return _ggx_a_up(w[:, 2], s2, alpha2)

    def _vndf_local(self, wo, u1, u2):
        return _ggx_vndf_local(wo, self.ax, self.ay, u1, u2), np.ones(wo.shape[0])

    def sample_normals(
        self, n_macro: FloatArray, tangent: FloatArray | None, wo: FloatArray, u1: FloatArray, u2: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        # the compiled per-ray draw (the same arithmetic as the array code of the base class)
        if self.anisotropic and tangent is None:
            raise ValueError(f"{self.name}: an anisotropic model needs the tangent")
        n, t, wo = _rows(n_macro, tangent, wo)
        m, weight = np.empty_like(wo), np.empty(wo.shape[0])
        _ggx_sample_rows(
            n,
            t,
            wo,
            np.ascontiguousarray(u1, dtype=np.float64),
            np.ascontiguousarray(u2, dtype=np.float64),
            self.ax,
            self.ay,
            self.orientation,
            m,
            weight,
        )
        return m, weight

    def masking(self, n_macro: FloatArray, tangent: FloatArray | None, w: FloatArray) -> FloatArray:
        if self.anisotropic and tangent is None:
            raise ValueError(f"{self.name}: an anisotropic model needs the tangent")
        n, t, w = _rows(n_macro, tangent, w)
        out = np.empty(w.shape[0])
        _smith_masking_rows(n, t, w, self.code, self.ax, self.ay, self.orientation, out)
        return out

    def _dcos_local(self, u1, u2):
        # tan^2 theta = alpha_phi^2 u/(1-u); tan phi = (ay/ax) tan(2 pi u1)
        phi = np.arctan2(self.ay * np.sin(2.0 * np.pi * u1), self.ax * np.cos(2.0 * np.pi * u1))
        a2 = 1.0 / (np.cos(phi) ** 2 / self.ax**2 + np.sin(phi) ** 2 / self.ay**2)
        t2 = a2 * u2 / np.maximum(1.0 - u2, _TINY)
        cz = 1.0 / np.sqrt(1.0 + t2)
        sz = np.sqrt(np.clip(1.0 - cz * cz, 0.0, 1.0))
        return np.stack([sz * np.cos(phi), sz * np.sin(phi), cz], axis=1)


class Beckmann(GGX):
    """Beckmann distribution, roughness ``alpha`` (RMS slope times sqrt 2) or ``alpha_x``, ``alpha_y``."""

    name = "beckmann"
    code = BECKMANN_CODE

    def _d_local(self, m):
        cz = m[:, 2]
        t = _slopes2(m, self.ax, self.ay)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            val = np.exp(-np.minimum(t, 745.0)) / (np.pi * self.ax * self.ay * cz**4)
        return np.where((cz > 0.0) & (t < 745.0), np.nan_to_num(val, nan=0.0, posinf=0.0), 0.0)

    def _a_up_local(self, w):
        alpha2, s2 = self._alpha2(w)
        return _beckmann_a_up(w[:, 2], s2, alpha2)

    def _log_accept(self, m):
        # proposal GGX with the same alphas: D_B/D_GGX = e^-s (1+s)^2 <= 4/e, max at s = 1
        s = _slopes2(m, self.ax, self.ay)
        big = s > 1e6
        ss = np.where(big, 1.0, s)
        return np.where(big, -np.inf, 1.0 - ss + 2.0 * np.log1p(ss) - math.log(4.0))

    def _vndf_local(self, wo, u1, u2):
        return self._rejection_vndf(wo, u1, u2, self.ax, self.ay, self._log_accept, 4.0 / math.e)

    def sample_normals(
        self, n_macro: FloatArray, tangent: FloatArray | None, wo: FloatArray, u1: FloatArray, u2: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        return _Microfacet.sample_normals(self, n_macro, tangent, wo, u1, u2)  # by rejection (array code)

    def _dcos_local(self, u1, u2):
        phi = np.arctan2(self.ay * np.sin(2.0 * np.pi * u1), self.ax * np.cos(2.0 * np.pi * u1))
        a2 = 1.0 / (np.cos(phi) ** 2 / self.ax**2 + np.sin(phi) ** 2 / self.ay**2)
        t2 = -a2 * np.log(np.maximum(1.0 - u2, _TINY))
        cz = 1.0 / np.sqrt(1.0 + t2)
        sz = np.sqrt(np.clip(1.0 - cz * cz, 0.0, 1.0))
        return np.stack([sz * np.cos(phi), sz * np.sin(phi), cz], axis=1)


class BlenderGloss(_Microfacet):
    """Murakowski 2014 sec. 2.2.6: Blender's gloss perturbation, ``gloss`` g in [0, 1] (1 = smooth),
    for the thesis's scenes."""

    name = "blender_gloss"

    def __init__(self, gloss: float) -> None:
        super().__init__(0.0)
        self.gloss = float(gloss)
        if not 0.0 <= self.gloss <= 1.0:
            raise ValueError(f"gloss must lie in [0, 1], got {gloss!r}")
        self.L = (1.0 - self.gloss) ** 3

    def params(self) -> dict[str, float]:
        return {"gloss": self.gloss}

    def _perturbation(self, u1, u2):
        # r = sqrt(1 - b^(2L)) = tan(theta_m) <= 1 (Blender's QMC_samplePhong)
        phi = 2.0 * np.pi * u1
        if self.L == 0.0:
            r = np.zeros_like(u2)
        else:
            r = np.sqrt(np.clip(-np.expm1(2.0 * self.L * np.log(np.maximum(u2, _TINY))), 0.0, 1.0))
        return r * np.cos(phi), r * np.sin(phi)

    def _literal_pdf_local(self, m):
        """Solid-angle density of the recipe: (1 - tan^2)^(1/(2L) - 1) / (2 pi L cos^3), theta < 45 deg."""
        cz = m[:, 2]
        t2 = _slopes2(m)
        if self.L == 0.0:
            return np.zeros(m.shape[0])  # a delta at n
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            val = np.exp((0.5 / self.L - 1.0) * np.log1p(-np.minimum(t2, 1.0))) / (2.0 * np.pi * self.L * cz**3)
        return np.where((cz > 0.0) & (t2 < 1.0), np.nan_to_num(val, nan=0.0, posinf=0.0), 0.0)

    def _d_local(self, m):
        # the recipe's density per projected area, normalized as a distribution would be
        p = self._literal_pdf_local(m)
        return p / self._mean_cos()

    def _mean_cos(self):
        if not hasattr(self, "_mc"):
            u, w = np.polynomial.legendre.leggauss(200)
            b = 0.5 * (u + 1.0)
            r2 = -np.expm1(2.0 * self.L * np.log(b)) if self.L > 0.0 else np.zeros_like(b)
            self._mc = float(0.5 * np.sum(w / np.sqrt(1.0 + r2)))  # E[cos theta_m] = E[1/sqrt(1+r^2)]
        return self._mc

    def _sample(self, wo, u1, u2):
        px, py = self._perturbation(u1, u2)
        m = unit(np.stack([px, py, np.ones_like(px)], axis=1))
        back = dot(m, wo) <= 0.0
        if np.any(back):
            m[back] = unit(np.stack([-px[back], -py[back], np.ones(int(back.sum()))], axis=1))
        return m

    def sample_normals(
        self, n_macro: FloatArray, tangent: FloatArray | None, wo: FloatArray, u1: FloatArray, u2: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        frame = self._frame(n_macro, tangent)
        wl = _to_local(np.asarray(wo, dtype=np.float64), frame)
        ml = self._sample(wl, np.asarray(u1, dtype=np.float64), np.asarray(u2, dtype=np.float64))
        return _to_world(ml, frame), (dot(ml, wl) > 0.0).astype(np.float64)

    def masking(self, n_macro: FloatArray, tangent: FloatArray | None, w: FloatArray) -> FloatArray:
        """No masking in the thesis's recipe: 1 above the macro surface, 0 on the wrong side."""
        w = np.asarray(w, dtype=np.float64)
        n = np.broadcast_to(np.asarray(n_macro, dtype=np.float64), w.shape)
        return (dot(w, n) > 0.0).astype(np.float64)

    def projected_area(self, n_macro: FloatArray, tangent: FloatArray | None, w: FloatArray) -> FloatArray:
        w = np.asarray(w, dtype=np.float64)
        return np.maximum(dot(w, np.broadcast_to(np.asarray(n_macro, dtype=np.float64), w.shape)), 0.0)

    def pdf(self, n_macro: FloatArray, tangent: FloatArray | None, wo: FloatArray, m: FloatArray) -> FloatArray:
        """Density of the literal recipe with the mirror replacement of back-facing draws."""
        frame = self._frame(n_macro, tangent)
        wl = _to_local(np.asarray(wo, dtype=np.float64), frame)
        ml = _to_local(np.asarray(m, dtype=np.float64), frame)
        p = self._literal_pdf_local(ml)
        mirror = ml * np.array([-1.0, -1.0, 1.0])
        factor = 1.0 + (dot(mirror, wl) <= 0.0)
        return np.where(dot(ml, wl) > 0.0, p * factor, 0.0)

    def _dcos_local(self, u1, u2):
        raise NotImplementedError("blender_gloss has no D(m) cos sampler")

    def sample_dcos(
        self, n_macro: FloatArray, tangent: FloatArray | None, u1: FloatArray, u2: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        raise NotImplementedError("blender_gloss is not a microfacet distribution (no analytic BRDF)")


# ----------------------------------------------------------------------------------------------
# Bidirectional shadowing forms used by the analytic BRDF
# ----------------------------------------------------------------------------------------------


def torrance_sparrow(n_macro: FloatArray, m: FloatArray, wi: FloatArray, wo: FloatArray) -> FloatArray:
    """V-groove shadowing of Torrance and Sparrow (1967), as SCATMECH's
    ``Torrance_Sparrow_Shadow_Function``: ``min(1, 2 (n.m)(n.wi)/(wi.m), 2 (n.m)(n.wo)/(wo.m))``.

    Parameters
    ----------
    n_macro, m, wi, wo : ndarray, shape (N, 3), float64
        Unit vectors; ``m`` the half vector of a reflection.

    Returns
    -------
    ndarray, shape (N,), float64 in [0, 1]
    """
    nm = dot(n_macro, m)
    wim, wom = dot(wi, m), dot(wo, m)
    with np.errstate(divide="ignore", invalid="ignore"):
        gi = np.where(wim > 0.0, 2.0 * nm * dot(n_macro, wi) / np.where(wim > 0.0, wim, 1.0), 0.0)
        go = np.where(wom > 0.0, 2.0 * nm * dot(n_macro, wo) / np.where(wom > 0.0, wom, 1.0), 0.0)
    return np.clip(np.minimum(1.0, np.minimum(gi, go)), 0.0, 1.0)


def ashikhmin_pair(
    g1_i: FloatArray, g1_o: FloatArray, n_macro: FloatArray, wi: FloatArray, wo: FloatArray
) -> FloatArray:
    """Stryjewski et al. 2009 eq. 6: ``(1 - f) G1(wi) G1(wo) + f min(G1(wi), G1(wo))`` with ``f = cos(phi/2)``,
    phi the angle between the projections of wi and wo on the macro surface (f = 1 in
    backscatter, 0 in the forward specular plane).

    Parameters
    ----------
    g1_i, g1_o : ndarray, shape (N,)
        Smith masking of the two directions.
    n_macro, wi, wo : ndarray, shape (N, 3)

    Returns
    -------
    ndarray, shape (N,), float64 in [0, 1]
    """
    pi_ = wi - dot(wi, n_macro)[:, None] * n_macro
    po = wo - dot(wo, n_macro)[:, None] * n_macro
    ni, no = np.linalg.norm(pi_, axis=1), np.linalg.norm(po, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cphi = np.where((ni > 0) & (no > 0), dot(pi_, po) / np.where((ni > 0) & (no > 0), ni * no, 1.0), 1.0)
    f = np.sqrt(np.clip(0.5 * (1.0 + cphi), 0.0, 1.0))  # cos(phi/2)
    return (1.0 - f) * g1_i * g1_o + f * np.minimum(g1_i, g1_o)


# ----------------------------------------------------------------------------------------------
# Registry
# ----------------------------------------------------------------------------------------------

#: Model name -> constructor (keyword parameters as in `PARAMETERS`).
REGISTRY: dict[str, Callable[..., MicrofacetModel]] = {
    "ashikhmin_shirley": AshikhminShirley,
    "blinn_phong": BlinnPhong,
    "ggx": GGX,
    "beckmann": Beckmann,
    "blender_gloss": BlenderGloss,
}

# name -> {parameter: (lower bound, inclusive?, upper bound or None, default or _REQUIRED, what)}
_REQUIRED = object()
_EXP = (0.0, True, 1e12, _REQUIRED, "an exponent >= 0 (larger is smoother)")
_ALPHA = (0.0, False, 1e6, None, "a roughness > 0 (RMS slope scale; smaller is smoother)")
_ORIENT = (-1e6, True, 1e6, 0.0, "the anisotropy orientation about the normal [deg]")
PARAMETERS: dict[str, dict[str, tuple]] = {
    "ashikhmin_shirley": {"ex": _EXP, "ey": _EXP, "orientation_deg": _ORIENT},
    "blinn_phong": {"m": _EXP},
    "ggx": {"alpha": _ALPHA, "alpha_x": _ALPHA, "alpha_y": _ALPHA, "orientation_deg": _ORIENT},
    "beckmann": {"alpha": _ALPHA, "alpha_x": _ALPHA, "alpha_y": _ALPHA, "orientation_deg": _ORIENT},
    "blender_gloss": {"gloss": (0.0, True, 1.0, _REQUIRED, "a gloss in [0, 1] (1 = mirror)")},
}


def _join(key, sub):
    return f"{key}.{sub}" if key else sub


def make_model(spec: object, *, file: str | Path | None = None, key: str | None = None) -> MicrofacetModel:
    """Build a roughness model from its YAML record.

    Parameters
    ----------
    spec : mapping
        ``{model: NAME, PARAM: value, ...}``, e.g. ``{model: ashikhmin_shirley, ex: 15, ey: 15,
        orientation_deg: 0}``, ``{model: blinn_phong, m: 1e3}``, ``{model: ggx, alpha: 0.3}``,
        ``{model: beckmann, alpha_x: 0.2, alpha_y: 0.4}``, ``{model: blender_gloss, gloss: 0.8}``.
    file : str or Path, optional
        The file the record comes from (for error messages).
    key : str, optional
        Dotted key path of the record, e.g. ``materials.sand.roughness``.

    Returns
    -------
    MicrofacetModel

    Raises
    ------
    UserError or UserErrors
        Not a mapping; no or unknown ``model`` (the message lists the known ones); unknown
        parameter names, missing or non-numeric values, values out of range (each names its key
        path); ``alpha`` given together with ``alpha_x``/``alpha_y``.
    """
    if not isinstance(spec, Mapping):
        raise UserError(
            f"a roughness entry is a mapping like {{model: ashikhmin_shirley, ex: 15, ey: 15}}, got {spec!r}",
            file=file,
            key=key,
        )
    known = ", ".join(REGISTRY)
    name = spec.get("model")
    if name is None:
        raise UserError(f"missing `model:`; known roughness models: {known}", file=file, key=_join(key, "model"))
    if not isinstance(name, str) or name not in REGISTRY:
        raise UserError(f"unknown roughness model {name!r}; known: {known}", file=file, key=_join(key, "model"))
    table = PARAMETERS[name]
    errors: list[UserError] = []
    values: dict[str, float] = {}
    for pkey, raw in spec.items():
        if pkey == "model":
            continue
        if pkey not in table:
            errors.append(
                UserError(
                    f"unknown parameter {pkey!r} for roughness model {name}; expected: {', '.join(table)}",
                    file=file,
                    key=_join(key, str(pkey)),
                )
            )
            continue
        lo, lo_incl, hi, _default, what = table[pkey]
        if isinstance(raw, bool) or not isinstance(raw, (int, float)):
            errors.append(UserError(f"expected a number ({what}), got {raw!r}", file=file, key=_join(key, pkey)))
            continue
        val = float(raw)
        ok = math.isfinite(val) and (val >= lo if lo_incl else val > lo) and (hi is None or val <= hi)
        if not ok:
            bound = f">= {lo:g}" if lo_incl else f"> {lo:g}"
            errors.append(
                UserError(
                    f"{pkey} must be {bound} and <= {hi:g} ({what}), got {raw!r}", file=file, key=_join(key, pkey)
                )
            )
            continue
        values[pkey] = val
    for pkey, (_lo, _li, _hi, default, what) in table.items():
        if default is _REQUIRED and pkey not in values and pkey not in spec:
            errors.append(
                UserError(f"missing {pkey} ({what}) for roughness model {name}", file=file, key=_join(key, pkey))
            )
    if name in ("ggx", "beckmann") and not errors:
        has_a = "alpha" in values
        has_xy = [k for k in ("alpha_x", "alpha_y") if k in values]
        if has_a and has_xy:
            errors.append(
                UserError("give either alpha or alpha_x and alpha_y, not both", file=file, key=_join(key, has_xy[0]))
            )
        elif not has_a and len(has_xy) != 2:
            errors.append(UserError("missing alpha (or both alpha_x and alpha_y)", file=file, key=_join(key, "alpha")))
    if errors:
        raise errors[0] if len(errors) == 1 else UserErrors(errors)
    return REGISTRY[name](**values)
