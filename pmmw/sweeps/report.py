"""The trade-study report of a sweep: ``DIR/report.md`` with the results table, which variants
are detectable by the one detection criterion (`imaging.detection`: SNR >= 5), each contrast's
detection limit along the first numeric axis (`imaging.detection.detection_limit`), a plot of each
contrast's SNR against the swept values with that threshold, a heat map for two numeric axes, a
contact sheet of the previews and, for a sweep with keys side by side (a flight path), an
animation of the sequence.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from pmmw.imaging.detection import CRITERION, ROSE_SNR, detection_limit
from pmmw.io.atomic import atomic_path, write_text_atomic
from pmmw.io.preview import save_figure
from pmmw.sweeps.spec import _NUMBER_UNIT, SweepSpec, _label, zipped_keys

MAX_ANIMATIONS = 12  # GIFs per sweep (one per combination of the keys not side by side)
FRAME_MS = 600  # display time of one animation frame [ms]


def _numeric(values: Iterable[object]) -> list[float] | None:
    """Plot positions of a grid key's values (numbers or numbers with a unit), or None."""
    out = []
    for v in values:
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            out.append(float(v))
            continue
        m = _NUMBER_UNIT.match(str(v))
        if not m:
            return None
        out.append(float(m.group(1)))
    return out


def _pair_channel(snr_col: str) -> tuple[str, str]:
    """``"snr beacon - runway Ey2"`` -> (``"beacon - runway"``, ``"Ey2"``)."""
    pair, chan = snr_col.removeprefix("snr ").rsplit(" ", 1)
    return pair, chan


def _finite(v: object) -> bool:
    return isinstance(v, float) and math.isfinite(v)


def write_report(out: Path, spec: SweepSpec, table: list[dict]) -> Path:
    """``report.md``: the table, the detectable variants, a plot of each contrast's SNR against
    the swept keys, heat maps, a contact sheet and animations (module docstring)."""
    keys = [k for k, _ in spec.grid]
    lines = [
        f"# Sweep of `{spec.scenario.name}`",
        "",
        f"- grid (every combination{'; side by side: ' + ', '.join(zipped_keys(spec)) if spec.zip else ''}): "
        + "; ".join(f"`{k}` = {', '.join(map(str, v))}" for k, v in spec.grid),
        f"- executor: {spec.executor}; {sum(r['status'] == 'done' for r in table)} of {len(table)} done",
        "",
    ]
    cols = list(dict.fromkeys(k for r in table for k in r))
    snr_cols = [c for c in cols if c.startswith("snr ")]
    k_cols = [f"contrast {' '.join(_pair_channel(c))} [K]" for c in snr_cols]
    det_cols = [c.replace("snr ", "detectable ", 1) for c in snr_cols]
    any_cols = [c for c in cols if c.endswith(" in any channel")]
    best_cols = [c for c in cols if c.startswith("best channel ")]
    head = ["variant", *keys, "status", *k_cols, *snr_cols, *det_cols, *best_cols, *any_cols]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("| " + " | ".join("---" for _ in head) + " |")
    for r in table:
        cells = []
        for h in head:
            v = r.get(h, "")
            cells.append(f"{v:.3g}" if isinstance(v, float) and math.isfinite(v) else str(v))
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    if snr_cols:
        lines += [
            "",
            f"Detection: a target is {CRITERION}; SNR of each contrast in the channel its reports lead with.",
            "",
        ]
        lines += _detection_lines(spec, table, snr_cols)
        lines += _any_channel_lines(table, any_cols)
    limit_lines, limit_plots = _limits_against(out, spec, table, snr_cols)
    lines += limit_lines
    lines += _warning_lines(out, table)
    plots = _plots(out, spec, table, snr_cols) + limit_plots + _heatmaps(out, spec, table, snr_cols)
    sheet = _contact_sheet(out, spec, table)
    lines += [""] + [f"![{p.stem}]({p.name})" for p in plots + ([sheet] if sheet else [])]
    movies = _animations(out, spec, table)
    if movies:
        lines += ["", "Sequences (the keys side by side, in order; one display range per sequence):", ""]
        lines += [f"![{p.stem}]({p.name})" for p in movies]
    return write_text_atomic(out / "report.md", "\n".join(lines) + "\n")


