"""The add-on's operators, panel and preferences (``bpy``): export the scenario, run ``pmmw render``
on it in the background, and load the EXR it writes into an image editor."""

from __future__ import annotations

import shlex
import subprocess
import tempfile
from pathlib import Path

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ExportHelper

from . import exporter, exr, mapping

ADDON = __package__


def _prefs(context):
    addon = context.preferences.addons.get(ADDON)
    return addon.preferences if addon else None


class PmmwPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON

    command: StringProperty(
        name="pmmw command",
        description="How to run pmmw: the pmmw program (on PATH or a full path), or e.g. '/path/to/python -m pmmw_cli'",
        default="pmmw",
    )
    extra: StringProperty(
        name="Extra render options",
        description="Options added to 'pmmw render', e.g. '--spp 4 --workers 2'",
        default="",
    )

    def draw(self, context):
        self.layout.prop(self, "command")
        self.layout.prop(self, "extra")


def _report_problems(op, e: mapping.ExportError):
    for p in getattr(e, "problems", [e]):
        op.report({"ERROR"}, str(p))


class PMMW_OT_export(bpy.types.Operator, ExportHelper):
    """Export the scene as a pmmw scenario: YAML plus one GLB per mesh object"""

    bl_idname = "export_scene.pmmw"
    bl_label = "Export pmmw scenario"
    filename_ext = ".yaml"
    filter_glob: StringProperty(default="*.yaml;*.yml", options={"HIDDEN"})

    def execute(self, context):
        try:
            path, notes = exporter.export(context, self.filepath)
        except mapping.ExportError as e:
            _report_problems(self, e)
            return {"CANCELLED"}
        for n in notes:
            self.report({"WARNING"}, n)
        self.report({"INFO"}, f"pmmw scenario written: {path}")
        return {"FINISHED"}


def _work_folder() -> Path:
    if bpy.data.filepath:
        blend = Path(bpy.data.filepath)
        return blend.parent / f"{blend.stem}_pmmw"
    return Path(tempfile.mkdtemp(prefix="pmmw-blender-"))


CHANNELS = ("I", "Q", "U", "V", "Ex2", "Ey2")


def load_result(context, path: Path) -> list:
    """pmmw's EXR as Blender images, one per sensor channel (``"example I [K]"``: float pixels in
    kelvin, grey, row 0 of the EXR at the top), and its display-scaled preview of I shown in an
    image editor if the screen has one.

    Blender's own EXR reader takes only R, G, B, A-like channel names, so the EXR is read by
    `exr.read` and the images are made from its arrays.

    Returns
    -------
    list of bpy.types.Image
        The channel images, then the preview if pmmw wrote one.
    """
    import numpy as np

    channels = exr.read(path)
    images = []
    for name in CHANNELS:
        if name not in channels:
            continue
        a = channels[name]
        h, w = a.shape
        title = f"{path.stem} {name} [K]"
        image = bpy.data.images.get(title)
        if image is not None and tuple(image.size) != (w, h):
            bpy.data.images.remove(image)
            image = None
        if image is None:
            image = bpy.data.images.new(title, w, h, alpha=False, float_buffer=True)
        image.colorspace_settings.name = "Non-Color"
        rgba = np.ones((h, w, 4), np.float32)
        rgba[..., :3] = a[::-1, :, None]  # Blender's rows go bottom up
        image.pixels.foreach_set(rgba.ravel())
        image.update()
        images.append(image)
    preview = path.parent / "previews" / f"{path.stem}_I.png"
    shown = images[0] if images else None
    if preview.is_file():
        shown = bpy.data.images.load(str(preview), check_existing=True)
        shown.reload()
        images.append(shown)
    for area in context.screen.areas if context.screen else []:
        if area.type == "IMAGE_EDITOR" and shown is not None:
            area.spaces.active.image = shown
            break
    return images


class PMMW_OT_render(bpy.types.Operator):
    """Export the scene, render it with pmmw in the background and show the image"""

    bl_idname = "render.pmmw"
    bl_label = "Render with pmmw"

    _proc = None
    _timer = None

    def execute(self, context):
        folder = _work_folder()
        folder.mkdir(parents=True, exist_ok=True)
        try:
            self._scenario, notes = exporter.export(context, folder / f"{_name(context)}.yaml")
        except mapping.ExportError as e:
            _report_problems(self, e)
            return {"CANCELLED"}
        for n in notes:
            self.report({"WARNING"}, n)
        prefs = _prefs(context)
        command = shlex.split(prefs.command if prefs else "pmmw")
        extra = shlex.split(prefs.extra) if prefs else []
        self._out = folder / "out"
        args = [*command, "render", str(self._scenario), "--out", str(self._out), "--quiet", *extra]
        self._log = open(folder / "pmmw.log", "w")
        try:
            self._proc = subprocess.Popen(args, stdout=self._log, stderr=subprocess.STDOUT)
        except OSError as e:
            self._log.close()
            self.report(
                {"ERROR"}, f"cannot run {command[0]!r} ({e.strerror}): set the pmmw command in the add-on's preferences"
            )
            return {"CANCELLED"}
        if bpy.app.background or context.window is None:  # no window to wait in (a script): wait here
            self._proc.wait()
            return self._finish(context)
        self.report({"INFO"}, f"pmmw is rendering {self._scenario.name} (log: {folder / 'pmmw.log'})")
        self._timer = context.window_manager.event_timer_add(0.5, window=context.window)
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type != "TIMER" or self._proc.poll() is None:
            return {"PASS_THROUGH"}
        context.window_manager.event_timer_remove(self._timer)
        return self._finish(context)

    def _finish(self, context):
        self._log.close()
        log = Path(self._log.name).read_text(errors="replace").strip().splitlines()
        if self._proc.returncode != 0:
            self.report({"ERROR"}, log[-1] if log else f"pmmw exited with status {self._proc.returncode}")
            return {"CANCELLED"}
        loaded = []
        for path in sorted(self._out.glob("*.exr")):
            try:
                loaded += load_result(context, path)
            except (OSError, exr.ExrError) as e:
                self.report({"WARNING"}, f"{path.name}: {e}")
        self.report({"INFO"}, f"{log[-1] if log else 'pmmw finished'}; {len(loaded)} image(s) loaded")
        return {"FINISHED"}


def _name(context) -> str:
    stem = Path(bpy.data.filepath).stem if bpy.data.filepath else context.scene.name
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in stem) or "scene"


class PMMW_PT_panel(bpy.types.Panel):
    bl_label = "pmmw"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"

    def draw(self, context):
        col = self.layout.column()
        col.operator(PMMW_OT_render.bl_idname, icon="RENDER_STILL")
        col.operator(PMMW_OT_export.bl_idname, icon="EXPORT")
        col.label(text=f"Frequency: {context.scene.get('pmmw:frequency', mapping.DEFAULT_FREQUENCY)}")


def _export_menu(self, context):
    self.layout.operator(PMMW_OT_export.bl_idname, text="pmmw scenario (.yaml)")


def _render_menu(self, context):
    self.layout.operator(PMMW_OT_render.bl_idname)


CLASSES = (PmmwPreferences, PMMW_OT_export, PMMW_OT_render, PMMW_PT_panel)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.TOPBAR_MT_file_export.append(_export_menu)
    bpy.types.TOPBAR_MT_render.append(_render_menu)


def unregister():
    bpy.types.TOPBAR_MT_render.remove(_render_menu)
    bpy.types.TOPBAR_MT_file_export.remove(_export_menu)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
