"""The gallery, run at build time (mkdocs-gen-files, `make docs`): each examples/ script is executed
at a small size and its page shows the script, what it printed and the figures it wrote.

Each script runs as a user runs it (``python examples/NAME.py OUT_DIR``), with
``PMMW_EXAMPLE_SCALE`` set so that it renders a fraction of the pixels per side, in a folder of its
own; a script that fails fails the build. Where a full run's figure is committed under docs/
(``FULL``), the page shows it too: the small run's numbers are only indicative.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mkdocs_gen_files

ROOT = Path(__file__).resolve().parents[1]
SCALE = os.environ.get("PMMW_EXAMPLE_SCALE", "0.1")
# script -> the figure of a full run, committed under docs/ (shown after the small run's)
FULL = {"frequency_trade.py": "sweeps/frequency_trade.png"}
# PMMW_GALLERY=skip: pages without running the scripts (for a quick look at the other pages)
RUN = os.environ.get("PMMW_GALLERY", "run") != "skip"
TIMEOUT = 900  # [s] per script: a hung example fails the build instead of holding it


def _docstring(path: Path) -> str:
    return ast.get_docstring(ast.parse(path.read_text())) or ""


def _page(script: Path) -> str:
    name = script.stem
    doc = _docstring(script)
    title, _, rest = doc.partition("\n")
    lines = [f"# {title.rstrip('.')}", "", rest.strip(), ""]
    if not RUN:
        lines += ['!!! note "Not run in this build (PMMW_GALLERY=skip)"', ""]
    else:
        with tempfile.TemporaryDirectory(prefix=f"pmmw-gallery-{name}-") as tmp:
            env = dict(
                os.environ,
                PMMW_EXAMPLE_SCALE=SCALE,
                MPLBACKEND="Agg",
                PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep),
            )
            t0 = time.perf_counter()
            run = subprocess.run(
                [sys.executable, str(script), tmp], cwd=ROOT, env=env, capture_output=True, text=True, timeout=TIMEOUT
            )
            seconds = time.perf_counter() - t0
            if run.returncode != 0:
                raise RuntimeError(f"examples/{script.name} failed (exit {run.returncode}):\n{run.stderr[-3000:]}")
            lines += [
                f"Run when the site was built, with `PMMW_EXAMPLE_SCALE={SCALE}` (a fraction of the "
                f"pixels per side, so its numbers are only indicative), in {seconds:.0f} s:",
                "",
                "```text",
                run.stdout.strip().replace(tmp, "OUT_DIR"),
                "```",
                "",
            ]
            for png in sorted(Path(tmp).glob("*.png")):  # the script's figures (not its renders' previews)
                rel = png.name
                with mkdocs_gen_files.open(f"gallery/{name}/{rel}", "wb") as f:
                    f.write(png.read_bytes())
                lines += [f"![{rel}]({name}/{rel})", ""]
    if script.name in FULL:
        lines += [
            "A full run (`python examples/" + script.name + "`, every pixel), committed with the documentation:",
            "",
            f"![{name}, full run](../{FULL[script.name]})",
            "",
        ]
    lines += [
        "## The script",
        "",
        f"`examples/{script.name}`:",
        "",
        "```python",
        script.read_text().rstrip(),
        "```",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    scripts = sorted((ROOT / "examples").glob("*.py"))
    index = [
        "# Gallery",
        "",
        "The `examples/` scripts, each run with the Python API as a user runs it. The figures are made "
        "when the site is built (`make docs`), at a reduced size.",
        "",
        "| example | what |",
        "| --- | --- |",
    ]
    for script in scripts:
        text = _page(script)
        with mkdocs_gen_files.open(f"gallery/{script.stem}.md", "w") as f:
            f.write(text)
        mkdocs_gen_files.set_edit_path(f"gallery/{script.stem}.md", f"../examples/{script.name}")
        index.append(f"| [{script.stem}]({script.stem}.md) | {_docstring(script).partition(chr(10))[0]} |")
    with mkdocs_gen_files.open("gallery/index.md", "w") as f:
        f.write("\n".join(index) + "\n")


main()
