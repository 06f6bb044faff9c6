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
noisy region) come as `PmmwWarning` through Python's `warnings`, and in each report. See `pmmw_cli.api` (the functions' documentation and their errors)
and the README's "Python API".
"""

from pmmw_cli import __version__
from pmmw_cli.api import LoadedScene, Scenario, brdf, load, po, regions, render, sky, sweep, validate
from pmmw_cli.errors import EnvironmentProblem, PmmwWarning, UserError, UserErrors

__all__ = ["Scenario", "render", "load", "LoadedScene", "regions", "validate", "sky", "brdf", "po", "sweep", "UserError", "UserErrors",
           "EnvironmentProblem", "PmmwWarning", "__version__"]
