"""Blender's scene, as plain data, -> a pmmw scenario mapping. Pure Python: no ``bpy`` here, so it
runs (and is tested) without Blender; `exporter` reads ``bpy`` into the plain records this takes.

What maps to what (docs/blender.md):

* The active camera is the imager: its world position, its view direction (the camera's -Z axis)
  and up (its +Y axis); the horizontal field of view from the lens, the sensor and its fit, and the
  render resolution (``resolution_x/y`` times ``resolution_percentage``).
* Each visible mesh object is one scene entry with its own GLB (Blender's glTF exporter, +Y up as
  glTF requires; pmmw turns glTF's Y-up to its Z-up on load, so the object lands as it stood).
* A material's database id is its custom property ``pmmw_material``, else the material's name;
  an object's ``pmmw_material`` gives one id to all its faces.
* Custom properties ``pmmw_temperature`` (kelvin, or a quantity such as ``"27 degC"``),
  ``pmmw_roughness`` (a GGX alpha, or a mapping as JSON) and ``pmmw_coating`` (``"denim 0.8 mm"``,
  layers outermost first separated by ``;``, each ``ID THICKNESS [TEMPERATURE]``) on a material, or
  on an object for all its faces, make a scenario material ``same_as`` the id with these fields.
* A Scene custom property ``pmmw:KEY.PATH`` sets that scenario key (``pmmw:render.spp = 4``,
  ``pmmw:frequency = "35 GHz"``); without ``pmmw:frequency`` the frequency is 95 GHz.
* An object with the custom property ``pmmw_region`` (a radius in pixels) is a region of the
  report, centred on the object's world position.
"""

from __future__ import annotations

import json
import math
import re

DEFAULT_FREQUENCY = "95 GHz"
# a database id: lower_snake_case, optionally in one named set (pmmw.scene.materials._ID_RE)
ID_RE = re.compile(r"^(?:[a-z][a-z0-9]*\.)?[a-z][a-z0-9]*(?:_[a-z0-9]+)*$")
KEY_PREFIX = "pmmw:"
PROPS = ("pmmw_material", "pmmw_temperature", "pmmw_roughness", "pmmw_coating")
_QUANTITY = re.compile(r"^\s*([-+0-9.eE]+)\s*([A-Za-z/%]+)?\s*$")


class ExportError(Exception):
    """A problem of the Blender scene that stops the export, located by what it is on.

    Parameters
    ----------
    message : str
        What is wrong and how to fix it in Blender.
    key : str
        Where: ``object "Cube"``, ``material "Steel" of object "Cube"``, ``camera "Camera"``, ...
    """

    def __init__(self, message: str, key: str = ""):
        super().__init__(message)
        self.message = message
        self.key = key

    def __str__(self) -> str:
        return f"{self.key}: {self.message}" if self.key else self.message


# -- the camera -----------------------------------------------------------------------------------


def render_resolution(resolution_x: int, resolution_y: int, percentage: int) -> tuple[int, int]:
    """The size Blender renders at: ``resolution_x/y`` scaled by ``resolution_percentage`` (its
    rounding down, as Blender's render does) [pixels]."""
    return max(1, int(resolution_x * percentage / 100)), max(1, int(resolution_y * percentage / 100))


def horizontal_fov(
    lens_mm: float,
    sensor_width_mm: float,
    sensor_height_mm: float,
    sensor_fit: str,
    width_px: int,
    height_px: int,
    pixel_aspect_x: float = 1.0,
    pixel_aspect_y: float = 1.0,
) -> float:
    """The horizontal field of view [rad] of a perspective Blender camera on its rendered image.

    Blender fits the sensor to the image (Blender manual, Camera, "Sensor Fit"): ``HORIZONTAL``
    fits the sensor width across the image, ``VERTICAL`` the sensor height up it, and ``AUTO`` the
    sensor width along the image's longer side. The other side follows from the image's aspect
    ratio (pixels times pixel aspect).

    Parameters
    ----------
    lens_mm, sensor_width_mm, sensor_height_mm : float
        Focal length and sensor size [mm].
    sensor_fit : {"AUTO", "HORIZONTAL", "VERTICAL"}
    width_px, height_px : int
        The rendered image [pixels].
    pixel_aspect_x, pixel_aspect_y : float
        Blender's pixel aspect ratio.
    """
    aspect = (width_px * pixel_aspect_x) / (height_px * pixel_aspect_y)  # image width / height
    if sensor_fit == "AUTO":
        sensor_fit, sensor_height_mm = (
            ("HORIZONTAL", sensor_height_mm) if aspect >= 1 else ("VERTICAL", sensor_width_mm)
        )
    if sensor_fit == "HORIZONTAL":
        return 2.0 * math.atan(sensor_width_mm / (2.0 * lens_mm))
    half_tan_v = sensor_height_mm / (2.0 * lens_mm)
    return 2.0 * math.atan(half_tan_v * aspect)


