"""The run report: ``report.json`` for programs and ``report.md`` for people.

Expected report keys (any may be absent): ``name``, ``version``, ``frequency_hz``, ``output_exr``,
``channels`` {name: {min, mean, max, display_low, display_high}} [K], ``timing`` {step: seconds},
``rays``, ``pixels``, ``spp``, ``workers``, ``materials_band`` (`pipeline.materials_band`: where
every material is inside its stated range, and what limits it), ``warnings`` [str], ``scenario`` (the resolved scenario
as plain data), ``atmosphere`` (`pipeline.atmosphere_summary`: dB/km at the ground, zenith opacity
and sky, path loss to the target), ``regions`` (`pipeline.region_stats`: the detection criterion,
each contrast's verdict in words, region means and contrasts), ``regions_preview`` (the PNG with the
regions outlined), ``regions_outlines`` {region: colour word} (the legend of a regions preview
that does not name them), ``figures`` {channel: PNG} (each with its colour bar), ``side_by_side``
{channel: PNG}. Other keys go into the JSON only.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path, PurePath
from typing import Any

import numpy as np
import yaml

from pmmw.io.atomic import write_text_atomic


def _plain(value):
    """Plain JSON/YAML data: numpy scalars and arrays to Python, paths to str, NaN/inf to None."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, (list, tuple, set, frozenset)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return _plain(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, PurePath):
        return str(value)
    if value is None or isinstance(value, (str, int, float, bool)):
        return value
    return str(value)


def _num(x: Any, fmt: str = ".2f") -> str:
    if x is None:
        return "-"
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    return format(x, fmt) if math.isfinite(x) else str(x)


def _md_link(target: str) -> str:
    """A Markdown link target; angle brackets keep spaces and parentheses in the path."""
    target = target.replace(os.sep, "/")
    return f"<{target}>" if any(c in target for c in " ()<>") else target


def _pm(x: object) -> str:
    """A standard error for a ``value ± error`` cell."""
    return "n/a" if x is None else _num(x, ".2g")


def _snr_cell(contrast: Mapping) -> str:
    """``7.2 ± 0.3 (yes)``: a contrast's SNR by the detection criterion, ``-`` without one."""
    snr = contrast.get("snr")
    if snr is None:
        return "-"
    err = contrast.get("snr_stderr")
    return (
        f"{_num(snr, '.3g')}"
        + (f" ± {_pm(err)}" if err is not None else "")
        + (" (yes)" if contrast.get("detectable") else " (no)")
    )


def _cell(text: object) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _range(stats: Mapping) -> str:
    if stats.get("display_low") is None and stats.get("display_high") is None:
        return "-"
    return f"{_num(stats.get('display_low'))} .. {_num(stats.get('display_high'))}"


