"""Writing scenes as pmmw reads them: named Z-up meshes -> a Y-up glTF binary, checked.

The scene generators in ``scenes/`` build closed meshes in the world frame (Z up, metres), one
mesh material name per part (what a scenario maps to database ids), and write them with
`export_glb`; `check_glb` then proves that the file reads back with the same names and bounds
(`pmmw.scene.geometry.load_entry_mesh`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh
from trimesh.visual import TextureVisuals
from trimesh.visual.material import PBRMaterial

from pmmw.scene.geometry import Y_UP_TO_Z_UP, load_entry_mesh


def export_glb(nodes: dict, out: Path) -> None:
    """Write ``{node name: (material name, Z-up Trimesh)}`` as a Y-up GLB, atomically.

    Each node's vertices are stored (float32) about the whole metre nearest its centre and the
    node translation (float64 in the glTF JSON) adds it back, so small parts far from the origin
    keep their shape to float32 precision at their own size.
    """
    z_up_to_y_up = Y_UP_TO_Z_UP.T
    scene = trimesh.Scene()
    for name, (material, mesh) in nodes.items():
        offset = np.round(mesh.bounds.mean(axis=0))
        m = trimesh.Trimesh((mesh.vertices - offset) @ z_up_to_y_up.T, mesh.faces, process=False)
        m.visual = TextureVisuals(material=PBRMaterial(name=material))
        transform = np.eye(4)
        transform[:3, 3] = z_up_to_y_up @ offset
        scene.add_geometry(m, geom_name=name, node_name=name, transform=transform)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp.glb")
    scene.export(tmp, file_type="glb", tree_postprocessor=_state_y_up)
    tmp.replace(out)


def _state_y_up(tree: dict) -> None:
    """The file says it is Y-up (``asset.extras.up_axis``), so that pmmw reads it without the
    warning it gives other trimesh-written glTF files (`geometry.file_up_axis`)."""
    tree.setdefault("asset", {}).setdefault("extras", {})["up_axis"] = "Y"


def check_glb(nodes: dict, out: Path, expected: set | None = None) -> None:
    """Every part closed and outward; material names and bounds survive the GLB round trip.

    Raises
    ------
    ValueError
        Naming the first problem found.
    """
    for name, (_, mesh) in nodes.items():
        if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0.0):
            raise ValueError(f"{name}: not a closed outward mesh")
    parts = load_entry_mesh(out)
    names = {n for n, _ in parts}
    expected = {m for m, _ in nodes.values()} if expected is None else set(expected)
    if names != expected:
        raise ValueError(f"material names after the round trip: {sorted(names)}, expected {sorted(expected)}")
    loaded = np.concatenate([m.vertices for _, m in parts])
    built = np.concatenate([m.vertices for _, m in nodes.values()])
    tol = 1e-6 * max(1.0, float(np.abs(built).max()))  # float32 storage
    if not (np.allclose(loaded.min(0), built.min(0), atol=tol) and np.allclose(loaded.max(0), built.max(0), atol=tol)):
        raise ValueError("bounds changed in the round trip")
