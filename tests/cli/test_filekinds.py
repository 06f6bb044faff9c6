"""`pmmw validate FILE` on every kind of pmmw file, and a sweep's grid checked before anything renders."""

from pathlib import Path

import pytest
from typer.testing import CliRunner

from pmmw import pipeline
from pmmw.errors import PmmwWarning
from pmmw.filekinds import CLUSTER, PO_JOB, SCENARIO, STACK, SWEEP, file_kind
from pmmw.io.yamlio import read_yaml
from pmmw_cli.cli import app
from tests.scenes import ground_and_block

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]
CONFIGS = sorted((ROOT / "configs").rglob("*.yaml"))


def _expected_kind(path: Path) -> str:
    """The kind a shipped config is, from its name and folder (independent of `file_kind`)."""
    name = path.stem
    if name.startswith("po_"):
        return PO_JOB
    if name == "glass_on_copper":
        return STACK
    if name == "slurm":
        return CLUSTER
    if name.endswith(("_sweep", "_trade", "_range", "_frequency", "_frequency_scaled")):
        return SWEEP
    return SCENARIO


def test_there_are_shipped_configs_of_every_kind():
    kinds = {_expected_kind(p) for p in CONFIGS}
    assert kinds == {SCENARIO, SWEEP, PO_JOB, STACK, CLUSTER}, kinds
    assert len(CONFIGS) >= 15


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.relative_to(ROOT / "configs").as_posix())
def test_every_shipped_config_validates_as_its_kind(path):
    """`pmmw validate` accepts each shipped config and says which kind it took it for (before, the
    sweep and physical-optics files were rejected with a list of missing scenario keys)."""
    res = runner.invoke(app, ["validate", str(path)])
    assert res.exit_code == 0, res.output
    assert res.stdout.startswith(f"kind: {_expected_kind(path)}\n") or res.stdout.startswith(
        f"{{kind: {_expected_kind(path)},"
    ), res.stdout[:200]


def test_kind_detection_by_keys():
    assert file_kind({"scenario": "s.yaml", "grid": {"frequency": [1]}}) == SWEEP
    assert file_kind({"targets": [], "frequency": "95 GHz"}) == PO_JOB
    assert file_kind({"layers": [{"n": 1.5}]}) == STACK
    assert file_kind({"kind": "slurm", "cores": 8}) == CLUSTER
    assert file_kind({"name": "x", "imager": {}, "scene": []}) == SCENARIO
    assert file_kind({"kind": "slurm", "imager": {}}) == SCENARIO  # a scenario's keys win


def _tiny(tmp_path: Path) -> Path:
    ground_and_block(tmp_path)
    path = tmp_path / "tiny.yaml"
    path.write_text("""
name: tiny
frequency: 35 GHz
imager: {position: [0, 0, 1.5], look_at: [0, 4, 0.1], fov: 20 deg, resolution: [12, 8], noise: 1 K}
scene:
  - {mesh: ground.obj, material: concrete}
  - {mesh: block.obj, material: metal}
sky: {model: uniform, temperature: 40 K}
render: {spp: 1, max_depth: 2, workers: 1}
""")
    return path


def test_a_typo_in_a_sweeps_grid_key_is_one_line_and_renders_nothing(tmp_path, monkeypatch):
    """Before, the typo failed every variant at render time and the sweep exited 1 with a folder
    of failed rows; now it is one line naming the sweep file, the grid key and the near key, exit 2."""
    _tiny(tmp_path)
    sweep = tmp_path / "sw.yaml"
    sweep.write_text(f"scenario: tiny.yaml\ngrid:\n  imager.nosie: [1 K, 2 K]\nout: {tmp_path / 'out'}\n")

    def no_render(*a, **k):
        raise AssertionError("a variant was rendered")

    monkeypatch.setattr(pipeline, "render", no_render)
    for command in (["sweep", str(sweep), "-q"], ["validate", str(sweep)]):
        res = runner.invoke(app, command)
        assert res.exit_code == 2, res.output
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1, lines
        assert lines[0].startswith(f"error: {sweep}: grid.imager.nosie: unknown key 'nosie' (did you mean 'noise'?)")
    assert not (tmp_path / "out").exists()


def test_a_sweeps_wrong_value_is_named_with_its_value(tmp_path):
    scn = _tiny(tmp_path)
    res = runner.invoke(
        app,
        [
            "sweep",
            str(scn),
            "--grid",
            "frequency=[35 GHz, 5000 GHz]",
            "--grid",
            "render.spp=[1, 2]",
            "--out",
            str(tmp_path / "out"),
            "-q",
        ],
    )
    assert res.exit_code == 2, res.output
    assert res.stderr.strip().splitlines() == [
        "error: --grid: frequency: value 5000 GHz: 5000 GHz is outside the 1-1000 GHz that pmmw's atmosphere and "
        "material models cover"
    ]
    assert not (tmp_path / "out").exists()


def test_a_job_file_checked_as_a_scenario_says_what_it_looks_like(tmp_path):
    """A file with `targets:` and an `imager:` key is a (broken) scenario; the error says that a
    physical-optics job has no imager."""
    bad = tmp_path / "job.yaml"
    bad.write_text("name: j\nimager: {}\ntargets: []\n")
    res = runner.invoke(app, ["validate", str(bad)])
    assert res.exit_code == 2
    assert "a physical-optics job has `targets:`" in res.output


def test_bad_cluster_and_stack_files_are_named_by_key(tmp_path):
    cluster = tmp_path / "c.yaml"
    cluster.write_text("kind: slurm\ncores: 0\n")
    res = runner.invoke(app, ["validate", str(cluster)])
    assert res.exit_code == 2
    assert "c.yaml: memory: required key missing" in res.output and "c.yaml: cores: expected a whole" in res.output
    stack = tmp_path / "s.yaml"
    stack.write_text("wavelength: 635 nm\nlayers: [{n: 1.5, thicknes: 1 mm}]\n")
    res = runner.invoke(app, ["validate", str(stack)])
    assert res.exit_code == 2 and "s.yaml" in res.output and "thicknes" in res.output
    assert read_yaml(stack, "x")["layers"]  # the file is what the test meant


def test_the_api_validates_every_kind_too():
    import pmmw

    assert pmmw.validate(ROOT / "configs/cwd_sweep.yaml")["kind"] == SWEEP
    assert pmmw.validate(str(ROOT / "configs/examples/glass_on_copper.yaml"))["kind"] == STACK
    assert "geometry" in pmmw.validate(ROOT / "configs/cinderblocks_35ghz.yaml")  # a scenario as before


def test_a_sweeps_region_out_of_some_variants_view_is_one_warning(tmp_path):
    scn = _tiny(tmp_path)
    text = scn.read_text() + "output: {regions: {block: {center: [0, 4, 0.1], radius: 1}}}\n"
    scn.write_text(text)
    sweep = tmp_path / "sw.yaml"
    sweep.write_text("scenario: tiny.yaml\ngrid:\n  imager.look_at: [[0, 4, 0.1], [0, -4, 0.1], [4, 0, 1.5]]\n")
    import yaml

    with pytest.warns(PmmwWarning) as caught:
        res = runner.invoke(app, ["validate", str(sweep)])
    assert res.exit_code == 0, res.output
    warned = yaml.safe_load(res.stdout)["scenario_check"]["warnings"]
    assert len(warned) == 1 and "output.regions.block" in warned[0] and "variant(s) v001, v002:" in warned[0], warned
    assert any("variant(s) v001, v002" in str(w.message) for w in caught)
