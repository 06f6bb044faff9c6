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
from collections.abc import Iterable, Mapping
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np
import OpenImageIO as oiio

from pmmw.errors import UserError
from pmmw.io.atomic import atomic_path
from pmmw.memory import check_fits

#: Header attribute holding the channel names in their written order.
CHANNEL_ORDER_ATTR = "pmmw:channels"

_INT32 = (-(2**31), 2**31 - 1)

#: The largest image pmmw reads (sky and bump textures, `pmmw view`, the Python API) [pixels]: a
#: side, and in all. 128 Mpx is twice the largest image a render writes (64 Mpx,
#: `config.schema.MAX_PIXELS`) and holds a 16384 x 8192 equirectangular sky (0.022 deg a pixel);
#: the header says the size, so a larger image is refused before a pixel is read.
MAX_IMAGE_SIDE = 32768
MAX_IMAGE_PIXELS = 1 << 27

#: [bytes] `read_exr` takes per pixel of each channel read: OpenImageIO's float32 buffer and the
#: channel's own float32 array (all channels at once); 4 when the channels are named (one buffer each).
READ_BYTES_PER_SAMPLE = 8


def _oiio_error(obj: oiio.ImageInput | oiio.ImageOutput | None = None) -> str:
    """The pending error text of an OIIO object and of the library (reading clears them), on one
    line (OpenImageIO's own texts run over several: "... Possible corrupt input?\n If ...")."""
    msgs = [obj.geterror() if obj is not None else "", oiio.geterror()]
    return "; ".join(" ".join(m.split()) for m in msgs if m and m.strip()) or "unknown OpenImageIO error"


def _set_double(spec: oiio.ImageSpec, name: str, value: float) -> None:
    """Set a 64-bit float attribute (the Python binding has no direct way to)."""
    text = repr(float(value))  # exact round trip; 'nan', 'inf' and '-inf' parse too
    holder = oiio.ImageSpec()
    holder.from_xml(
        f'<ImageSpec version="27"><attrib name={quoteattr(name)} type="double">{escape(text)}</attrib></ImageSpec>'
    )
    for pv in holder.extra_attribs:
        spec.extra_attribs.add_or_replace(pv)
    if spec.getattribute(name) is None:
        raise RuntimeError(f"could not set EXR header attribute {name!r} = {value!r}")


def _set_attribute(spec: oiio.ImageSpec, name: str, value: object) -> None:
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


