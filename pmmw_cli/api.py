"""The Python API: what the commands do, for notebooks and scripts (``import pmmw``).

A `Scenario` is a scenario mapping and the place it stands (relative paths resolve against that
folder, errors name it): from a YAML file (`Scenario.load`) or a dict (`Scenario.from_dict`),
with overrides by dotted key (`Scenario.set`, values as Python objects or strings with units).
`render` returns the image as an `xarray.Dataset` in kelvin (one variable per EXR channel, dims
``frequency``, ``y``, ``x``), writing the EXR, previews and report only when given ``out``; the
same seed gives the same numbers either way. `validate`, `sky`, `po` and `sweep` do what their
commands do and return data. Errors are `pmmw_cli.errors.UserError` (or `UserErrors`), whose
text is the command's one-line message.

The command line is a layer over the same functions (`pmmw_cli.pipeline`, `pmmw_cli.po`,
`pmmw_cli.sweep`): nothing here computes anything of its own.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

__all__ = ["Scenario", "render", "validate", "sky", "brdf", "po", "sweep"]


@dataclass(frozen=True)
class Scenario:
    """A scenario mapping, where it stands, and overrides (applied in order, after the mapping).

    data : dict or None
        The mapping (None: read ``path`` when used, so edits to the file are seen).
    path : Path
        The YAML file, or for a mapping the file it stands for (its folder resolves relative paths).
    values : dict
        ``{"imager.noise": "2 K", "render.spp": 8, ...}``: dotted keys as ``--set`` takes them.
    """

    data: dict | None
    path: Path
    values: dict = field(default_factory=dict)

    @classmethod
    def load(cls, path) -> Scenario:
        """The scenario of a YAML file (read when rendered or validated)."""
        return cls(None, Path(path).expanduser().resolve())

    @classmethod
    def from_dict(cls, data: dict, base_dir=".") -> Scenario:
        """A scenario from a mapping as the YAML would hold it; relative paths (meshes, sky
        texture) resolve against ``base_dir``."""
        if not isinstance(data, dict):
            raise TypeError(f"a scenario is a dict of keys (name, frequency, imager, scene, ...), got {type(data)}")
        return cls(copy.deepcopy(data), Path(base_dir).expanduser().resolve() / "<scenario dict>.yaml")

    def set(self, values: dict | None = None, **keys) -> Scenario:
        """A copy with more overrides: ``s.set({"imager.noise": "2 K"})`` or, for top-level keys,
        ``s.set(frequency="35 GHz")``."""
        return replace(self, values={**self.values, **(values or {}), **keys})

    def resolved(self):
        """The validated, typed scenario (`pmmw_cli.config.schema.Scenario`): SI values, defaults
        filled in, paths absolute."""
        from pmmw_cli.config import load_scenario

        return load_scenario(self.path, data=self.data, values=self.values)

    def _kw(self) -> dict:
        return {"data": self.data, "values": self.values}


def _scenario(s) -> Scenario:
    if isinstance(s, Scenario):
        return s
    if isinstance(s, dict):
        return Scenario.from_dict(s)
    return Scenario.load(s)


def validate(scenario) -> dict:
    """What ``pmmw validate`` prints: the resolved scenario, geometry, media per frequency, the
    slab sky's values, resources and warnings."""
    from pmmw_cli.pipeline import validate as run

    s = _scenario(scenario)
    return run(s.path, **s._kw())


