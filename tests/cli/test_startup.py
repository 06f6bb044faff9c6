"""What `pmmw render` imports before its first ray: heavy modules that a render needs only after
its trace (figures, the imager's FFTs, statistics) or only for some scenes (rain tables,
Dask) are imported where they are used. Checked in a fresh interpreter
through ``sys.modules``, each with a control that imports the module when its use comes."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: Modules not needed before a render's first ray (each ~0.1-0.5 s to import on 2 cores).
#: (scipy.ndimage, scipy.spatial, scipy.optimize come with trimesh, which reads the meshes.)
LATER = ("matplotlib", "xarray", "dask", "jinja2", "scipy.signal", "scipy.stats", "scipy.interpolate")


def _loaded(code: str) -> set:
    out = subprocess.run([sys.executable, "-c", "import sys\n" + code + "\nprint(' '.join(sorted(sys.modules)))"],
                         capture_output=True, text=True, check=True, cwd=ROOT).stdout.split()
    return {m for m in LATER if m in out}


def test_the_command_line_and_the_pipeline_import_none_of_them():
    assert _loaded("import pmmw_cli.__main__, pmmw_cli.cli") == set()
    # everything `pmmw render` imports before it traces: the pipeline, the scenario's schema and
    # its atmosphere, the scene loader, the tracer and its process pool
    assert _loaded("import pmmw.pipeline, pmmw.trace.pool, pmmw.atmosphere.model, pmmw.scene.geometry") == set()


def test_control_each_comes_when_used():
    # the imager model (scipy.fft only, not scipy.signal), a figure (matplotlib), a rain table
    # (scipy.interpolate), the report's detection probability (scipy.special, not scipy.stats)
    loaded = _loaded("import numpy as np\n"
                     "from pmmw.io.preview import write_figure\n"
                     "import tempfile, os\n"
                     "write_figure(os.path.join(tempfile.mkdtemp(), 'p.png'), [(None, np.eye(4))], title='t')\n"
                     "from pmmw.atmosphere import itu\n"
                     "itu.rain_single_scattering_albedo(95e9, 10.0)\n"
                     "from pmmw.imaging.detection import probability_of_detection\n"
                     "probability_of_detection(5.0, 1e-3)\n")
    assert loaded == {"matplotlib", "scipy.interpolate"}
