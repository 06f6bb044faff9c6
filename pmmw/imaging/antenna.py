"""A real antenna: the far-field beam of a circular aperture from its illumination, blockage and
spillover, and the beam's energy budget.

The aperture of radius a carries the field f(rho), rho = r / a in [0, 1], zero inside a central
blockage of diameter ratio b. Its far field is the Hankel transform (Silver 1949, ch. 6, the
circular aperture; Balanis 2016, ch. 12, circular apertures)

    F(u) = int_b^1 f(rho) J0(u rho) rho d rho,      u = k a sin(theta)                  (`pattern`)

and the power pattern |F(u) / F(0)|^2. The illuminations (`illumination`), with the edge's field
C = 10^(-T_e / 20) for an edge taper T_e [dB]:

- ``uniform``: f = 1: F(u) = J1(u) / u, the Airy pattern of Murakowski 2014 eq. 2.41.
- ``parabolic`` (parabolic on a pedestal): f = C + (1 - C)(1 - rho^2) (Balanis 2016, ch. 12, circular apertures;
  Silver 1949, Table 6.2, for C = 0).
- ``gaussian`` (a Gaussian feed beam truncated at the rim): f = exp(-ln(1/C) rho^2) (Goldsmith
  1998, the Gaussian illumination of an antenna).

Energy budget: the feed sends a fraction ``spillover`` of its power past the reflector, where the
beam sees ``spillover_temperature`` (the instrument, the ground, the sky); for a Gaussian feed it is
the edge taper in power, 10^(-T_e / 10) (Goldsmith 1998: the power of a Gaussian beam outside
radius a is exp(-2 a^2 / w^2), which is the edge taper). The rest forms the beam, whose energy
within angle u is (Parseval's theorem for the Hankel transform)

    EE(u) = int_0^u |F(u')|^2 u' du' / int_b^1 |f(rho)|^2 rho d rho                  (`encircled_energy`)

(for the uniform aperture Rayleigh's 1 - J0(u)^2 - J1(u)^2; Born & Wolf 1999, sec. 8.5.2, 0.838 at
the first null). The main-beam efficiency is (1 - spillover) EE(first null). The aperture
(taper) efficiency is eta_a = 2 |int f rho d rho|^2 / int |f|^2 rho d rho over the whole disc
(Balanis 2016, ch. 12, circular apertures; 1 for the uniform aperture, 0.75 for 1 - rho^2 as Silver 1949, Table 6.2,
1 - b^2 with a blockage b).

Sampling: an aperture of diameter D passes angular frequencies up to D / lambda [cycles/rad], so
the image is sampled without aliasing when the pixel pitch is at most lambda / (2 D) (the Nyquist
pitch; Goodman 2005, sec. 2.4). A coarser pitch under-samples the beam and aliases.

The sensor image is T_sensor = (1 - spillover) (PSF * T) + spillover T_spill in Ex2 and Ey2 (an
unpolarized spillover: none in U and V).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import j0

from pmmw.imaging.imager import PSF_ENERGY_TAIL, _airy_encircled_energy

ILLUMINATIONS = ("uniform", "parabolic", "gaussian")
_U_STEP = 0.01  # [-] table step in u = k a sin(theta): the pattern's finest structure has period ~pi
_MAX_RADIUS_PX = 256


def edge_field(edge_taper_db: float) -> float:
    """The edge's field relative to the centre, C = 10^(-T_e / 20), of an edge taper [dB]."""
    return 10.0 ** (-edge_taper_db / 20.0)


def illumination(
    rho: np.typing.ArrayLike, kind: str = "uniform", edge_taper_db: float = 0.0, blockage: float = 0.0
) -> np.ndarray:
    """Aperture field f(rho) [-] at normalized radius ``rho`` (ndarray in [0, 1]); zero inside the
    blockage (ratio of diameters ``blockage``)."""
    rho = np.asarray(rho, dtype=float)
    c = edge_field(edge_taper_db)
    if kind == "uniform":
        f = np.ones_like(rho)
    elif kind == "parabolic":
        f = c + (1.0 - c) * (1.0 - rho**2)
    elif kind == "gaussian":
        f = np.exp(-np.log(1.0 / c) * rho**2)
    else:
        raise ValueError(f"unknown illumination {kind!r}; known: {', '.join(ILLUMINATIONS)}")
    return np.where(rho < blockage, 0.0, f)