def _column(m, j) -> list[float]:
    return [float(m[i][j]) for i in range(3)]


def _unit(v, what: str, key: str) -> list[float]:
    n = math.sqrt(sum(c * c for c in v))
    if not n > 0.0:
        raise ExportError(f"the {what} axis has zero length (a zero scale?)", key)
    return [c / n for c in v]


def imager(camera: dict, scale: float = 1.0) -> dict:
    """The ``imager`` mapping of a camera record.

    Parameters
    ----------
    camera : dict
        ``name``, ``matrix_world`` (4 x 4 rows, Blender units), ``type`` (``PERSP``...), ``lens``,
        ``sensor_width``, ``sensor_height`` [mm], ``sensor_fit``, ``shift_x``, ``shift_y``,
        ``resolution`` ([x, y]), ``percentage``, ``pixel_aspect`` ([x, y]), ``focus_distance``
        (Blender units, or None without depth of field), ``props`` (custom properties).
    scale : float
        Metres per Blender unit (the scene's unit scale).
    """
    key = f"camera {camera['name']!r}"
    if camera.get("type", "PERSP") != "PERSP":
        raise ExportError(
            f"pmmw's imager is a perspective camera; this one is {camera['type']} "
            "(set the camera's Type to Perspective)",
            key,
        )
    if camera.get("shift_x") or camera.get("shift_y"):
        raise ExportError("lens shift is not supported by pmmw's imager (set Shift X and Y to 0)", key)
    w, h = render_resolution(*camera["resolution"], camera.get("percentage", 100))
    ax, ay = camera.get("pixel_aspect", (1.0, 1.0))
    if abs(ax / ay - 1.0) > 1e-9:
        raise ExportError(
            f"pmmw's pixels are square; the render's pixel aspect is {ax:g}:{ay:g} (set it to 1:1)", "render settings"
        )
    fov = horizontal_fov(
        camera["lens"], camera["sensor_width"], camera["sensor_height"], camera.get("sensor_fit", "AUTO"), w, h, ax, ay
    )
    m = camera["matrix_world"]
    position = [float(m[i][3]) * scale for i in range(3)]
    forward = [-c for c in _unit(_column(m, 2), "camera's Z", key)]
    up = _unit(_column(m, 1), "camera's Y", key)
    out = {
        "position": [_num(c) for c in position],
        "look_at": [_num(p + f) for p, f in zip(position, forward)],
        "up": [_num(c) for c in up],
        "fov": f"{math.degrees(fov):.7g} deg",
        "resolution": [w, h],
    }
    if camera.get("focus_distance"):
        out["focus_distance"] = f"{camera['focus_distance'] * scale:.7g} m"
    return out


def _num(x: float) -> float:
    """A float to 7 significant digits: Blender keeps its coordinates, lens and sensor as float32
    (about 7 digits), so more would print only float32's rounding (``1.60000002384``)."""
    return float(f"{x:.7g}") + 0.0  # + 0.0: no -0.0


# -- materials ------------------------------------------------------------------------------------


def _quantity(value, unit: str, what: str, key: str) -> str:
    if isinstance(value, bool):
        raise ExportError(f"{what} is a number [{unit}] or a quantity like '300 K', got {value!r}", key)
    if isinstance(value, (int, float)):
        return f"{float(value):.7g} {unit}"
    if isinstance(value, str) and value.strip():
        return value.strip()
    raise ExportError(f"{what} is a number [{unit}] or a quantity like '300 K', got {value!r}", key)


def roughness(value, key: str) -> dict:
    """``pmmw_roughness``: a number is a GGX alpha; a string is a mapping as JSON
    (``{"model": "beckmann", "alpha": 0.2}``)."""
    if isinstance(value, bool):
        pass
    elif isinstance(value, (int, float)):
        return {"model": "ggx", "alpha": _num(float(value))}
    elif isinstance(value, str):
        try:
            spec = json.loads(value)
        except ValueError:
            spec = None
        if isinstance(spec, (int, float)) and not isinstance(spec, bool):
            return {"model": "ggx", "alpha": _num(float(spec))}
        if isinstance(spec, dict):
            return spec
    elif isinstance(value, dict):
        return dict(value)
    raise ExportError(
        "pmmw_roughness is a GGX alpha (e.g. 0.3) or a mapping as JSON, e.g. "
        f'{{"model": "beckmann", "alpha": 0.2}}; got {value!r}',
        key,
    )


