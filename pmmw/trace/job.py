"""The trace job: everything a worker needs to render tiles, as plain arrays.

Built once in the main process by `pmmw.pipeline` from the resolved scenario, then handed to
workers (inherited on fork). Media are numbered: 0 is the ambient medium (air, or vacuum with
``atmosphere: none``), 1.. are the scene's materials in `SceneGeometry.material_ids` order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from pmmw.constants import C0
from pmmw.scene.camera import Camera
from pmmw.surface.media import (  # noqa: F401  (the media live below the tracer; re-exported, build_media as docs/ARCHITECTURE.md says)
    BLACKBODY,
    DIELECTRIC,
    KIND_CODES,
    METAL,
    OPAQUE,
    THIN,
    Coating,
    Media,
    RoughLayer,
    build_media,
    split_coating,
)

if TYPE_CHECKING:
    from pmmw.atmosphere.model import AtmosphereModel


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
    atmosphere: AtmosphereModel | None = None  # attenuation and emission along ambient paths

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