def _warning_lines(out: Path, table: list[dict]) -> list[str]:
    """The variants' warnings (a material outside its model's or table's range, ...), each once with
    the variants that gave it."""
    import json

    seen: dict[str, list[str]] = {}
    for r in table:
        for rep in sorted((out / r["variant"]).glob("report*.json")) if r["status"] == "done" else ():
            try:
                warnings = json.loads(rep.read_text()).get("warnings") or []
            except (OSError, ValueError):
                continue
            for w in warnings:
                names = seen.setdefault(str(w), [])
                if r["variant"] not in names:
                    names.append(r["variant"])
    if not seen:
        return ["", "Warnings: none."]
    out_lines = ["", "Warnings (each once, with the variants that gave it):", ""]
    for w, names in seen.items():
        which = "every variant" if len(names) == len(table) else ", ".join(names)
        out_lines.append(f"- {w} ({which})")
    return out_lines


def _detection_lines(spec: SweepSpec, table: list[dict], snr_cols: list[str]) -> list[str]:
    """Per contrast (and per value of the keys not on the first numeric axis): the values of that
    axis where it is detectable and where not (its detection range), or the variants without
    a numeric axis."""
    axes = _numeric_axes(spec)
    x_key, x_of = axes[0] if axes else (None, {})
    line_keys = _other_keys(spec, [x_key]) if x_key else []
    lines = []
    for col in snr_cols:
        pair, chan = _pair_channel(col)
        groups: dict[str, list[dict]] = {}
        for r in table:
            if r["status"] == "done" and _finite(r.get(col)):
                groups.setdefault(", ".join(f"{k}={r[k]}" for k in line_keys), []).append(r)
        if not groups:
            lines.append(f"- {pair} ({chan}): no SNR (no imager noise)")
        for label, rows in groups.items():
            if x_key:
                rows = sorted(rows, key=lambda r: x_of[r[x_key]])
            name = (lambda r: str(r[x_key])) if x_key else (lambda r: r["variant"])
            yes = [name(r) for r in rows if r[col] >= ROSE_SNR]
            no = [name(r) for r in rows if r[col] < ROSE_SNR]
            at, there = (f"at {x_key} =", "at") if x_key else ("in", "in")
            words = (f"detectable {at} {', '.join(yes)}" if yes else "not detectable") + (
                f"; not {there} {', '.join(no)}" if yes and no else f" {at} {', '.join(no)}" if no else ""
            )
            lines.append(f"- {pair} ({chan}{', ' + label if label else ''}): {words}")
            if x_key and len(rows) > 1:
                lines[-1] += f"; {_limit_words(_axis_label(spec, x_key), _limit(rows, col, x_key, x_of))}"
    return lines + [""]


def _any_channel_lines(table: list[dict], any_cols: list[str]) -> list[str]:
    """Per contrast, the variants detectable in some channel (each variant's own verdict, as its
    report.md states it), where the lines above judge the lead channel only."""
    lines = []
    for col in any_cols:
        pair = col.removeprefix("detectable ").removesuffix(" in any channel")
        done = [r for r in table if r["status"] == "done" and col in r]
        yes = [r["variant"] for r in done if r[col]]
        no = [r["variant"] for r in done if not r[col]]
        words = (f"detectable in {', '.join(yes)}" if yes else "not detectable") + (
            f"; not in {', '.join(no)}" if yes and no else f" in {', '.join(no)}" if no else ""
        )
        lines.append(f"- {pair} (in any channel, each variant's own verdict): {words}")
    return lines + ([""] if lines else [])


def _limit(rows: list[dict], col: str, x_key: str, x_of: dict) -> dict:
    """`detection_limit` of one line of the sweep (rows sorted along ``x_key``)."""
    err_col = col.replace("snr ", "snr_stderr ", 1)
    errs = [r.get(err_col) if _finite(r.get(err_col)) else None for r in rows]
    return detection_limit([x_of[r[x_key]] for r in rows], [r[col] for r in rows], errs)


