"""In-memory scenes for render tests: trimesh primitives -> a TraceJob, without YAML or files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from pmmw.physics.jones import stokes_images
from pmmw.physics.roughness import make_model
from pmmw.scene.camera import Camera
from pmmw.scene.sky import UniformSky
from pmmw.trace.integrator import Integrator
from pmmw.trace.intersect import make_intersector
from pmmw.trace.job import C0, DIELECTRIC, KIND_CODES, Media, RenderSettings, TraceJob, split_coating
from pmmw.trace.pool import assemble


def box(lo, hi):
    """Closed, outward-oriented box between corners lo and hi [m]."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    m.apply_translation((lo + hi) / 2)
    return m


def hollow_box(lo, hi, wall):
    """A closed shell: the wall volume between two boxes (the inner surface faces the cavity)."""
    outer = box(lo, hi)
    inner = box(np.asarray(lo) + wall, np.asarray(hi) - wall)
    inner.invert()
    return trimesh.util.concatenate([outer, inner])


def sphere(center, radius, subdivisions=3):
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    m.apply_translation(center)
    return m


def material(kind="dielectric", eps=1 + 0j, temperature=300.0, coating=(), thickness=None, roughness=None, bump=None):
    """A material spec: coating is a list of (eps, thickness [m], temperature [K][, roughness]),
    outermost first (a layer with a roughness model or record is a rough layer of its own);
    roughness a MicrofacetModel (or a record for `roughness.make_model`), bump a BumpMap."""
    if isinstance(roughness, dict):
        roughness = make_model(roughness)
    return dict(
        kind=kind,
        eps=complex(eps),
        temperature=float(temperature),
        coating=list(coating),
        thickness=thickness,
        roughness=roughness,
        bump=bump,
    )


def make_job(objects, camera, sky, frequency, settings=None, ambient=None):
    """objects: list of (trimesh.Trimesh, material spec). ambient: (alpha [Np/m], T [K]) or None."""
    k0 = 2 * np.pi * frequency / C0
    verts, faces, normals, fmed = [], [], [], []
    ids, eps, kind, temp, alpha, coat = ["ambient"], [1 + 0j], [DIELECTRIC], [], [], [None]
    rough, bumps, stacks = [None], [None], [()]
    temp.append(ambient[1] if ambient else 290.0)
    alpha.append(ambient[0] if ambient else 0.0)
    off = 0
    for i, (mesh, spec) in enumerate(objects):
        verts.append(np.asarray(mesh.vertices, float))
        faces.append(np.asarray(mesh.faces, np.int64) + off)
        normals.append(np.asarray(mesh.face_normals, float))
        fmed.append(np.full(len(mesh.faces), i + 1, np.int32))
        off += len(mesh.vertices)
        code = KIND_CODES[spec["kind"]]
        ids.append(f"m{i}")
        kind.append(code)
        eps.append(spec["eps"])
        temp.append(spec["temperature"])
        alpha.append(2 * k0 * np.sqrt(spec["eps"]).imag if code == DIELECTRIC else 0.0)
        rough.append(spec.get("roughness"))
        bumps.append(spec.get("bump"))
        layers = []
        for layer in spec["coating"]:  # (eps, thickness, temperature[, roughness])
            r = layer[3] if len(layer) > 3 else None
            layers.append((layer[0], layer[1], layer[2], make_model(r) if isinstance(r, dict) else r))
        if spec["kind"] == "thin":
            layers.append((spec["eps"], spec["thickness"], spec["temperature"], None))
        rough_layers, films = split_coating(layers, k0)
        coat.append(films)
        stacks.append(rough_layers)
    media = Media(
        ids,
        np.array(eps),
        np.array(kind, np.int8),
        np.array(temp),
        np.array(alpha),
        tuple(coat),
        tuple(rough),
        tuple(bumps),
        tuple(stacks),
    )
    return TraceJob(
        vertices=np.concatenate(verts),
        faces=np.concatenate(faces),
        face_normals=np.concatenate(normals),
        face_medium=np.concatenate(fmed),
        media=media,
        camera=camera,
        sky=sky,
        frequency=frequency,
        settings=settings or RenderSettings(spp=1, max_depth=8, threshold=1e-6, termination="temperature"),
    )


def render(job, intersector="embree"):
    """Render every tile in-process; returns the six channels as (H, W) arrays [K]."""
    integ = Integrator(job, make_intersector(job.vertices, job.faces, kind=intersector))
    results = [integ.render_tile(t) for t in job.tiles()]
    return stokes_images(assemble(job, results).mean)


def looking_down_at(theta_deg, height=1.0, width=1, height_px=1, fov_deg=0.01):
    """A camera at (0, 0, height) looking at the ground z=0 at incidence angle theta from the normal.

    The image x axis is horizontal, so Ex2 is s-polarized and Ey2 p-polarized for the ground.
    """
    th = np.radians(theta_deg)
    pos = np.array([0.0, 0.0, height])
    target = np.array([0.0, height * np.tan(th), 0.0])
    up = np.array([0.0, 0.0, 1.0]) if theta_deg > 1e-6 else np.array([0.0, 1.0, 0.0])
    return Camera.look_at(pos, target, up, np.radians(fov_deg), (width, height_px))


__all__ = ["box", "hollow_box", "sphere", "material", "make_job", "render", "looking_down_at", "UniformSky"]


def ground_and_block(folder):
    """The tiny scene of the CLI, sweep and API tests: ``ground.obj`` (a 40 m x 40 m slab whose top
    is z = 0) and ``block.obj`` (0.4 x 0.2 x 0.2 m, 4 m along +y) written into ``folder``."""
    ground = trimesh.creation.box(extents=[40, 40, 1])
    ground.apply_translation([0, 0, -0.5])
    block = trimesh.creation.box(extents=[0.4, 0.2, 0.2])
    block.apply_translation([0, 4, 0.1])
    ground.export(folder / "ground.obj")
    block.export(folder / "block.obj")


def tiny_scenario(tmp_path: Path, extra: str = "", render: str = "{spp: 2, max_depth: 4, tile: 8}") -> Path:
    """A 24 x 16 pixel scenario of `ground_and_block` (concrete ground, metal block) under a 40 K
    sky, written to ``tmp_path/tiny.yaml``; ``extra`` is appended YAML, ``render`` the render block."""
    ground_and_block(tmp_path)
    yaml = f"""
name: tiny
frequency: 35 GHz
imager: {{position: [0, 0, 1.5], look_at: [0, 4, 0.1], fov: 20 deg, resolution: [24, 16]}}
scene:
  - {{mesh: ground.obj, material: concrete}}
  - {{mesh: block.obj, material: metal}}
sky: {{model: uniform, temperature: 40 K}}
render: {render}
{extra}
"""
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml)
    return path
