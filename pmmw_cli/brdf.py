"""``pmmw brdf``: the polarized BRDF of a rough layered surface on Optics Express 2016's hemispherical grid.

Two methods share one surface description (`Stack`) and one output grid:

``mc``
    Optics Express 2016's Monte Carlo: rays enter from the incidence direction, meet rough interfaces whose
    facet normals come from `pmmw_cli.physics.roughness`, split by the polarized Fresnel
    coefficients of `pmmw_cli.physics.fresnel` / `pmmw_cli.physics.multilayer` about each facet,
    and are followed through the layers until they leave the top surface (collected), enter the
    substrate, or are absorbed. It is the estimator of the renderer (roughness module docstring,
    "How the renderer uses this"): exact visible normals, Smith masking, masked and wrong-side
    rays re-hit the same interface, nothing is discarded. Each path carries a Jones matrix, so
    one run gives the whole Mueller matrix; the branch (reflected or transmitted) is drawn with
    probability proportional to its unpolarized power and the Jones matrix is rescaled, so a
    lossless stack returns R + T = 1 exactly, path by path.
``analytic``
    The polarized Ashikhmin model of Stryjewski et al. 2009 for one rough interface (the substrate, optionally
    under a coherent coating on its facets): the single-reflection term
    ``M1 = D(h) G(wi, wo) M_F(h) / (4 cos th_i cos th_o)`` with the Jones matrix of the facet
    rotated between the facet's (s, p) and the global (h, v) bases, plus the double-reflection
    term of Stryjewski et al. 2009 eq. 12-16 written for the same Smith microsurface (facet h1 seen from wi,
    the reflected ray masked, facet h2, then out to wo)::

        f2(wi, wo) cos th_o = E_{h1 ~ D_wi} [ D(h2) G1(wo) M_F2 / (4 A(w12+)) ]

    with ``w12`` the direction from facet 1 to facet 2, ``w12+`` it folded into the upper
    hemisphere, ``A`` the projected area and ``M_F2`` the Mueller matrix of the product of the
    two facets' Jones matrices (Stryjewski et al. 2009 eq. 15-16: coherent within a path). The masking
    probability and the second facet's visible-normal density combine into ``1/A(w12+)``
    exactly, which is what makes the term reciprocal. The integral over w12 is a scrambled Sobol
    quadrature with a fixed seed (deterministic), sampled from both ends and combined by the
    balance heuristic (`_double_term`); the broad double lobe is evaluated every 2 degrees and
    interpolated onto the grid. ``--shadowing`` picks G in the single term: ``smith`` (``G1
    G1``, the first order of ``mc``), ``ashikhmin`` (Stryjewski et al. 2009 eq. 6), ``torrance_sparrow``
    (SCATMECH's ``Shadowed_Facet_BRDF_Model``) or ``none`` (SCATMECH's ``Facet_BRDF_Model``).
    Its hemispherical totals are integrated over facet normals (`analytic_totals`), not over the
    grid, so they stay right for lobes narrower than a cell. Stryjewski et al. 2009's own double-bounce
    probability (its eq. 17) is garbled in the extraction; this is the Smith form of the same
    idea, and it equals the Monte Carlo's second order.

Grid and bases
--------------
Optics Express 2016's collection grid: 91 x 360 cells, 1 degree; row i holds zenith angles within half a
degree of i (row 0 the cap below 0.5 degree, row 90 the band above 89.5), column j azimuths
within half a degree of j. ``mc`` sums the power of the rays leaving through each cell and
divides by the cell's projected solid angle (a cell-averaged BRDF); ``analytic`` evaluates the
BRDF at the cell centre (zenith i, azimuth j degrees). Stokes vectors of both the incident and
the reflected waves are expressed in the basis of the global Z axis that `pmmw_cli.physics.jones`
uses for the sky: ``h = Z x k / |Z x k|``, ``v = k x h`` for propagation direction k, and
``I = |Eh|^2 + |Ev|^2, Q = |Eh|^2 - |Ev|^2, U = 2 Re(Eh Ev*), V = 2 Im(Eh Ev*)``. Over a flat
surface h and v are the s and p directions of the plane of incidence. The incidence direction
``wi`` (theta_i, phi_i) points from the surface toward the source; the specular direction is at
azimuth phi_i + 180 degrees.

Outputs (`run_brdf` with ``out``)
---------------------------------
``brdf_<method>.exr``: channels ``I, Q, U, V`` (the reflected Stokes vector as a BRDF [1/sr] for
an incident Stokes vector normalized to I = 1), ``DoP`` [-], ``AoP`` [deg] (``0.5 atan2(U, Q)``)
and, with ``mueller``, ``M00 .. M33`` [1/sr]; rows are zenith 0..90 degrees, columns azimuth
0..359 degrees. ``brdf_<method>.png``: polar maps of the six channels. ``brdf_inplane.png``: I in
the plane of incidence. ``brdf.json``: the summary (also printed with ``--json``), with
``total_reflectance`` = the hemispherical integral of I over the incident I.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pmmw_cli.io.yamlio import read_yaml

from pmmw_cli.errors import UserError, UserErrors
from pmmw_cli.physics import fresnel, multilayer
from pmmw_cli.physics import roughness as rough

__all__ = [
    "METHODS",
    "N_PHI",
    "N_THETA",
    "SHADOWING",
    "BrdfResult",
    "Layer",
    "MethodResult",
    "Stack",
    "analytic",
    "analytic_mueller",
    "analytic_totals",
    "flat_reflectance",
    "grid_directions",
    "load_stack",
    "monte_carlo",
    "mueller_from_jones",
    "parse_complex",
    "projected_solid_angle",
    "roughness_spec_from_options",
    "run_brdf",
]

#: Optics Express 2016's collection grid: zenith rows 0..90 degrees, azimuth columns 0..359 degrees.
N_THETA, N_PHI = 91, 360
METHODS = ("mc", "analytic", "both")
SHADOWING = ("smith", "ashikhmin", "torrance_sparrow", "none")
_C0 = 299_792_458.0  # [m/s]
_TINY = 1e-300
# Paths are followed in chunks of this many rays (memory, not results: chunks have own seeds).
_CHUNK = 1 << 17
# Facet interactions after which a path is ended and counted as lost (never reached in practice:
# reported in the summary as ``lost``).
_MAX_EVENTS = 1000
# Zenith and azimuth step [deg] of the sub-grid on which `analytic` evaluates the (broad) double-
# reflection term before interpolating it onto the 1-degree grid (4 x fewer evaluations).
_DOUBLE_STEP = 2
_STOKES_A = np.array([[1, 0, 0, 1], [1, 0, 0, -1], [0, 1, 1, 0], [0, -1j, 1j, 0]], dtype=np.complex128)
_STOKES_A_INV = np.linalg.inv(_STOKES_A)


# ----------------------------------------------------------------------------------------------
# Surface description
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Layer:
    """One medium below the ambient one, with the interface on its top.

    Attributes
    ----------
    eps : complex
        Relative permittivity [-] (eps'' >= 0 lossy). Ignored for a ``metal`` substrate.
    roughness : MicrofacetModel or None
        Model of the interface on top of this layer; None is smooth.
    thickness : float or None
        [m]; a lossy layer with a thickness attenuates each path by ``exp(-2 k0 Im(n) L)`` over
        its length L (and a ray masked inside it by one wavelength on its way back to the same
        interface, as in the renderer); without one, absorption inside the layer is ignored (Optics
        Express 2016, assumption 3).
        Ignored for the substrate (the last layer, a half-space).
    coating : tuple of (complex, float)
        Coherent films ``(eps, thickness [m])``, outermost first, conformal to the facets of the
        top interface (`pmmw_cli.physics.multilayer`).
    metal : bool
        Perfect conductor (only for the substrate).
    name : str
    """

    eps: complex
    roughness: object = None
    thickness: float | None = None
    coating: tuple = ()
    metal: bool = False
    name: str = ""


@dataclass(frozen=True)
class Stack:
    """Layers from the top (just below the ambient medium) down; the last is the substrate.

    Attributes
    ----------
    layers : tuple of Layer
    ambient_eps : complex
        Permittivity of the incidence medium (lossless).
    frequency : float or None
        [Hz]; needed for coatings and absorbing layers with a thickness.
    """

    layers: tuple
    ambient_eps: complex = 1.0 + 0j
    frequency: float | None = None

    @property
    def k0(self):
        return None if self.frequency is None else 2.0 * math.pi * self.frequency / _C0

    def media(self):
        """Permittivities of the ambient medium, the layers and the substrate, top down."""
        return [complex(self.ambient_eps)] + [complex(layer.eps) for layer in self.layers]


def parse_complex(value, *, file=None, key=None) -> complex:
    """``0.23+3.46j`` (or ``i``), a number, or a pair ``[re, im]`` -> complex."""
    if isinstance(value, bool):
        raise UserError(f"expected a complex number like 0.23+3.46j, got {value!r}", file, key)
    if isinstance(value, (int, float)):
        return complex(float(value), 0.0)
    if isinstance(value, (list, tuple)) and len(value) == 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return complex(float(value[0]), float(value[1]))
    if isinstance(value, str):
        text = value.replace(" ", "").replace("i", "j").replace("J", "j")
        if "," in text:
            parts = text.split(",")
            try:
                if len(parts) == 2:
                    return complex(float(parts[0]), float(parts[1]))
            except ValueError:
                pass
        else:
            try:
                return complex(text)
            except ValueError:
                pass
    raise UserError(f"cannot read {value!r} as a complex number; expected e.g. 0.23+3.46j or [0.23, 3.46]", file, key)


def _check_eps(eps, file, key):
    if not (math.isfinite(eps.real) and math.isfinite(eps.imag)):
        raise UserError(f"permittivity must be finite, got {eps}", file, key)
    if eps.imag < 0.0:
        raise UserError(f"eps'' must be >= 0 (lossy; exp(-i w t) convention), got {eps}", file, key)
    if eps == 0:
        raise UserError("permittivity 0 is not a medium", file, key)


def _medium_eps(entry: dict, *, frequency, file, key, db=None):
    """(eps, metal) from one of ``n``, ``eps``, ``material``, ``kind: metal``."""
    given = [k for k in ("n", "eps", "material") if k in entry]
    if entry.get("kind") == "metal":
        if given:
            raise UserError(f"a metal (perfect conductor) takes no {given[0]}", file, f"{key}.{given[0]}")
        return 0j, True
    if len(given) != 1:
        raise UserError("give exactly one of n, eps, material (or kind: metal)", file, key)
    which = given[0]
    if which == "n":
        n = parse_complex(entry["n"], file=file, key=f"{key}.n")
        if n.imag < 0.0:
            raise UserError(f"Im(n) must be >= 0 (lossy; exp(-i w t) convention), got {n}", file, f"{key}.n")
        eps = n * n
    elif which == "eps":
        eps = parse_complex(entry["eps"], file=file, key=f"{key}.eps")
    else:
        from pmmw_cli.scene.materials import MaterialDB

        if frequency is None:
            raise UserError("a material from the database needs the frequency (frequency: or --frequency)",
                            file, f"{key}.material")
        db = db or MaterialDB.load()
        mat = db.get(entry["material"], file=file, key=f"{key}.material")
        if mat.kind == "metal":
            return 0j, True
        if mat.kind == "blackbody":
            raise UserError(f"material {mat.id!r} is a blackbody: it has no surface to scatter from", file,
                            f"{key}.material")
        eps = complex(mat.eps_at(frequency))
    _check_eps(eps, file, f"{key}.{which}")
    return eps, False


_LAYER_KEYS = ("n", "eps", "material", "kind", "roughness", "thickness", "coating", "name")
_STACK_KEYS = ("frequency", "wavelength", "ambient", "layers")


def _frequency(frequency, wavelength, file, key_f="frequency", key_w="wavelength"):
    from pmmw_cli.units import parse_quantity

    if frequency is not None and wavelength is not None:
        raise UserError("give either a frequency or a wavelength, not both", file, key_w)
    if frequency is not None:
        f = parse_quantity(frequency, "frequency", file=file, key=key_f)
    elif wavelength is not None:
        lam = parse_quantity(wavelength, "length", file=file, key=key_w)
        if not lam > 0.0:
            raise UserError(f"wavelength must be > 0, got {wavelength!r}", file, key_w)
        f = _C0 / lam
    else:
        return None
    if not f > 0.0:
        raise UserError(f"frequency must be > 0, got {frequency!r}", file, key_f)
    return f


def load_stack(path, *, frequency=None, wavelength=None) -> Stack:
    """Read a stack file (YAML)::

        frequency: 95 GHz          # or wavelength: 635 nm (needed for coatings, thicknesses,
                                   # database materials)
        ambient: {n: 1}            # optional, vacuum by default
        layers:                    # top first; the last one is the substrate
          - n: 1.5
            thickness: 1 mm        # optional: absorption along paths in a lossy layer
            roughness: {model: ashikhmin_shirley, ex: 10, ey: 10}
          - n: 0.23+3.46j          # or eps: [eps', eps''], material: ID, kind: metal
            roughness: {model: ashikhmin_shirley, ex: 15, ey: 15}
            coating: [{eps: [2.5, 0.01], thickness: 0.1 mm}]   # coherent films on the facets

    ``frequency``/``wavelength`` arguments (command line) override the file's.

    Raises
    ------
    UserError or UserErrors
        Every problem, with the file and key path.
    """
    from pmmw_cli.units import parse_quantity

    path = Path(path)
    file = str(path)
    if not path.is_file():
        raise UserError("stack file not found", file)
    raw = read_yaml(path, "stack file")
    if not isinstance(raw, dict):
        raise UserError("a stack file is a mapping with `layers:` (and optionally frequency, ambient)", file)
    errors: list[UserError] = []
    for k in raw:
        if k not in _STACK_KEYS:
            errors.append(UserError(f"unknown key {k!r}; expected: {', '.join(_STACK_KEYS)}", file, str(k)))
    if frequency is not None or wavelength is not None:
        f = _frequency(frequency, wavelength, "command line", "--frequency", "--wavelength")
    else:
        f = _frequency(raw.get("frequency"), raw.get("wavelength"), file)
    ambient = 1.0 + 0j
    if "ambient" in raw:
        amb = raw["ambient"]
        if not isinstance(amb, dict):
            errors.append(UserError("ambient is a mapping like {n: 1}", file, "ambient"))
        else:
            try:
                ambient, metal = _medium_eps(amb, frequency=f, file=file, key="ambient")
                if metal or abs(ambient.imag) > 0.0:
                    errors.append(UserError("the ambient medium must be lossless", file, "ambient"))
            except UserError as ex:
                errors.append(ex)
    layers_raw = raw.get("layers")
    if not isinstance(layers_raw, list) or not layers_raw:
        errors.append(UserError("`layers:` must be a non-empty list, top layer first, substrate last", file, "layers"))
        layers_raw = []
    layers = []
    for i, entry in enumerate(layers_raw):
        key = f"layers[{i}]"
        if not isinstance(entry, dict):
            errors.append(UserError("a layer is a mapping like {n: 1.5, roughness: {...}}", file, key))
            continue
        bad = [k for k in entry if k not in _LAYER_KEYS]
        for k in bad:
            errors.append(UserError(f"unknown key {k!r}; expected: {', '.join(_LAYER_KEYS)}", file, f"{key}.{k}"))
        try:
            eps, metal = _medium_eps(entry, frequency=f, file=file, key=key)
            if metal and i != len(layers_raw) - 1:
                raise UserError("only the substrate (last layer) can be a metal", file, key)
            model = None
            if entry.get("roughness") is not None:
                model = rough.make_model(entry["roughness"], file=file, key=f"{key}.roughness")
            thickness = None
            if entry.get("thickness") is not None:
                thickness = parse_quantity(entry["thickness"], "length", file=file, key=f"{key}.thickness")
                if thickness < 0.0:
                    raise UserError("thickness must be >= 0", file, f"{key}.thickness")
            coating = []
            for j, film in enumerate(entry.get("coating") or []):
                fkey = f"{key}.coating[{j}]"
                if not isinstance(film, dict) or "thickness" not in film:
                    raise UserError("a coating film is {n: ..., thickness: '0.1 mm'} (or eps:, material:)", file, fkey)
                feps, fmetal = _medium_eps({k: v for k, v in film.items() if k != "thickness"}, frequency=f,
                                           file=file, key=fkey)
                if fmetal:
                    raise UserError("a coating film cannot be a metal", file, fkey)
                d = parse_quantity(film["thickness"], "length", file=file, key=f"{fkey}.thickness")
                if d < 0.0:
                    raise UserError("thickness must be >= 0", file, f"{fkey}.thickness")
                coating.append((feps, d))
            if coating and f is None:
                raise UserError("a coating needs the frequency (frequency: or --frequency)", file, f"{key}.coating")
            if thickness and eps.imag > 0.0 and f is None and i != len(layers_raw) - 1:
                raise UserError("an absorbing layer with a thickness needs the frequency", file, f"{key}.thickness")
            layers.append(Layer(eps=eps, roughness=model, thickness=thickness, coating=tuple(coating), metal=metal,
                                name=str(entry.get("name", f"layer {i}"))))
        except UserErrors as ex:
            errors.extend(ex.errors)
        except UserError as ex:
            errors.append(ex)
    if errors:
        raise errors[0] if len(errors) == 1 else UserErrors(errors)
    return Stack(layers=tuple(layers), ambient_eps=ambient, frequency=f)


# ----------------------------------------------------------------------------------------------
# Grid, bases, Mueller
# ----------------------------------------------------------------------------------------------


def grid_directions():
    """Cell-centre directions of the 91 x 360 grid.

    Returns
    -------
    theta, phi : ndarray, shape (91, 360), float64
        Zenith and azimuth [rad] (rows i degrees, columns j degrees).
    w : ndarray, shape (91, 360, 3), float64
        Unit directions.
    """
    th = np.radians(np.arange(N_THETA, dtype=np.float64))[:, None] * np.ones((1, N_PHI))
    ph = np.radians(np.arange(N_PHI, dtype=np.float64))[None, :] * np.ones((N_THETA, 1))
    w = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)
    return th, ph, w


def projected_solid_angle():
    """``int cos(theta) dw`` over each cell [sr], shape (91, 360); sums to pi."""
    lo = np.radians(np.clip(np.arange(N_THETA) - 0.5, 0.0, 90.0))
    hi = np.radians(np.clip(np.arange(N_THETA) + 0.5, 0.0, 90.0))
    band = 0.5 * (np.sin(hi) ** 2 - np.sin(lo) ** 2) * np.radians(1.0)
    return band[:, None] * np.ones((1, N_PHI))


def _cells(d):
    """Grid cell (row, column) of upward unit directions d, shape (N, 3)."""
    th = np.degrees(np.arccos(np.clip(d[:, 2], -1.0, 1.0)))
    ph = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 360.0
    row = np.clip(np.floor(th + 0.5).astype(np.int64), 0, N_THETA - 1)
    col = np.floor(ph + 0.5).astype(np.int64) % N_PHI
    return row, col


def _hv(k, phi_fallback):
    """Sky basis (h, v) of propagation directions k (N, 3); at the poles h follows phi_fallback."""
    h = np.stack([-k[:, 1], k[:, 0], np.zeros(k.shape[0])], axis=1)  # Z x k
    norm = np.linalg.norm(h, axis=1)
    pole = norm < 1e-12
    h = h / np.where(pole, 1.0, norm)[:, None]
    if np.any(pole):
        # limit of Z x k / |Z x k| along the azimuth phi of k's horizontal part
        phi = phi_fallback[pole]
        h[pole] = np.stack([-np.sin(phi), np.cos(phi), np.zeros(phi.shape)], axis=1)
    v = np.cross(k, h)
    return h, v


def mueller_from_jones(j):
    """Mueller matrices of Jones matrices in this module's Stokes convention.

    Parameters
    ----------
    j : ndarray, shape (N, 2, 2), complex128
        ``[[a, b], [c, d]]`` mapping incident (E1, E2) to outgoing (E1, E2).

    Returns
    -------
    ndarray, shape (N, 4, 4), float64
        ``M = A (J kron J*) A^-1`` with ``S = A (E kron E*)``, ``S = (I, Q, U, V)`` as in
        `pmmw_cli.physics.jones` (``U = 2 Re(E1 E2*)``, ``V = 2 Im(E1 E2*)``), written out.
    """
    a, b, c, d = j[:, 0, 0], j[:, 0, 1], j[:, 1, 0], j[:, 1, 1]
    aa, bb, cc, dd = (x.real ** 2 + x.imag ** 2 for x in (a, b, c, d))
    ab, cd = a * np.conj(b), c * np.conj(d)
    ac, bd = a * np.conj(c), b * np.conj(d)
    ad, bc = a * np.conj(d), b * np.conj(c)
    m = np.empty((j.shape[0], 4, 4))
    m[:, 0, 0] = 0.5 * (aa + bb + cc + dd)
    m[:, 0, 1] = 0.5 * (aa - bb + cc - dd)
    m[:, 0, 2] = (ab + cd).real
    m[:, 0, 3] = -(ab + cd).imag
    m[:, 1, 0] = 0.5 * (aa + bb - cc - dd)
    m[:, 1, 1] = 0.5 * (aa - bb - cc + dd)
    m[:, 1, 2] = (ab - cd).real
    m[:, 1, 3] = -(ab - cd).imag
    m[:, 2, 0] = (ac + bd).real
    m[:, 2, 1] = (ac - bd).real
    m[:, 2, 2] = (ad + bc).real
    m[:, 2, 3] = -(ad - bc).imag
    m[:, 3, 0] = (ac + bd).imag
    m[:, 3, 1] = (ac - bd).imag
    m[:, 3, 2] = (ad + bc).imag
    m[:, 3, 3] = (ad - bc).real
    return m


def _dot(a, b):
    return np.einsum("...i,...i->...", a, b)


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0.0, n, 1.0)


def _amplitude(amp, power):
    """An amplitude with the phase of ``amp`` and the magnitude sqrt(power) (renormalized R, T)."""
    mag = np.abs(amp)
    phase = np.where(mag > 0.0, amp / np.where(mag > 0.0, mag, 1.0), 1.0)
    return phase * np.sqrt(np.maximum(power, 0.0))


def _basis_matrix(s_old, p_old, s_new, p_new):
    """Components in (s_new, p_new) from components in (s_old, p_old): shape (N, 2, 2)."""
    b = np.empty((s_old.shape[0], 2, 2))
    b[:, 0, 0] = _dot(s_old, s_new)
    b[:, 0, 1] = _dot(p_old, s_new)
    b[:, 1, 0] = _dot(s_old, p_new)
    b[:, 1, 1] = _dot(p_old, p_new)
    return b


def _facet_basis(m, k, s_fallback):
    """Local s = unit(m x k) (jones.py with the facet normal), p = k x s; fallback at normal incidence."""
    s = np.cross(m, k)
    norm = np.linalg.norm(s, axis=1)
    ok = norm > 1e-12
    s = np.where(ok[:, None], s / np.where(ok, norm, 1.0)[:, None], s_fallback)
    if not np.all(ok):
        # any s perpendicular to k does at normal incidence (r_p = -r_s there)
        sf = s[~ok] - _dot(s[~ok], k[~ok])[:, None] * k[~ok]
        s[~ok] = _unit(sf)
    return s, np.cross(k, s)


# ----------------------------------------------------------------------------------------------
# Interfaces
# ----------------------------------------------------------------------------------------------


class _Interface:
    """Interface ``i`` between media i (above) and i+1 (below) of a stack, top of layer i."""

    def __init__(self, stack: Stack, i: int):
        media = stack.media()
        layer = stack.layers[i]
        self.above, self.below = media[i], media[i + 1]
        self.model = layer.roughness
        self.coating = layer.coating
        self.metal = layer.metal
        self.last = i == len(stack.layers) - 1
        self.k0 = stack.k0
        # a substrate that absorbs what enters it (lossy half-space or perfect conductor)
        self.sink = self.last and (self.metal or self.below.imag > 0.0)

    def fresnel(self, cos1, from_above: bool):
        """Facet coefficients for rays crossing from the side ``from_above`` (N,) cosines."""
        n = cos1.shape[0]
        eps1, eps2 = (self.above, self.below) if from_above else (self.below, self.above)
        if not self.coating and not self.metal:
            return fresnel.interface(np.full(n, eps1), np.full(n, eps2), cos1)
        films = list(self.coating) if from_above else list(self.coating)[::-1]
        eps = np.array([eps1] + [e for e, _ in films] + [eps2], dtype=np.complex128)
        thick = np.array([d for _, d in films], dtype=np.float64)
        k0 = self.k0 if self.k0 is not None else 1.0  # films need k0 (checked at load time)
        return multilayer.stack(eps[None, :], thick[None, :], cos1, k0, substrate="metal" if self.metal else "dielectric")


def _refract(d, m, eps1, eps2):
    """Real transmitted direction about facet normal m (facing the incident side), as the
    renderer's integrator: tangential component conserved, normal component Re q2."""
    cos1 = -_dot(d, m)
    tang = d + cos1[:, None] * m
    sin2 = np.clip(1.0 - cos1 ** 2, 0.0, 1.0)
    n1 = np.sqrt(complex(eps1))
    q2 = fresnel.normal_component(np.full(d.shape[0], eps2), eps1 * sin2, branch="outgoing")
    return _unit(n1.real * tang - q2.real[:, None] * m)


