"""Blender's scene -> a pmmw scenario folder (``bpy``): each visible mesh object one GLB by Blender's
glTF exporter, the camera, materials and custom properties read into the plain records that
`mapping` turns into the scenario, written as YAML."""

from __future__ import annotations

import os
import re
from pathlib import Path

import bpy

from . import mapping

# Blender's glTF exporter: +Y up (glTF's own convention, which pmmw turns back to Z up on load),
# modifiers applied, material names kept (they are what the scenario maps) but no textures.
GLTF_OPTIONS = {
    "export_format": "GLB",
    "use_selection": True,
    "export_yup": True,
    "export_apply": True,
    "export_materials": "EXPORT",
    "export_image_format": "NONE",
    "export_texcoords": False,
    "export_normals": False,
    "export_cameras": False,
    "export_lights": False,
    "export_animations": False,
    "export_skins": False,
    "export_morph": False,
    "export_extras": False,
}


def _props(idblock) -> dict:
    """An ID's or object's custom properties as plain Python values."""
    out = {}
    for k in idblock.keys():
        v = idblock[k]
        if hasattr(v, "to_dict"):
            v = v.to_dict()
        elif hasattr(v, "to_list"):
            v = v.to_list()
        out[k] = v
    return out


def _camera(scene) -> dict | None:
    cam = scene.camera
    if cam is None:
        return None
    data, render = cam.data, scene.render
    focus = None
    if data.dof.use_dof:
        if data.dof.focus_object is not None:
            focus = (data.dof.focus_object.matrix_world.translation - cam.matrix_world.translation).length
        else:
            focus = data.dof.focus_distance
    return {
        "name": cam.name,
        "matrix_world": [list(row) for row in cam.matrix_world],
        "type": data.type,
        "lens": data.lens,
        "sensor_width": data.sensor_width,
        "sensor_height": data.sensor_height,
        "sensor_fit": data.sensor_fit,
        "shift_x": data.shift_x,
        "shift_y": data.shift_y,
        "resolution": [render.resolution_x, render.resolution_y],
        "percentage": render.resolution_percentage,
        "pixel_aspect": [render.pixel_aspect_x, render.pixel_aspect_y],
        "focus_distance": focus,
        "props": _props(cam),
    }


def mesh_objects(scene, view_layer) -> list:
    """The objects exported: visible in renders, in the view layer, of type mesh; by name."""
    names = {o.name for o in view_layer.objects}
    return sorted(
        (o for o in scene.objects if o.type == "MESH" and not o.hide_render and o.name in names), key=lambda o: o.name
    )


def _slots(obj) -> list[dict]:
    used = {p.material_index for p in obj.data.polygons}
    if not obj.material_slots:
        return []
    top = len(obj.material_slots) - 1
    used = {min(i, top) for i in used}  # Blender draws an index past the slots with the last one
    return [
        {
            "name": s.material.name if s.material else None,
            "props": _props(s.material) if s.material else {},
            "used": i in used,
        }
        for i, s in enumerate(obj.material_slots)
    ]


def _file_name(name: str, taken: set) -> str:
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "object"
    out, n = stem, 2
    while out.lower() in taken:
        out, n = f"{stem}_{n}", n + 1
    taken.add(out.lower())
    return f"{out}.glb"


def _export_glb(context, obj, path: Path) -> None:
    allowed = set(bpy.ops.export_scene.gltf.get_rna_type().properties.keys())
    options = {k: v for k, v in GLTF_OPTIONS.items() if k in allowed}
    view_layer = context.view_layer
    was = {o.name: o.select_get() for o in view_layer.objects}
    active = view_layer.objects.active
    hidden = obj.hide_get()
    try:
        obj.hide_set(False)
        for o in view_layer.objects:
            o.select_set(o == obj)
        view_layer.objects.active = obj
        result = bpy.ops.export_scene.gltf(filepath=str(path), **options)
        if "FINISHED" not in result:
            raise mapping.ExportError(
                f"Blender's glTF exporter did not finish ({sorted(result)})", f"object {obj.name!r}"
            )
    finally:
        obj.hide_set(hidden)
        for o in view_layer.objects:
            o.select_set(was.get(o.name, False))
        view_layer.objects.active = active


def export(context, yaml_path) -> tuple[Path, list[str]]:
    """Write the scenario of ``context.scene`` to ``yaml_path``, its GLBs into ``<stem>_meshes/``
    beside it.

    Returns
    -------
    (Path, list of str)
        The scenario file and notes for the user (objects left out).

    Raises
    ------
    mapping.ExportError
        The scene cannot be exported (every problem found, the first raised; ``problems`` on it).
    """
    scene = context.scene
    yaml_path = Path(yaml_path).resolve()
    folder = yaml_path.parent / f"{yaml_path.stem}_meshes"
    notes = [
        f"object {o.name!r} ({o.type.lower()}) is not a mesh: left out (Object > Convert > Mesh)"
        for o in scene.objects
        if o.type in ("CURVE", "SURFACE", "META", "FONT") and not o.hide_render
    ]
    notes += [
        f"object {o.name!r} instances a collection: left out (Object > Apply > Make Instances Real)"
        for o in scene.objects
        if o.type == "EMPTY" and o.instance_type == "COLLECTION" and not o.hide_render
    ]
    objects = mesh_objects(scene, context.view_layer)
    records, taken = [], set()
    for obj in objects:
        name = _file_name(obj.name, taken)
        records.append(
            {
                "name": obj.name,
                "mesh": f"{folder.name}/{name}",
                "props": _props(obj),
                "slots": _slots(obj),
                "file": folder / name,
            }
        )
    regions = [
        {"name": o.name, "location": list(o.matrix_world.translation), "radius": o["pmmw_region"]}
        for o in scene.objects
        if "pmmw_region" in o.keys()
    ]
    record = {
        "camera": _camera(scene),
        "objects": records,
        "regions": regions,
        "props": _props(scene),
        "scale": scene.unit_settings.scale_length if scene.unit_settings.system != "NONE" else 1.0,
    }
    data, errors = mapping.build(record)
    if errors:
        err = errors[0]
        err.problems = errors
        raise err
    folder.mkdir(parents=True, exist_ok=True)
    for obj, r in zip(objects, records):
        _export_glb(context, obj, r["file"])
    text = (
        f"# pmmw scenario exported from Blender {bpy.app.version_string}"
        f" ({Path(bpy.data.filepath).name or 'unsaved file'}, scene {scene.name!r}) by the pmmw add-on\n"
    )
    tmp = yaml_path.with_name(yaml_path.name + ".tmp")
    tmp.write_text(text + mapping.to_yaml(data) + "\n", encoding="utf-8")
    os.replace(tmp, yaml_path)
    return yaml_path, notes