@dataclass(frozen=True)
class Aperture:
    """A circular aperture's illumination (module docstring)."""

    kind: str = "uniform"
    edge_taper_db: float = 0.0
    blockage: float = 0.0
    spillover: float = 0.0  # fraction of the feed's power that misses the reflector [-]
    spillover_temperature: float = 290.0  # [K]

    def _nodes(self, u_max: float) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-Legendre nodes and weights on [blockage, 1], enough for J0(u rho) up to ``u_max``."""
        n = int(max(64, u_max / 2.0 + 64))
        x, w = np.polynomial.legendre.leggauss(n)
        b = self.blockage
        rho = 0.5 * (1.0 - b) * x + 0.5 * (1.0 + b)
        return rho, 0.5 * (1.0 - b) * w

    def field(self, u: np.typing.ArrayLike) -> np.ndarray:
        """F(u) [-] (module docstring) at ``u`` = k a sin(theta) (ndarray)."""
        u = np.asarray(u, dtype=float)
        flat = u.ravel()
        rho, w = self._nodes(float(flat.max(initial=0.0)))
        fw = illumination(rho, self.kind, self.edge_taper_db, self.blockage) * rho * w
        out = np.empty_like(flat)
        for s in range(0, flat.size, 4096):  # rows of (4096, nodes): bounded memory
            out[s : s + 4096] = j0(np.outer(flat[s : s + 4096], rho)) @ fw
        return out.reshape(u.shape)

    def power(self, u: np.typing.ArrayLike) -> np.ndarray:
        """Normalized power pattern |F(u) / F(0)|^2 [-] (1 on axis)."""
        return (self.field(u) / self.field(np.zeros(1))[0]) ** 2

    def aperture_integrals(self) -> tuple[float, float]:
        """(int f rho d rho, int |f|^2 rho d rho) over the aperture."""
        rho, w = self._nodes(0.0)
        f = illumination(rho, self.kind, self.edge_taper_db, self.blockage)
        return float(np.sum(f * rho * w)), float(np.sum(f * f * rho * w))

    def taper_efficiency(self) -> float:
        """Aperture efficiency eta_a [-] (module docstring)."""
        s1, s2 = self.aperture_integrals()
        return 2.0 * s1 * s1 / s2

    def encircled_energy(self, u: np.typing.ArrayLike) -> np.ndarray:
        """Fraction of the beam's energy within ``u`` (ndarray of increasing u >= 0) by the
        trapezoidal rule on a `_U_STEP` grid, normalized by Parseval's aperture integral."""
        u = np.atleast_1d(np.asarray(u, dtype=float))
        grid = np.arange(0.0, u.max() + 2 * _U_STEP, _U_STEP / 4.0)
        g = self.field(grid) ** 2 * grid
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(grid))])
        return np.interp(u, grid, cum) / self.aperture_integrals()[1]

    def beam_shape(self, u_max: float = 40.0) -> dict:
        """Half-power full width, first null and first sidelobe of the pattern, in u: ``hpbw_u``
        (full width, u units), ``first_null_u``, ``first_sidelobe_dB``, ``first_sidelobe_u``."""
        u = np.arange(0.0, u_max, _U_STEP / 4.0)
        p = self.power(u)
        k = int(np.argmax(p < 0.5))
        # half power between u[k-1] and u[k], linearly
        u_half = u[k - 1] + (0.5 - p[k - 1]) * (u[k] - u[k - 1]) / (p[k] - p[k - 1])
        dp = np.diff(p)
        i_min = int(np.argmax(dp[k:] > 0)) + k  # first minimum after the half-power point
        i_max = int(np.argmax(dp[i_min:] < 0)) + i_min  # the sidelobe's peak after it
        return {
            "hpbw_u": float(2.0 * u_half),
            "first_null_u": float(u[i_min]),
            "first_sidelobe_u": float(u[i_max]),
            "first_sidelobe_dB": float(10.0 * np.log10(p[i_max])),
        }

    def main_beam_efficiency(self) -> float:
        """(1 - spillover) x the beam's energy within its first null [-]."""
        return float((1.0 - self.spillover) * self.encircled_energy(self.beam_shape()["first_null_u"])[0])


