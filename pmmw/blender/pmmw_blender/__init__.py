"""pmmw for Blender: export the scene as a pmmw scenario (File > Export > pmmw scenario), render it
with pmmw and see the result in Blender's image editor (Render > Render with pmmw).

Install: Edit > Preferences > Add-ons (Get Extensions in Blender 4.2+) > Install from Disk, and
pick the zip that ``make blender-addon`` builds (docs/blender.md). ``bpy`` is imported only when
Blender registers the add-on, so `mapping` runs and is tested without Blender.
"""

bl_info = {
    "name": "pmmw: passive millimetre-wave imaging",
    "author": "pmmw",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "File > Export > pmmw scenario (.yaml); Render > Render with pmmw",
    "description": "Export the scene as a pmmw scenario, render it with pmmw, show the EXR",
    "doc_url": "",
    "category": "Import-Export",
}


def register():
    from . import operators

    operators.register()


def unregister():
    from . import operators

    operators.unregister()
