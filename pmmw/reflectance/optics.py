"""Surface optics of the analytic model: the interfaces of a `Stack` with their polarized Fresnel
coefficients (bare, coated or metal), the facet's (s, p) basis, and the reflectance of the same
stack made smooth. (The Monte Carlo traces the stack through the renderer's surface layer,
`pmmw.surface`.)
"""

from __future__ import annotations

import math

import numpy as np

from pmmw.arrays import FloatArray
from pmmw.physics import fresnel, multilayer
from pmmw.physics.fresnel import Fresnel
from pmmw.physics.vec import cross, dot, unit
from pmmw.reflectance.stack import Stack

__all__ = ["flat_reflectance"]

# Floor of the powers that branch weights are divided by.
_TINY = 1e-300


def _amplitude(amp: np.ndarray, power: np.ndarray) -> np.ndarray:
    """An amplitude with the phase of ``amp`` and the magnitude sqrt(power) (renormalized R, T)."""
    mag = np.abs(amp)
    phase = np.where(mag > 0.0, amp / np.where(mag > 0.0, mag, 1.0), 1.0)
    return phase * np.sqrt(np.maximum(power, 0.0))


def _facet_basis(m: FloatArray, k: FloatArray, s_fallback: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Local s = unit(m x k) (jones.py with the facet normal), p = k x s; fallback at normal incidence."""
    s = cross(m, k)
    norm = np.linalg.norm(s, axis=1)
    ok = norm > 1e-12
    s = np.where(ok[:, None], s / np.where(ok, norm, 1.0)[:, None], s_fallback)
    if not np.all(ok):
        # any s perpendicular to k does at normal incidence (r_p = -r_s there)
        sf = s[~ok] - dot(s[~ok], k[~ok])[:, None] * k[~ok]
        s[~ok] = unit(sf)
    return s, cross(k, s)


class _Interface:
    """Interface ``i`` between media i (above) and i+1 (below) of a stack, top of layer i."""

    def __init__(self, stack: Stack, i: int) -> None:
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

    def fresnel(self, cos1: np.ndarray, from_above: bool) -> Fresnel:
        """Facet coefficients for rays crossing from the side ``from_above`` (N,) cosines."""
        n = cos1.shape[0]
        eps1, eps2 = (self.above, self.below) if from_above else (self.below, self.above)
        if not self.coating and not self.metal:
            return fresnel.interface(np.full(n, eps1), np.full(n, eps2), cos1)
        films = list(self.coating) if from_above else list(self.coating)[::-1]
        eps = np.array([eps1] + [e for e, _ in films] + [eps2], dtype=np.complex128)
        thick = np.array([d for _, d in films], dtype=np.float64)
        k0 = self.k0 if self.k0 is not None else 1.0  # films need k0 (checked at load time)
        return multilayer.stack(
            eps[None, :], thick[None, :], cos1, k0, substrate="metal" if self.metal else "dielectric"
        )


def flat_reflectance(stack: Stack, theta_i: float) -> float:
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

    def cos_in(j: int) -> float:
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