def gaussian_feed_spillover(edge_taper_db: float) -> float:
    """Spillover [-] of a Gaussian feed beam with edge taper T_e [dB] at the rim: 10^(-T_e/10)."""
    return 10.0 ** (-edge_taper_db / 10.0)


def antenna_kernel(
    pixel_angle: float, k0: float, aperture_diameter: float, aperture: Aperture, max_radius: int = _MAX_RADIUS_PX
) -> np.ndarray:
    """Pixel-integrated PSF of ``aperture``, normalized to unit sum (as `imaging.imager.psf_kernel`
    does for the Airy pattern, with the same radius: that enclosing all but `PSF_ENERGY_TAIL` of
    the Airy pattern's energy, which tapered beams' lower sidelobes enclose better).

    Returns
    -------
    ndarray, shape (2r+1, 2r+1), float64
    """
    a = aperture_diameter / 2.0
    xs = np.linspace(1.0, 1.5 * 2.0 / (np.pi * PSF_ENERGY_TAIL), 20000)
    x_max = xs[np.argmax(_airy_encircled_energy(xs) >= 1.0 - PSF_ENERGY_TAIL)]
    theta_max = np.arcsin(min(1.0, x_max / (k0 * a)))
    r = max(1, min(int(np.ceil(theta_max / pixel_angle)), max_radius))
    core = 3.8317 / (k0 * a)
    sub = int(np.clip(np.ceil(5.0 * pixel_angle / core), 3, 15)) | 1
    offs = (np.arange(sub) + 0.5) / sub - 0.5
    grid = np.arange(-r, r + 1, dtype=float)
    gx = (grid[:, None] + offs[None, :]).ravel() * pixel_angle
    tx, ty = np.meshgrid(gx, gx)
    u = k0 * a * np.sin(np.minimum(np.hypot(tx, ty), np.pi / 2))
    table_u = np.arange(0.0, u.max() + 2 * _U_STEP, _U_STEP)
    table = aperture.power(table_u)
    val = np.interp(u, table_u, table).reshape(2 * r + 1, sub, 2 * r + 1, sub).mean(axis=(1, 3))
    return val / val.sum()


def beam_report(aperture: Aperture, k0: float, aperture_diameter: float, pixel_angle: float) -> dict:
    """The beam's figures and energy budget as a report states them (angles in mrad)."""
    a = aperture_diameter / 2.0
    shape = aperture.beam_shape()
    lam = 2.0 * np.pi / k0
    nyquist = lam / (2.0 * aperture_diameter)
    spill = aperture.spillover
    in_null = float(aperture.encircled_energy(shape["first_null_u"])[0])
    return _floats(
        {
            "illumination": aperture.kind,
            **({"edge_taper_dB": aperture.edge_taper_db} if aperture.kind != "uniform" else {}),
            "blockage": aperture.blockage,
            "hpbw_mrad": 1e3 * float(np.arcsin(min(1.0, shape["hpbw_u"] / 2.0 / (k0 * a)))) * 2.0,
            "hpbw_lambda_over_D": shape["hpbw_u"] / np.pi,
            "first_null_mrad": 1e3 * float(np.arcsin(min(1.0, shape["first_null_u"] / (k0 * a)))),
            "first_sidelobe_dB": shape["first_sidelobe_dB"],
            "taper_efficiency": aperture.taper_efficiency(),
            "energy_budget": {
                "main_beam": (1.0 - spill) * in_null,
                "sidelobes": (1.0 - spill) * (1.0 - in_null),
                "spillover": spill,
                "spillover_temperature_K": aperture.spillover_temperature,
            },
            "main_beam_efficiency": (1.0 - spill) * in_null,
            "pixel_pitch_mrad": 1e3 * pixel_angle,
            "nyquist_pitch_mrad": 1e3 * nyquist,
            "pitch_over_nyquist": pixel_angle / nyquist,
            "sampling": (
                "under-sampled: the pixel pitch is coarser than lambda / 2D, the beam aliases"
                if pixel_angle > nyquist * (1 + 1e-9)
                else "Nyquist-sampled (pitch <= lambda / 2D)"
            ),
        }
    )


def _floats(d):
    """numpy scalars -> Python floats, through nested dicts (a report is YAML and JSON)."""
    return {
        k: _floats(v) if isinstance(v, dict) else float(v) if isinstance(v, np.floating) else v for k, v in d.items()
    }