def flat_reflectance(stack: Stack, theta_i):
    """Unpolarized reflectance of the same stack with every interface smooth (the specular
    limit of the rough one): per polarization, incoherent multiple reflections between the
    interfaces summed in closed form from the substrate up,
    ``R_i = Ra + Ta Tb tau^2 R_(i+1) / (1 - Rb tau^2 R_(i+1))`` (a: from above, b: from below,
    tau: one-way transmittance of the layer between), then the mean of s and p.

    Parameters
    ----------
    stack : Stack
    theta_i : float
        Incidence angle [rad].

    Returns
    -------
    float
    """
    media = stack.media()
    nl = len(stack.layers)
    kpar2 = (media[0] * math.sin(theta_i) ** 2).real

    def cos_in(j):
        return math.sqrt(max(1.0 - kpar2 / media[j].real, 0.0)) if j > 0 else math.cos(theta_i)

    total = 0.0
    for pol in ("s", "p"):
        r_stack = 0.0
        for i in range(nl - 1, -1, -1):
            itf = _Interface(stack, i)
            fa = itf.fresnel(np.array([cos_in(i)]), True)
            ra, ta = float(getattr(fa, "R" + pol)[0]), float(getattr(fa, "T" + pol)[0])
            if i == nl - 1:
                r_stack = ra
                continue
            fb = itf.fresnel(np.array([cos_in(i + 1)]), False)
            rb, tb = float(getattr(fb, "R" + pol)[0]), float(getattr(fb, "T" + pol)[0])
            layer, eps_b = stack.layers[i], media[i + 1]
            tau = 1.0
            if layer.thickness and eps_b.imag > 0.0 and stack.k0 is not None:
                tau = math.exp(-2.0 * stack.k0 * np.sqrt(eps_b).imag * layer.thickness / max(cos_in(i + 1), 1e-12))
            rr = r_stack * tau * tau
            r_stack = ra + ta * tb * rr / (1.0 - rb * rr)
        total += 0.5 * r_stack
    return total