def _limit_words(x_key: str, lim: dict) -> str:
    """The detection limit in words: ``detection limit 12.3 ± 1.1 (between 10 and 15; ± 1 from the
    spacing, ± 0.2 from the Monte Carlo)``."""
    if lim["kind"] == "all":
        return f"detected over the whole swept {x_key}: the limit lies beyond it"
    if lim["kind"] == "none":
        return f"detected nowhere on the swept {x_key}"
    mc = lim["mc_error"]
    return (
        f"detection limit ({'largest' if lim['falls_with_x'] else 'smallest'} {x_key} detected) "
        f"{lim['crossing_x']:.3g} ± {lim['error']:.2g} (SNR {ROSE_SNR:g} crossed between {lim['detected_x']:g}, "
        f"detected, and {lim['missed_x']:g}; ± {lim['spacing_error']:.2g} from the spacing"
        + (f", ± {mc:.2g} from the Monte Carlo" if math.isfinite(mc) else "")
        + ")"
    )


def _plots(out: Path, spec: SweepSpec, table: list[dict], snr_cols: list[str]) -> list[Path]:
    """Per contrast, its SNR against the first numeric axis, one line per value of the other
    keys, the criterion's threshold drawn; detectable variants filled, the others open."""
    from pmmw.io.preview import subplots

    axes = _numeric_axes(spec)
    if not axes or not snr_cols:
        return []
    x_key, x_of = axes[0]
    line_keys = _other_keys(spec, [x_key])
    written = []
    for col in snr_cols:
        pair, chan = _pair_channel(col)
        groups: dict[str, list[dict]] = {}
        for r in table:
            if r["status"] == "done" and _finite(r.get(col)):
                groups.setdefault(", ".join(str(r[k]) for k in line_keys), []).append(r)
        if not groups:
            continue
        fig, ax = subplots(figsize=(6.4, 4.2), dpi=110)
        values = []
        for label, rows in groups.items():
            rows = sorted(rows, key=lambda r: x_of[r[x_key]])
            xs, ys = [x_of[r[x_key]] for r in rows], [r[col] for r in rows]
            values += ys
            (line,) = ax.plot(xs, ys, "-", label=label or None)
            ax.scatter(
                xs,
                ys,
                s=28,
                zorder=3,
                edgecolors=line.get_color(),
                facecolors=[line.get_color() if y >= ROSE_SNR else "white" for y in ys],
            )
            lim = _limit(rows, col, x_key, x_of) if len(rows) > 1 else {"kind": "all"}
            if lim["kind"] == "limit":  # the detection limit and its uncertainty, on the threshold
                ax.errorbar(
                    [lim["crossing_x"]],
                    [ROSE_SNR],
                    xerr=[lim["error"]],
                    fmt="D",
                    ms=5,
                    capsize=3,
                    color=line.get_color(),
                    zorder=4,
                )
        ax.axhline(
            ROSE_SNR,
            color="k",
            lw=0.9,
            ls="--",
            label=f"SNR {ROSE_SNR:g}: detectable above (Rose); diamonds: detection limit ± error",
        )
        if min(values) > 0 and max(values) > 20 * min(values):
            ax.set_yscale("log")
        ax.set_xlabel(_axis_label(spec, x_key))
        ax.set_ylabel(f"SNR (matched filter, {chan}); filled: detectable")
        ax.set_title(f"{spec.scenario.stem}: {pair} ({chan})")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, title=", ".join(line_keys) or None, title_fontsize=7)
        fig.tight_layout()
        path = out / ("plot_" + re.sub(r"[^A-Za-z0-9]+", "_", pair) + ".png")
        save_figure(fig, path)
        written.append(path)
    return written


