"""The media of a scene at one frequency, as the surfaces and the tracer take them: each material's
kind (Murakowski 2014 sec. 2.2.9), permittivity, absorption, temperature, coherent coating films,
roughness, rough coating layers and bump map (`Media`), numbered as `pmmw.trace.job` says (0 the
ambient medium), and the two places they are made: `build_media` from the materials database (a
scenario's materials at one frequency), `stack_media` from a reflectance stack (`pmmw.reflectance`).
The surface layer (`pmmw.surface`) and the compiled kernels read them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pmmw.constants import C0

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


def build_media(db, material_ids, f: float, t_default: float = 290.0, atm=None) -> Media:
    """Optical properties of the ambient medium and every material at frequency f [Hz]: the one
    place where a database material (`pmmw.scene.materials.MaterialDB` ``db``) becomes a
    medium of the tracer. ``t_default`` [K] for materials without a temperature, ``atm`` the
    scenario's atmosphere (a uniform one fills the ambient medium; None or layered: lossless air)."""
    k0 = 2.0 * np.pi * f / C0
    ids, eps, kind, temp, alpha, coat = ["ambient"], [1.0 + 0j], [DIELECTRIC], [], [], [None]
    rough, bump, stacks = [None], [None], [()]
    uniform = atm is not None and atm.model == "uniform"  # the layered model lives on the job
    temp.append(atm.temperature if uniform else t_default)
    alpha.append(atm.loss if uniform else 0.0)
    for mid in material_ids:
        m = db.get(mid)
        code = KIND_CODES[m.kind]
        t_m = m.temperature if m.temperature is not None else t_default
        e = m.eps_at(f, t_m) if m.has_eps() else 1.0 + 0j
        ids.append(mid)
        kind.append(code)
        eps.append(complex(e))
        temp.append(t_m)
        alpha.append(2.0 * k0 * np.sqrt(complex(e)).imag if code == DIELECTRIC else 0.0)
        rough.append(m.roughness)
        bump.append(m.bump)
        layers = []
        for layer in m.coating:
            lm = db.get(layer.material)
            t_l = layer.temperature_over(lm, t_m)
            layers.append((lm.eps_at(f, t_l), layer.thickness, t_l, layer.roughness))
        if code == THIN:
            layers.append((e, m.thickness or 0.0, t_m, None))
        rough_layers, films = split_coating(layers, k0)
        coat.append(films)
        stacks.append(rough_layers)
    return Media(
        ids,
        np.array(eps),
        np.array(kind, np.int8),
        np.array(temp, float),
        np.array(alpha, float),
        tuple(coat),
        tuple(rough),
        tuple(bump),
        tuple(stacks),
    )


def stack_media(stack, t_absorber: float = 1.0) -> Media:
    """A reflectance stack (`pmmw.reflectance.stack.Stack`) as the renderer's media: index 0 the
    ambient medium, index 1 the substrate with the stack's layers above it as rough coating layers
    (`RoughLayer`, each with its films and the roughness of its top), the substrate's own films
    and roughness, every absorber at ``t_absorber`` [K] (1 K: the brightness a path deposits is
    the power it loses).

    A layer without a thickness absorbs nothing on its way across (Optics Express 2016,
    assumption 3); what enters a lossy substrate stays there (an ``opaque`` body: its
    transmitted power is absorbed at the surface); a perfect conductor (``metal``) reflects
    everything."""
    k0 = stack.k0

    def films(layer):
        if not layer.coating:
            return None
        eps, thick = zip(*layer.coating)
        return Coating(np.array(eps, complex), np.array(thick, float), t_absorber)

    rough = []
    for layer in stack.layers[:-1]:
        eps = complex(layer.eps)
        lossy = layer.thickness is not None and k0 is not None
        alpha = 2.0 * k0 * np.sqrt(eps).imag if lossy else 0.0  # power attenuation [1/m] (PHYSICS.md)
        rough.append(RoughLayer(eps, alpha, float(layer.thickness or 0.0), t_absorber, layer.roughness, films(layer)))
    sub = stack.layers[-1]
    kind = METAL if sub.metal else OPAQUE if complex(sub.eps).imag > 0.0 else DIELECTRIC
    return Media(
        ids=["ambient", sub.name or "substrate"],
        eps=np.array([stack.ambient_eps, sub.eps], complex),
        kind=np.array([DIELECTRIC, kind], np.int8),
        temperature=np.full(2, t_absorber),
        alpha=np.zeros(2),
        coating=(None, films(sub)),
        roughness=(None, sub.roughness),
        bump=(),
        layers=((), tuple(rough)),
    )
