"""PNG previews of temperature images with the display scaling of Murakowski 2014 sec. 3.2.

Display scaling (Murakowski 2014 sec. 3.2 footnote): the coldest and hottest 1/256 of the pixels clip to
black and white, and the range between is mapped linearly onto 256 grey levels.

Two kinds: the plain previews a render writes by default (`write_preview`, `write_regions_png`:
one pixel per image pixel, written by OpenImageIO in milliseconds, their range stated in the
report), and the figures a person reads alone (`write_figure` and the others: a colour bar in
kelvin, a title, the regions named; matplotlib, about 0.3 s each with its import shared), which
``output.previews: figures`` and ``pmmw view`` draw.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import OpenImageIO as oiio

from pmmw import __version__
from pmmw.io.atomic import atomic_path

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Fraction of the pixels clipped at each end of the display range (Murakowski 2014 sec. 3.2 footnote).
CLIP_FRACTION = 1.0 / 256.0

#: Grey level of an image without contrast (a constant image).
MID_GREY = 128

#: PNG options of the figures (matplotlib): zlib level 1 writes a render's previews 1.7x faster than
#: matplotlib's default and, on these noisy images, 45 % smaller (landing: 1.4 MB against 2.5 MB).
#: The ``Software`` text names pmmw: a render replaces only files it recognises as its own
#: (`io.rundir.made_by_pmmw`).
_PNG = {"format": "png", "pil_kwargs": {"compress_level": 1}, "metadata": {"Software": f"pmmw {__version__}"}}


def display_range(img: npt.ArrayLike, clip_fraction: float = CLIP_FRACTION) -> tuple[float, float]:
    """Temperatures [K] shown as black and white.

    With n finite pixels sorted ascending as t, and k = floor(clip_fraction * n): low = t[k] and
    high = t[n - 1 - k], so exactly k pixels lie below low and k above high (fewer where values
    tie). When that range collapses (more than 1 - 2 clip_fraction of the pixels share one
    temperature) the full finite range is used instead. Non-finite pixels are ignored; with no
    finite pixel the result is (nan, nan).

    Parameters
    ----------
    img : array_like, any shape, float
        Temperatures [K].
    clip_fraction : float
        Fraction of the pixels clipped at each end, in [0, 0.5).
    """
    if not 0.0 <= clip_fraction < 0.5:
        raise ValueError(f"clip_fraction must lie in [0, 0.5), got {clip_fraction}")
    t = np.asarray(img, dtype=np.float64).ravel()
    finite = np.isfinite(t)
    if not finite.all():
        t = t[finite]
    n = t.size
    if n == 0:
        return float("nan"), float("nan")
    k = int(np.floor(clip_fraction * n))
    low, high = np.partition(t, (k, n - 1 - k))[[k, n - 1 - k]]
    if high <= low:
        low, high = t.min(), t.max()
    return float(low), float(high)


def scale_to_u8(img: npt.ArrayLike, low: float, high: float) -> np.ndarray:
    """Map temperatures [K] onto 256 equal bins between low and high, clipping outside.

    Returns an ndarray of img's shape, uint8. NaN -> 0, +inf -> 255, -inf -> 0. Without a range
    (high <= low, or either end not finite) pixels equal to low are mid grey, colder ones 0 and
    hotter ones 255.
    """
    t = np.asarray(img, dtype=np.float64)
    if np.isfinite(low) and np.isfinite(high) and high > low and np.isfinite(t).all():
        # floor, clip to [0, 255], then to uint8 in three passes: for finite pixels clipping first
        # and truncating after is the same (both give 0 below 0 and 255 at and above 255)
        out = (t - low) * (256.0 / (high - low))
        np.clip(out, 0.0, 255.0, out=out)
        return out.astype(np.uint8)
    if np.isfinite(low) and np.isfinite(high) and high > low:
        with np.errstate(invalid="ignore", over="ignore"):
            out = np.floor((t - low) * (256.0 / (high - low)))
    else:
        out = np.where(t > low, 255.0, np.where(t < low, 0.0, float(MID_GREY)))
    out = np.clip(np.nan_to_num(out, nan=0.0, posinf=255.0, neginf=0.0), 0, 255)
    out[np.isnan(t)] = 0
    return out.astype(np.uint8)


def display_scale(img: npt.ArrayLike, clip_fraction: float = CLIP_FRACTION) -> np.ndarray:
    """An 8-bit display image of a temperature image.

    Parameters
    ----------
    img : array_like, shape (H, W), float
        Temperatures [K]; NaN pixels are shown black and do not move the range.
    clip_fraction : float
        Fraction of the pixels clipped at each end (Murakowski 2014 sec. 3.2 footnote: 1/256).

    Returns
    -------
    ndarray, shape (H, W), uint8
        0 at and below the display range's low end, 255 at and above its high end, 256 equal
        bins between; a constant image is mid grey (128).
    """
    low, high = display_range(img, clip_fraction)
    return scale_to_u8(img, low, high)


#: zlib level of the plain previews (`write_png`): 0 stores the pixels as they are. A sensor
#: image's noise leaves deflate little to take (the landing's 500 x 500 Ey2: 205 kB at level 1
#: against 251 kB stored) for 20 times the time (12 ms against 0.6 ms a channel).
PNG_COMPRESSION = 0


def write_png(path: str | os.PathLike, img_u8: np.ndarray) -> None:
    """Write a grey (H, W) or colour (H, W, 3) uint8 image as PNG, atomically, without
    matplotlib; its ``Software`` text names pmmw (`io.rundir.made_by_pmmw`). RuntimeError if OIIO
    fails."""
    img = np.ascontiguousarray(img_u8, dtype=np.uint8)
    if img.ndim == 2:
        img = img[:, :, np.newaxis]  # (H, W, 1): OIIO's binding misreads a 2-D array's strides
    if img.ndim != 3 or img.shape[2] not in (1, 3):
        raise ValueError(f"write_png: expected an (H, W) or (H, W, 3) image, got shape {np.shape(img_u8)}")
    spec = oiio.ImageSpec(img.shape[1], img.shape[0], img.shape[2], oiio.UINT8)
    spec.channelnames = ("Y",) if img.shape[2] == 1 else ("R", "G", "B")
    spec.attribute("Software", f"pmmw {__version__}")
    spec.attribute("png:compressionLevel", PNG_COMPRESSION)
    spec.attribute("png:filter", 8)  # libpng's PNG_FILTER_NONE: no per-row filter search
    with atomic_path(path) as tmp:
        out = oiio.ImageOutput.create("png")
        if out is None:
            raise RuntimeError(f"OpenImageIO has no PNG writer: {oiio.geterror()}")
        if not out.open(str(tmp), spec):
            raise RuntimeError(f"cannot open {path} for writing: {out.geterror() or oiio.geterror()}")
        ok = out.write_image(img)
        closed = out.close()
        if not (ok and closed):
            raise RuntimeError(f"cannot write {path}: {out.geterror() or oiio.geterror()}")


def write_preview(
    path: str | os.PathLike, img: npt.ArrayLike, clip_fraction: float = CLIP_FRACTION
) -> tuple[float, float]:
    """Write the display-scaled PNG preview of a temperature image [K]: one grey pixel per
    image pixel (row 0 at the top), without matplotlib.

    Returns the (low, high) temperatures [K] shown as black and white (`display_range`).
    """
    low, high = display_range(img, clip_fraction)
    write_png(path, scale_to_u8(img, low, high))
    return low, high


REGION_COLOURS = ("#ff3b30", "#34c759", "#0a84ff", "#ffcc00", "#ff2dfc", "#00e5ff")  # outlines on grey
#: The outlines' colours in words, for a report's legend (`REGION_COLOURS` in turn).
REGION_COLOUR_NAMES = ("red", "green", "blue", "yellow", "magenta", "cyan")


def region_colour_names(names: Iterable[str]) -> dict[str, str]:
    """Region name -> the colour word of its outline (`write_regions_png`, `write_regions_figure`)."""
    return {name: REGION_COLOUR_NAMES[k % len(REGION_COLOUR_NAMES)] for k, name in enumerate(names)}


def write_regions_png(
    path: str | os.PathLike, img: npt.ArrayLike, masks: Mapping[str, np.ndarray], clip_fraction: float = CLIP_FRACTION
) -> tuple[float, float]:
    """The display-scaled image (`write_preview`'s grey) with each region outlined in its own
    colour (`REGION_COLOURS` in the order of ``masks``): the ring of pixels just outside the
    region's own pixels (the pixels its statistics average, left as they are), without matplotlib.
    The names are not drawn: `region_colour_names` gives each one's colour for the legend.

    Parameters
    ----------
    img : (H, W) array
        Temperatures [K].
    masks : dict of str -> (H, W) bool array
        Region name -> its pixels (`pipeline.region_masks`).

    Returns
    -------
    (low, high) : the temperatures [K] shown as black and white (`display_range`).
    """
    low, high = display_range(img, clip_fraction)
    grey = scale_to_u8(img, low, high)
    rgb = np.repeat(grey[:, :, np.newaxis], 3, axis=2)
    for k, m in enumerate(masks.values()):
        m = np.asarray(m, dtype=bool)
        if not m.any():
            continue
        # the region dilated by its 8 neighbours, less the region (scipy.ndimage.binary_dilation
        # with a 3 x 3 square; its import, 45-50 ms, would be a sixth of the after-trace budget)
        padded = np.pad(m, 1)
        h, w = m.shape
        ring = np.zeros_like(m)
        for dy in range(3):
            for dx in range(3):
                ring |= padded[dy : dy + h, dx : dx + w]
        ring &= ~m
        colour = REGION_COLOURS[k % len(REGION_COLOURS)]
        rgb[ring] = [int(colour[i : i + 2], 16) for i in (1, 3, 5)]
    write_png(path, rgb)
    return low, high


#: Previews narrower than this many pixels are scaled up (nearest neighbour) for reading.
MIN_DISPLAY_WIDTH = 480


def write_figure(
    path: str | os.PathLike,
    panels: Sequence[tuple[str | None, npt.ArrayLike]],
    *,
    title: str,
    clip_fraction: float = CLIP_FRACTION,
    units: str = "K",
    quantity: str = "brightness temperature",
) -> tuple[float, float]:
    """A preview a person reads: the image(s) in grey, each on its own display range with its own
    colour bar in kelvin stating that range, and a title; small images scaled up with nearest
    neighbour, pixels never smoothed.

    Each panel has its own range (`panel_ranges`: Murakowski 2014 sec. 3.2's clipping of each
    image), so an ideal image's few kelvin of structure stay readable beside a sensor image whose
    noise spans tens.

    Parameters
    ----------
    panels : list of (label, (H, W) array)
        Images side by side (e.g. ``[("ideal", a), ("sensor", b)]``); one unlabelled panel for a
        single channel (label None).
    title : str
        E.g. ``"landing_95ghz: Ey2, 95 GHz"``.

    Returns
    -------
    (low, high) : the temperatures [K] shown as black and white in the first panel.
    """

    imgs = [np.asarray(img, dtype=np.float64) for _, img in panels]
    ranges = panel_ranges(imgs, clip_fraction)
    h, w = imgs[0].shape
    fig, axes = figure_for(h, w, len(imgs), extra_w=1.6 * len(imgs))
    if len(imgs) > 1:  # room for each panel's colour bar and its label
        fig.set_layout_engine("constrained")
    for ax, (label, _), img, (low, high) in zip(axes[0], panels, imgs, ranges):
        shown = ax.imshow(img, cmap="gray", vmin=low, vmax=high, interpolation="nearest")
        ax.set_xticks([])
        ax.set_yticks([])
        if label:
            ax.set_title(label, fontsize=9)
        bar = fig.colorbar(shown, ax=ax, fraction=0.05, pad=0.02)
        bar.set_label(
            f"{quantity} [{units}]" + (f"\nblack {low:.4g}, white {high:.4g}" if len(imgs) > 1 else ""), fontsize=8
        )
        bar.ax.tick_params(labelsize=7)
    fig.suptitle(title, fontsize=10)
    save_figure(fig, path)
    return ranges[0]


def panel_ranges(imgs: Sequence[npt.ArrayLike], clip_fraction: float = CLIP_FRACTION) -> list[tuple[float, float]]:
    """The display range [K] of each image of a figure (`usable_range` of each on its own)."""
    return [usable_range(np.asarray(img, dtype=np.float64), clip_fraction) for img in imgs]


def write_regions_figure(
    path: str | os.PathLike,
    img: npt.ArrayLike,
    shapes: Mapping[str, tuple | None],
    *,
    title: str,
    caption: str | None = None,
    units: str = "K",
    quantity: str = "brightness temperature",
) -> tuple[float, float]:
    """The image with its report's regions outlined and named, each in its own colour.

    Parameters
    ----------
    img : (H, W) array
        Temperatures [K], on its display range (`usable_range`) with a colour bar.
    shapes : dict of str -> tuple or None
        Region name -> ``("circle", u, v, radius)`` or ``("box", x0, y0, x1, y1)`` in pixels (x
        right, y down, pixel k spanning [k, k + 1): `pipeline.region_shapes`); None (behind the
        imager) is not drawn.
    caption : str, optional
        A line under the image (the report's first verdict).

    Returns
    -------
    (low, high) : the temperatures [K] shown as black and white.
    """
    import matplotlib.patches as mpatches

    img = np.asarray(img, dtype=np.float64)
    low, high = usable_range(img)
    h, w = img.shape
    fig, axes = figure_for(h, w)
    ax = axes[0, 0]
    shown = ax.imshow(img, cmap="gray", vmin=low, vmax=high, interpolation="nearest")
    for k, (name, shape) in enumerate(shapes.items()):
        if shape is None:
            continue
        colour = REGION_COLOURS[k % len(REGION_COLOURS)]
        patch: mpatches.Patch
        if shape[0] == "circle":  # imshow puts pixel k's centre at k: the image coordinate minus 0.5
            _, u, v, r = shape
            patch, at = mpatches.Circle((u - 0.5, v - 0.5), r, fill=False, ec=colour, lw=1.5), (u - 0.5, v - 0.5 - r)
        else:
            _, x0, y0, x1, y1 = shape
            patch, at = (
                mpatches.Rectangle((x0 - 0.5, y0 - 0.5), x1 - x0, y1 - y0, fill=False, ec=colour, lw=1.5),
                ((x0 + x1) / 2 - 0.5, y0 - 0.5),
            )
        ax.add_patch(patch)
        # names staggered upwards, each joined to its region: close regions' names stay apart
        ax.annotate(
            name,
            at,
            xytext=(0, 4 + 11 * k),
            textcoords="offset points",
            ha="center",
            va="bottom",
            color=colour,
            fontsize=8,
            fontweight="bold",
            annotation_clip=False,
            bbox={"boxstyle": "round,pad=0.15", "fc": "black", "alpha": 0.65, "lw": 0},
            arrowprops={"arrowstyle": "-", "color": colour, "lw": 0.8, "shrinkA": 0, "shrinkB": 0},
        )
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_xticks([])
    ax.set_yticks([])
    bar = fig.colorbar(shown, ax=ax, fraction=0.05, pad=0.02)
    bar.set_label(f"{quantity} [{units}]", fontsize=8)
    bar.ax.tick_params(labelsize=7)
    fig.suptitle(title, fontsize=10)
    if caption:
        ax.set_xlabel(caption, fontsize=7, wrap=True)
    save_figure(fig, path, bbox_inches="tight")
    return low, high


def subplots(
    *args: Any, figsize: tuple[float, float] | None = None, dpi: float | None = None, **kwargs: Any
) -> tuple[Figure, Any]:
    """`matplotlib.pyplot.subplots` without pyplot: a `Figure` that pyplot does not know, so no
    backend is chosen or changed (a notebook's stays as it was) and nothing is left to close.
    ``figsize`` [in] and ``dpi`` make the figure, the rest goes to `Figure.subplots`."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)  # its own raster canvas (animations read its pixels), the global backend untouched
    return fig, fig.subplots(*args, **kwargs)


def save_figure(fig: Figure, path: str | os.PathLike, **savefig: Any) -> Path:
    """Write a matplotlib figure as PNG (`_PNG`) to ``path`` atomically."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, **{**_PNG, **savefig})
    return Path(path)


def usable_range(values: npt.ArrayLike, clip_fraction: float = CLIP_FRACTION) -> tuple[float, float]:
    """`display_range`, widened to 1 K around a constant image (and 0-1 K with no finite pixel),
    so that a colour scale can always be drawn."""
    low, high = display_range(values, clip_fraction)
    if not (np.isfinite(low) and np.isfinite(high) and high > low):
        low, high = (low - 0.5, low + 0.5) if np.isfinite(low) else (0.0, 1.0)
    return low, high


def figure_for(h: int, w: int, panels: int = 1, extra_w: float = 1.6) -> tuple[Figure, np.ndarray]:
    """A figure for ``panels`` images of h x w pixels side by side, small ones scaled up."""
    scale = max(1.0, MIN_DISPLAY_WIDTH / (w * panels))
    dpi = 100
    fig_w = max(4.0, (w * panels * scale) / dpi + extra_w)
    fig_h = max(2.5, (h * scale) / dpi + 0.9)
    return subplots(1, panels, figsize=(fig_w, fig_h), dpi=dpi, squeeze=False)


def write_depth_figure(path: str | os.PathLike, depth: npt.ArrayLike, *, title: str) -> None:
    """``aux.depth`` [m] as a picture: distance to the first hit on a colour scale in metres,
    pixels whose every sample saw the sky in light blue."""
    import matplotlib

    d = np.asarray(depth, dtype=np.float64)
    fig, axes = figure_for(*d.shape)
    ax = axes[0, 0]
    cmap = matplotlib.colormaps["viridis"].with_extremes(bad="#bcd7ee")
    finite = d[np.isfinite(d)]
    lo, hi = display_range(finite, 0.0) if finite.size else (0.0, 1.0)
    shown = ax.imshow(
        np.where(np.isfinite(d), d, np.nan), cmap=cmap, vmin=lo, vmax=max(hi, lo + 1e-9), interpolation="nearest"
    )
    ax.set_xticks([])
    ax.set_yticks([])
    bar = fig.colorbar(shown, ax=ax, fraction=0.05, pad=0.02)
    bar.set_label("distance to the first hit [m] (light blue: sky)", fontsize=8)
    bar.ax.tick_params(labelsize=7)
    fig.suptitle(title, fontsize=10)
    save_figure(fig, path)


def write_material_figure(
    path: str | os.PathLike, material: npt.ArrayLike, names: Sequence[str], *, title: str
) -> None:
    """``aux.material`` as a picture: each material of the first hit in its own colour, with a
    legend of the database ids (``names[i]`` for index i; -1 is the sky)."""
    import matplotlib
    import matplotlib.patches as mpatches

    m = np.rint(np.asarray(material, dtype=np.float64)).astype(int)
    present = [int(i) for i in np.unique(m)]
    palette = matplotlib.colormaps["tab20"].colors  # type: ignore[attr-defined]  # a ListedColormap's
    colours = {i: ((0.74, 0.84, 0.93) if i < 0 else palette[k % len(palette)]) for k, i in enumerate(present)}
    rgb = np.zeros(m.shape + (3,))
    for i, c in colours.items():
        rgb[m == i] = c
    fig, axes = figure_for(m.shape[0], m.shape[1], extra_w=2.6)
    ax = axes[0, 0]
    ax.imshow(rgb, interpolation="nearest")
    ax.set_xticks([])
    ax.set_yticks([])
    labels = [("sky" if i < 0 else (names[i] if 0 <= i < len(names) else f"medium {i}")) for i in present]
    ax.legend(
        handles=[mpatches.Patch(color=colours[i], label=lab) for i, lab in zip(present, labels)],
        loc="center left",
        bbox_to_anchor=(1.02, 0.5),
        fontsize=7,
        title="first hit",
        title_fontsize=8,
    )
    fig.suptitle(title, fontsize=10)
    save_figure(fig, path, bbox_inches="tight")
