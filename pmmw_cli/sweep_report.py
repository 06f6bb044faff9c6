"""The trade-study report of a sweep: ``DIR/report.md`` with the results table, a plot of each
I contrast against the swept values, a heat map for two numeric axes, a contact sheet of the
previews and, for a sweep with keys side by side (a flight path), an animation of the sequence.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from pmmw_cli.io.atomic import atomic_path, write_text_atomic
from pmmw_cli.io.preview import save_figure
from pmmw_cli.sweep import _NUMBER_UNIT, SweepSpec, _label, zipped_keys

MAX_ANIMATIONS = 12  # GIFs per sweep (one per combination of the keys not side by side)
FRAME_MS = 600  # display time of one animation frame [ms]


def _numeric(values) -> list[float] | None:
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


def write_report(out: Path, spec: SweepSpec, table: list[dict]) -> Path:
    """``report.md``: the table, a plot per I contrast against the swept keys, heat maps, a
    contact sheet and animations (module docstring)."""
    keys = [k for k, _ in spec.grid]
    lines = [f"# Sweep of `{spec.scenario.name}`", "",
             f"- grid (every combination{'; side by side: ' + ', '.join(zipped_keys(spec)) if spec.zip else ''}): "
             + "; ".join(f"`{k}` = {', '.join(map(str, v))}" for k, v in spec.grid),
             f"- executor: {spec.executor}; {sum(r['status'] == 'done' for r in table)} of {len(table)} done", ""]
    contrast_cols = [c for c in dict.fromkeys(k for r in table for k in r)
                     if c.startswith("contrast ") and c.endswith(" I [sigma]")]
    k_cols = [c.replace("[sigma]", "[K]") for c in contrast_cols]
    head = ["variant", *keys, "status", *k_cols, *contrast_cols]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("| " + " | ".join("---" for _ in head) + " |")
    for r in table:
        cells = []
        for h in head:
            v = r.get(h, "")
            cells.append(f"{v:.3g}" if isinstance(v, float) and math.isfinite(v) else str(v))
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    plots = _plots(out, spec, table, contrast_cols) + _heatmaps(out, spec, table, contrast_cols)
    sheet = _contact_sheet(out, spec, table)
    lines += [""] + [f"![{p.stem}]({p.name})" for p in plots + ([sheet] if sheet else [])]
    movies = _animations(out, spec, table)
    if movies:
        lines += ["", "Sequences (the keys side by side, in order; one display range per sequence):", ""]
        lines += [f"![{p.stem}]({p.name})" for p in movies]
    return write_text_atomic(out / "report.md", "\n".join(lines) + "\n")


def _plots(out: Path, spec: SweepSpec, table: list[dict], contrast_cols: list[str]) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    axes = _numeric_axes(spec)
    if not axes or not contrast_cols:
        return []
    x_key, x_of = axes[0]
    line_keys = _other_keys(spec, [x_key])
    written = []
    for col in contrast_cols:
        fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=110)
        groups = {}
        for r in table:
            if r["status"] == "done" and isinstance(r.get(col), float) and math.isfinite(r[col]):
                groups.setdefault(", ".join(str(r[k]) for k in line_keys), []).append(r)
        for label, rows in groups.items():
            xs = [x_of[r[x_key]] for r in rows]
            order = sorted(range(len(rows)), key=lambda i: xs[i])
            ax.plot([xs[i] for i in order], [rows[i][col] for i in order], "o-", label=label or None)
        ax.axhline(3.0, color="k", lw=0.8, ls="--")
        ax.axhline(-3.0, color="k", lw=0.8, ls="--")
        ax.set_xlabel(_axis_label(spec, x_key))
        ax.set_ylabel(col.replace("contrast ", "").replace(" [sigma]", " contrast [noise sigma]"))
        ax.set_title(f"{spec.scenario.stem}: {col.split(' I ')[0].replace('contrast ', '')} (I)")
        ax.grid(True, alpha=0.3)
        if line_keys:
            ax.legend(fontsize=7, title=", ".join(line_keys), title_fontsize=7)
        fig.tight_layout()
        path = out / ("plot_" + re.sub(r"[^A-Za-z0-9]+", "_", col.split(" I ")[0].replace("contrast ", "")) + ".png")
        save_figure(fig, path)
        written.append(path)
    return written


def _contact_sheet(out: Path, spec: SweepSpec, table: list[dict]) -> Path | None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt

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
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.8 * rows), dpi=100, squeeze=False)
    keys = [k for k, _ in spec.grid]
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (r, png) in zip(axes.ravel(), shots):
        ax.imshow(mpimg.imread(png), cmap="gray", interpolation="nearest")
        ax.set_title(f"{r['variant']}: " + ", ".join(f"{k.split('.')[-1]}={r[k]}" for k in keys), fontsize=7)
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
        return None if pos is None else dict(zip((_label(spec, key, v) for v in grid[key]), pos))

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


def _other_keys(spec: SweepSpec, used) -> list[str]:
    """The keys with more than one value that are neither in ``used`` nor side by side with one
    of them (what the lines, panels or sequences of a figure are per)."""
    zipped = zipped_keys(spec)
    taken = set(used) | (set(zipped) if set(used) & set(zipped) else set())
    return [k for k, v in spec.grid if len(v) > 1 and k not in taken]


def _heatmaps(out: Path, spec: SweepSpec, table: list[dict], contrast_cols: list[str]) -> list[Path]:
    """For two numeric axes, each I contrast [noise sigma] as a heat map over them, one panel per
    combination of the other varying keys; cells at 3 sigma or more are outlined."""
    axes = _numeric_axes(spec)
    if len(axes) < 2 or not contrast_cols:
        return []
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    (x_key, x_pos), (y_key, y_pos) = axes[:2]
    panel_keys = _other_keys(spec, [x_key, y_key])
    xs, ys = sorted(set(x_pos.values())), sorted(set(y_pos.values()))
    written = []
    for col in contrast_cols:
        panels: dict[str, np.ndarray] = {}
        for r in table:
            v = r.get(col)
            if r["status"] != "done" or not isinstance(v, float) or not math.isfinite(v):
                continue
            z = panels.setdefault(", ".join(str(r[k]) for k in panel_keys), np.full((len(ys), len(xs)), np.nan))
            z[ys.index(y_pos[r[y_key]]), xs.index(x_pos[r[x_key]])] = v
        if not panels:
            continue
        lim = max(3.0, max(float(np.nanmax(np.abs(z))) for z in panels.values()))
        fig, axs = plt.subplots(1, len(panels), figsize=(0.6 + 3.6 * len(panels), 3.6), dpi=110, squeeze=False)
        for ax, (label, z) in zip(axs[0], panels.items()):
            shown = ax.imshow(z, cmap="RdBu_r", vmin=-lim, vmax=lim, origin="lower", aspect="auto")
            for (i, j), v in np.ndenumerate(z):
                if math.isfinite(v):
                    ax.text(j, i, f"{v:.1f}", ha="center", va="center", fontsize=7,
                            fontweight="bold" if abs(v) >= 3.0 else "normal",
                            color="w" if abs(v) > 0.6 * lim else "k")
                    if abs(v) >= 3.0:
                        ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, lw=1.2, ec="k"))
            ax.set_xticks(range(len(xs)), [f"{x:g}" for x in xs], fontsize=7)
            ax.set_yticks(range(len(ys)), [f"{y:g}" for y in ys], fontsize=7)
            ax.set_xlabel(_axis_label(spec, x_key), fontsize=8)
            ax.set_ylabel(_axis_label(spec, y_key), fontsize=8)
            if label:
                ax.set_title(label, fontsize=8)
        bar = fig.colorbar(shown, ax=axs[0].tolist(), fraction=0.04, pad=0.02)
        bar.set_label("contrast [noise sigma] (outlined: |c| >= 3)", fontsize=7)
        pair = col.split(" I ")[0].replace("contrast ", "")
        fig.suptitle(f"{spec.scenario.stem}: {pair} (I)", fontsize=9)
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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    from pmmw_cli.io.exr import read_exr
    from pmmw_cli.io.preview import figure_for, usable_range

    others = _other_keys(spec, zipped)
    groups: dict[str, list[dict]] = {}
    for r in table:
        if r["status"] == "done" and r.get("exr"):
            groups.setdefault(", ".join(f"{k.split('.')[-1]}={r[k]}" for k in others), []).append(r)
    written = []
    for label, rows in list(groups.items())[:MAX_ANIMATIONS]:
        if len(rows) < 2:
            continue
        imgs = [np.asarray(read_exr(out / r["exr"])[0]["I"], float) for r in rows]
        low, high = usable_range(np.concatenate([i.ravel() for i in imgs]))
        h, w = imgs[0].shape
        fig, axes = figure_for(plt, h, w)
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
            ax.set_title(f"{spec.scenario.stem}: " + ", ".join(f"{k.split('.')[-1]}={r[k]}" for k in zipped[:2])
                         + (f" ({label})" if label else ""), fontsize=8)
            fig.canvas.draw()
            frames.append(Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()))
        plt.close(fig)
        path = out / ("sequence_" + (re.sub(r"[^A-Za-z0-9]+", "_", label).strip("_") or "all") + ".gif")
        with atomic_path(path) as tmp:
            frames[0].save(tmp, format="GIF", save_all=True, append_images=frames[1:], duration=FRAME_MS, loop=0)
        written.append(path)
    return written