def write_exr(
    path: str | os.PathLike,
    channels: Mapping[str, np.ndarray],
    attrs: Mapping[str, object] | None = None,
    *,
    compression: str = "zip",
) -> None:
    """Write float32 channels and header attributes to an OpenEXR file, atomically.

    Parameters
    ----------
    path : str or Path
        Destination; the format is OpenEXR whatever the suffix. Parent directories are created.
    channels : mapping of str to ndarray, each shape (H, W)
        Channel name -> image, e.g. ``I``, ``Ex2``, ``ideal.I``, ``aux.depth``; all the same
        shape; converted to float32 and written in the given order.
    attrs : mapping of str to str, int, float or list, optional
        Header attributes (see the module docstring for how each type is stored).
    compression : {"zip", "none"}
        OpenEXR's ZIP (16 scanlines a block) or none (several times faster to write; a render's
        default, ``output.compression``). The Blender add-on reads both.

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
    if compression not in ("zip", "none"):
        raise ValueError(f"write_exr: compression must be zip or none, got {compression!r}")
    spec.attribute("compression", compression)
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


def _open_image(path: Path, key: str | None) -> oiio.ImageInput:
    """An open OIIO reader of ``path`` (its header read, no pixel); `UserError` when the file is
    missing or not an image."""
    if not path.is_file():
        raise UserError("image file not found", file=path, key=key)
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise UserError(f"cannot read image: {_oiio_error()}", file=path, key=key)
    return inp


def image_size(path: str | os.PathLike, *, key: str | None = None) -> tuple[int, int, tuple[str, ...]]:
    """Width, height [pixels] and channel names of an image, from its header alone.

    Raises
    ------
    UserError
        The file is missing or cannot be read as an image.
    """
    inp = _open_image(Path(path), key)
    try:
        spec = inp.spec()
        return spec.width, spec.height * max(spec.depth, 1), tuple(spec.channelnames)
    finally:
        inp.close()


def _check_size(
    spec: oiio.ImageSpec, path: Path, key: str | None, names: list[str] | None, bytes_per_pixel: float
) -> None:
    """Refuse an image beyond `MAX_IMAGE_SIDE` / `MAX_IMAGE_PIXELS`, or one whose reading (and
    the caller's ``bytes_per_pixel``) needs more memory than is available, from its header."""
    w, h = spec.width, spec.height * max(spec.depth, 1)
    px = w * h
    if max(w, h) > MAX_IMAGE_SIDE or px > MAX_IMAGE_PIXELS:
        raise UserError(
            f"{w} x {h} pixels ({px / 2**20:.3g} Mpx) is more than pmmw reads: at most "
            f"{MAX_IMAGE_SIDE} a side and {MAX_IMAGE_PIXELS // 2**20} Mpx in all; use a smaller image",
            file=path,
            key=key,
        )
    per_sample = READ_BYTES_PER_SAMPLE if names is None else READ_BYTES_PER_SAMPLE // 2
    n_read = spec.nchannels if names is None else len(names)
    check_fits(
        px * (per_sample * n_read + bytes_per_pixel),
        f"reading this {w} x {h} image ({n_read} channel{'s' if n_read != 1 else ''})",
        file=path,
        key=key,
        remedy="use a smaller image or free memory",
    )


def read_exr(
    path: str | os.PathLike,
    *,
    key: str | None = None,
    channels: Iterable[str] | None = None,
    bytes_per_pixel: float = 0.0,
) -> tuple[dict[str, np.ndarray], dict]:
    """Read the channels and the header attributes of an image file (OpenEXR or any OIIO format).

    The size comes from the header first: an image beyond `MAX_IMAGE_SIDE` a side or
    `MAX_IMAGE_PIXELS` in all, or whose reading needs more memory than is available, is refused
    before a pixel is read.

    Parameters
    ----------
    path : str or Path
        The image; only its first subimage is read.
    key : str, optional
        Dotted scenario key (or option) that named the file, for the error message.
    channels : sequence of str, optional
        Read only these (those the file has; the caller reports the missing ones); default all.
    bytes_per_pixel : float
        Memory the caller goes on to take per pixel of the image [bytes] (its own copies, a
        figure), added to the reading's for the memory check.

    Returns
    -------
    channels : dict of str to ndarray, shape (H, W), float32
        In the written order when the file has ``pmmw:channels``, else in the file's order (the
        order asked for when ``channels`` is given).
    attrs : dict
        Header attributes, name -> value (str, int, float or tuple).

    Raises
    ------
    UserError
        The file is missing, cannot be read as an image, is too large, or too large for the
        memory available.
    """
    path = Path(path)
    inp = _open_image(path, key)
    try:
        spec = inp.spec()
        file_names = list(spec.channelnames)
        wanted = None if channels is None else [n for n in dict.fromkeys(channels) if n in file_names]
        _check_size(spec, path, key, wanted, bytes_per_pixel)
        shape = (spec.height * max(spec.depth, 1), spec.width)
        if wanted is None:
            data = inp.read_image(oiio.FLOAT)
            if data is None:
                raise UserError(f"cannot read image pixels: {_oiio_error(inp)}", file=path, key=key)
            data = np.asarray(data, dtype=np.float32).reshape(*shape, spec.nchannels)
            planes = {n: np.ascontiguousarray(data[:, :, i]) for i, n in enumerate(file_names)}
            del data
        else:
            planes = {}
            for n in wanted:  # one channel at a time: no buffer of the others
                i = file_names.index(n)
                plane = inp.read_image(0, 0, i, i + 1, oiio.FLOAT)
                if plane is None:
                    raise UserError(f"cannot read image pixels: {_oiio_error(inp)}", file=path, key=key)
                planes[n] = np.ascontiguousarray(np.asarray(plane, dtype=np.float32).reshape(shape))
    finally:
        inp.close()
    attrs = {pv.name: pv.value for pv in spec.extra_attribs}
    if wanted is not None:
        return planes, attrs
    order = attrs.get(CHANNEL_ORDER_ATTR)
    if isinstance(order, str):
        order = (order,)
    if not (isinstance(order, tuple) and sorted(order) == sorted(file_names)):
        order = file_names
    return {n: planes[n] for n in order}, attrs
