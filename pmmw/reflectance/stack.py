"""The surface that `pmmw brdf` scatters from: a `Stack` of `StackLayer` records, top layer first.

A stack comes from a stack file (`load_stack`, YAML; every problem reported with the file and key
path) or from the command line (`pmmw.reflectance.command`). Permittivities follow the
``exp(-i w t)`` convention (eps'' >= 0 is lossy); thicknesses are in [m], frequencies in [Hz].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from pmmw.constants import C0 as _C0
from pmmw.errors import UserError, UserErrors
from pmmw.io.records import check_keys
from pmmw.io.yamlio import read_yaml
from pmmw.physics import roughness as rough

if TYPE_CHECKING:
    from pmmw.scene.materials import MaterialDB

__all__ = ["StackLayer", "Stack", "load_stack", "parse_complex"]


@dataclass(frozen=True)
class StackLayer:
    """One medium below the ambient one, with the interface on its top.

    Attributes
    ----------
    eps : complex
        Relative permittivity [-] (eps'' >= 0 lossy). Ignored for a ``metal`` substrate.
    roughness : MicrofacetModel or None
        Model of the interface on top of this layer; None is smooth.
    thickness : float or None
        [m]; a lossy layer with a thickness attenuates each path by ``exp(-2 k0 Im(n) L)`` over
        its length L (and a ray masked inside it by one wavelength on its way back to the same
        interface, as in the renderer); without one, absorption inside the layer is ignored (Optics
        Express 2016, assumption 3).
        Ignored for the substrate (the last layer, a half-space).
    coating : tuple of (complex, float)
        Coherent films ``(eps, thickness [m])``, outermost first, conformal to the facets of the
        top interface (`pmmw.physics.multilayer`).
    metal : bool
        Perfect conductor (only for the substrate).
    name : str
    """

    eps: complex
    roughness: object = None
    thickness: float | None = None
    coating: tuple = ()
    metal: bool = False
    name: str = ""


@dataclass(frozen=True)
class Stack:
    """Layers from the top (just below the ambient medium) down; the last is the substrate.

    Attributes
    ----------
    layers : tuple of StackLayer
    ambient_eps : complex
        Permittivity of the incidence medium (lossless).
    frequency : float or None
        [Hz]; needed for coatings and absorbing layers with a thickness.
    """

    layers: tuple
    ambient_eps: complex = 1.0 + 0j
    frequency: float | None = None

    @property
    def k0(self) -> float | None:
        return None if self.frequency is None else 2.0 * math.pi * self.frequency / _C0

    def media(self) -> list[complex]:
        """Permittivities of the ambient medium, the layers and the substrate, top down."""
        return [complex(self.ambient_eps)] + [complex(layer.eps) for layer in self.layers]


def parse_complex(value: object, *, file: str | Path | None = None, key: str | None = None) -> complex:
    """``0.23+3.46j`` (or ``i``), a number, or a pair ``[re, im]`` -> complex."""
    if isinstance(value, bool):
        raise UserError(f"expected a complex number like 0.23+3.46j, got {value!r}", file, key)
    if isinstance(value, (int, float)):
        return complex(float(value), 0.0)
    if (
        isinstance(value, (list, tuple))
        and len(value) == 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    ):
        return complex(float(value[0]), float(value[1]))
    if isinstance(value, str):
        text = value.replace(" ", "").replace("i", "j").replace("J", "j")
        if "," in text:
            parts = text.split(",")
            try:
                if len(parts) == 2:
                    return complex(float(parts[0]), float(parts[1]))
            except ValueError:
                pass
        else:
            try:
                return complex(text)
            except ValueError:
                pass
    raise UserError(f"cannot read {value!r} as a complex number; expected e.g. 0.23+3.46j or [0.23, 3.46]", file, key)


def _check_eps(eps: complex, file: str | Path | None, key: str) -> None:
    if not (math.isfinite(eps.real) and math.isfinite(eps.imag)):
        raise UserError(f"permittivity must be finite, got {eps}", file, key)
    if eps.imag < 0.0:
        raise UserError(f"eps'' must be >= 0 (lossy; exp(-i w t) convention), got {eps}", file, key)
    if eps == 0:
        raise UserError("permittivity 0 is not a medium", file, key)


def _medium_eps(
    entry: dict, *, frequency: float | None, file: str | Path | None, key: str, db: MaterialDB | None = None
) -> tuple[complex, bool]:
    """(eps, metal) from one of ``n``, ``eps``, ``material``, ``kind: metal``."""
    given = [k for k in ("n", "eps", "material") if k in entry]
    if entry.get("kind") == "metal":
        if given:
            raise UserError(f"a metal (perfect conductor) takes no {given[0]}", file, f"{key}.{given[0]}")
        return 0j, True
    if len(given) != 1:
        raise UserError("give exactly one of n, eps, material (or kind: metal)", file, key)
    which = given[0]
    if which == "n":
        n = parse_complex(entry["n"], file=file, key=f"{key}.n")
        if n.imag < 0.0:
            raise UserError(f"Im(n) must be >= 0 (lossy; exp(-i w t) convention), got {n}", file, f"{key}.n")
        eps = n * n
    elif which == "eps":
        eps = parse_complex(entry["eps"], file=file, key=f"{key}.eps")
    else:
        from pmmw.scene.materials import MaterialDB

        if frequency is None:
            raise UserError(
                "a material from the database needs the frequency (frequency: or --frequency)", file, f"{key}.material"
            )
        db = db or MaterialDB.load()
        mat = db.get(entry["material"], file=file, key=f"{key}.material")
        if mat.kind == "metal":
            return 0j, True
        if mat.kind == "blackbody":
            raise UserError(
                f"material {mat.id!r} is a blackbody: it has no surface to scatter from", file, f"{key}.material"
            )
        eps = complex(mat.eps_at(frequency))
    _check_eps(eps, file, f"{key}.{which}")
    return eps, False


_LAYER_KEYS = ("n", "eps", "material", "kind", "roughness", "thickness", "coating", "name")
_STACK_KEYS = ("frequency", "wavelength", "ambient", "layers")


def _frequency(
    frequency: object, wavelength: object, file: str | Path | None, key_f: str = "frequency", key_w: str = "wavelength"
) -> float | None:
    from pmmw.units import parse_quantity

    if frequency is not None and wavelength is not None:
        raise UserError("give either a frequency or a wavelength, not both", file, key_w)
    if frequency is not None:
        f = parse_quantity(frequency, "frequency", file=file, key=key_f)
    elif wavelength is not None:
        lam = parse_quantity(wavelength, "length", file=file, key=key_w)
        if not lam > 0.0:
            raise UserError(f"wavelength must be > 0, got {wavelength!r}", file, key_w)
        f = _C0 / lam
    else:
        return None
    if not f > 0.0:
        raise UserError(f"frequency must be > 0, got {frequency!r}", file, key_f)
    return f


def load_stack(
    path: str | Path, *, frequency: str | float | None = None, wavelength: str | float | None = None
) -> Stack:
    """Read a stack file (YAML)::

        frequency: 95 GHz          # or wavelength: 635 nm (needed for coatings, thicknesses,
                                   # database materials)
        ambient: {n: 1}            # optional, vacuum by default
        layers:                    # top first; the last one is the substrate
          - n: 1.5
            thickness: 1 mm        # optional: absorption along paths in a lossy layer
            roughness: {model: ashikhmin_shirley, ex: 10, ey: 10}
          - n: 0.23+3.46j          # or eps: [eps', eps''], material: ID, kind: metal
            roughness: {model: ashikhmin_shirley, ex: 15, ey: 15}
            coating: [{eps: [2.5, 0.01], thickness: 0.1 mm}]   # coherent films on the facets

    ``frequency``/``wavelength`` arguments (command line) override the file's.

    Raises
    ------
    UserError or UserErrors
        Every problem, with the file and key path.
    """
    from pmmw.units import parse_quantity

    path = Path(path)
    file = str(path)
    if not path.is_file():
        raise UserError("stack file not found", file)
    raw = read_yaml(path, "stack file")
    if not isinstance(raw, dict):
        raise UserError("a stack file is a mapping with `layers:` (and optionally frequency, ambient)", file)
    errors: list[UserError] = []
    errors += check_keys(raw, _STACK_KEYS, file)
    if frequency is not None or wavelength is not None:
        f = _frequency(frequency, wavelength, "command line", "--frequency", "--wavelength")
    else:
        f = _frequency(raw.get("frequency"), raw.get("wavelength"), file)
    ambient = 1.0 + 0j
    if "ambient" in raw:
        amb = raw["ambient"]
        if not isinstance(amb, dict):
            errors.append(UserError("ambient is a mapping like {n: 1}", file, "ambient"))
        else:
            try:
                ambient, metal = _medium_eps(amb, frequency=f, file=file, key="ambient")
                if metal or abs(ambient.imag) > 0.0:
                    errors.append(UserError("the ambient medium must be lossless", file, "ambient"))
            except UserError as ex:
                errors.append(ex)
    layers_raw = raw.get("layers")
    if not isinstance(layers_raw, list) or not layers_raw:
        errors.append(UserError("`layers:` must be a non-empty list, top layer first, substrate last", file, "layers"))
        layers_raw = []
    layers = []
    for i, entry in enumerate(layers_raw):
        key = f"layers[{i}]"
        if not isinstance(entry, dict):
            errors.append(UserError("a layer is a mapping like {n: 1.5, roughness: {...}}", file, key))
            continue
        errors += check_keys(entry, _LAYER_KEYS, file, prefix=("layers", i))
        try:
            eps, metal = _medium_eps(entry, frequency=f, file=file, key=key)
            if metal and i != len(layers_raw) - 1:
                raise UserError("only the substrate (last layer) can be a metal", file, key)
            model = None
            if entry.get("roughness") is not None:
                model = rough.make_model(entry["roughness"], file=file, key=f"{key}.roughness")
            thickness = None
            if entry.get("thickness") is not None:
                thickness = parse_quantity(entry["thickness"], "length", file=file, key=f"{key}.thickness")
                if thickness < 0.0:
                    raise UserError("thickness must be >= 0", file, f"{key}.thickness")
            coating = []
            for j, film in enumerate(entry.get("coating") or []):
                fkey = f"{key}.coating[{j}]"
                if not isinstance(film, dict) or "thickness" not in film:
                    raise UserError("a coating film is {n: ..., thickness: '0.1 mm'} (or eps:, material:)", file, fkey)
                feps, fmetal = _medium_eps(
                    {k: v for k, v in film.items() if k != "thickness"}, frequency=f, file=file, key=fkey
                )
                if fmetal:
                    raise UserError("a coating film cannot be a metal", file, fkey)
                d = parse_quantity(film["thickness"], "length", file=file, key=f"{fkey}.thickness")
                if d < 0.0:
                    raise UserError("thickness must be >= 0", file, f"{fkey}.thickness")
                coating.append((feps, d))
            if coating and f is None:
                raise UserError("a coating needs the frequency (frequency: or --frequency)", file, f"{key}.coating")
            if thickness and eps.imag > 0.0 and f is None and i != len(layers_raw) - 1:
                raise UserError("an absorbing layer with a thickness needs the frequency", file, f"{key}.thickness")
            layers.append(
                StackLayer(
                    eps=eps,
                    roughness=model,
                    thickness=thickness,
                    coating=tuple(coating),
                    metal=metal,
                    name=str(entry.get("name", f"layer {i}")),
                )
            )
        except UserErrors as ex:
            errors.extend(ex.errors)
        except UserError as ex:
            errors.append(ex)
    if errors:
        raise errors[0] if len(errors) == 1 else UserErrors(errors)
    return Stack(layers=tuple(layers), ambient_eps=ambient, frequency=f)
