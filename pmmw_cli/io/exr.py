"""OpenEXR images through OpenImageIO: float32 channels by name plus header attributes.

OpenEXR stores channels sorted by name, whatever order they were written in; the written order
is kept in the header attribute ``pmmw:channels`` (a string array) and `read_exr` restores it.

Header attributes (prefix custom ones with ``pmmw:``) map as follows:

* ``str`` -> string; ``bool`` and ``int`` in the 32-bit range -> int;
* ``float`` (and ints beyond 32 bits) -> double, so frequencies [Hz] survive exactly;
* a list or tuple of strings -> string array; of numbers -> one string of the values separated
  by spaces, each written with ``repr`` so that ``float(s)`` gives back the exact value (OpenEXR
  only has fixed-size double vectors).

OpenImageIO's Python binding silently drops attributes declared ``double`` and stores a Python
float as a 32-bit float, so doubles are set through `ImageSpec.from_xml` (see `_set_double`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np
import OpenImageIO as oiio

from pmmw_cli.errors import UserError
from pmmw_cli.io.atomic import atomic_path

#: Header attribute holding the channel names in their written order.
CHANNEL_ORDER_ATTR = "pmmw:channels"

_INT32 = (-(2**31), 2**31 - 1)


def _oiio_error(obj=None) -> str:
    """The pending error text of an OIIO object and of the library (reading clears them)."""
    msgs = [obj.geterror() if obj is not None else "", oiio.geterror()]
    return "; ".join(m.strip() for m in msgs if m and m.strip()) or "unknown OpenImageIO error"


def _set_double(spec: oiio.ImageSpec, name: str, value: float) -> None:
    """Set a 64-bit float attribute (the Python binding has no direct way to)."""
    text = repr(float(value))  # exact round trip; 'nan', 'inf' and '-inf' parse too
    holder = oiio.ImageSpec()
    holder.from_xml(
        f'<ImageSpec version="27"><attrib name={quoteattr(name)} type="double">'
        f"{escape(text)}</attrib></ImageSpec>"
    )
    for pv in holder.extra_attribs:
        spec.extra_attribs.add_or_replace(pv)
    if spec.getattribute(name) is None:
        raise RuntimeError(f"could not set EXR header attribute {name!r} = {value!r}")


def _set_attribute(spec: oiio.ImageSpec, name: str, value) -> None:
    if isinstance(value, np.generic):
        value = value.item()
    elif isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, Path):
        value = str(value)
    if isinstance(value, str):
        spec.attribute(name, value)
    elif isinstance(value, bool):
        spec.attribute(name, int(value))
    elif isinstance(value, int):
        if _INT32[0] <= value <= _INT32[1]:
            spec.attribute(name, value)
        else:
            _set_double(spec, name, float(value))
    elif isinstance(value, float):
        _set_double(spec, name, value)
    elif isinstance(value, (list, tuple)):
        items = [v.item() if isinstance(v, np.generic) else v for v in value]
        if items and all(isinstance(v, str) for v in items):
            spec.attribute(name, oiio.TypeDesc(f"string[{len(items)}]"), tuple(items))
        elif all(isinstance(v, (int, float)) for v in items):
            spec.attribute(name, " ".join(repr(v) for v in items))
        else:
            raise TypeError(f"EXR attribute {name!r}: a list must hold only numbers or only strings")
    else:
        raise TypeError(f"EXR attribute {name!r}: unsupported type {type(value).__name__}")


def write_exr(path: str | os.PathLike, channels: Mapping[str, np.ndarray],
              attrs: Mapping[str, object] | None = None) -> None:
    """Write float32 channels and header attributes to an OpenEXR file, atomically.

    Parameters
    ----------
    path : str or Path
        Destination; the format is OpenEXR whatever the suffix. Parent directories are created.
    channels : mapping of str to ndarray, each shape (H, W)
        Channel name -> image, e.g. ``I``, ``Ex2``, ``ideal.I``, ``aux.depth``; all the same
        shape; converted to float32 and written in the given order with zip compression.
    attrs : mapping of str to str, int, float or list, optional
        Header attributes (see the module docstring for how each type is stored).

    Raises
    ------
    ValueError
        No channels, or channels not all 2-D of one shape.
    RuntimeError
        OpenImageIO failed to write; the message carries its error text.
    """
    if not channels:
        raise ValueError("write_exr: no channels")
    names = list(channels)
    planes = [np.asarray(channels[n]) for n in names]
    shape = planes[0].shape
    if len(shape) != 2 or any(p.shape != shape for p in planes):
        raise ValueError(
            "write_exr: channels must all be 2-D of one shape; got "
            + ", ".join(f"{n} {p.shape}" for n, p in zip(names, planes))
        )
    height, width = shape
    pixels = np.ascontiguousarray(np.stack(planes, axis=-1), dtype=np.float32)

    spec = oiio.ImageSpec(width, height, len(names), oiio.FLOAT)
    spec.channelnames = tuple(names)
    for key, value in (attrs or {}).items():
        _set_attribute(spec, key, value)
    spec.attribute("compression", "zip")
    spec.attribute(CHANNEL_ORDER_ATTR, oiio.TypeDesc(f"string[{len(names)}]"), tuple(names))

    with atomic_path(path) as tmp:
        out = oiio.ImageOutput.create("exr")
        if out is None:
            raise RuntimeError(f"OpenImageIO has no OpenEXR writer: {_oiio_error()}")
        if not out.open(str(tmp), spec):
            raise RuntimeError(f"cannot open {path} for writing: {_oiio_error(out)}")
        ok = out.write_image(pixels)
        closed = out.close()
        if not (ok and closed):
            raise RuntimeError(f"cannot write {path}: {_oiio_error(out)}")


def read_exr(path: str | os.PathLike, *, key: str | None = None) -> tuple[dict[str, np.ndarray], dict]:
    """Read every channel and the header attributes of an image file (OpenEXR or any OIIO format).

    Parameters
    ----------
    path : str or Path
        The image; only its first subimage is read.
    key : str, optional
        Dotted scenario key that named the file, for the error message.

    Returns
    -------
    channels : dict of str to ndarray, shape (H, W), float32
        In the written order when the file has ``pmmw:channels``, else in the file's order.
    attrs : dict
        Header attributes, name -> value (str, int, float or tuple).

    Raises
    ------
    UserError
        The file is missing or cannot be read as an image.
    """
    path = Path(path)
    if not path.is_file():
        raise UserError("image file not found", file=path, key=key)
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise UserError(f"cannot read image: {_oiio_error()}", file=path, key=key)
    try:
        spec = inp.spec()
        data = inp.read_image(oiio.FLOAT)
        if data is None:
            raise UserError(f"cannot read image pixels: {_oiio_error(inp)}", file=path, key=key)
    finally:
        inp.close()
    data = np.asarray(data, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    file_names = list(spec.channelnames)
    attrs = {pv.name: pv.value for pv in spec.extra_attribs}
    order = attrs.get(CHANNEL_ORDER_ATTR)
    if isinstance(order, str):
        order = (order,)
    if not (isinstance(order, tuple) and sorted(order) == sorted(file_names)):
        order = file_names
    channels = {n: np.ascontiguousarray(data[:, :, file_names.index(n)]) for n in order}
    return channels, attrs