def coating(value, key: str) -> list[dict]:
    """``pmmw_coating``: layers outermost first, separated by ``;``, each ``ID THICKNESS
    [TEMPERATURE]`` (``"denim 0.8 mm; skin 2 mm 310 K"``)."""
    example = "'denim 0.8 mm' or 'denim 0.8 mm 300 K; paint 50 um' (outermost first)"
    if not isinstance(value, str) or not value.strip():
        raise ExportError(f"pmmw_coating is text like {example}; got {value!r}", key)
    layers = []
    for text in value.split(";"):
        words = text.split()
        if len(words) not in (3, 5) or not ID_RE.match(words[0]):
            raise ExportError(
                f"pmmw_coating layer {text.strip()!r}: expected ID THICKNESS [TEMPERATURE], e.g. {example}", key
            )
        layer = {"material": words[0], "thickness": f"{words[1]} {words[2]}"}
        if len(words) == 5:
            layer["temperature"] = f"{words[3]} {words[4]}"
        layers.append(layer)
    return layers


def material_fields(props: dict, key: str) -> dict:
    """The scenario material fields (``temperature``, ``roughness``, ``coating``) that custom
    properties give."""
    fields = {}
    if props.get("pmmw_temperature") is not None:
        fields["temperature"] = _quantity(props["pmmw_temperature"], "K", "pmmw_temperature", key)
    if props.get("pmmw_roughness") is not None:
        fields["roughness"] = roughness(props["pmmw_roughness"], key)
    if props.get("pmmw_coating") is not None:
        fields["coating"] = coating(props["pmmw_coating"], key)
    return fields


def material_id(name: str, props: dict, key: str) -> str:
    """A Blender material's database id: its ``pmmw_material`` property, else its name."""
    mid = props.get("pmmw_material", name)
    if not isinstance(mid, str) or not ID_RE.match(mid):
        how = (
            "name the material by a database id (e.g. concrete, metal, murakowski2014.asphalt) or give it the "
            "custom property pmmw_material"
        )
        if "pmmw_material" in props:
            raise ExportError(f"pmmw_material {mid!r} is not a database id (lower_snake_case); {how}", key)
        raise ExportError(f"material {name!r} is not a pmmw database id; {how}", key)
    return mid


def _slug(text: str) -> str:
    s = re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")
    return s if s and s[0].isalpha() else f"m_{s}" if s else "m"


class _Materials:
    """The scenario's ``materials:`` map: one derived id per (database id, fields) pair."""

    def __init__(self):
        self.entries: dict[str, dict] = {}
        self._ids: dict[str, str] = {}

    def resolve(self, base: str, fields: dict, label: str) -> str:
        if not fields:
            return base
        sig = json.dumps([base, fields], sort_keys=True)
        if sig not in self._ids:
            mid = stem = f"blender_{_slug(label)}"
            n = 2
            while mid in self.entries:
                mid, n = f"{stem}_{n}", n + 1
            self._ids[sig] = mid
            self.entries[mid] = {"same_as": base, **fields}
        return self._ids[sig]


# -- the scenario ---------------------------------------------------------------------------------


def scene_entry(obj: dict, materials: _Materials, scale: float) -> dict:
    """One ``scene`` entry of an object record: ``name``, ``mesh`` (its GLB, relative to the
    scenario), ``props``, ``slots`` (``[{"name": material name or None, "props": {...}, "used":
    bool}]``)."""
    key = f"object {obj['name']!r}"
    own = obj.get("props", {})
    entry = {"name": obj["name"], "mesh": obj["mesh"]}
    used = [s for s in obj.get("slots", []) if s.get("used", True)]
    if own.get("pmmw_material") is not None:
        base = material_id(own["pmmw_material"], own, key)
        entry["material"] = materials.resolve(base, material_fields(own, key), obj["name"])
    else:
        if not used:
            raise ExportError(
                "no material: give the object a material named by a database id (e.g. concrete, "
                "metal), or the custom property pmmw_material",
                key,
            )
        ids = {}
        for s in used:
            if s.get("name") is None:
                raise ExportError(
                    "some faces are in an empty material slot: give the slot a material, or the object "
                    "the custom property pmmw_material",
                    key,
                )
            where = f"material {s['name']!r} of {key}"
            fields = {**material_fields(s.get("props", {}), where), **material_fields(own, key)}
            base = material_id(s["name"], s.get("props", {}), where)
            label = s["name"] if not material_fields(own, key) else f"{obj['name']}_{s['name']}"
            ids[s["name"]] = materials.resolve(base, fields, label)
        if len(set(ids.values())) == 1:
            entry["material"] = next(iter(ids.values()))
        else:
            entry["materials"] = ids
    if scale != 1.0:
        entry["transform"] = {"scale": _num(scale)}
    return entry


