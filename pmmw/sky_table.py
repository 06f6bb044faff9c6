"""``pmmw sky``: sky brightness temperature against elevation for an atmosphere and weather.

Prints a table or CSV (``elevation_deg,Tv_K,Th_K``), and can write an equirectangular EXR map
(channels Tv, Th: usable directly as ``sky: {texture: ...}``) and a PNG plot comparing the given
atmosphere with the weathers of Murakowski 2014 chapter 3 at the same frequency.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pmmw.errors import UserError
from pmmw.io.preview import save_figure
from pmmw.io.records import validate
from pmmw.io.yamlio import read_yaml
from pmmw.units import parse_quantity

# Weathers of Murakowski 2014 ch. 3: fog 0-600 m of 0.02 and 0.06 g/cm2 (sec. 3.1.1: 200 and
# 600 g/m2 over 600 m), cloud 1-2 km (sec. 3.3.3; its water is pmmw's, fitted to the SAR path loss:
# docs/thesis_parameters.md), rain 10 mm/h up to 1.5 km (sec. 3.3.4; here ITU-R P.838, which holds
# at any frequency, not Table 3.5's 35/95 GHz power law).
PRESETS = {
    "clear": (),
    "cloud 1-2 km, 1.3 g/m3": (("cloud", 1000.0, 2000.0, 1.3e-3, 0.0),),
    "heavy fog 0.02 g/cm2 (0.33 g/m3)": (("fog", 0.0, 600.0, 0.2 / 600.0, 0.0),),
    "extreme fog 0.06 g/cm2 (1 g/m3)": (("fog", 0.0, 600.0, 0.6 / 600.0, 0.0),),
    "rain 10 mm/h to 1.5 km": (("rain", 0.0, 1500.0, 0.0, 10.0),),
}


def parse_layer(text: str):
    """``KIND,BASE,TOP,AMOUNT`` (e.g. ``fog,0 m,600 m,0.3 g/m3`` or ``rain,0,3 km,10 mm/h``)."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 4 or parts[0] not in ("fog", "cloud", "rain"):
        raise UserError(f"expected KIND,BASE,TOP,AMOUNT with KIND fog|cloud|rain, got {text!r}", file="--layer")
    kind = parts[0]
    base = parse_quantity(parts[1], "length", file="--layer", key=kind)
    top = parse_quantity(parts[2], "length", file="--layer", key=kind)
    if kind == "rain":
        return {
            "kind": kind,
            "base": base,
            "top": top,
            "rain_rate": f"{parse_quantity(parts[3], 'rate', file='--layer', key=kind) * 3.6e6} mm/h",
        }
    return {"kind": kind, "base": base, "top": top, "liquid_water": parts[3]}


def parse_elevations(value, file="--elevations", key: str | None = None) -> list[float]:
    """Elevations [deg] as ``pmmw sky --elevations`` and `pmmw.sky` take them: ``"5,10,90"`` or a
    sequence of numbers; at least one, each finite and within 0..90 deg (above the horizon, where
    the layered atmosphere's sky is). Errors name ``file`` (the option or function) and ``key``."""
    example = "expected elevations in degrees like 5,10,90"
    if isinstance(value, str):
        try:
            values = [float(v) for v in value.split(",")]
        except ValueError:
            raise UserError(f"{example}, got {value!r}", file, key) from None
    elif isinstance(value, (list, tuple, np.ndarray)) and all(
        isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) for v in value
    ):
        values = [float(v) for v in value]
    else:
        raise UserError(f"{example} (a list of numbers), got {value!r}", file, key)
    if not values:
        raise UserError(f"{example}, got none", file, key)
    bad = [v for v in values if not 0.0 <= v <= 90.0]  # NaN too
    if bad:
        raise UserError(f"elevations must be within 0..90 deg, got {bad[0]:g}", file, key)
    return values


