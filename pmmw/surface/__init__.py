"""Layered surfaces: built once per material table and frequency, one call per bounce.

What pbrt's BxDFs and Mitsuba's BSDF plugins are to those renderers: the scene's media
(`pmmw.surface.media.Media`: smooth interfaces, coherent films, rough interfaces, bump maps,
rough coating layers) flattened into the compiled kernels' tables (`tables.kernel_tables`), and
`surfaces.Surfaces.interact`, which takes the rays of a wave that meet faces and returns their
children with the emission they deposit. The renderer, `pmmw brdf` and `pmmw po` all use it.
"""

from pmmw.surface.surfaces import Surfaces, deposit
from pmmw.surface.tables import Pile, kernel_tables, surface_coefficients, surface_response
from pmmw.surface.wave import Wave

__all__ = ["Pile", "Surfaces", "Wave", "deposit", "kernel_tables", "surface_coefficients", "surface_response"]