def _limits_against(out: Path, spec: SweepSpec, table: list[dict], snr_cols: list[str]) -> tuple[list[str], list[Path]]:
    """With two numeric axes or more: each contrast's detection limit along the first (a detection
    range) against the second (the fog's liquid water, the aperture), one line per value of the
    other keys, as a table in report.md and a plot (``limits_PAIR.png``). A limit beyond the
    swept values (detected everywhere, or nowhere) is drawn at the end it lies past, with a
    triangle pointing past it. Returns (report lines, plot paths)."""
    from pmmw.io.preview import subplots

    axes = _numeric_axes(spec)
    if len(axes) < 2 or not snr_cols:
        return [], []
    (x_key, x_of), (y_key, y_of) = axes[:2]
    line_keys = _other_keys(spec, [x_key, y_key])
    x_name, y_name = _axis_label(spec, x_key), _axis_label(spec, y_key)
    lines, written = [], []
    for col in snr_cols:
        pair, chan = _pair_channel(col)
        curves: dict[str, dict[str, list[dict]]] = {}
        for r in table:
            if r["status"] == "done" and _finite(r.get(col)):
                label = ", ".join(str(r[k]) for k in line_keys)
                curves.setdefault(label, {}).setdefault(r[y_key], []).append(r)
        if not curves:
            continue
        ys = sorted({y for c in curves.values() for y in c}, key=lambda y: y_of[y])
        lines += [
            f"Detection limit of {pair} ({chan}) along {x_name} against {y_name} (± its error; "
            "> or <: beyond the swept values, the triangles of the plot):",
            "",
            "| " + " | ".join([y_name, *(k or "limit" for k in curves)]) + " |",
            "| " + " | ".join("---" for _ in range(len(curves) + 1)) + " |",
        ]
        cells: dict[str, list[str]] = {y: [] for y in ys}
        fig, ax = subplots(figsize=(6.4, 4.2), dpi=110)
        x_lo, x_hi = min(x_of.values()), max(x_of.values())
        for label, by_y in curves.items():
            pts = []
            for y in ys:
                rows = sorted(by_y.get(y, []), key=lambda r: x_of[r[x_key]])
                lim = _limit(rows, col, x_key, x_of) if len(rows) > 1 else {"kind": "one"}
                if lim["kind"] == "limit":
                    cells[y].append(f"{lim['crossing_x']:.4g} ± {lim['error']:.2g}")
                    pts.append((y_of[y], lim["crossing_x"], lim["error"], "o"))
                elif lim["kind"] in ("all", "none"):
                    # beyond the swept values: past the end the SNR falls towards (a range), or
                    # before the start (an aperture); a line detected nowhere, the other way
                    falls = rows[-1][col] < rows[0][col]
                    high = falls == (lim["kind"] == "all")
                    cells[y].append(f"> {x_hi:g}" if high else f"< {x_lo:g}")
                    pts.append((y_of[y], x_hi if high else x_lo, 0.0, "^" if high else "v"))
                else:
                    cells[y].append("")
            if not pts:
                continue
            (line,) = ax.plot([p[0] for p in pts], [p[1] for p in pts], "-", label=label or None)
            for yv, xv, err, mark in pts:
                ax.errorbar([yv], [xv], yerr=[err] if err else None, fmt=mark, ms=6, capsize=3, color=line.get_color())
        lines += ["| " + " | ".join([str(y), *cells[y]]) + " |" for y in ys] + [""]
        ax.set_xlabel(y_name)
        ax.set_ylabel(f"detection limit: {x_name}")
        ax.set_title(f"{spec.scenario.stem}: {pair} ({chan}), SNR {ROSE_SNR:g} crossed", fontsize=9)
        ax.grid(True, alpha=0.3)
        if any(curves):
            ax.legend(fontsize=7, title=", ".join(line_keys) or None, title_fontsize=7)
        fig.tight_layout()
        path = out / ("limits_" + re.sub(r"[^A-Za-z0-9]+", "_", pair) + ".png")
        save_figure(fig, path)
        written.append(path)
    return lines, written


def _contact_sheet(out: Path, spec: SweepSpec, table: list[dict]) -> Path | None:
    import matplotlib.image as mpimg

    from pmmw.io.preview import subplots

    shots = []
    for r in table:
        if r["status"] != "done":
            continue
        pngs = sorted((out / r["variant"] / "previews").glob("*_I.png"))
        if pngs:
            shots.append((r, pngs[0]))
    if not shots:
        return None
    cols = min(4, len(shots))
    rows = math.ceil(len(shots) / cols)
    fig, axes = subplots(rows, cols, figsize=(3.2 * cols, 2.8 * rows), dpi=100, squeeze=False)
    keys = [k for k, _ in spec.grid]
    for ax in axes.ravel():
        ax.axis("off")
    short = short_keys(keys)
    for ax, (r, png) in zip(axes.ravel(), shots):
        ax.imshow(mpimg.imread(png), cmap="gray", interpolation="nearest")
        ax.set_title(f"{r['variant']}: " + ", ".join(f"{short[k]}={r[k]}" for k in keys), fontsize=7)
    fig.tight_layout()
    path = out / "contact_sheet.png"
    save_figure(fig, path)
    return path


