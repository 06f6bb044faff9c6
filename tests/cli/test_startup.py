"""What `pmmw render` imports before its first ray: heavy modules that a render needs only after
its trace (figures, the imager's FFTs, statistics) or only for some scenes (rain tables,
Dask) are imported where they are used. Checked in a fresh interpreter
through ``sys.modules``, each with a control that imports the module when its use comes."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: Modules not needed before a render's first ray (each ~0.1-0.5 s to import on 2 cores), and the
#: other commands' stacks (the API's Datasets, sweeps, physical optics, reflectance).
LATER = (
    "matplotlib",
    "matplotlib.pyplot",
    "xarray",
    "zarr",
    "dask",
    "jinja2",
    "scipy.signal",
    "scipy.stats",
    "scipy.interpolate",
    "pmmw.api",
    "pmmw.sweeps.run",
    "pmmw.physical_optics.solver",
    "pmmw.reflectance.montecarlo",
)
#: Imported where used, not by importing the render's modules: trimesh (with scipy.spatial,
#: scipy.optimize, scipy.special, scipy.ndimage) for a mesh other than the usual GLB
#: (`pmmw.scene.glb`), pint for units outside `pmmw.units._EXACT`, and scipy.special,
#: scipy.ndimage for the imager model and adaptive sampling, after the first ray.
WHEN_USED = ("trimesh", "pint", "scipy.special", "scipy.ndimage", "scipy.spatial", "scipy.optimize")


def _loaded(code: str, names=LATER) -> set:
    out = subprocess.run(
        [sys.executable, "-c", "import sys\n" + code + "\nprint(' '.join(sorted(sys.modules)))"],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    ).stdout.split()
    return {m for m in names if m in out}


def test_the_command_line_and_the_pipeline_import_none_of_them():
    assert _loaded("import pmmw_cli.__main__, pmmw_cli.cli") == set()
    # everything `pmmw render` imports before it traces: the pipeline, the scenario's schema and
    # its atmosphere, the scene loader, the tracer and its process pool
    assert _loaded("import pmmw.pipeline, pmmw.trace.pool, pmmw.atmosphere.model, pmmw.scene.geometry") == set()
    # nor these, which a render imports where it uses them
    code = "import pmmw_cli.cli, pmmw.pipeline, pmmw.trace.pool, pmmw.atmosphere.model, pmmw.scene.geometry"
    assert _loaded(code, WHEN_USED) == set()


#: `python -c` of a render (`pmmw render ARGV`) that prints the modules imported when its first
#: ray is traced (`pmmw.timings`' mark "first ray") and stops there.
_AT_FIRST_RAY = """import os, sys
from pmmw import timings
mark = timings.mark
def stop_at_first_ray(step):
    mark(step)
    if step == "first ray":
        print(" ".join(sorted(sys.modules)), flush=True)
        os._exit(0)
