"""``pmmw brdf``: the polarized BRDF of a rough layered surface on Optics Express 2016's hemispherical grid.

Two methods share one surface description (`Stack`) and one output grid:

``mc``
    Optics Express 2016's Monte Carlo: rays enter from the incidence direction, meet rough interfaces whose
    facet normals come from `pmmw.physics.roughness`, split by the polarized Fresnel
    coefficients of `pmmw.physics.fresnel` / `pmmw.physics.multilayer` about each facet,
    and are followed through the layers until they leave the top surface (collected), enter the
    substrate, or are absorbed. It is the renderer's own code: the stack becomes one medium of
    the renderer's tables (`pmmw.surface.media.stack_media`: rough layers, films, roughness, a lossy
    substrate as an ``opaque`` sink) and each wave of facet events runs through
    `pmmw.surface.Surfaces` (roughness module docstring, "How the renderer uses this"): exact
    visible normals, Smith masking, masked and wrong-side rays re-hit the same interface, nothing
    is discarded. Each path carries a Jones matrix (the transpose of the renderer's M), so one run
    gives the whole Mueller matrix; the branch (reflected or transmitted) is drawn with
    probability proportional to the power it would carry (``render.strategy: stochastic``) and
    the Jones matrix is rescaled, so a lossless stack returns R + T = 1 to rounding, path by path.
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
the reflected waves are expressed in the basis of the global Z axis that `pmmw.physics.jones`
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

Modules
-------
``stack`` (the surface and its stack file), ``grid`` (the grid, the (h, v) basis, Jones ->
Mueller), ``optics`` (interfaces, facet bases, refraction, `flat_reflectance`), ``montecarlo``
(``mc``), ``analytic_model`` (``analytic``), ``command`` (`run_brdf`: options, the run, the
summary) and ``outputs`` (EXR maps, PNG plots); everything public is importable from here.
"""

from __future__ import annotations

from pmmw.reflectance.analytic_model import SHADOWING, analytic, analytic_mueller, analytic_totals
from pmmw.reflectance.command import METHODS, BrdfResult, MethodResult, roughness_spec_from_options, run_brdf
from pmmw.reflectance.command import _direction as _direction  # tests build directions with it
from pmmw.reflectance.grid import N_PHI, N_THETA, grid_directions, mueller_from_jones, projected_solid_angle
from pmmw.reflectance.montecarlo import monte_carlo
from pmmw.reflectance.optics import flat_reflectance
from pmmw.reflectance.stack import Stack, StackLayer, load_stack, parse_complex

__all__ = [
    "METHODS",
    "N_PHI",
    "N_THETA",
    "SHADOWING",
    "BrdfResult",
    "StackLayer",
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