# ----------------------------------------------------------------------------------------------
# Monte Carlo
# ----------------------------------------------------------------------------------------------


@dataclass
class _Paths:
    """Struct of arrays of live paths."""

    d: np.ndarray        # (n, 3) propagation direction
    s: np.ndarray        # (n, 3) current basis
    p: np.ndarray        # (n, 3) p = d x s
    j: np.ndarray        # (n, 2, 2) complex: incident (h, v) -> current (s, p)
    itf: np.ndarray      # (n,) interface index of the next interaction
    above: np.ndarray    # (n,) bool: the ray meets it from above
    order: np.ndarray    # (n,) facet interactions so far
    rehits: np.ndarray   # (n,) consecutive re-hits

    def take(self, idx):
        return _Paths(*(getattr(self, f)[idx] for f in self.__dataclass_fields__))

    @staticmethod
    def concat(parts):
        parts = [p for p in parts if p is not None and p.d.shape[0]]
        if not parts:
            return None
        return _Paths(*(np.concatenate([getattr(p, f) for p in parts]) for f in _Paths.__dataclass_fields__))


@dataclass
class _Tally:
    by_order: np.ndarray                 # (3, 91, 360, 4, 4) summed path Mueller, orders 1, 2, >= 3
    i_sum: float = 0.0                   # sum over paths of reflected I (for S_in)
    i_sq: float = 0.0                    # sum of squares (standard error)
    transmitted: float = 0.0             # unpolarized power into a lossless substrate
    absorbed: float = 0.0                # at interfaces, in sinks, in layers, ended re-hit chains
    lost: float = 0.0                    # paths ended at _MAX_EVENTS
    events: int = 0
    fallback_weights: int = 0            # rejection fallbacks (roughness module)