def set_key(data: dict, dotted: str, value, key: str) -> None:
    """``data[a][b][c] = value`` for ``"a.b.c"``, making the mappings on the way."""
    parts = dotted.split(".")
    if not all(parts):
        raise ExportError(f"malformed scenario key {dotted!r} (expected e.g. render.spp)", key)
    node = data
    for p in parts[:-1]:
        node = node.setdefault(p, {})
        if not isinstance(node, dict):
            raise ExportError(f"{dotted!r}: {p!r} is not a mapping", key)
    node[parts[-1]] = value


def scenario(scene: dict) -> dict:
    """The scenario mapping of a plain scene record.

    Parameters
    ----------
    scene : dict
        ``camera`` (see `imager`; None: no active camera), ``objects`` (see `scene_entry`),
        ``regions`` (``[{"name", "location", "radius"}]``), ``props`` (the Scene's custom
        properties), ``scale`` (metres per Blender unit).

    Raises
    ------
    ExportError
        The first problem; `problems` collects them all.
    """
    data, errors = build(scene)
    if errors:
        raise errors[0]
    return data


def build(scene: dict) -> tuple[dict, list[ExportError]]:
    """`scenario`, with every problem collected instead of the first raised."""
    errors: list[ExportError] = []
    scale = float(scene.get("scale", 1.0))
    data: dict = {"frequency": DEFAULT_FREQUENCY}
    if scene.get("camera") is None:
        errors.append(
            ExportError(
                "the scene has no active camera: pmmw's imager is the active camera (Scene properties > Camera)",
                "scene",
            )
        )
    else:
        try:
            data["imager"] = imager(scene["camera"], scale)
        except ExportError as e:
            errors.append(e)
    materials = _Materials()
    entries = []
    for obj in scene.get("objects", []):
        try:
            entries.append(scene_entry(obj, materials, scale))
        except ExportError as e:
            errors.append(e)
    if not scene.get("objects"):
        errors.append(ExportError("no visible mesh objects to export", "scene"))
    data["scene"] = entries
    if materials.entries:
        data["materials"] = materials.entries
    regions = {}
    for r in scene.get("regions", []):
        radius = r["radius"]
        if isinstance(radius, bool) or not isinstance(radius, (int, float)) or not radius > 0:
            errors.append(
                ExportError(
                    f"pmmw_region is the region's radius in pixels (> 0), got {radius!r}", f"object {r['name']!r}"
                )
            )
            continue
        regions[r["name"]] = {"center": [_num(c * scale) for c in r["location"]], "radius": _num(float(radius))}
    if regions:
        data["output"] = {"regions": regions}
    for name, value in sorted(scene.get("props", {}).items()):
        if name.startswith(KEY_PREFIX):
            try:
                set_key(data, name[len(KEY_PREFIX) :], value, f"scene custom property {name!r}")
            except ExportError as e:
                errors.append(e)
    return data, errors


# -- YAML -----------------------------------------------------------------------------------------


def to_yaml(data, indent: int = 0) -> str:
    """A small YAML writer (Blender ships no YAML library): block mappings, lists of scalars in
    flow style, strings quoted as JSON (which YAML reads as double-quoted strings)."""
    pad = " " * indent
    lines = []
    if isinstance(data, dict):
        for k, v in data.items():
            head = f"{pad}{_key(k)}:"
            if isinstance(v, dict) and v:
                lines.append(head)
                lines.append(to_yaml(v, indent + 2))
            elif isinstance(v, list) and any(isinstance(x, (dict, list)) for x in v):
                lines.append(head)
                lines.append(to_yaml(v, indent + 2))
            else:
                lines.append(f"{head} {_flow(v)}")
    else:
        for item in data:
            if isinstance(item, dict) and item:
                body = to_yaml(item, indent + 2)
                lines.append(f"{pad}- {body[indent + 2 :]}")
            else:
                lines.append(f"{pad}- {_flow(item)}")
    return "\n".join(lines)


_PLAIN_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_YAML_WORDS = {"y", "n", "yes", "no", "on", "off", "true", "false", "null"}


def _key(k) -> str:
    k = str(k)
    return k if _PLAIN_KEY.match(k) and k.lower() not in _YAML_WORDS else json.dumps(k)


def _flow(v) -> str:
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)}: {_flow(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_flow(x) for x in v) + "]"
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if not math.isfinite(v):
            return json.dumps(str(v))
        text = repr(v)
        mantissa, e, exponent = text.partition("e")
        return f"{mantissa}.0e{exponent}" if e and "." not in mantissa else text  # YAML 1.1: 1.0e-05, not 1e-05
    if isinstance(v, int):
        return str(v)
    return json.dumps(str(v))
