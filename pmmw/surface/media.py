"""The media of a scene at one frequency, as the surfaces and the tracer take them: each material's
kind (Murakowski 2014 sec. 2.2.9), permittivity, absorption, temperature, coherent coating films,
roughness, rough coating layers and bump map (`Media`), numbered as `pmmw.trace.job` says (0 the
ambient medium). `pmmw.trace.job.build_media` makes them from the materials database; the surface
layer (`pmmw.surface`) and the compiled kernels read them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Material kind codes (Murakowski 2014 sec. 2.2.9).
DIELECTRIC, METAL, BLACKBODY, OPAQUE, THIN = 0, 1, 2, 3, 4
KIND_CODES = {"dielectric": DIELECTRIC, "metal": METAL, "blackbody": BLACKBODY, "opaque": OPAQUE, "thin": THIN}


@dataclass(frozen=True)
class Coating:
    """A coherent layer stack on a surface, outermost layer first (Murakowski 2014 sec. 2.2.3).

    Attributes
    ----------
    eps : ndarray, shape (L,), complex128
    thickness : ndarray, shape (L,), float64 [m]
    temperature : float
        Temperature at which the stack's own absorption emits [K] (Murakowski 2014 eq. 2.36): the
        layers' temperatures weighted by eps'' x thickness, a proxy of each layer's share of the
        absorbed power for layers thinner than a penetration depth.
    """

    eps: np.ndarray
    thickness: np.ndarray
    temperature: float

    @classmethod
    def from_layers(cls, eps, thickness, temperatures):
        eps = np.asarray(eps, complex)
        thickness = np.asarray(thickness, float)
        temps = np.asarray(temperatures, float)
        w = np.maximum(eps.imag, 0.0) * thickness
        t = float(np.sum(w * temps) / np.sum(w)) if np.sum(w) > 0 else float(np.mean(temps))
        return cls(eps, thickness, t)


@dataclass(frozen=True)
class RoughLayer:
    """A coating layer with a rough top surface of its own: an incoherent layer (Optics Express 2016).

    Attributes
    ----------
    eps : complex
    alpha : float
        Power attenuation [Np/m] (2 k0 Im n).
    thickness : float [m]
    temperature : float [K]
    roughness : MicrofacetModel
        The model of its top surface.
    films : Coating or None
        Coherent films on its top surface (following its facets), outermost first.
    """

    eps: complex
    alpha: float
    thickness: float
    temperature: float
    roughness: object
    films: object = None


def split_coating(layers, k0):
    """A coating as the renderer traces it.

    Parameters
    ----------
    layers : sequence of (eps, thickness [m], temperature [K], roughness or None)
        Outermost first.
    k0 : float
        Free-space wavenumber [1/m].

    Returns
    -------
    rough : tuple of RoughLayer
        The layers with a rough top of their own, outermost first, each with the smooth films
        above it (down to the previous rough layer) as its coherent films.
    films : Coating or None
        The smooth films below the last rough layer: coherent, on the substrate's surface.
    """
    rough, films = [], []
    for eps, d, t, model in layers:
        if model is None:
            films.append((eps, d, t))
            continue
        eps = complex(eps)
        coat = Coating.from_layers(*zip(*films)) if films else None
        rough.append(RoughLayer(eps, 2.0 * k0 * np.sqrt(eps).imag, float(d), float(t), model, coat))
        films = []
    return tuple(rough), (Coating.from_layers(*zip(*films)) if films else None)


@dataclass(frozen=True)
class Media:
    """Optical properties of every medium at one frequency.

    Attributes
    ----------
    ids : list of str
        Names, index 0 = ``ambient``.
    eps : ndarray, shape (K,), complex128
        Relative permittivity (metal/blackbody: unused).
    kind : ndarray, shape (K,), int8
        Kind codes (`DIELECTRIC` ...).
    temperature : ndarray, shape (K,), float64 [K]
    alpha : ndarray, shape (K,), float64
        Power absorption coefficient [Np/m] (Murakowski 2014 eq. 2.37: alpha = 2 k0 Im n).
    coating : tuple of (Coating or None), length K
        For ``thin`` media the sheet itself is the last layer of the stack.
    roughness : tuple of (MicrofacetModel or None), length K or empty
        Microfacet roughness of each medium's surface (`pmmw.physics.roughness`); empty or
        None: smooth. A coating follows the facets (conformal coherent films).
    bump : tuple of (BumpMap or None), length K or empty
        Height map tilting each medium's macro surface normal (`pmmw.scene.bump`).
    layers : tuple of (tuple of RoughLayer), length K or empty
        Rough coating layers on each medium's surface, outermost first, above the coherent
        films of `coating` and the surface's own `roughness` (`split_coating`).
    """

    ids: list
    eps: np.ndarray
    kind: np.ndarray
    temperature: np.ndarray
    alpha: np.ndarray
    coating: tuple
    roughness: tuple = ()
    bump: tuple = ()
    layers: tuple = ()

    def rough(self, k: int):
        """The roughness model of medium k, or None."""
        return self.roughness[k] if k < len(self.roughness) else None

    def bump_map(self, k: int):
        """The bump map of medium k, or None."""
        return self.bump[k] if k < len(self.bump) else None

    def rough_layers(self, k: int) -> tuple:
        """The rough coating layers of medium k (empty: none)."""
        return self.layers[k] if k < len(self.layers) and self.layers[k] else ()

    @property
    def any_rough(self) -> bool:
        """Whether any surface is rough or bumped (smooth scenes skip all of that work)."""
        return any(r is not None for r in self.roughness) or any(b is not None for b in self.bump) or any(self.layers)