def monte_carlo(stack: Stack, wi, stokes_in, *, samples=1_000_000, seed=0, threshold=1e-3):
    """Optics Express 2016's Monte Carlo over a rough layered surface (module docstring).

    Parameters
    ----------
    stack : Stack
    wi : ndarray, shape (3,), float64
        Unit direction toward the source (wi.z > 0).
    stokes_in : ndarray, shape (4,), float64
        Incident Stokes vector in the incident (h, v) basis (only for ``i_sum``/standard error;
        the Mueller matrix is independent of it).
    samples : int
        Incident rays.
    seed : int
        Run seed; chunk c uses ``SeedSequence([seed, c])``.
    threshold : float
        Russian roulette below this unpolarized path power (survivors scaled up: unbiased).

    Returns
    -------
    _Tally
        Sums over paths (divide by ``samples`` for fractions of the incident power).
    """
    interfaces = [_Interface(stack, i) for i in range(len(stack.layers))]
    tally = _Tally(by_order=np.zeros((3, N_THETA, N_PHI, 4, 4)))
    phi_i = math.atan2(wi[1], wi[0])
    k_in = -np.asarray(wi, dtype=np.float64)
    h_in, v_in = _hv(k_in[None, :], np.array([phi_i + math.pi]))
    for c, start in enumerate(range(0, samples, _CHUNK)):
        n = min(_CHUNK, samples - start)
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), c]))
        j0 = np.zeros((n, 2, 2), dtype=np.complex128)
        j0[:, 0, 0] = j0[:, 1, 1] = 1.0
        paths = _Paths(d=np.tile(k_in, (n, 1)), s=np.tile(h_in[0], (n, 1)), p=np.tile(v_in[0], (n, 1)), j=j0,
                       itf=np.zeros(n, np.int64), above=np.ones(n, bool), order=np.zeros(n, np.int64),
                       rehits=np.zeros(n, np.int64))
        while paths is not None:
            nxt = []
            for i, itf in enumerate(interfaces):
                for from_above in (True, False):
                    sel = np.nonzero((paths.itf == i) & (paths.above == from_above))[0]
                    if sel.size:
                        nxt.append(_mc_event(paths.take(sel), itf, i, from_above, stack, rng, tally, stokes_in,
                                             threshold))
            paths = _Paths.concat(nxt)
    return tally


def _mc_event(pt: _Paths, itf: _Interface, i: int, from_above: bool, stack, rng, tally: _Tally, stokes_in,
              threshold):
    """One facet interaction for paths meeting interface i from one side; returns survivors."""
    n = pt.d.shape[0]
    tally.events += n
    n_x = np.array([0.0, 0.0, 1.0 if from_above else -1.0])  # macro normal on the rays' side
    tangent = np.array([1.0, 0.0, 0.0])
    wo = -pt.d
    u = rng.random((n, 4))
    # 1. facet normal (roughness module, "How the renderer uses this")
    if itf.model is not None:
        m, w = itf.model.sample_normals(n_x, tangent, wo, u[:, 0], u[:, 1])
        fb = w != 1.0
        if np.any(fb):
            tally.fallback_weights += int(fb.sum())
            # weight 0: no facet faces the ray; it ends absorbed at the surface
            tally.absorbed += 0.5 * float(np.sum(np.abs(pt.j[w == 0.0]) ** 2))
            pt.j = pt.j * np.sqrt(w)[:, None, None]
    else:
        m = np.tile(n_x, (n, 1))
    # 2. Fresnel about the facet, in the facet's (s, p) basis
    cos1 = np.clip(_dot(wo, m), 0.0, 1.0)
    co = itf.fresnel(cos1, from_above)
    s_loc, p_in = _facet_basis(m, pt.d, pt.s)
    jl = _basis_matrix(pt.s, pt.p, s_loc, p_in) @ pt.j
    p_before = np.sum(np.abs(pt.j) ** 2, axis=(1, 2))
    ars, arp = _amplitude(co.rs, co.Rs), _amplitude(co.rp, co.Rp)
    ats, atp = _amplitude(co.ts, co.Ts), _amplitude(co.tp, co.Tp)
    jr = jl * np.stack([ars, arp], axis=1)[:, :, None]
    jt = jl * np.stack([ats, atp], axis=1)[:, :, None]
    pr = np.sum(np.abs(jr) ** 2, axis=(1, 2))
    ptr = np.sum(np.abs(jt) ** 2, axis=(1, 2))
    eps_from, eps_to = (itf.above, itf.below) if from_above else (itf.below, itf.above)
    into_sink = itf.sink and from_above
    if into_sink:
        # what enters an absorbing substrate stays there: keep only the reflected child
        tally.absorbed += 0.5 * float(np.sum(p_before - pr))
        take_r = np.ones(n, bool)
        gain = np.ones(n)
    else:
        tally.absorbed += 0.5 * float(np.sum(np.maximum(p_before - pr - ptr, 0.0)))
        tot = pr + ptr
        prob_r = np.where(tot > 0.0, pr / np.where(tot > 0.0, tot, 1.0), 1.0)
        take_r = u[:, 2] < prob_r
        gain = np.sqrt(np.where(take_r, tot / np.maximum(pr, _TINY), tot / np.maximum(ptr, _TINY)))
    alive = np.where(take_r, pr, ptr) > 0.0
    j_new = np.where(take_r[:, None, None], jr, jt) * gain[:, None, None]
    d_r = pt.d - 2.0 * _dot(pt.d, m)[:, None] * m
    d_new = d_r.copy()
    if np.any(~take_r):
        t_idx = np.nonzero(~take_r)[0]
        d_new[t_idx] = _refract(pt.d[t_idx], m[t_idx], eps_from, eps_to)
    p_new = np.cross(d_new, s_loc)
    # 3. side of the child and masking
    child_above = np.where(take_r, from_above, not from_above)  # side it is on (above the interface?)
    n_side = np.where(child_above[:, None], np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]))
    if itf.model is not None:
        leave_p = itf.model.masking(n_side, tangent, d_new)
    else:
        leave_p = (_dot(d_new, n_side) > 0.0).astype(np.float64)
    leave = u[:, 3] < leave_p
    order = pt.order + 1
    rehits = np.where(leave, 0, pt.rehits + 1)
    new = _Paths(d=d_new, s=s_loc, p=p_new, j=j_new, itf=np.full(n, i), above=child_above, order=order, rehits=rehits)
    # ended re-hit chains: absorbed at the surface (roughness.MAX_REHITS)
    chain_end = ~leave & (rehits > rough.MAX_REHITS)
    if np.any(chain_end):
        tally.absorbed += 0.5 * float(np.sum(np.abs(j_new[chain_end]) ** 2))
    keep = alive & ~chain_end
    out = []
    # re-hits: same interface, from the child's side, after one wavelength of the medium there
    # (the shortest way to another facet for which geometrical optics holds; the renderer's rule)
    rh = keep & ~leave
    if np.any(rh):
        back = new.take(np.nonzero(rh)[0])
        # only where absorption is modelled: a layer with a thickness (Optics Express 2016 assumption 3)
        lay_above = stack.layers[i - 1] if i > 0 else None
        lossy_above = lay_above is not None and lay_above.thickness is not None
        lossy_below = stack.layers[i].thickness is not None and not itf.last
        if stack.k0 is not None and (lossy_above or lossy_below):
            eps_side = np.where(back.above, itf.above if lossy_above else 1.0, itf.below if lossy_below else 1.0)
            tau = np.exp(-4.0 * math.pi * np.sqrt(eps_side + 0j).imag)  # exp(-alpha lambda), alpha = 2 k0 Im n
            if np.any(tau < 1.0):
                before = 0.5 * np.sum(np.abs(back.j) ** 2, axis=(1, 2))
                back.j = back.j * np.sqrt(tau)[:, None, None]
                tally.absorbed += float(np.sum(before * (1.0 - tau)))
        out.append(back)
    lv = keep & leave
    if np.any(lv):
        go = new.take(np.nonzero(lv)[0])
        up = go.above  # it leaves into the medium above interface i
        if np.any(up):
            if i == 0:
                _collect(go.take(np.nonzero(up)[0]), tally, stokes_in)
            else:
                g = go.take(np.nonzero(up)[0])
                g.itf = g.itf - 1
                g.above = np.zeros(g.d.shape[0], bool)  # meets the interface above from below
                out.append(_travel(g, stack, i, tally))
        if np.any(~up):
            g = go.take(np.nonzero(~up)[0])
            if itf.last:
                tally.transmitted += 0.5 * float(np.sum(np.abs(g.j) ** 2))
            else:
                g.itf = g.itf + 1
                g.above = np.ones(g.d.shape[0], bool)
                out.append(_travel(g, stack, i + 1, tally))
    surv = _Paths.concat(out)
    if surv is None:
        return None
    # depth cap and Russian roulette on the unpolarized power
    power = 0.5 * np.sum(np.abs(surv.j) ** 2, axis=(1, 2))
    capped = surv.order >= _MAX_EVENTS
    if np.any(capped):
        tally.lost += float(np.sum(power[capped]))
    low = (power < threshold) & ~capped
    keep = ~capped
    if np.any(low):
        idx = np.nonzero(low)[0]
        q = power[idx] / threshold
        survive = rng.random(idx.size) < q
        surv.j[idx[survive]] /= np.sqrt(q[survive])[:, None, None]
        keep[idx[~survive]] = False
    return surv.take(np.nonzero(keep)[0]) if not np.all(keep) else surv


