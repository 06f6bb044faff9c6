"""Write the targets of the shipped physical-optics jobs (`configs/po_*.yaml`) as PLY (z up, metres).

* ``beacon_plate.ply``: the landing beacon of Murakowski 2014 sec. 3.1 as
  `scenes/landing/make_scene.py` builds it: a 1 m x 1 m metal plate 5 mm thick, tilted 45 deg
  about x, its front face toward -y and up (normal theta 45 deg, phi 270 deg).
* ``angle_bracket.ply``: one of that scene's low angle brackets (90 deg angle iron, legs 10 cm at
  +-45 deg, ridge up, 1 m long along x), its front leg facing -y and up.
* ``handgun.ply``: the concealed-weapon scene's handgun (`scenes/cwd/make_scene.py`), barrel along
  +x, 3 cm wide, in its own frame.
* ``sphere_ka50.ply``: a sphere of radius 25.1 mm (ka = 50 at 95 GHz), 20480 facets.

    python scenes/po/make_targets.py
"""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import trimesh

HERE = Path(__file__).resolve().parent


def _module(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def main() -> None:
    landing = _module("landing_scene", HERE.parent / "landing" / "make_scene.py")
    cwd = _module("cwd_scene", HERE.parent / "cwd" / "make_scene.py")
    args = landing.argparse.Namespace(
        tilt=45.0, beacon_size=1.0, plate_thickness=0.005, bracket_leg=0.10, bracket_thickness=0.003
    )
    landing.plate(args).export(HERE / "beacon_plate.ply")
    landing.bracket(args).export(HERE / "angle_bracket.ply")
    cwd.gun_local().export(HERE / "handgun.ply")
    radius = 50.0 / (2.0 * np.pi * 95e9 / 299_792_458.0)
    trimesh.creation.icosphere(subdivisions=5, radius=radius).export(HERE / "sphere_ka50.ply")


if __name__ == "__main__":
    main()
