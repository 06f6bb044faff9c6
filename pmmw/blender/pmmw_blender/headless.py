"""Export a .blend as a pmmw scenario without Blender's window: ``python headless.py FILE.blend
OUT.yaml`` with a Python that has the ``bpy`` package (pmmw runs this for ``pmmw render
FILE.blend``). Self-contained: pmmw itself is not imported here.

Prints one line per finding on standard error, tab-separated, ``pmmw-error KEY MESSAGE`` or
``pmmw-note MESSAGE``, and exits 0 (written), 2 (the scene cannot be exported as it is) or 1.
"""

import sys
from pathlib import Path


def main(argv) -> int:
    if len(argv) != 2:
        print("usage: headless.py FILE.blend OUT.yaml", file=sys.stderr)
        return 1
    blend, out = argv
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import bpy
    from pmmw_blender import exporter, mapping

    try:
        bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
    except RuntimeError as e:
        why = " ".join(str(e).split()).removeprefix("Error: ")
        print(f"pmmw-error\t\tBlender cannot open it: {why}", file=sys.stderr)
        return 2
    try:
        _, notes = exporter.export(bpy.context, out)
    except mapping.ExportError as e:
        for p in getattr(e, "problems", [e]):
            print(f"pmmw-error\t{p.key}\t{p.message}", file=sys.stderr)
        return 2
    for n in notes:
        print(f"pmmw-note\t{n}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]))