def _travel(g: _Paths, stack: Stack, layer_index: int, tally: _Tally):
    """Cross layer ``layer_index`` (1-based medium index) to its other interface, absorbing."""
    layer = stack.layers[layer_index - 1]
    eps = stack.media()[layer_index]
    if layer.thickness and eps.imag > 0.0 and stack.k0 is not None:
        alpha = 2.0 * stack.k0 * np.sqrt(eps).imag  # power attenuation [1/m] (PHYSICS.md)
        length = layer.thickness / np.maximum(np.abs(g.d[:, 2]), 1e-12)
        tau = np.exp(-alpha * length)
        before = 0.5 * np.sum(np.abs(g.j) ** 2, axis=(1, 2))
        g.j = g.j * np.sqrt(tau)[:, None, None]
        tally.absorbed += float(np.sum(before * (1.0 - tau)))
    g.rehits = np.zeros_like(g.rehits)
    return g


def _collect(g: _Paths, tally: _Tally, stokes_in):
    """Rays leaving the top surface: rotate to the outgoing (h, v) basis and bin their Mueller."""
    phi = np.arctan2(g.d[:, 1], g.d[:, 0])
    h, v = _hv(g.d, phi)
    j_out = _basis_matrix(g.s, g.p, h, v) @ g.j
    mm = mueller_from_jones(j_out)
    row, col = _cells(g.d)
    flat = row * N_PHI + col
    size = N_THETA * N_PHI
    order = np.clip(g.order, 1, 3) - 1
    for o in range(3):
        sel = order == o
        if np.any(sel):
            tally.by_order[o] += np.stack(
                [np.bincount(flat[sel], weights=mm[sel, a, b], minlength=size) for a in range(4) for b in range(4)],
                axis=-1).reshape(N_THETA, N_PHI, 4, 4)
    i_out = mm[:, 0, :] @ stokes_in
    tally.i_sum += float(i_out.sum())
    tally.i_sq += float((i_out ** 2).sum())


# ----------------------------------------------------------------------------------------------
# Analytic polarized Ashikhmin model (Stryjewski et al. 2009)
# ----------------------------------------------------------------------------------------------


def _facet_jones(itf: _Interface, m, k_in, k_out, s_in_basis, p_in_basis, s_out_basis, p_out_basis,
                 out_basis=True):
    """Jones matrix of one specular facet reflection, shape (N, 2, 2), from the (s_in, p_in)
    basis of the incoming wave to the (s_out, p_out) basis of the outgoing one, or with
    ``out_basis=False`` to the facet's own (s, k_out x s); also returns that s and p."""
    cos1 = np.clip(-_dot(k_in, m), 0.0, 1.0)
    co = itf.fresnel(cos1, True)
    s, p_in = _facet_basis(m, k_in, s_in_basis)
    p_out = np.cross(k_out, s)
    r = np.stack([_amplitude(co.rs, co.Rs), _amplitude(co.rp, co.Rp)], axis=1)
    j = r[:, :, None] * _basis_matrix(s_in_basis, p_in_basis, s, p_in)
    if out_basis:
        j = _basis_matrix(s, p_out, s_out_basis, p_out_basis) @ j
    return j, s, p_out


def analytic_mueller(stack: Stack, wi, wo, *, phi_o=None, shadowing="smith", double=True, double_samples=256,
                     seed=0):
    """Stryjewski et al. 2009's polarized Ashikhmin BRDF for given outgoing directions (module docstring).

    Parameters
    ----------
    stack : Stack
        One layer (the substrate), optionally coated; its roughness a microfacet model or None.
    wi : ndarray, shape (3,), float64
        Unit direction toward the source (wi.z > 0).
    wo : ndarray, shape (N, 3), float64
        Unit outgoing directions (wo.z >= 0).
    phi_o : ndarray, shape (N,), optional
        Azimuth defining the (h, v) basis where wo is the zenith (default: atan2 of wo).
    shadowing : {"smith", "ashikhmin", "torrance_sparrow", "none"}
        G of the single-reflection term.
    double : bool
        Add the double-reflection term.
    double_samples : int
        Quadrature points over the first facet (scrambled Sobol, seeded by ``seed``).

    Returns
    -------
    single, double : ndarray, shape (N, 4, 4), float64
        BRDF Mueller matrices [1/sr] (``double`` zeros when off; a smooth surface returns zeros:
        its BRDF is a delta, see `analytic`).
    """
    if len(stack.layers) != 1:
        raise UserError("the analytic model is for one rough interface (a substrate, optionally coated); "
                        "use --method mc for layered stacks", "--method")
    if shadowing not in SHADOWING:
        raise UserError(f"unknown shadowing {shadowing!r}; known: {', '.join(SHADOWING)}", "--shadowing")
    itf = _Interface(stack, 0)
    model = itf.model
    if isinstance(model, rough.BlenderGloss):
        raise UserError("blender_gloss is Blender's normal perturbation, not a microfacet distribution: it has no "
                        "analytic BRDF; use --method mc", "--method")
    wo = np.asarray(wo, dtype=np.float64)
    nc = wo.shape[0]
    phi_o = np.arctan2(wo[:, 1], wo[:, 0]) if phi_o is None else np.asarray(phi_o, dtype=np.float64)
    wi = np.asarray(wi, dtype=np.float64)
    cos_i = float(wi[2])
    phi_i = math.atan2(wi[1], wi[0])
    zero = np.zeros((nc, 4, 4))
    if model is None:
        return zero, zero.copy()
    k_in = np.tile(-wi, (nc, 1))
    h_in, v_in = _hv(k_in, np.full(nc, phi_i + math.pi))
    h_out, v_out = _hv(wo, phi_o)
    nz = np.tile([0.0, 0.0, 1.0], (nc, 1))
    tangent = np.tile([1.0, 0.0, 0.0], (nc, 1))
    cos_o = wo[:, 2]
    valid = cos_o > 1e-12
    cos_o_safe = np.where(valid, cos_o, 1.0)

    # Single reflection (Stryjewski et al. 2009 eq. 4 with the full Fresnel Jones matrix, eq. 10-11)
    hv = _unit(wi[None, :] + wo)
    d_h = model.D(nz, tangent, hv)
    j1, _, _ = _facet_jones(itf, hv, k_in, wo, h_in, v_in, h_out, v_out)
    wi_n = np.tile(wi, (nc, 1))
    if shadowing == "smith":
        g = model.shadowing(nz, hv, wi_n, wo, tangent)
    elif shadowing == "ashikhmin":
        g = rough.ashikhmin_pair(model.masking(nz, tangent, wi_n), model.masking(nz, tangent, wo), nz, wi_n, wo)
    elif shadowing == "torrance_sparrow":
        g = rough.torrance_sparrow(nz, hv, wi_n, wo)
    else:
        g = np.ones(nc)
    scale = np.where(valid, d_h * g / (4.0 * cos_i * cos_o_safe), 0.0)
    single = mueller_from_jones(j1) * scale[:, None, None]
    if not double:
        return single, zero

    dbl = _double_term(itf, model, wi, wo, h_in, v_in, h_out, v_out, int(double_samples), int(seed))
    return single, dbl


def _double_term(itf: _Interface, model, wi, wo, h_in, v_in, h_out, v_out, n_samples, seed):
    """Stryjewski et al. 2009's double-reflection term for the Smith microsurface, shape (N, 4, 4) [1/sr].

    ``f2(wi, wo) = int f(w12) dw12`` over the direction w12 from facet 1 (h1 = unit(wi + w12))
    to facet 2 (h2 = unit(wo - w12)), with
    ``f = G1(wi) G1(wo) D(h1) D(h2) M_F2 / (16 cos_i cos_o A(w12+))`` (module docstring). Two
    sampling strategies share one scrambled Sobol set: h1 ~ D cos (w12 from the incident side,
    density q1 = D(h1) cos(h1) / (4 wi.h1)) and h2 ~ D cos (w12 from the outgoing side,
    q2 = D(h2) cos(h2) / (4 wo.h2)), combined by the balance heuristic ``f / (q1 + q2)``: each
    captures the peak the other misses, and the estimate is reciprocal (swapping wi and wo swaps
    the strategies).
    """
    from scipy.stats import qmc

    nc = wo.shape[0]
    wi = np.asarray(wi, dtype=np.float64)
    cos_i = float(wi[2])
    cos_o = wo[:, 2]
    z = np.array([0.0, 0.0, 1.0])
    tx = np.array([1.0, 0.0, 0.0])
    sob = qmc.Sobol(d=2, scramble=True, seed=seed).random(n_samples)
    hs, _ = model.sample_dcos(z, tx, sob[:, 0], sob[:, 1])
    g1_i = float(model.masking(z, tx, wi[None, :])[0])
    g1_o = model.masking(z, tx, wo)
    acc = np.zeros((nc, 4, 4))
    cells = np.nonzero(cos_o > 1e-12)[0]
    wo_c = wo[cells]
    k_in1 = -wi[None, :]

    def area_up(w12):
        up = w12.copy()
        up[:, 2] = np.abs(up[:, 2])  # A(-w) = A(w with z flipped): D is point-symmetric in x, y
        return model.projected_area(z, tx, up)

    def accumulate(sel, h1, h2, w12, c1, c2, dc1, dc2, a12, ja, s_a, p_a):
        """acc[sel] += M(J) f/(q1 + q2), arrays over the cells ``sel`` (broadcastable)."""
        q = dc1 / (4.0 * c1) + dc2 / (4.0 * c2)
        fw = (g1_i * g1_o[sel] * (dc1 / h1[..., 2]) * (dc2 / h2[..., 2])
              / (16.0 * cos_i * cos_o[sel] * a12 * q))
        n = sel.size
        jb, _, _ = _facet_jones(itf, h2, np.broadcast_to(w12, (n, 3)), wo[sel], np.broadcast_to(s_a, (n, 3)),
                                np.broadcast_to(p_a, (n, 3)), h_out[sel], v_out[sel])
        acc[sel] += mueller_from_jones(jb @ ja) * np.maximum(fw, 0.0)[:, None, None]  # distinct cells

    for h in hs:
        dch = float(model.D(z, tx, h[None, :])[0]) * h[2]
        if not (dch > 0.0 and h[2] > 0.0):
            continue
        # strategy 1: h is facet 1, seen from wi (w12, facet 1's Jones matrix shared by all cells)
        c1 = float(h @ wi)
        if c1 > 0.0:
            w12 = -wi + 2.0 * c1 * h
            h2 = _unit(wo_c - w12[None, :])
            c2 = _dot(wo_c, h2)
            dc2 = model.D(z, tx, h2) * h2[:, 2]
            ok = (c2 > 0.0) & (dc2 > 0.0) & (h2[:, 2] > 0.0)
            if np.any(ok):
                ja, s_a, p_a = _facet_jones(itf, h[None, :], k_in1, w12[None, :], h_in[:1], v_in[:1], None, None,
                                            out_basis=False)
                a12 = float(area_up(w12[None, :])[0])
                accumulate(cells[ok], h, h2[ok], w12, c1, c2[ok], dch, dc2[ok], a12, ja, s_a[0], p_a[0])
        # strategy 2: h is facet 2, seen from wo (the reversed path); w12 and facet 1 per cell
        co = wo_c @ h
        m2 = co > 0.0
        if np.any(m2):
            sel = cells[m2]
            w12 = wo_c[m2] - 2.0 * co[m2][:, None] * h[None, :]
            h1 = _unit(wi[None, :] + w12)
            c1v = h1 @ wi
            dc1 = model.D(z, tx, h1) * h1[:, 2]
            ok = (c1v > 0.0) & (dc1 > 0.0) & (h1[:, 2] > 0.0)
            if np.any(ok):
                sel, w12, h1, c1v, dc1, cov = sel[ok], w12[ok], h1[ok], c1v[ok], dc1[ok], co[m2][ok]
                n = sel.size
                ja, s_a, p_a = _facet_jones(itf, h1, np.broadcast_to(k_in1, (n, 3)), w12, h_in[sel], v_in[sel],
                                            None, None, out_basis=False)
                accumulate(sel, h1, np.broadcast_to(h, (n, 3)), w12, c1v, cov, dc1, dch, area_up(w12), ja, s_a, p_a)
    return acc / n_samples