def render_markdown(report: Mapping, previews: Mapping[str, str]) -> str:
    """The human report as Markdown text (see the module docstring for the keys used)."""
    report = _plain(report)
    lines = [f"# {report.get('name', 'pmmw report')}", ""]

    facts = []
    if report.get("version") is not None:
        facts.append(f"- pmmw version: {report['version']}")
    f = report.get("frequency_hz")
    if isinstance(f, (int, float)) and not isinstance(f, bool):
        facts.append(f"- frequency: {f / 1e9:g} GHz")
    if report.get("output_exr") is not None:
        facts.append(f"- image: `{report['output_exr']}`")
    for key, label in (("pixels", "pixels"), ("spp", "samples per pixel"), ("workers", "workers")):
        if report.get(key) is not None:
            value = report[key]
            mean = report.get("mean_samples_per_pixel")
            if key == "spp" and isinstance(mean, (int, float)) and mean < value:
                value = f"{value} at most, {mean:.3g} on average (adaptive sampling)"
            facts.append(f"- {label}: {value}")
    if report.get("rays") is not None:
        rays = report["rays"]
        facts.append(f"- rays traced: {rays:,}" if isinstance(rays, int) else f"- rays traced: {rays}")
    if facts:
        lines += facts + [""]

    lines += _imager_lines(report.get("imager") or {})

    regions = report.get("regions") or {}
    if regions.get("verdicts") is not None or report.get("regions_preview"):
        lines += ["## Detection", ""]
        if regions.get("criterion"):
            lines += [
                f'Criterion: a target is {regions["criterion"]}; the SNR of a pair of regions "a - b" '
                "is the contrast of their means in the ideal image times the norm of a's footprint "
                "blurred by the imager's PSF, over the channel's noise per pixel "
                + (
                    f"({_num(regions.get('noise_K'))} K in Ex2 and Ey2, sqrt(2) times it in I)"
                    if not (report.get("imager") or {}).get("receiver")
                    else "(the receiver's, pixel by pixel, whitened over the footprint; "
                    f"{_num(regions.get('noise_K'))} K on average in Ex2 and Ey2)"
                )
                + "; ± its Monte Carlo standard error.",
                "",
            ]
        lines += [f"- {_cell(v)}" for v in (regions.get("verdicts") or {}).values()]
        if regions.get("verdicts"):
            lines.append("")
        lead = regions.get("channel", "Ey2")
        pds = {
            pair: ch[lead]["pd"]
            for pair, ch in (regions.get("contrasts") or {}).items()
            if ch.get(lead, {}).get("pd") is not None
        }
        if pds:
            lines += [
                f"Probability of detection in {lead} by the matched filter at a false-alarm probability of "
                f"{_num(regions.get('false_alarm'), 'g')} per target-sized test (Pd = Q(Q^-1(Pfa) - SNR), "
                "Kay 1998, eq. 4.14; `output.false_alarm`): "
                + "; ".join(f"{_cell(p)} {_num(v, '.3g')}" for p, v in pds.items())
                + ".",
                "",
            ]
        if report.get("regions_preview"):
            rel = str(report["regions_preview"])
            outlines = report.get("regions_outlines") or {}
            legend = (
                ", outlined on the pixels just outside each: "
                + ", ".join(f"{_cell(name)} {colour}" for name, colour in outlines.items())
                if outlines
                else ""
            )
            lines += [
                f"![regions]({_md_link(rel)})",
                "",
                f"The regions on the sensor image ({regions.get('channel', 'Ey2')}{legend}).",
                "",
            ]

    channels = report.get("channels") or {}
    if channels:
        lines += [
            "## Channels [K]",
            "",
            "| channel | min | mean | max | display range |",
            "| --- | ---: | ---: | ---: | --- |",
        ]
        for name, stats in channels.items():
            stats = stats or {}
            lines.append(
                f"| {_cell(name)} | {_num(stats.get('min'))} | {_num(stats.get('mean'))} | "
                f"{_num(stats.get('max'))} | {_range(stats)} |"
            )
        lines.append("")

    if previews:
        lines += [
            "## Previews",
            "",
            "Display scaling: the coldest and hottest 1/256 of the pixels clip to black and white "
            "(Murakowski 2014 sec. 3.2).",
            "",
        ]
        for name, rel in previews.items():
            stats = channels.get(name) or {}
            lines += [f"### {name}", "", f"![{name}]({_md_link(str(rel))})", ""]
            if _range(stats) != "-":
                lines += [f"black {_num(stats.get('display_low'))} K, white {_num(stats.get('display_high'))} K", ""]

    lines += _image_section(
        "Figures",
        "Each channel with its colour bar in kelvin (`output.previews: figures`), on the display range of its preview.",
        report.get("figures"),
        "",
    )
    lines += _image_section(
        "Ideal and sensor",
        "Left: the ideal image; right: after the imager's PSF and noise. Each on its own display "
        "range (the coldest and hottest 1/256 of its pixels clip), stated on its colour bar.",
        report.get("side_by_side"),
        ": ideal | sensor",
    )

    if regions.get("means"):
        chans = list(next(iter(regions["means"].values())).keys())
        errors, trunc = regions.get("stderr") or {}, regions.get("truncation") or {}
        lines += [
            "## Regions of interest",
            "",
            "Mean sensor temperatures [K] over each region declared in `output.regions`, with the "
            "Monte Carlo standard error of each mean (± s.e.; `n/a` with one sample per pixel) "
            "and the truncation bound: the largest change of the Ex2/Ey2 mean that paths ended at "
            "`render.max_depth` could bring (fraction of the region's power they carry).",
            "",
            "| region | pixels | " + " | ".join(chans) + " | truncation bound [K] (power) |",
            "| --- | ---: | " + " | ".join("---:" for _ in chans) + " | ---: |",
        ]
        for name, m in regions["means"].items():
            e = errors.get(name) or {}
            t = trunc.get(name)
            cells = [f"{_num(m[c])} ± {_pm(e.get(c))}" for c in chans]
            tcell = f"{_num(t['bound_K'], '.3g')} ({_num(100 * t['fraction'], '.2g')} %)" if t else "-"
            lines.append(f"| {_cell(name)} | {regions['pixels'][name]} | " + " | ".join(cells) + f" | {tcell} |")
        lines.append("")
        if regions.get("contrasts"):
            lines += [
                "Contrast between regions (first minus second) in the sensor image, in kelvin ± its "
                "Monte Carlo standard error (figures above "
                f"{_num(regions.get('limit_K'), '.3g')} K are warned about), and its SNR by the detection "
                "criterion above (yes: detectable):",
                "",
                "| regions | " + " | ".join(f"{c} [K] | {c} SNR" for c in chans) + " | truncation bound [K] |",
                "| --- | " + " | ".join("---: | ---:" for _ in chans) + " | ---: |",
            ]
            for pair, cs in regions["contrasts"].items():
                first = cs[chans[0]] if chans else {}
                lines.append(
                    f"| {_cell(pair)} | "
                    + " | ".join(
                        f"{_num(cs[c]['K'])} ± {_pm(cs[c].get('stderr_K'))} | {_snr_cell(cs[c])}" for c in chans
                    )
                    + f" | {_num(first.get('truncation_bound_K'), '.3g')} |"
                )
            lines.append("")

    atm = report.get("atmosphere") or {}
    if atm:
        rows = [
            ("specific attenuation at the ground", "specific_attenuation_at_ground_dB_per_km", "dB/km", ".3g"),
            ("zenith opacity", "zenith_opacity_Np", "Np", ".3g"),
            ("zenith sky brightness", "zenith_sky_K", "K", ".1f"),
            ("distance to the target (the view's centre on the scene)", "target_distance_m", "m", ".0f"),
            ("path loss from the imager to the target", "path_loss_imager_to_target_dB", "dB", ".3g"),
        ]
        lines += ["## Atmosphere", "", "| quantity | value |", "| --- | ---: |"]
        lines += [f"| {label} | {_num(atm[key], fmt)} {unit} |" for label, key, unit, fmt in rows if key in atm]
        lines.append("")

    trunc = report.get("truncation")
    if trunc:
        lines += [
            "## Path truncation",
            "",
            f"Paths still carrying power at `render.max_depth` = {trunc.get('max_depth')} end on the last "
            "object's temperature. Per pixel (`aux.truncated`, `aux.truncation_bound`): mean fraction of "
            f"power ended {_num(100 * trunc['mean_fraction'], '.3g')} % (largest "
            f"{_num(100 * trunc['max_fraction'], '.3g')} %, {_num(100 * trunc['pixels_truncated'], '.3g')} % "
            f"of the pixels); bound on the change of Ex2/Ey2: mean {_num(trunc['mean_bound_K'], '.3g')} K, "
            f"99th percentile {_num(trunc['p99_bound_K'], '.3g')} K, largest {_num(trunc['max_bound_K'], '.3g')} K.",
            "",
        ]

    timing = report.get("timing") or {}
    if timing:
        lines += ["## Timing", "", "| step | seconds |", "| --- | ---: |"]
        lines += [f"| {_cell(step)} | {_num(sec, '.3f')} |" for step, sec in timing.items()]
        lines.append("")

    band = report.get("materials_band")
    if band:
        limits = band.get("limited_by") or {}
        lines += [
            "## Materials' stated ranges",
            "",
            f"Every material of the scene is inside its stated range (its table, model or fit) at "
            f"{band['within_stated_ranges']} (of the {band.get('accepted', 'frequencies')} a scenario accepts); outside, a value "
            "is extrapolated or interpolated and warned."
            + (" Limited by: " + "; ".join(f"{_cell(k)} {v}" for k, v in limits.items()) + "." if limits else ""),
            "",
        ]

    warnings = report.get("warnings")
    if warnings is not None:
        lines += ["## Warnings", ""]
        lines += [f"- {w}" for w in warnings] if warnings else ["None."]
        lines.append("")

    if report.get("scenario") is not None:
        text = yaml.safe_dump(report["scenario"], sort_keys=False, allow_unicode=True)
        lines += ["## Resolved scenario", "", "```yaml", text.rstrip("\n"), "```", ""]

    return "\n".join(lines)