def render(scenario, *, spp: int | None = None, workers: int | None = None, seed: int | None = None,
           out=None, quiet: bool = True):
    """Render a scenario; returns an `xarray.Dataset`.

    Parameters
    ----------
    scenario : Scenario, dict or path
    spp, workers, seed : optional
        As ``--spp``, ``--workers``, ``--seed``.
    out : path, optional
        Also write what ``pmmw render --out`` writes (EXR, previews, report) there.

    Returns
    -------
    xarray.Dataset
        Variables named as the EXR channels (``I``, ``Q``, ``U``, ``V``, ``Ex2``, ``Ey2`` after the
        imager, ``ideal.I`` ... before it, ``aux.*``), float32 [K] with dims (frequency, y, x);
        coordinates ``frequency`` [Hz] and pixel indices ``y`` (row 0 at the top) and ``x``;
        attributes: the EXR header without its ``pmmw:`` prefix, ``regions`` (the report's
        region means and contrasts per frequency, when the scenario names regions) and, rendered
        in memory, ``warnings`` (the report's; they are printed too).
    """
    from pmmw_cli import pipeline

    s = _scenario(scenario)
    cli = {k: v for k, v in (("spp", spp), ("workers", workers), ("seed", seed)) if v is not None}
    if out is not None:
        import json

        from pmmw_cli.io.exr import read_exr

        exrs = pipeline.render(s.path, (), out=out, quiet=quiet, **cli, **s._kw())
        per_f, regions = [], {}
        scn = s.resolved()
        for path, f in zip(exrs, scn.frequencies):
            chans, attrs = read_exr(path)
            per_f.append((f, chans, attrs))
            report = json.loads((Path(path).parent / pipeline.output_names(scn, f)["reports"][0]).read_text())
            if report.get("regions"):
                regions[f"{f / 1e9:g} GHz"] = report["regions"]
        return _dataset(per_f, regions)
    pipeline.clear_warnings()
    res = pipeline.resolve(s.path, (), cli={**cli}, **s._kw())
    scn = res.scenario
    n = scn.render.workers or pipeline.default_workers()
    # the memory check of `pmmw render` (no disk check: nothing is written)
    pipeline.check_memory(pipeline.estimate_resources(scn, int(res.geometry.faces.shape[0]), n), scn.source_file)
    shash = pipeline.scenario_hash(scn, res.db)
    per_f, regions = [], {}
    for f in scn.frequencies:
        job, img, _ = pipeline.trace_frequency(res, f, workers=n, quiet=quiet)
        images = pipeline.frequency_images(scn, f, job, img, shash)
        per_f.append((f, images["channels"], images["attrs"]))
        if scn.output.regions:
            regions[f"{f / 1e9:g} GHz"] = pipeline.region_stats(scn, job.camera, images["sensor"], img, images["kernel"])
    ds = _dataset(per_f, regions)
    ds.attrs["warnings"] = list(pipeline.collected_warnings())
    return ds


def _dataset(per_f, regions):
    """An xarray.Dataset of [(frequency [Hz], channels {name: (H, W)}, EXR header)]."""
    import xarray as xr

    per_f = sorted(per_f, key=lambda t: t[0])
    names = list(per_f[0][1])
    h, w = per_f[0][1][names[0]].shape
    from pmmw_cli.pipeline import channel_quantity

    data = {c: (("frequency", "y", "x"), np.stack([np.asarray(ch[c]) for _, ch, _ in per_f]),
                dict(zip(("units", "long_name"), channel_quantity(c))))
            for c in names}
    attrs = {k.removeprefix("pmmw:"): v for k, v in per_f[0][2].items() if k != "pmmw:frequency_hz"}
    if regions:
        attrs["regions"] = regions
    return xr.Dataset(data, coords={"frequency": ("frequency", [f for f, _, _ in per_f], {"units": "Hz"}),
                                    "y": np.arange(h), "x": np.arange(w)}, attrs=attrs)


def sky(frequency, atmosphere: dict | None = None, elevations_deg=(5, 10, 15, 20, 30, 45, 60, 90)):
    """Sky brightness of a layered atmosphere against elevation, as ``pmmw sky`` computes it.

    frequency : str or float ('95 GHz' or [Hz]); atmosphere : a scenario's ``atmosphere:`` mapping
    (default ``{profile: standard}``). Returns an `xarray.Dataset` of ``Tv`` and ``Th`` [K] over
    ``elevation`` [deg].
    """
    import xarray as xr

    from pmmw_cli import skycmd
    from pmmw_cli.config.schema import parse_frequency

    f = parse_frequency(frequency, "frequency")
    atm = skycmd.load_atmosphere(None, None, [], None, None, data=atmosphere or {})
    rows = skycmd.sky_table(atm, f, list(elevations_deg))
    return xr.Dataset({"Tv": ("elevation", rows[:, 1], {"units": "K"}), "Th": ("elevation", rows[:, 2], {"units": "K"})},
                      coords={"elevation": ("elevation", rows[:, 0], {"units": "deg"})}, attrs={"frequency_hz": f})