def _numeric_axes(spec: SweepSpec) -> list[tuple[str, dict]]:
    """The sweep's numeric axes: (key, {table label: position}). Keys side by side form one axis
    (the ``axis`` key if it is one of them, else their first numeric key); any other key with more
    than one value whose values are numbers (with or without a unit) is an axis of its own."""
    grid = dict(spec.grid)
    zipped = zipped_keys(spec)

    def positions(key):
        pos = spec.axis.get("values") if spec.axis.get("key") == key else None
        pos = pos or _numeric(grid[key])
        return None if pos is None else dict(zip((_label(spec, key, i) for i in range(len(grid[key]))), pos))

    axes = []
    if zipped:
        first = [spec.axis["key"]] if spec.axis.get("key") in zipped else []
        for k in first + [k for k in zipped if k not in first]:
            if positions(k) is not None and len(grid[k]) > 1:
                axes.append((k, positions(k)))
                break
    for k, values in spec.grid:
        if k not in zipped and len(values) > 1 and positions(k) is not None:
            axes.append((k, positions(k)))
    if spec.axis.get("key"):  # the plots' x axis first
        axes.sort(key=lambda a: a[0] != spec.axis["key"])
    return axes


def _axis_label(spec: SweepSpec, key: str) -> str:
    """The ``axis`` label for its key; else the key, with the unit its values share (``frequency [GHz]``)."""
    if spec.axis.get("key") == key and spec.axis.get("label"):
        return spec.axis["label"]
    units = {m.group(2).strip() for m in (_NUMBER_UNIT.match(str(v)) for v in dict(spec.grid)[key]) if m}
    return f"{key} [{units.pop()}]" if len(units) == 1 and "" not in units else key


def short_keys(keys: list[str]) -> dict[str, str]:
    """Each grid key by its last part (``imager.noise`` -> ``noise``), or by as many of its last
    parts as tell it from the others (``materials.denim.extrapolate`` -> ``denim.extrapolate``
    beside ``materials.leather.extrapolate``): the labels in the figures' titles, and so in the
    animations' file names."""
    out = {}
    for k in keys:
        parts = k.split(".")
        n = 1
        while n < len(parts) and any(o != k and o.split(".")[-n:] == parts[-n:] for o in keys):
            n += 1
        out[k] = ".".join(parts[-n:])
    return out


def _other_keys(spec: SweepSpec, used: Iterable[str]) -> list[str]:
    """The keys with more than one value that are neither in ``used`` nor side by side with one
    of them (what the lines, panels or sequences of a figure are per)."""
    zipped = zipped_keys(spec)
    taken = set(used) | (set(zipped) if set(used) & set(zipped) else set())
    return [k for k, v in spec.grid if len(v) > 1 and k not in taken]


