"""``python -m pmmw.blender [ZIP]``: build the Blender add-on's zip (``make blender-addon``),
by default ``dist/pmmw_blender.zip``."""

import sys

from pmmw.blender import addon_zip

if __name__ == "__main__":
    print(addon_zip(sys.argv[1] if len(sys.argv) > 1 else "dist/pmmw_blender.zip"))