def analytic_totals(stack: Stack, wi, *, shadowing="smith", double=True, n_points=1 << 16, seed=0):
    """Hemispherical Mueller matrices [-] of the analytic single and double terms, integrated
    over facet normals rather than over the grid (accurate for any roughness, also where the
    lobe is narrower than a grid cell):

    ``R1 = int D(h) G F (wi.h) / cos_i dw_h`` with h ~ D cos (scrambled Sobol), and
    ``R2 = int int G1(wi) G1(wo) D1 D2 F2 (wi.h1)(-w12.h2) / (cos_i A(w12+)) dw_h1 dw_h2``
    (the double term of `_double_term` with ``dw12 = 4 (wi.h1) dw_h1``, ``dwo = 4 (-w12.h2) dw_h2``).

    Returns
    -------
    single, double : ndarray, shape (4, 4), float64
    """
    from scipy.stats import qmc

    itf = _Interface(stack, 0)
    model = itf.model
    wi = np.asarray(wi, dtype=np.float64)
    cos_i = float(wi[2])
    phi_i = math.atan2(wi[1], wi[0])
    z = np.array([0.0, 0.0, 1.0])
    tx = np.array([1.0, 0.0, 0.0])
    zero = np.zeros((4, 4))
    if model is None or isinstance(model, rough.BlenderGloss):
        return zero, zero.copy()
    pts = qmc.Sobol(d=4, scramble=True, seed=int(seed)).random(int(n_points))
    n = pts.shape[0]
    k_in = np.tile(-wi, (n, 1))
    h_in, v_in = _hv(k_in, np.full(n, phi_i + math.pi))
    wi_n = np.tile(wi, (n, 1))
    g1_i = float(model.masking(z, tx, wi[None, :])[0])

    h1, _ = model.sample_dcos(z, tx, pts[:, 0], pts[:, 1])
    c1 = h1 @ wi
    wo = 2.0 * c1[:, None] * h1 - wi
    ok = (c1 > 0.0) & (wo[:, 2] > 0.0)
    h_out, v_out = _hv(wo, np.arctan2(wo[:, 1], wo[:, 0]))
    if shadowing == "smith":
        g = model.shadowing(z, h1, wi_n, wo, tx)
    elif shadowing == "ashikhmin":
        g = rough.ashikhmin_pair(np.full(n, g1_i), model.masking(z, tx, wo), np.tile(z, (n, 1)), wi_n, wo)
    elif shadowing == "torrance_sparrow":
        g = rough.torrance_sparrow(np.tile(z, (n, 1)), h1, wi_n, wo)
    else:
        g = np.ones(n)
    w = np.where(ok, g * c1 / (cos_i * np.maximum(h1[:, 2], _TINY)), 0.0)
    j1, _, _ = _facet_jones(itf, h1, k_in, wo, h_in, v_in, h_out, v_out)
    single = np.einsum("n,nij->ij", w, mueller_from_jones(j1)) / n
    if not double:
        return single, zero.copy()

    w12 = wo  # the first reflection's direction
    h2, _ = model.sample_dcos(z, tx, pts[:, 2], pts[:, 3])
    c2 = -_dot(w12, h2)
    wo2 = w12 + 2.0 * c2[:, None] * h2
    ok2 = (c1 > 0.0) & (c2 > 0.0) & (wo2[:, 2] > 0.0)
    up = w12.copy()
    up[:, 2] = np.abs(up[:, 2])
    a12 = model.projected_area(z, tx, up)
    g1_o = model.masking(z, tx, wo2)
    with np.errstate(divide="ignore", invalid="ignore"):
        w2 = np.where(ok2 & (a12 > 0.0), g1_i * g1_o * c1 * c2 /
                      (cos_i * a12 * np.maximum(h1[:, 2], _TINY) * np.maximum(h2[:, 2], _TINY)), 0.0)
    ja, s_a, p_a = _facet_jones(itf, h1, k_in, w12, h_in, v_in, None, None, out_basis=False)
    h2_out, v2_out = _hv(wo2, np.arctan2(wo2[:, 1], wo2[:, 0]))
    jb, _, _ = _facet_jones(itf, h2, w12, wo2, s_a, p_a, h2_out, v2_out)
    dbl = np.einsum("n,nij->ij", w2, mueller_from_jones(jb @ ja)) / n
    return single, dbl


def analytic(stack: Stack, wi, *, shadowing="smith", double=True, double_samples=256, seed=0):
    """`analytic_mueller` at the centres of the 91 x 360 grid.

    A smooth interface has a delta BRDF: its Fresnel Mueller matrix divided by the projected
    solid angle of the specular cell, so that the grid sums to the flat reflectance.

    Returns
    -------
    single, double : ndarray, shape (91, 360, 4, 4), float64 [1/sr]
    """
    _, ph, wgrid = grid_directions()
    single, _ = analytic_mueller(stack, wi, wgrid.reshape(-1, 3), phi_o=ph.reshape(-1), shadowing=shadowing,
                                 double=False)
    single = single.reshape(N_THETA, N_PHI, 4, 4)
    dbl = np.zeros_like(single)
    if double and stack.layers[0].roughness is not None:
        # the double-reflection lobe is broad: evaluate it every _DOUBLE_STEP degrees and
        # interpolate bilinearly (periodic in azimuth)
        st = _DOUBLE_STEP
        rows, cols = np.arange(0, N_THETA, st), np.arange(0, N_PHI, st)
        sub_w = wgrid[np.ix_(rows, cols)].reshape(-1, 3)
        sub_ph = ph[np.ix_(rows, cols)].reshape(-1)
        _, sub = analytic_mueller(stack, wi, sub_w, phi_o=sub_ph, shadowing=shadowing, double=True,
                                  double_samples=double_samples, seed=seed)
        sub = sub.reshape(rows.size, cols.size, 4, 4)
        sub = np.concatenate([sub, sub[:, :1]], axis=1)  # wrap azimuth
        r = np.arange(N_THETA) / st
        c = np.arange(N_PHI) / st
        r0 = np.minimum(np.floor(r).astype(int), rows.size - 2)
        c0 = np.floor(c).astype(int)
        tr = (r - r0)[:, None, None, None]
        tc = (c - c0)[None, :, None, None]
        a, b = sub[r0][:, c0], sub[r0][:, c0 + 1]
        cc, d = sub[r0 + 1][:, c0], sub[r0 + 1][:, c0 + 1]
        dbl = (1 - tr) * ((1 - tc) * a + tc * b) + tr * ((1 - tc) * cc + tc * d)
    if stack.layers[0].roughness is None:
        wi = np.asarray(wi, dtype=np.float64)
        phi_i = math.atan2(wi[1], wi[0])
        ws = np.array([[-wi[0], -wi[1], wi[2]]])
        row, col = _cells(ws)
        h_in, v_in = _hv(-wi[None, :], np.array([phi_i + math.pi]))
        h_out, v_out = _hv(ws, np.array([phi_i + math.pi]))
        jj, _, _ = _facet_jones(_Interface(stack, 0), np.array([[0.0, 0.0, 1.0]]), -wi[None, :], ws, h_in, v_in,
                                h_out, v_out)
        single[row[0], col[0]] = mueller_from_jones(jj)[0] / projected_solid_angle()[row[0], col[0]]
    return single, dbl


# ----------------------------------------------------------------------------------------------
# The job
# ----------------------------------------------------------------------------------------------


