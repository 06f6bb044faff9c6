"""`pmmw sweep`: grids, zipped axes, the results table, executors (local and Dask), resume,
failed variants and the batch-queue job script."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from pmmw import pipeline
from pmmw.errors import UserError
from pmmw.io.exr import read_exr
from pmmw.sweeps.run import SweepSpec, linspace, parse_grid_options, variant_steps, variants
from pmmw_cli.cli import app
from tests.scenes import ground_and_block

runner = CliRunner()


def _scene(tmp_path: Path) -> Path:
    ground_and_block(tmp_path)
    path = tmp_path / "tiny.yaml"
    path.write_text("""
name: tiny
frequency: 35 GHz
imager: {position: [0, 0, 1.5], look_at: [0, 4, 0.1], fov: 20 deg, resolution: [24, 16], noise: 1 K}
scene:
  - {mesh: ground.obj, material: concrete}
  - {mesh: block.obj, material: metal}
sky: {model: uniform, temperature: 40 K}
render: {spp: 2, max_depth: 4, tile: 8, workers: 1}
output:
  regions:
    block: {center: [0, 4, 0.1], radius: 2}
    ground: {box: [0, 12, 6, 16]}
""")
    return path


def test_product_zip_and_partial_zip():
    grid = [("a", [1, 2]), ("b", ["x", "y"]), ("c", [10, 20])]
    assert len(variants(SweepSpec(Path("s.yaml"), grid))) == 8
    assert [tuple(v.values()) for v in variants(SweepSpec(Path("s.yaml"), grid, zip=True))] == [
        (1, "x", 10),
        (2, "y", 20),
    ]
    part = variants(SweepSpec(Path("s.yaml"), grid, zip=["a", "c"]))  # a flight path x b
    assert [(v["a"], v["b"], v["c"]) for v in part] == [(1, "x", 10), (1, "y", 10), (2, "x", 20), (2, "y", 20)]
    with pytest.raises(UserError, match="one length"):
        variants(SweepSpec(Path("s.yaml"), [("a", [1, 2]), ("b", [1])], zip=True))


def test_a_value_written_twice_keeps_the_label_of_its_place():
    """A zipped list may hold one value twice (a control row beside the others, as
    configs/cwd_plastic_gun_sweep.yaml's metal gun): each variant's row takes the label of its own
    place in the list, not of the value's first place."""
    from pmmw.sweeps.run import _row

    grid = [("eps", [[2.7, 0.001], [2.7, 0.01], [2.7, 0.01]]), ("gun", ["plastic", "plastic", "metal"])]
    spec = SweepSpec(Path("s.yaml"), grid, zip=True, names={"eps": ["low", "mid", "(metal)"]})
    failed = {"status": "failed: not rendered", "exr": "", "wall_s": 0.0}
    rows = [_row(spec, Path("out"), f"v{i}", step, failed) for i, step in enumerate(variant_steps(spec))]
    assert [(r["eps"], r["gun"]) for r in rows] == [("low", "plastic"), ("mid", "plastic"), ("(metal)", "metal")]
    assert [v["eps"] for v in variants(spec)] == [[2.7, 0.001], [2.7, 0.01], [2.7, 0.01]]


def test_linspace_with_and_without_units():
    assert linspace("linspace(2000 m, 200 m, 4)", "g") == ["2000 m", "1400 m", "800 m", "200 m"]
    assert linspace("linspace(0, 1, 3)", "g") == [0.0, 0.5, 1.0]
    assert linspace("[1, 2]", "g") is None
    with pytest.raises(UserError, match="share a unit"):
        linspace("linspace(1 m, 2 km, 3)", "g")
    assert parse_grid_options(["imager.noise=linspace(1 K, 4 K, 4)"]) == [
        ("imager.noise", ["1 K", "2 K", "3 K", "4 K"])
    ]


def test_local_sweep_table_report_and_resume(tmp_path, monkeypatch):
    scn = _scene(tmp_path)
    out = tmp_path / "sw"
    res = runner.invoke(
        app,
        [
            "sweep",
            str(scn),
            "--grid",
            "render.seed=[1, 2]",
            "--grid",
            "imager.noise=[0.5 K, 2 K]",
            "--out",
            str(out),
            "-q",
        ],
    )
    assert res.exit_code == 0, res.output
    with open(out / "sweep.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["variant"] for r in rows] == ["v000", "v001", "v002", "v003"]
    assert [(r["render.seed"], r["imager.noise"]) for r in rows] == [
        ("1", "0.5 K"),
        ("1", "2 K"),
        ("2", "0.5 K"),
        ("2", "2 K"),
    ]
    assert all(r["status"] == "done" and (out / r["exr"]).is_file() for r in rows)
    # the table carries the variant's report: the contrast in K and in noise sigmas
    rep = json.loads((out / "v001" / "report.json").read_text())["regions"]["contrasts"]["block - ground"]["I"]
    assert float(rows[1]["contrast block - ground I [K]"]) == pytest.approx(rep["K"])
    assert float(rows[1]["contrast block - ground I [sigma]"]) == pytest.approx(rep["sigma"])
    assert float(rows[0]["contrast block - ground I [sigma]"]) == pytest.approx(
        4 * float(rows[1]["contrast block - ground I [sigma]"]), rel=0.2
    )  # a quarter of the noise
    report = (out / "report.md").read_text()
    assert "| v003 |" in report and (out / "contact_sheet.png").is_file()
    assert any(out.glob("plot_*.png"))
    # two numeric axes (seed, noise): a heat map of each contrast over them, in the report
    assert (out / "heatmap_block_ground.png").stat().st_size > 5_000 and "heatmap_block_ground.png" in report

    def no_render(*a, **k):
        raise AssertionError("--resume rendered a finished variant")

    real_render = pipeline.render
    monkeypatch.setattr(pipeline, "render", no_render)
    res = runner.invoke(
        app,
        [
            "sweep",
            str(scn),
            "--grid",
            "render.seed=[1, 2]",
            "--grid",
            "imager.noise=[0.5 K, 2 K]",
            "--out",
            str(out),
            "-q",
            "--resume",
        ],
    )
    assert res.exit_code == 0, res.output

    # a sweep killed inside v001 (its folder never got its variant.json): --resume renders v001 only,
    # and its progress goes to the log (not a terminal here) as plain lines with the ray rate
    (out / "v001" / "variant.json").unlink()
    calls = []

    def counting(*a, **k):
        calls.append(k["out"])
        return real_render(*a, **k)

    monkeypatch.setattr(pipeline, "render", counting)
    res = runner.invoke(
        app,
        [
            "sweep",
            str(scn),
            "--grid",
            "render.seed=[1, 2]",
            "--grid",
            "imager.noise=[0.5 K, 2 K]",
            "--out",
            str(out),
            "--resume",
        ],
    )
    assert res.exit_code == 0, res.output
    assert [Path(c).name for c in calls] == ["v001"]
    assert "sweep: 4/4 variants" in res.stderr and "Mrays/s" in res.stderr


def test_a_failed_variant_is_recorded_and_the_others_go_on(tmp_path):
    scn = _scene(tmp_path)
    out = tmp_path / "sw"
    # a mesh file without triangles: the sweep's checks take it (they read no mesh), the render
    # refuses it (a value the schema refuses or an unknown material id stops the sweep before
    # anything renders: tests/cli/test_filekinds.py, test_a_sweeps_unknown_material_id_is_one_line...)
    (tmp_path / "empty.obj").write_text("# no faces\nv 0 0 0\n")
    res = runner.invoke(
        app, ["sweep", str(scn), "--grid", "scene[1].mesh=[block.obj, empty.obj, block.obj]", "--out", str(out), "-q"]
    )
    assert res.exit_code == 1, res.output
    with open(out / "sweep.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["status"] for r in rows][0::2] == ["done", "done"]
    assert rows[1]["status"].startswith("failed:") and "empty.obj" in rows[1]["status"], rows[1]
    assert "v001" in res.output


@pytest.mark.full  # zipped axes: test_product_zip_and_partial_zip; a sweep file rendered: the local sweep test
def test_sweep_file_with_a_zipped_flight_path(tmp_path):
    _scene(tmp_path)  # the meshes and tiny.yaml the sweep file names
    sweep = tmp_path / "trade.yaml"
    sweep.write_text(f"""
scenario: tiny.yaml
grid:
  imager.position: [[0, 0, 1.5], [0, 1, 1.5], [0, 2, 1.5]]
  name: [p0, p1, p2]
  frequency: [35 GHz, 95 GHz]
zip: [imager.position, name]
out: {tmp_path / "trade"}
""")
    res = runner.invoke(app, ["sweep", str(sweep), "-q"])
    assert res.exit_code == 0, res.output
    with open(tmp_path / "trade" / "sweep.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["name"], r["frequency"]) for r in rows] == [
        ("p0", "35 GHz"),
        ("p0", "95 GHz"),
        ("p1", "35 GHz"),
        ("p1", "95 GHz"),
        ("p2", "35 GHz"),
        ("p2", "95 GHz"),
    ]
    assert (tmp_path / "trade" / "v005" / "p2.exr").is_file()
    # the flight path as an animation, one per frequency, a frame per pose in order
    from PIL import Image

    report = (tmp_path / "trade" / "report.md").read_text()
    for f in ("35_GHz", "95_GHz"):
        gif = tmp_path / "trade" / f"sequence_frequency_{f}.gif"
        with Image.open(gif) as im:
            assert im.n_frames == 3
        assert gif.name in report


def test_the_slurm_job_script_of_a_cluster_file(tmp_path):
    """No SLURM here: the script dask-jobqueue would submit, from the cluster file."""
    cluster = tmp_path / "slurm.yaml"
    cluster.write_text("kind: slurm\nqueue: normal\ncores: 8\nmemory: 16GB\nwalltime: '02:00:00'\njobs: 4\n")
    res = runner.invoke(
        app, ["sweep", str(_scene(tmp_path)), "--grid", "render.seed=[1]", "--cluster", str(cluster), "--dry-run"]
    )
    assert res.exit_code == 0, res.output
    assert "#SBATCH -p normal" in res.output and "#SBATCH --cpus-per-task=8" in res.output
    assert "#SBATCH -t 02:00:00" in res.output and "--nworkers 8" in res.output and "--nthreads 1" in res.output
    cluster.write_text("kind: condor\ncores: 8\nmemory: 16GB\n")
    res = runner.invoke(
        app, ["sweep", str(_scene(tmp_path)), "--grid", "render.seed=[1]", "--cluster", str(cluster), "--dry-run"]
    )
    assert res.exit_code == 2 and "kind" in res.output


@pytest.mark.parametrize(
    "args, words",
    [
        (["--grid", "render.seed"], "KEY=LIST"),
        (["--grid", "render.seed=[]"], "empty list"),
        (["--grid", "a=[1]", "--grid", "a=[2]"], "swept twice"),
        (["--executor", "spark", "--grid", "render.seed=[1]"], "--executor"),
        ([], "--grid"),
    ],
)
def test_bad_sweep_options_are_one_line(tmp_path, args, words):
    res = runner.invoke(app, ["sweep", str(_scene(tmp_path)), *args])
    assert res.exit_code == 2, res.output
    assert res.output.startswith("error:") and words in res.output


# A Dask worker preload (DASK_DISTRIBUTED__WORKER__PRELOAD) that SIGKILLs its worker process the first
# time, over all workers, that it starts a variant ("sweep") or a tile ("tile"): a worker lost mid-task,
# as to the OOM killer. The marks file is created atomically, so exactly one kill happens.
_PRELOAD = """
import os, signal
import pmmw.pipeline, pmmw.trace.integrator

def _kill_once():
    try:
        os.close(os.open(os.environ["PMMW_TEST_MARKS"], os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return
    os.kill(os.getpid(), signal.SIGKILL)

if getattr(pmmw.pipeline, "_test_killer", False):  # Dask may run a preload more than once
    pass
elif os.environ["PMMW_TEST_KILL"] == "sweep":
    _render = pmmw.pipeline.render
    def render(*a, **k):
        _kill_once()
        return _render(*a, **k)
    pmmw.pipeline.render = render
else:
    _tile = pmmw.trace.integrator.Integrator.render_tile
    def render_tile(self, tile):
        _kill_once()
        return _tile(self, tile)
    pmmw.trace.integrator.Integrator.render_tile = render_tile
pmmw.pipeline._test_killer = True
"""


def _pmmw_with_a_worker_killed(tmp_path: Path, what: str, args: list[str]):
    """Run the real `pmmw` (a subprocess, so a hang fails by timeout) with the killing preload."""
    import os
    import subprocess
    import sys

    preload = tmp_path / "killer_preload.py"
    preload.write_text(_PRELOAD)
    marks = tmp_path / f"kills-{what}"
    env = dict(
        os.environ, DASK_DISTRIBUTED__WORKER__PRELOAD=f'["{preload}"]', PMMW_TEST_MARKS=str(marks), PMMW_TEST_KILL=what
    )
    proc = subprocess.run(
        [str(Path(sys.executable).parent / "pmmw"), *args], env=env, capture_output=True, text=True, timeout=240
    )
    return proc, marks.exists()


@pytest.mark.full  # test_render_on_dask_is_bit_identical_even_with_a_worker_killed kills a worker too
def test_a_dask_worker_killed_mid_sweep_and_the_sweep_completes(tmp_path):
    """A LocalCluster of 2 worker processes, one of which dies (SIGKILL) inside a variant: the
    scheduler reruns that variant on a worker the nanny restarts, every variant ends done, and
    every image is bit-identical to the local executor's."""
    scn = _scene(tmp_path)
    grid = ["--grid", "render.seed=[1, 7, 9]"]
    proc, killed = _pmmw_with_a_worker_killed(
        tmp_path,
        "sweep",
        ["sweep", str(scn), *grid, "--out", str(tmp_path / "dask"), "--executor", "dask", "--workers", "2", "-q"],
    )
    assert killed, "the preload never killed a worker"
    assert proc.returncode == 0, proc.stderr[-2000:]
    with open(tmp_path / "dask" / "sweep.csv") as f:
        assert [r["status"] for r in csv.DictReader(f)] == ["done"] * 3
    res = runner.invoke(app, ["sweep", str(scn), *grid, "--out", str(tmp_path / "local"), "-q"])
    assert res.exit_code == 0, res.output
    for v in ("v000", "v001", "v002"):
        a, _ = read_exr(tmp_path / "local" / v / "tiny.exr")
        b, _ = read_exr(tmp_path / "dask" / v / "tiny.exr")
        assert all(np.array_equal(a[c], b[c]) for c in a)


def test_render_on_dask_is_bit_identical_even_with_a_worker_killed(tmp_path):
    """`pmmw render --executor dask` spreads the tiles of one image over a LocalCluster of 2
    workers, one of which is killed inside a tile: the tile is rerun and the assembled image
    equals the local render bit for bit."""
    scn = _scene(tmp_path)
    res = runner.invoke(app, ["render", str(scn), "--out", str(tmp_path / "local"), "-q"])
    assert res.exit_code == 0, res.output
    proc, killed = _pmmw_with_a_worker_killed(
        tmp_path,
        "tile",
        ["render", str(scn), "--out", str(tmp_path / "dask"), "--executor", "dask", "--workers", "2", "-q"],
    )
    assert killed and proc.returncode == 0, proc.stderr[-2000:]
    a, _ = read_exr(tmp_path / "local" / "tiny.exr")
    b, _ = read_exr(tmp_path / "dask" / "tiny.exr")
    assert all(np.array_equal(a[c], b[c]) for c in a)


def test_dask_render_refuses_a_shard(tmp_path):
    res = runner.invoke(app, ["render", str(_scene(tmp_path)), "--executor", "dask", "--shard", "1/2"])
    assert res.exit_code == 2 and "--shard" in res.output


def test_render_progress_in_a_log_is_plain_lines(tmp_path):
    """Standard error not a terminal (a cluster log): plain lines with tiles done, ray rate and
    time left, no carriage returns."""
    res = runner.invoke(app, ["render", str(_scene(tmp_path)), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert "tiny: tiles 6/6" in res.stderr and "Mrays/s" in res.stderr and "\r" not in res.stderr


@pytest.mark.parametrize(
    "grid, key, value",
    [
        ("scene[1].material: [metal, metl]", "grid.scene[1].material: value metl: ", "'metl'; did you mean 'metal'?"),
        # the same entry written with a dot: named by the grid key as the sweep file spells it
        ("scene.1.material: [metl, metal]", "grid.scene.1.material: value metl: ", "'metl'; did you mean 'metal'?"),
        # a swept materials map whose entry names an unknown id: every value is wrong, no value named
        ("materials: [{concrete: {same_as: metl}}]", "grid.materials: ", "'metl' in same_as; did you mean 'metal'?"),
    ],
)
def test_a_sweeps_unknown_material_id_is_one_line_before_any_render(tmp_path, monkeypatch, grid, key, value):
    """Before, `validate` passed such a sweep and `pmmw sweep` rendered it, each bad variant failing at
    render time; now the ids of every variant are checked as `validate` checks a scenario's: one line
    naming the grid key, the bad id and the nearest known id, exit 2, nothing rendered."""
    _scene(tmp_path)
    sweep = tmp_path / "sw.yaml"
    sweep.write_text(f"scenario: tiny.yaml\ngrid:\n  {grid}\nout: {tmp_path / 'out'}\n")

    def no_render(*a, **k):
        raise AssertionError("a variant was rendered")

    monkeypatch.setattr(pipeline, "render", no_render)
    for command in (["sweep", str(sweep), "-q"], ["validate", str(sweep)]):
        res = runner.invoke(app, command)
        assert res.exit_code == 2, res.output
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1, lines
        assert lines[0].startswith(f"error: {sweep}: {key}"), lines[0]
        assert value in lines[0], lines[0]
    assert not (tmp_path / "out").exists()


def test_a_sweep_over_known_material_ids_passes_the_check(tmp_path):
    """The control: the same grids with known ids (and a materials map defining a new id) pass."""
    _scene(tmp_path)
    sweep = tmp_path / "sw.yaml"
    sweep.write_text(
        "scenario: tiny.yaml\ngrid:\n  scene[1].material: [metal, concrete]\n"
        "  materials: [{}, {concrete: {same_as: metal}}]\n"
        f"out: {tmp_path / 'out'}\n"
    )
    res = runner.invoke(app, ["validate", str(sweep)])
    assert res.exit_code == 0, res.output
    assert "variants: 4" in res.stdout, res.stdout


def test_grid_keys_are_labelled_by_the_parts_that_tell_them_apart():
    """Titles and GIF names label a key by its last part, or by as many last parts as tell it from
    the other keys: `denim.extrapolate` beside `leather.extrapolate` (both were `extrapolate`, and
    the GIFs of two keys were named sequence_extrapolate_hold_extrapolate_trend)."""
    from pmmw.sweeps.report import short_keys

    keys = ["frequency", "imager.noise", "materials.denim.extrapolate", "materials.leather.extrapolate"]
    assert short_keys(keys) == {
        "frequency": "frequency",
        "imager.noise": "noise",
        "materials.denim.extrapolate": "denim.extrapolate",
        "materials.leather.extrapolate": "leather.extrapolate",
    }
    # a key that is the tail of another keeps its whole name; the other needs one part more
    assert short_keys(["a.b", "x.a.b"]) == {"a.b": "a.b", "x.a.b": "x.a.b"}