timings.mark = stop_at_first_ray
from pmmw_cli.__main__ import main
sys.argv = ["pmmw", *sys.argv[1:]]
main()
"""


def _at_first_ray(scenario, out, names=LATER, *args) -> set:
    run = [
        sys.executable,
        "-c",
        _AT_FIRST_RAY,
        "render",
        str(scenario),
        "--out",
        str(out),
        "-q",
        "--workers",
        "1",
        *args,
    ]
    res = subprocess.run(run, capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0 and res.stdout, res.stderr
    return {m for m in names if m in res.stdout.split()}


def test_a_render_traces_its_first_ray_without_them(tmp_path):
    """What `pmmw render` has imported when its first ray is traced: none of `LATER`, and pint not
    for a scenario in the usual units; the control, a scenario with a unit pint alone reads
    (``1.5 metre``), has imported pint by then. A scene of GLB meshes (the landing, made small)
    has imported none of `WHEN_USED`; the control, the OBJ meshes of the first, trimesh."""
    from tests.scenes import tiny_scenario

    scn = tiny_scenario(tmp_path)
    assert _at_first_ray(scn, tmp_path / "a") == set()
    assert _at_first_ray(scn, tmp_path / "b", ("pint", "trimesh")) == {"trimesh"}
    scn.write_text(scn.read_text().replace("[0, 0, 1.5]", "[0, 0, 1.5 metre]"))
    assert _at_first_ray(scn, tmp_path / "c", ("pint",)) == {"pint"}
    landing = ROOT / "configs" / "landing_95ghz.yaml"
    assert _at_first_ray(landing, tmp_path / "d", WHEN_USED, "--set", "imager.resolution=[16, 16]") == set()


def test_control_the_check_sees_a_module_that_imports_them():
    # the same checks where they are imported: the API's functions, the Datasets' and figures'
    # libraries (pmmw imports each inside the function that uses it), the examples' shapes (trimesh)
    assert "pmmw.api" in _loaded("import pmmw\npmmw.render")
    assert {"xarray", "zarr", "dask", "matplotlib.pyplot"} <= _loaded("import xarray, zarr, dask, matplotlib.pyplot")
    assert {"trimesh", "scipy.special"} <= _loaded("import pmmw.scene.shapes", WHEN_USED)


def test_control_each_comes_when_used():
    # the imager model (scipy.fft only, not scipy.signal), a figure (matplotlib), a rain table
    # (scipy.interpolate), the report's detection probability (scipy.special, not scipy.stats)
    loaded = _loaded(
        "import numpy as np\n"
        "from pmmw.io.preview import write_figure\n"
        "import tempfile, os\n"
        "write_figure(os.path.join(tempfile.mkdtemp(), 'p.png'), [(None, np.eye(4))], title='t')\n"
        "from pmmw.atmosphere import itu\n"
        "itu.rain_single_scattering_albedo(95e9, 10.0)\n"
        "from pmmw.imaging.detection import probability_of_detection\n"
        "probability_of_detection(5.0, 1e-3)\n"
    )
    assert loaded == {"matplotlib", "scipy.interpolate"}


def test_render_timings_prints_the_steps_and_phases(tmp_path):
    """``--timings``: the moments (after the process started, in order) and each phase; without
    it nothing of the kind (the control)."""
    from tests.scenes import tiny_scenario

    scn = tiny_scenario(tmp_path)
    run = [sys.executable, "-m", "pmmw_cli", "render", str(scn), "-q", "--workers", "1", "--out"]
    res = subprocess.run([*run, str(tmp_path / "a"), "--timings"], capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0, res.stderr
    lines = res.stderr.split("timings:\n", 1)[1].splitlines()
    moments = [
        (line.split(" at ")[0].strip(), float(line.split(" at ")[1].split()[0])) for line in lines if " at " in line
    ]
    assert [m for m, _ in moments] == [
        "command started",
        "pipeline imported",
        "outputs checked",
        "kernels loaded",
        "first tile sent",
        "first ray",
        "done",
    ]
    times = [t for _, t in moments]
    assert times == sorted(times) and 0.0 < times[0]
    phases = {line.rsplit(None, 2)[0].strip() for line in lines if " at " not in line}
    # the steps before the first ray (the worker's scene: a one-worker render builds it here) and after the trace
    before = {"scenario", "materials", "meshes", "resolve", "atmosphere", "media", "kernels", "worker's scene (Embree)"}
    assert before | {"trace", "imager model", "EXR", "previews", "report", "after the trace, together"} <= phases
    res = subprocess.run([*run, str(tmp_path / "b")], capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0 and "timings:" not in res.stderr


def test_seconds_since_the_process_started():
    # a process that slept 0.3 s has been running at least that long (a clock tick of 10 ms is
    # the resolution: margin 0.02 s), and not minutes (the control that the start is its own)
    code = "import time\ntime.sleep(0.3)\nfrom pmmw import timings\nprint(timings._since_start())\n"
    ago = float(
        subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT).stdout
    )
    assert 0.28 <= ago < 30.0


def test_marks_once_and_phases_add_up():
    from pmmw import timings

    timings.clear()
    timings.mark("a")
    timings.mark("a")  # a second frequency's first tile: the first one counts
    for _ in range(2):
        with timings.phase("EXR"):
            pass
    marks, phases = timings.recorded()
    assert [m for m, _ in marks] == ["a"] and list(phases) == ["EXR"]
    assert any(line.startswith("after the trace, together") for line in timings.lines())
    timings.clear()
    assert timings.recorded() == ([], {})


def test_a_default_render_draws_no_figure(tmp_path):
    """A whole render with the default previews (plain PNGs, `io.preview.write_preview`) imports
    no matplotlib, nor scipy.signal or scipy.stats (the imager model's FFTs and the report's
    detection probability need neither); the same render with ``output.previews: figures``
    imports matplotlib (the control)."""
    from tests.scenes import tiny_scenario

    scn = tiny_scenario(tmp_path)

    def code(sets, out):
        return (
            f"from pmmw.pipeline import render\nrender({str(scn)!r}, {sets!r}, out={str(out)!r}, workers=1, quiet=True)"
        )

    assert _loaded(code([], tmp_path / "a")) == set()
    assert _loaded(code(["output.previews=figures"], tmp_path / "b")) == {"matplotlib"}