def _image_section(title: str, intro: str, images: Mapping[str, str] | None, alt: str) -> list[str]:
    """A section of images, one per channel ({channel: PNG}): its title, a line saying what they
    are, then each under its channel's name (alt text: the name and ``alt``); none without images."""
    if not images:
        return []
    lines = [f"## {title}", "", intro, ""]
    for name, rel in images.items():
        lines += [f"### {name}", "", f"![{name}{alt}]({_md_link(str(rel))})", ""]
    return lines


def _imager_lines(imager: Mapping) -> list[str]:
    """``## Imager``: the receiver's NETD and per-pixel noise, the beam and its energy budget."""
    rx, beam = imager.get("receiver"), imager.get("beam")
    if not rx and not beam:
        return []
    lines = ["## Imager", ""]
    if rx:
        lines += [
            f"- receiver: {_num(rx.get('noise_temperature_K'), '.4g')} K noise temperature, "
            f"{_num(rx.get('bandwidth_GHz'), '.4g')} GHz pre-detection bandwidth, "
            f"{_num(rx.get('integration_time_s'), '.3g')} s per pixel, {rx.get('mode')}, "
            f"dG/G {_num(rx.get('gain_fluctuation'), '.3g')}",
            f"- NETD: {_num(rx.get('netd_K'), '.3g')} K at a {_num(rx.get('netd_scene_K'), 'g')} K scene "
            "(radiometer equation)",
        ]
        px = rx.get("pixel_noise_K")
        if px:
            lines.append(
                f"- per-pixel noise in this image (Ex2, Ey2): {_num(px['min'], '.3g')} to "
                f"{_num(px['max'], '.3g')} K, mean {_num(px['mean'], '.3g')} K"
            )
    if beam:
        eb = beam.get("energy_budget") or {}
        lines += [
            f"- beam: {beam.get('illumination')} illumination"
            + (f", {_num(beam['edge_taper_dB'], 'g')} dB edge taper" if "edge_taper_dB" in beam else "")
            + f", blockage {_num(beam.get('blockage'), 'g')}; half-power width "
            f"{_num(beam.get('hpbw_mrad'), '.3g')} mrad ({_num(beam.get('hpbw_lambda_over_D'), '.4g')} "
            f"lambda/D), first sidelobe {_num(beam.get('first_sidelobe_dB'), '.3g')} dB",
            f"- energy budget: main beam {_num(eb.get('main_beam'), '.3f')}, sidelobes "
            f"{_num(eb.get('sidelobes'), '.3f')}, spillover {_num(eb.get('spillover'), '.3f')} (seeing "
            f"{_num(eb.get('spillover_temperature_K'), 'g')} K); main-beam efficiency "
            f"{_num(beam.get('main_beam_efficiency'), '.3f')}, taper efficiency "
            f"{_num(beam.get('taper_efficiency'), '.3f')}",
            f"- sampling: pixel pitch {_num(beam.get('pixel_pitch_mrad'), '.3g')} mrad, Nyquist pitch "
            f"{_num(beam.get('nyquist_pitch_mrad'), '.3g')} mrad: {beam.get('sampling')}",
        ]
        off = beam.get("off_axis")
        if off:
            lines.append(
                f"- off axis ({off.get('model')}): at the image's corner, {_num(off.get('corner_field_angle_deg'), '.3g')}"
                f" deg off the boresight, the beam is {_num(off.get('corner_hpbw_radial_mrad'), '.3g')} mrad wide "
                f"radially and {_num(off.get('corner_hpbw_tangential_mrad'), '.3g')} mrad across"
            )
    return lines + [""]


def write_report(
    out_dir: str | os.PathLike, report: Mapping, previews: Mapping[str, str], *, basename: str = "report"
) -> tuple[Path, Path]:
    """Write ``<basename>.json`` and ``<basename>.md`` in ``out_dir``, each atomically.

    Parameters
    ----------
    out_dir : str or Path
        The run's output directory (created if needed).
    report : mapping
        The report (module docstring); numpy values, paths and non-finite floats are made plain
        JSON (NaN and inf become null).
    previews : mapping of str to str
        Channel name -> preview PNG path relative to ``out_dir``.

    Returns
    -------
    (json_path, md_path) : tuple of Path
    """
    out_dir = Path(out_dir)
    json_path = out_dir / f"{basename}.json"
    md_path = out_dir / f"{basename}.md"
    write_text_atomic(json_path, json.dumps(_plain(report), indent=2, default=str) + "\n")
    write_text_atomic(md_path, render_markdown(report, previews))
    return json_path, md_path