@dataclass
class MethodResult:
    """One method's maps and numbers.

    Attributes
    ----------
    mueller : ndarray, shape (91, 360, 4, 4), float64
        BRDF Mueller matrix [1/sr] per cell.
    stokes : ndarray, shape (4, 91, 360), float64
        ``mueller @ stokes_in / stokes_in[0]`` [1/sr]: I, Q, U, V.
    summary : dict
        JSON-ready numbers (see `run_brdf`).
    parts : dict
        Method-specific arrays: ``mc``: ``by_order`` (3, 91, 360, 4, 4) [1/sr] for orders 1, 2,
        >= 3; ``analytic``: ``single`` and ``double`` (91, 360, 4, 4) [1/sr].
    """

    mueller: np.ndarray
    stokes: np.ndarray
    summary: dict
    parts: dict = field(default_factory=dict)


@dataclass
class BrdfResult:
    """What `run_brdf` computed: per-method results and the JSON summary."""

    methods: dict
    summary: dict
    files: list


# The option each "command line" problem comes from: the substrate and roughness checks are
# shared with stack files and locate problems by key (`--n.n`, `roughness.ex`); a user who typed
# options is told the option alone.
_ROUGHNESS_OPTIONS = {
    "roughness.model": "--model", "roughness.ex": "--ex", "roughness.ey": "--ey", "roughness.m": "--m",
    "roughness.alpha": "--alpha", "roughness.alpha_x": "--alpha", "roughness.alpha_y": "--alpha-y",
    "roughness.gloss": "--gloss", "roughness.orientation_deg": "--orientation",
}


def _option_error(err: UserError) -> UserError:
    if isinstance(err, UserErrors):
        return UserErrors([_option_error(e) for e in err.errors])
    if err.file != "command line" or not err.key:
        return err
    return UserError(err.message, _ROUGHNESS_OPTIONS.get(err.key, err.key.split(".")[0]))


def _stack_from_options(n, eps, material, roughness_spec, frequency, wavelength):
    f = _frequency(frequency, wavelength, "command line", "--frequency", "--wavelength")
    given = [k for k, v in (("--n", n), ("--eps", eps), ("--material", material)) if v is not None]
    if len(given) != 1:
        raise UserError("give exactly one of --n, --eps, --material (or --stack FILE)", "command line",
                        given[1] if len(given) > 1 else "--n")
    entry = {"n": n} if n is not None else {"eps": eps} if eps is not None else {"material": material}
    eps_val, metal = _medium_eps(entry, frequency=f, file="command line", key=given[0])
    model = rough.make_model(roughness_spec, file="command line", key="roughness") if roughness_spec else None
    if material is not None:
        return _material_stack(material, eps_val, metal, model, f)
    return Stack(layers=(Layer(eps=eps_val, roughness=model, metal=metal, name=given[0].lstrip("-")),), frequency=f)


def _material_stack(mid, eps_val, metal, model, f):
    """A database material as a stack: its ``roughness:`` (unless the options give one) and its
    coating, as the renderer sees it. Coating layers without roughness are coherent films on the
    interface below them; a layer with its own ``roughness:`` is a rough layer of its own."""
    from pmmw_cli.scene.materials import MaterialDB
    from pmmw_cli.trace.job import split_coating

    db = MaterialDB.load()
    mat = db.get(mid, file="command line", key="--material")
    rough_layers, films = split_coating(  # the renderer's grouping (temperatures do not matter here)
        [(db.get(x.material).eps_at(f), x.thickness, 0.0, x.roughness) for x in mat.coating], 2.0 * math.pi * f / _C0)

    def pairs(coat):
        return () if coat is None else tuple(zip(coat.eps.tolist(), coat.thickness.tolist()))

    names = [x.material for x in mat.coating if x.roughness is not None]
    layers = [Layer(eps=x.eps, roughness=x.roughness, thickness=x.thickness, coating=pairs(x.films), name=name)
              for x, name in zip(rough_layers, names)]
    layers.append(Layer(eps=eps_val, roughness=model if model is not None else mat.roughness, metal=metal,
                        coating=pairs(films), name=mid))
    return Stack(layers=tuple(layers), frequency=f)


def roughness_spec_from_options(model=None, ex=None, ey=None, m=None, alpha=None, alpha_y=None, gloss=None,
                                orientation=None):
    """The ``roughness:`` record implied by the command-line options (None: smooth)."""
    opts = {"ex": ex, "ey": ey, "m": m, "alpha": alpha, "alpha_y": alpha_y, "gloss": gloss}
    given = {k: v for k, v in opts.items() if v is not None}
    if model is None:
        if not given:
            return None
        if "ex" in given or "ey" in given:
            model = "ashikhmin_shirley"
        elif "m" in given:
            model = "blinn_phong"
        elif "gloss" in given:
            model = "blender_gloss"
        else:
            model = "ggx"
    spec = {"model": model}
    if model == "ashikhmin_shirley":
        if "ex" in given and "ey" not in given:
            given["ey"] = given["ex"]
        if "ey" in given and "ex" not in given:
            given["ex"] = given["ey"]
    if model in ("ggx", "beckmann") and "alpha_y" in given and "alpha" in given:
        given["alpha_x"] = given.pop("alpha")
    spec.update(given)
    if orientation is not None:
        spec["orientation_deg"] = orientation
    return spec


def _direction(theta_deg, phi_deg):
    th, ph = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])


def _stokes_maps(mueller, stokes_in):
    s = np.einsum("...ij,j->...i", mueller, stokes_in / stokes_in[0])
    return np.moveaxis(s, -1, 0)


def _dop_aop(stokes):
    i, q, u, v = stokes
    with np.errstate(divide="ignore", invalid="ignore"):
        dop = np.where(i > 0.0, np.sqrt(q * q + u * u + v * v) / np.where(i > 0.0, i, 1.0), 0.0)
    aop = 0.5 * np.degrees(np.arctan2(u, q))
    return dop, aop


def _totals(mueller, stokes_in):
    proj = projected_solid_angle()
    tot = np.einsum("ij,ijab->ab", proj, mueller)  # hemispherical Mueller matrix [-]
    s = tot @ (stokes_in / stokes_in[0])
    return tot, s


def _specular(mueller, wi):
    ws = np.array([-wi[0], -wi[1], wi[2]])
    row, col = _cells(ws[None, :])
    m = mueller[row[0], col[0]]
    norm = m[0, 0] if m[0, 0] != 0 else 1.0
    return {"cell": [int(row[0]), int(col[0])], "M00": float(m[0, 0]),
            "m12": float(m[0, 1] / norm), "m33": float(m[2, 2] / norm), "m34": float(m[2, 3] / norm)}


