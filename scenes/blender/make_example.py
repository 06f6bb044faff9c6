"""Make scenes/blender/example.blend, the add-on's example scene: a metal box standing on a concrete
ground, a warm water-filled tank (a cylinder at 310 K) beside it, looked at from 6 m by a 40 x 30
pixel camera at 95 GHz. Everything pmmw reads from a .blend is on it: material names as database
ids, a material's ``pmmw_material``, ``pmmw_temperature`` and ``pmmw_roughness`` custom properties,
an object's ``pmmw_coating``, a region (an empty with ``pmmw_region``) and the Scene's ``pmmw:KEY``
properties (docs/blender.md).

Run with a Python that has Blender's ``bpy`` package (``pip install 'pmmw[blender]'``)::

    python scenes/blender/make_example.py            # writes scenes/blender/example.blend
"""

import math
import sys
from pathlib import Path

import bpy
from mathutils import Vector

OUT = Path(__file__).resolve().with_name("example.blend")


def material(name, **props):
    m = bpy.data.materials.new(name)
    for k, v in props.items():
        m[k] = v
    return m


def add(obj, mat):
    obj.data.materials.append(mat)
    return obj


def main(out: Path = OUT) -> Path:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    # the ground: a 12 x 12 m slab, 0.2 m thick (closed, so the tracer knows its inside)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 3.0, -0.1))
    ground = bpy.context.object
    ground.name, ground.scale = "Ground", (12.0, 12.0, 0.2)
    add(ground, material("concrete"))  # the material's name is the database id
    # a metal box, taller than wide so an upside-down or lying export would show: 0.6 x 0.6 x 1.2 m
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-0.8, 3.0, 0.6))
    box = bpy.context.object
    box.name, box.scale = "Box", (0.6, 0.6, 1.2)
    box.rotation_euler = (0.0, 0.0, math.radians(20.0))
    add(box, material("Steel", pmmw_material="metal", pmmw_roughness=0.1))
    # a warm tank of water in a plastic shell: material by custom property, its temperature, and
    # a coating on the object
    bpy.ops.mesh.primitive_cylinder_add(vertices=24, radius=0.35, depth=0.9, location=(0.8, 3.2, 0.45))
    tank = bpy.context.object
    tank.name = "Tank"
    add(tank, material("Warm water", pmmw_material="water", pmmw_temperature=310.0))
    tank["pmmw_coating"] = "polyethylene 2 mm"
    # a region of the report on the tank's side facing the camera
    bpy.ops.object.empty_add(location=(0.8, 2.85, 0.45))
    bpy.context.object.name = "tank"
    bpy.context.object["pmmw_region"] = 2.0
    # the camera: 6 m away, 1.6 m up, looking at the box and tank
    bpy.ops.object.camera_add(location=(0.0, -3.0, 1.6))
    cam = bpy.context.object
    cam.name = "Imager"
    cam.rotation_euler = Vector((0.0, 6.0, -1.0)).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens, cam.data.sensor_width, cam.data.sensor_fit = 35.0, 36.0, "HORIZONTAL"
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 40, 30, 100
    scene["pmmw:frequency"] = "95 GHz"
    scene["pmmw:sky.model"] = "uniform"
    scene["pmmw:sky.temperature"] = "60 K"
    scene["pmmw:atmosphere"] = "none"
    scene["pmmw:render.spp"] = 4
    scene["pmmw:render.seed"] = 1
    bpy.context.preferences.filepaths.save_version = 0  # no example.blend1 backup
    bpy.ops.wm.save_as_mainfile(filepath=str(out), compress=True)
    return out


if __name__ == "__main__":
    print(main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT))
