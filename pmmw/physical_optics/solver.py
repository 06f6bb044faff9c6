"""Physical optics radar cross sections: `bistatic` and `monostatic` (Xia et al. 2023), from the
currents and far fields of `pmmw.physical_optics.currents` (its docstring: conventions and equations),
summed directly, by octree aggregation (`pmmw.physical_optics.octree`) or with the multiple bounces of
shooting and bouncing rays (`pmmw.physical_optics.sbr`).

The names of `pmmw.physical_optics.currents` are importable from here too (``solver.Target``, ...).
"""

from __future__ import annotations

import numpy as np

from pmmw.constants import C0  # noqa: F401  (re-exported)
from pmmw.physical_optics.currents import (  # noqa: F401  (re-exported)
    CALL_TERMS,
    ETA0,
    Target,
    call_slices,
    components,
    currents,
    direction,
    far_field,
    incident,
    lit_facets,
    make_target,
    radiation_vectors,
    surface_currents,
    theta_phi_hats,
    triangle_integral,
)

# `method="auto"` takes the octree from this many (lit facets x directions) on, and at least
# OCTREE_DIRECTIONS directions: there it beats the compiled direct sum (docs/benchmarks_po.md)
OCTREE_TERMS = 1e8
OCTREE_DIRECTIONS = 1000


def bistatic(
    target: Target,
    k0: float,
    theta_i: float,
    phi_i: float,
    polarization: str,
    theta,
    phi,
    bounces: int = 1,
    tube: float | None = None,
    method: str = "auto",
):
    """Bistatic RCS [m^2] (sigma_theta, sigma_phi) at observation angles [rad], and the number of
    lit facets. ``bounces`` > 1 adds the currents of waves reflected that many times, by shooting
    and bouncing ray tubes of side ``tube`` [m] (`pmmw.physical_optics.sbr`). ``method``: ``direct`` sums
    every facet for every direction; ``octree`` aggregates far fields up an octree
    (`pmmw.physical_optics.octree`, 1e-3 of the peak); ``auto`` takes the octree for many directions."""
    d_inc, e_inc = incident(theta_i, phi_i, polarization)
    lit, J, M = currents(target, d_inc, e_inc, k0)
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    shape = theta.shape
    th, ph = theta.ravel(), phi.ravel()
    r_hat = direction(th, ph)
    if method == "auto":
        big = th.size >= OCTREE_DIRECTIONS and float(lit.sum()) * th.size >= OCTREE_TERMS
        method = "octree" if big else "direct"
    if method == "octree":
        from pmmw.physical_optics.octree import far_field_octree

        ft, fp = far_field_octree(target, lit, J, M, -d_inc, k0, th, ph)
        N = L = np.zeros((th.size, 3), complex)
    else:
        N, L = radiation_vectors(target, lit, J, M, -d_inc, k0, r_hat)
        ft = fp = 0.0
    if bounces > 1:
        from pmmw.physical_optics.sbr import bounce_radiation

        N2, L2 = bounce_radiation(target, k0, d_inc, e_inc, bounces, r_hat, tube)
        N, L = N + N2, L + L2
    f2t, f2p = components(N, L, th, ph)
    ft, fp = ft + f2t, fp + f2p
    scale = k0 * k0 / (4.0 * np.pi)
    return (scale * np.abs(ft) ** 2).reshape(shape), (scale * np.abs(fp) ** 2).reshape(shape), int(lit.sum())


def monostatic(target: Target, k0: float, polarization: str, theta, phi, bounces: int = 1, tube: float | None = None):
    """Backscatter RCS [m^2] (sigma_theta, sigma_phi) with the radar at each of the angles [rad]
    (incidence = observation), and the lit facets at each."""
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    s_t, s_p, n_lit = np.zeros(theta.shape), np.zeros(theta.shape), np.zeros(theta.shape, int)
    for idx in np.ndindex(theta.shape):
        a, b, n = bistatic(
            target, k0, float(theta[idx]), float(phi[idx]), polarization, theta[idx], phi[idx], bounces, tube
        )
        s_t[idx], s_p[idx], n_lit[idx] = a, b, n
    return s_t, s_p, n_lit