def _heatmaps(out: Path, spec: SweepSpec, table: list[dict], snr_cols: list[str]) -> list[Path]:
    """For two numeric axes, each contrast's SNR as a heat map over them, one panel per
    combination of the other varying keys; detectable cells (SNR >= 5) outlined."""
    axes = _numeric_axes(spec)
    if len(axes) < 2 or not snr_cols:
        return []
    from matplotlib.patches import Rectangle

    from pmmw.io.preview import subplots

    (x_key, x_pos), (y_key, y_pos) = axes[:2]
    panel_keys = _other_keys(spec, [x_key, y_key])
    xs, ys = sorted(set(x_pos.values())), sorted(set(y_pos.values()))
    written = []
    for col in snr_cols:
        pair, chan = _pair_channel(col)
        panels: dict[str, np.ndarray] = {}
        for r in table:
            v = r.get(col)
            if r["status"] != "done" or not _finite(v):
                continue
            z = panels.setdefault(", ".join(str(r[k]) for k in panel_keys), np.full((len(ys), len(xs)), np.nan))
            z[ys.index(y_pos[r[y_key]]), xs.index(x_pos[r[x_key]])] = v
        if not panels:
            continue
        top = max(2.0 * ROSE_SNR, max(float(np.nanmax(z)) for z in panels.values()))
        fig, axs = subplots(1, len(panels), figsize=(0.6 + 3.6 * len(panels), 3.6), dpi=110, squeeze=False)
        for ax, (label, z) in zip(axs[0], panels.items()):
            shown = ax.imshow(z, cmap="viridis", vmin=0.0, vmax=top, origin="lower", aspect="auto")
            for (i, j), v in np.ndenumerate(z):
                if math.isfinite(v):
                    ax.text(
                        j,
                        i,
                        f"{v:.3g}",
                        ha="center",
                        va="center",
                        fontsize=7,
                        fontweight="bold" if v >= ROSE_SNR else "normal",
                        color="k" if v > 0.6 * top else "w",
                    )
                    if v >= ROSE_SNR:
                        ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, lw=1.4, ec="r"))
            ax.set_xticks(range(len(xs)), [f"{x:g}" for x in xs], fontsize=7)
            ax.set_yticks(range(len(ys)), [f"{y:g}" for y in ys], fontsize=7)
            ax.set_xlabel(_axis_label(spec, x_key), fontsize=8)
            ax.set_ylabel(_axis_label(spec, y_key), fontsize=8)
            if label:
                ax.set_title(label, fontsize=8)
        bar = fig.colorbar(shown, ax=axs[0].tolist(), fraction=0.04, pad=0.02)
        bar.set_label(f"SNR ({chan}) (outlined: detectable, SNR >= {ROSE_SNR:g})", fontsize=7)
        fig.suptitle(f"{spec.scenario.stem}: {pair} ({chan})", fontsize=9)
        path = out / ("heatmap_" + re.sub(r"[^A-Za-z0-9]+", "_", pair) + ".png")
        save_figure(fig, path)
        written.append(path)
    return written


def _animations(out: Path, spec: SweepSpec, table: list[dict]) -> list[Path]:
    """For keys side by side (a flight path of poses), a GIF of the I images in sequence order,
    one per combination of the other keys (at most `MAX_ANIMATIONS`), each on one display range
    with a kelvin colour bar and the frame's values in the title."""
    zipped = zipped_keys(spec)
    if not zipped or len(dict(spec.grid)[zipped[0]]) < 2:
        return []
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    from pmmw.io.exr import read_exr
    from pmmw.io.preview import figure_for, usable_range

    others = _other_keys(spec, zipped)
    short = short_keys([k for k, _ in spec.grid])
    groups: dict[str, list[dict]] = {}
    for r in table:
        if r["status"] == "done" and r.get("exr"):
            groups.setdefault(", ".join(f"{short[k]}={r[k]}" for k in others), []).append(r)
    written = []
    for label, rows in list(groups.items())[:MAX_ANIMATIONS]:
        if len(rows) < 2:
            continue
        imgs = [np.asarray(read_exr(out / r["exr"])[0]["I"], float) for r in rows]
        low, high = usable_range(np.concatenate([i.ravel() for i in imgs]))
        h, w = imgs[0].shape
        fig, axes = figure_for(h, w)
        ax = axes[0, 0]
        shown = ax.imshow(imgs[0], cmap="gray", vmin=low, vmax=high, interpolation="nearest")
        ax.set_xticks([])
        ax.set_yticks([])
        fig.colorbar(shown, ax=ax, fraction=0.05, pad=0.02).set_label("Stokes I (Ex2 + Ey2) [K]", fontsize=8)
        frames = []
        for r, img in zip(rows, imgs):
            if img.shape != (h, w):
                continue
            shown.set_data(img)
            ax.set_title(
                f"{spec.scenario.stem}: "
                + ", ".join(f"{short[k]}={r[k]}" for k in zipped[:2])
                + (f" ({label})" if label else ""),
                fontsize=8,
            )
            canvas = fig.canvas
            assert isinstance(canvas, FigureCanvasAgg)  # `preview.subplots` gives each figure its own
            canvas.draw()
            frames.append(Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy()))
        path = out / ("sequence_" + (re.sub(r"[^A-Za-z0-9]+", "_", label).strip("_") or "all") + ".gif")
        with atomic_path(path) as tmp:
            frames[0].save(tmp, format="GIF", save_all=True, append_images=frames[1:], duration=FRAME_MS, loop=0)
        written.append(path)
    return written