def brdf(*, method: str = "mc", out=None, **options):
    """The polarized BRDF of a rough (layered) surface, as ``pmmw brdf`` computes it; keyword
    options as its flags (``n``, ``eps``, ``material``, ``stack``, ``frequency``, ``incidence``,
    ``azimuth``, ``model``, ``ex``, ``alpha``, ``samples``, ``seed``, ...; docs/brdf.md).

    Returns an `xarray.Dataset` per method in a dict ``{method: Dataset}``: ``mueller`` [1/sr]
    over (zenith, azimuth, row, col) in 1-degree cells and ``stokes`` over (component: I, Q, U,
    V; zenith; azimuth) [1/sr], with
    the method's summary (total reflectance, ...) as attributes; files only with ``out``.
    """
    import xarray as xr

    from pmmw_cli.brdf import grid_directions, run_brdf

    res = run_brdf(method=method, out=out, **options)
    theta, phi, _ = grid_directions()
    zen, az = np.degrees(theta[:, 0]), np.degrees(phi[0, :])
    out_ds = {}
    for name, m in res.methods.items():
        attrs = {k: v for k, v in m.summary.items() if isinstance(v, (int, float, str))}
        out_ds[name] = xr.Dataset(
            {"mueller": (("zenith", "azimuth", "row", "col"), m.mueller, {"units": "1/sr"}),
             "stokes": (("component", "zenith", "azimuth"), m.stokes, {"units": "1/sr"})},
            coords={"zenith": ("zenith", zen, {"units": "deg"}), "azimuth": ("azimuth", az, {"units": "deg"}),
                    "component": ["I", "Q", "U", "V"]}, attrs=attrs)
    return out_ds


def po(mesh, *, frequency, material: str | None = None, eps: str | None = None, incidence="0,0",
       polarization="theta", theta=None, phi=None, monostatic=False, bounces=1, method="auto"):
    """Radar cross sections of a mesh by physical optics (``pmmw po``'s quick form); returns an
    `xarray.Dataset` with ``rcs_theta`` and ``rcs_phi`` [m^2] over (phi, theta) in degrees and
    the run's summary (backscatter, peak, lit facets) as attributes."""
    import xarray as xr

    from pmmw_cli.config.schema import parse_frequency
    from pmmw_cli.po.command import run_po

    res = run_po(mesh, material=material, eps=eps, frequency=parse_frequency(frequency, "frequency"),
                 incidence=incidence, polarization=polarization,
                 theta=theta, phi=phi, monostatic=monostatic, bounces=bounces, method=method)
    thetas, phis = res.axes
    shape = (phis.size, thetas.size)
    summary = {k: v for k, v in res.summary.items() if not isinstance(v, dict)}
    summary.update({f"peak_{k}": v for k, v in res.summary["peak"].items()})
    summary = {k: (v if v is not None else float("nan")) for k, v in summary.items()}
    return xr.Dataset({"rcs_theta": (("phi", "theta"), res.rcs_theta.reshape(shape), {"units": "m^2"}),
                       "rcs_phi": (("phi", "theta"), res.rcs_phi.reshape(shape), {"units": "m^2"})},
                      coords={"theta": np.degrees(thetas), "phi": np.degrees(phis)}, attrs=summary)


def sweep(scenario, grid: dict, *, out, zip: bool | list = False, executor: str = "local", workers=None,
          resume: bool = False, quiet: bool = True):
    """Render every variant of ``grid`` ({key: list of values}) as ``pmmw sweep`` does, into
    ``out``; returns the results table (``sweep.csv``) as a `pandas.DataFrame`."""
    import pandas as pd

    from pmmw_cli.sweep import SweepSpec, run_sweep

    s = _scenario(scenario)
    if s.data is not None or s.values:
        raise ValueError("a sweep renders a scenario file: save the scenario as YAML (its variants are its "
                         "grid), or give the overrides as grid keys with one value")
    spec = SweepSpec(scenario=s.path, grid=[(k, list(v)) for k, v in grid.items()], zip=zip, executor=executor,
                     out=Path(out), source="pmmw.sweep", workers=workers)
    run_sweep(spec, resume=resume, quiet=quiet)
    return pd.read_csv(Path(out) / "sweep.csv")