def run_brdf(*, n=None, eps=None, material=None, stack=None, frequency=None, wavelength=None,
             incidence=0.0, azimuth=0.0, stokes=(1.0, 0.0, 0.0, 0.0), model=None, ex=None, ey=None, m=None,
             alpha=None, alpha_y=None, gloss=None, orientation=None, method="mc", samples=1_000_000, seed=0,
             shadowing="smith", double=True, double_samples=256, mueller=False, threshold=1e-3, out=None,
             plots=True) -> BrdfResult:
    """The ``pmmw brdf`` job: build the surface, run the method(s), write the files.

    Parameters mirror the command-line options (docs/brdf.md). ``stack`` is a Stack or a path
    to a stack YAML file (then ``n``, ``eps``, ``material`` and the roughness options must be
    None). Angles in degrees. ``out`` None writes nothing.

    Returns
    -------
    BrdfResult
        ``summary`` holds, per method, ``total_reflectance`` (hemispherical integral of I over
        the incident I), the hemispherical Stokes vector and Mueller matrix, the specular cell's
        normalized Mueller elements, timings, and for ``mc`` the standard error,
        ``total_transmittance``, ``absorptance`` and ``lost``; plus ``flat_reflectance`` (the
        same stack with smooth interfaces).

    Raises
    ------
    UserError
        Bad options or stack file (with the option name or the file and key path).
    """
    t_start = time.perf_counter()
    if method not in METHODS:
        raise UserError(f"unknown method {method!r}; known: {', '.join(METHODS)}", "--method")
    if shadowing not in SHADOWING:
        raise UserError(f"unknown shadowing {shadowing!r}; known: {', '.join(SHADOWING)}", "--shadowing")
    try:
        stokes_in = np.array([float(v) for v in stokes], dtype=np.float64)
    except (TypeError, ValueError):
        raise UserError(f"expected four numbers I,Q,U,V, got {stokes!r}", "--stokes") from None
    if stokes_in.shape != (4,) or not np.all(np.isfinite(stokes_in)) or not stokes_in[0] > 0.0 or \
            np.sqrt(np.sum(stokes_in[1:] ** 2)) > stokes_in[0] * (1.0 + 1e-9):
        raise UserError(f"a Stokes vector needs I > 0 and Q^2 + U^2 + V^2 <= I^2, got {stokes!r}", "--stokes")
    if not (0.0 <= float(incidence) < 90.0):
        raise UserError(f"incidence must lie in [0, 90) degrees, got {incidence!r}", "--incidence")
    if not math.isfinite(float(azimuth)):
        raise UserError(f"azimuth must be finite, got {azimuth!r}", "--azimuth")
    if int(samples) < 1:
        raise UserError(f"samples must be >= 1, got {samples!r}", "--samples")
    if not (0.0 <= float(threshold) < 1.0):
        raise UserError(f"threshold must lie in [0, 1), got {threshold!r}", "--threshold")
    if int(double_samples) < 1:
        raise UserError(f"double-samples must be >= 1, got {double_samples!r}", "--double-samples")
    spec = roughness_spec_from_options(model, ex, ey, m, alpha, alpha_y, gloss, orientation)
    if stack is not None and (any(v is not None for v in (n, eps, material)) or spec is not None):
        raise UserError("--stack describes the layers and their roughness: drop --n/--eps/--material and the "
                        "roughness options", "--stack")
    try:
        if stack is not None:
            st = stack if isinstance(stack, Stack) else load_stack(stack, frequency=frequency, wavelength=wavelength)
        else:
            st = _stack_from_options(n, eps, material, spec, frequency, wavelength)
    except UserError as err:
        raise _option_error(err) from None
    wi = _direction(float(incidence), float(azimuth))
    methods = ("mc", "analytic") if method == "both" else (method,)
    results: dict[str, MethodResult] = {}
    proj = projected_solid_angle()
    flat_r = flat_reflectance(st, math.radians(float(incidence)))
    for meth in methods:
        t0 = time.perf_counter()
        if meth == "mc":
            tally = monte_carlo(st, wi, stokes_in, samples=int(samples), seed=int(seed), threshold=float(threshold))
            by_order = tally.by_order / (int(samples) * proj[None, :, :, None, None])
            mm = by_order.sum(axis=0)
            mean_i = tally.i_sum / int(samples) / stokes_in[0]
            var_i = max(tally.i_sq / int(samples) / stokes_in[0] ** 2 - mean_i ** 2, 0.0)
            extra = {
                "total_reflectance_stderr": math.sqrt(var_i / int(samples)),
                "total_transmittance": tally.transmitted / int(samples),
                "absorptance": tally.absorbed / int(samples),
                "lost": tally.lost / int(samples),
                "samples": int(samples),
                "facet_interactions_per_ray": tally.events / int(samples),
                "rejection_fallbacks": tally.fallback_weights,
                "reflectance_by_order": [float(np.einsum("ij,ij->", proj, by_order[o, :, :, 0, :] @ (stokes_in / stokes_in[0])))
                                         for o in range(3)],
            }
            parts = {"by_order": by_order}
        else:
            single, dbl = analytic(st, wi, shadowing=shadowing, double=bool(double),
                                   double_samples=int(double_samples), seed=int(seed))
            mm = single + dbl
            sn = stokes_in / stokes_in[0]
            if st.layers[0].roughness is None:
                t1, t2 = _totals(single, stokes_in)[0], np.zeros((4, 4))
            else:
                t1, t2 = analytic_totals(st, wi, shadowing=shadowing, double=bool(double), seed=int(seed))
            extra = {
                "shadowing": shadowing,
                "double": bool(double),
                "single_reflectance": float((t1 @ sn)[0]),
                "double_reflectance": float((t2 @ sn)[0]),
                "grid_total_reflectance": float(_totals(mm, stokes_in)[1][0]),
            }
            exact_tot = t1 + t2
            parts = {"single": single, "double": dbl}
        stk = _stokes_maps(mm, stokes_in)
        tot, s_tot = _totals(mm, stokes_in)
        if meth == "analytic":
            # facet-space quadrature: accurate also for lobes narrower than a grid cell
            tot = exact_tot
            s_tot = tot @ (stokes_in / stokes_in[0])
        summary = {
            "total_reflectance": float(s_tot[0]),
            "hemispherical_stokes": [float(v) for v in s_tot],
            "hemispherical_mueller": tot.tolist(),
            "specular": _specular(mm, wi),
            "seconds": time.perf_counter() - t0,
        }
        summary.update(extra)
        results[meth] = MethodResult(mueller=mm, stokes=stk, summary=summary, parts=parts)
    summary = {
        "incidence_deg": float(incidence),
        "azimuth_deg": float(azimuth),
        "stokes_in": [float(v) for v in stokes_in],
        "stack": _describe(st),
        "grid": {"rows": "zenith 0..90 deg (1 deg cells)", "columns": "azimuth 0..359 deg (1 deg cells)",
                 "shape": [N_THETA, N_PHI]},
        "flat_reflectance": flat_r,
        "methods": {k: v.summary for k, v in results.items()},
        "total_reflectance": results[methods[0]].summary["total_reflectance"],
    }
    files = []
    if out is not None:
        files = _write_outputs(Path(out), results, summary, wi, bool(mueller), bool(plots))
    summary["seconds"] = time.perf_counter() - t_start
    if out is not None:
        from pmmw_cli.io.atomic import write_text_atomic

        write_text_atomic(Path(out) / "brdf.json", json.dumps(summary, indent=2) + "\n")
    return BrdfResult(methods=results, summary=summary, files=files)


def _describe(st: Stack):
    layers = []
    for layer in st.layers:
        d = {"name": layer.name, "eps": [layer.eps.real, layer.eps.imag], "metal": layer.metal}
        if layer.roughness is not None:
            d["roughness"] = {"model": layer.roughness.name, **layer.roughness.params()}
        if layer.thickness is not None:
            d["thickness_m"] = layer.thickness
        if layer.coating:
            d["coating"] = [{"eps": [e.real, e.imag], "thickness_m": t} for e, t in layer.coating]
        layers.append(d)
    return {"ambient_eps": [st.ambient_eps.real, st.ambient_eps.imag], "frequency_hz": st.frequency, "layers": layers}


def _write_outputs(out: Path, results, summary, wi, mueller, plots):
    from pmmw_cli.io.exr import write_exr

    files = []
    for meth, res in results.items():
        dop, aop = _dop_aop(res.stokes)
        channels = {"I": res.stokes[0], "Q": res.stokes[1], "U": res.stokes[2], "V": res.stokes[3],
                    "DoP": dop, "AoP": aop}
        if mueller:
            for a in range(4):
                for b in range(4):
                    channels[f"M{a}{b}"] = res.mueller[:, :, a, b]
        attrs = {
            "pmmw:brdf:method": meth,
            "pmmw:brdf:incidence_deg": summary["incidence_deg"],
            "pmmw:brdf:azimuth_deg": summary["azimuth_deg"],
            "pmmw:brdf:stokes_in": summary["stokes_in"],
            "pmmw:brdf:total_reflectance": res.summary["total_reflectance"],
            "pmmw:brdf:grid": "rows zenith 0..90 deg, columns azimuth 0..359 deg, 1 deg cells (Optics Express 2016)",
            "pmmw:brdf:units": "I Q U V M: BRDF [1/sr] for incident I = 1; DoP [-]; AoP [deg]",
        }
        path = out / f"brdf_{meth}.exr"
        write_exr(path, channels, attrs)
        files.append(path)
        if plots:
            path = out / f"brdf_{meth}.png"
            _plot_maps(path, res, f"{meth}: total reflectance {res.summary['total_reflectance']:.4f}")
            files.append(path)
    if plots:
        path = out / "brdf_inplane.png"
        _plot_inplane(path, results, wi)
        files.append(path)
    return files


def _plot_maps(path: Path, res: MethodResult, title: str):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pmmw_cli.io.atomic import atomic_path

    dop, aop = _dop_aop(res.stokes)
    maps = [("I [1/sr]", res.stokes[0], "viridis"), ("Q [1/sr]", res.stokes[1], "RdBu_r"),
            ("U [1/sr]", res.stokes[2], "RdBu_r"), ("V [1/sr]", res.stokes[3], "RdBu_r"),
            ("DoP", dop, "magma"), ("AoP [deg]", aop, "twilight")]
    th_edges = np.concatenate([[0.0], np.arange(N_THETA - 1) + 0.5, [90.0]])
    ph_edges = np.radians(np.arange(N_PHI + 1) - 0.5)
    fig, axes = plt.subplots(2, 3, figsize=(12, 8), subplot_kw={"projection": "polar"})
    for ax, (name, data, cmap) in zip(axes.ravel(), maps):
        # colour limits from the 99.5th percentile: Monte Carlo cells near the pole and the
        # horizon have tiny projected solid angles and carry the largest noise
        lim = float(np.nanpercentile(np.abs(data[1:90]), 99.5)) or 1.0
        if cmap == "RdBu_r":
            kw = {"vmin": -lim, "vmax": lim}
        elif name.startswith("AoP"):
            kw = {"vmin": -90.0, "vmax": 90.0}
        else:
            kw = {"vmin": 0.0, "vmax": lim}
        pc = ax.pcolormesh(ph_edges, th_edges, data, cmap=cmap, shading="flat", **kw)
        ax.set_title(name)
        ax.set_ylim(0, 90)
        ax.set_yticks([30, 60, 90])
        ax.set_yticklabels([])
        fig.colorbar(pc, ax=ax, shrink=0.7)
    fig.suptitle(title)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=80, format="png")
    plt.close(fig)


def _plot_inplane(path: Path, results, wi):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pmmw_cli.io.atomic import atomic_path

    phi_s = round(math.degrees(math.atan2(-wi[1], -wi[0]))) % 360
    phi_b = (phi_s + 180) % 360
    fig, ax = plt.subplots(figsize=(7, 4.5))
    proj = projected_solid_angle()
    theta = np.arange(N_THETA - 1)  # the horizon row holds the singular cos -> 0 cells

    def profile(i_map, col, smooth):
        """Zenith profile at azimuth ``col``; Monte Carlo maps are averaged (projected solid
        angle weights) over +-2 degrees of azimuth, +-20 near the pole, all of row 0."""
        out = np.empty(theta.size)
        for r in theta:
            half = 0 if not smooth else (180 if r == 0 else max(2, 20 // r))
            cols = np.arange(col - half, col + half + 1) % N_PHI
            w = proj[r, cols]
            out[r] = np.sum(i_map[r, cols] * w) / np.sum(w)
        return out

    x = np.concatenate([-theta[::-1], theta[1:]])
    for meth, res in results.items():
        i_map = res.stokes[0]
        smooth = meth == "mc"
        y = np.concatenate([profile(i_map, phi_b, smooth)[::-1], profile(i_map, phi_s, smooth)[1:]])
        ax.plot(x, y, label=f"{meth} I" + (" (azimuth-averaged cells)" if smooth else " (cell centres)"), lw=1.2)
    ax.set_xlabel(f"zenith angle in the plane of incidence [deg] (positive: azimuth {phi_s} deg, specular side)")
    ax.set_ylabel("BRDF I [1/sr]")
    ax.set_yscale("log")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90, format="png")
    plt.close(fig)
