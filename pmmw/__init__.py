"""pmmw: passive millimetre-wave imaging simulation, as a Python library.

    import pmmw
    scn = pmmw.Scenario.load("configs/landing_95ghz.yaml").set({"imager.noise": "2 K"})
    ds = pmmw.render(scn, spp=4)          # xarray.Dataset of I, Q, U, V, Ex2, Ey2 [K]
    ds["I"].sel(frequency=95e9).plot()   # upright: y is the angle above the view axis [deg]
    pmmw.regions(ds)                       # the report's regions (JSON text in ds.attrs)
    ds.to_netcdf("landing.nc")             # or ds.to_zarr(...)
    scene = pmmw.load(scn)                 # meshes and materials built once ...
    ds = scene.render(frequency="35 GHz", pose={"position": [0, -500, 40]})   # ... many renders

Every misuse raises `UserError` naming the argument or the scenario key (`UserErrors` for
several at once); `EnvironmentProblem` (a `UserError` too) is the machine refusing (a disk full, a
folder that cannot be written). Results to read with care (a material outside its stated range, a
noisy region) come as `PmmwWarning` through Python's `warnings`, and in each report. See
`pmmw.api` (the functions' documentation and their errors) and docs/guide/python-api.md.

This package is the library: it returns data, raises and warns, and never imports the command
line (`pmmw_cli`, the ``pmmw`` command, is a layer on top of it; docs/ARCHITECTURE.md). Its
subpackages: `config`, `scene`, `atmosphere`, `physics`, `surface`, `trace`, `imaging`, `io`,
`physical_optics` (``pmmw po``), `reflectance` (``pmmw brdf``), `sweeps` (``pmmw sweep``). The
names below are loaded on first use, so that importing one subpackage (as the command line does)
does not load them all.
"""

import importlib

__version__ = "0.1.0"

_API = {"Scenario", "render", "load", "LoadedScene", "regions", "validate", "sky", "brdf", "po", "sweep"}
_ERRORS = {"EnvironmentProblem", "PmmwWarning", "UserError", "UserErrors"}

__all__ = [
    "Scenario",
    "render",
    "load",
    "LoadedScene",
    "regions",
    "validate",
    "sky",
    "brdf",
    "po",
    "sweep",
    "UserError",
    "UserErrors",
    "EnvironmentProblem",
    "PmmwWarning",
    "__version__",
]


def __getattr__(name: str):
    if name in _API:
        value = getattr(importlib.import_module("pmmw.api"), name)
    elif name in _ERRORS:
        value = getattr(importlib.import_module("pmmw.errors"), name)
    else:
        raise AttributeError(f"module 'pmmw' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | _API | _ERRORS)