def load_atmosphere(
    file: Path | None, profile: str | None, layers: list[str], ground_temperature, humidity, data: dict | None = None
):
    """An `Atmosphere` record from a YAML file (or the mapping ``data``) and/or command-line
    options (options win)."""
    from pmmw.config.schema import AtmosphereConfig

    raw: dict = dict(data) if data is not None else {}
    if file is not None:
        if not Path(file).is_file():
            raise UserError("file not found", file=file)
        data = read_yaml(file, "atmosphere file")
        data = data.get("atmosphere", data) if isinstance(data, dict) else data
        if not isinstance(data, dict):
            raise UserError("expected an atmosphere mapping (or a scenario with an `atmosphere:` key)", file=file)
        raw = dict(data)
    if profile:
        raw["profile"] = profile
    if layers:
        raw["layers"] = [parse_layer(t) for t in layers]
    if ground_temperature:
        raw["ground_temperature"] = ground_temperature
    if humidity:
        raw["humidity"] = humidity
    atm = validate(AtmosphereConfig, raw, file or "command line", prefix=("atmosphere",))
    if atm.model != "layered":
        raise UserError("pmmw sky needs a layered atmosphere (profile, layers), not model: uniform", file=file)
    return atm


def _model(atm, f, layers=None):
    from pmmw.atmosphere.model import Atmosphere, AtmosphereLayer, AtmosphereModel

    lay = atm.weather_at(f, file="pmmw sky") if layers is None else tuple(AtmosphereLayer(*layer) for layer in layers)
    return AtmosphereModel(
        Atmosphere(
            profile=atm.profile,
            ground_temperature=atm.ground_temperature,
            humidity=atm.humidity,
            layers=lay,
            ground_altitude=atm.ground_altitude,
        ),
        f,
    )


def sky_table(atm, f: float, elevations_deg) -> np.ndarray:
    """(n, 3) rows of elevation [deg], Tv [K], Th [K]."""
    model = _model(atm, f)
    t = model.sky_temperature(np.radians(np.asarray(elevations_deg, float)))
    return np.column_stack([elevations_deg, t, t])


def format_table(rows, fmt: str) -> str:
    if fmt == "csv":
        return "elevation_deg,Tv_K,Th_K\n" + "\n".join(f"{e:g},{tv:.3f},{th:.3f}" for e, tv, th in rows)
    lines = [f"{'elevation [deg]':>16} {'Tv [K]':>9} {'Th [K]':>9}"]
    lines += [f"{e:16g} {tv:9.2f} {th:9.2f}" for e, tv, th in rows]
    return "\n".join(lines)


def write_map(path: Path, atm, f: float, width: int = 720, ground_temperature: float = 290.0):
    """Equirectangular Tv/Th map (`pmmw.scene.sky_texture` convention); ground below horizon."""
    from pmmw.scene.sky_texture import write_sky_texture

    h = width // 2
    el = np.pi / 2 - np.pi * (np.arange(h) + 0.5) / h
    model = _model(atm, f)
    col = np.where(el >= 0, model.sky_temperature(np.clip(el, 0, None)), ground_temperature)
    tv = np.repeat(col[:, None], width, axis=1)
    write_sky_texture(path, tv, tv.copy())


def write_plot(path: Path, atm, f: float):
    from pmmw.io.preview import subplots

    el = np.linspace(0.0, 90.0, 361)
    fig, ax = subplots(figsize=(6.4, 4.4), dpi=110)
    ax.plot(el, _model(atm, f).sky_temperature(np.radians(el)), "k-", lw=2, label="this atmosphere")
    for name, layers in PRESETS.items():
        ax.plot(el, _model(atm, f, layers=layers).sky_temperature(np.radians(el)), lw=1, label=f"{atm.profile}, {name}")
    ax.set_xlabel("elevation [deg]")
    ax.set_ylabel("sky brightness temperature [K] (Rayleigh-Jeans)")
    ax.set_title(f"Sky at {f / 1e9:g} GHz")
    ax.set_xlim(0, 90)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path)
