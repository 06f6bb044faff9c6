"""The trace job: everything a worker needs to render tiles, as plain arrays.

Built once in the main process by `pmmw.pipeline` from the resolved scenario, then handed to
workers (inherited on fork). Media are numbered: 0 is the ambient medium (air, or vacuum with
``atmosphere: none``), 1.. are the scene's materials in `SceneGeometry.material_ids` order.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pmmw.constants import C0
from pmmw.scene.camera import Camera

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
        return (any(r is not None for r in self.roughness) or any(b is not None for b in self.bump)
                or any(self.layers))


@dataclass(frozen=True)
class RenderSettings:
    spp: int = 16
    max_depth: int = 32
    threshold: float = 1e-3
    seed: int = 1
    termination: str = "roulette"  # or "temperature" (Murakowski 2014 sec. 2.2.9)
    strategy: str = "split"  # "split" (Murakowski 2014), "stochastic", or "hybrid"
    split_depth: int = 2  # hybrid: interactions split deterministically before choosing
    target_error: float | None = None  # [K] adaptive sampling goal (per pixel, or after the PSF)
    min_spp: int = 4  # adaptive sampling: first pass
    # target_error / this is the error a pixel must reach: 1 / sqrt(sum psf^2) when the imager
    # blurs (`pmmw.imaging.imager.error_footprint`), 1 for an ideal imager
    error_footprint: float = 1.0
    # [K] largest change of any pixel's Ex2, Ey2 allowed from skipping the layered atmosphere on
    # short segments (`pmmw.trace.integrator.atmosphere_skip_length`); 0: never skip
    atmosphere_tolerance: float = 0.01
    tile: int = 64
    stack_size: int = 8
    aux: tuple = ()


@dataclass(frozen=True)
class TraceJob:
    """One frequency of one scenario, ready to trace.

    Attributes
    ----------
    vertices : ndarray, shape (V, 3), float64 [m]
    faces : ndarray, shape (F, 3), int64
    face_normals : ndarray, shape (F, 3), float64
        Outward unit normals (counter-clockwise winding).
    face_medium : ndarray, shape (F,), int32
        Medium index of each face's object (>= 1).
    media : Media
    camera : Camera
    sky : object with ``brightness(directions) -> (Tv, Th)`` and ``unpolarized``
    frequency : float [Hz]
    settings : RenderSettings
    atmosphere : AtmosphereModel or None
        The layered atmosphere along paths in the ambient medium (``path(z0, z1, length)``);
        None for vacuum or the uniform ambient medium of `Media`.
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_normals: np.ndarray
    face_medium: np.ndarray
    media: Media
    camera: Camera
    sky: object
    frequency: float
    settings: RenderSettings = field(default_factory=RenderSettings)
    atmosphere: object = None  # AtmosphereModel: attenuation and emission along ambient paths

    @property
    def k0(self) -> float:
        """Free-space wavenumber [1/m]."""
        return 2.0 * np.pi * self.frequency / C0

    def tiles(self):
        """Fixed tiling of the image: list of (index, x0, y0, x1, y1), independent of workers."""
        ts = self.settings.tile
        w, h = self.camera.width, self.camera.height
        out = []
        for y0 in range(0, h, ts):
            for x0 in range(0, w, ts):
                out.append((len(out), x0, y0, min(x0 + ts, w), min(y0 + ts, h)))
        return out


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
            t_l = layer.temperature if layer.temperature is not None else (lm.temperature if lm.temperature is not None else t_m)
            layers.append((lm.eps_at(f, t_l), layer.thickness, t_l, layer.roughness))
        if code == THIN:
            layers.append((e, m.thickness or 0.0, t_m, None))
        rough_layers, films = split_coating(layers, k0)
        coat.append(films)
        stacks.append(rough_layers)
    return Media(ids, np.array(eps), np.array(kind, np.int8), np.array(temp, float), np.array(alpha, float),
                 tuple(coat), tuple(rough), tuple(bump), tuple(stacks))
