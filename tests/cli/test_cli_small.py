"""Small command-line fixes, as a user meets them: the render summary's samples per pixel under
adaptive sampling, `pmmw bench`'s default output, a zero RCS in `pmmw po`'s table, `--version`."""

from pathlib import Path

from typer.testing import CliRunner

from pmmw import __version__
from pmmw_cli.cli import app
from tests.scenes import ground_and_block

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]


def test_version_option():
    for args in (["--version"], ["-V"], ["version"]):
        res = runner.invoke(app, args)
        assert res.exit_code == 0, res.output
        assert res.stdout.strip() == f"pmmw {__version__}"


def test_adaptive_render_summary_says_the_samples_averaged(tmp_path):
    """With a target error far above the Monte Carlo error every pixel stops at min_spp (4), so the
    summary must not claim render.spp (64)."""
    ground_and_block(tmp_path)
    scn = tmp_path / "tiny.yaml"
    scn.write_text("""
name: tiny
frequency: 35 GHz
imager: {position: [0, 0, 1.5], look_at: [0, 4, 0.1], fov: 20 deg, resolution: [8, 6]}
scene:
  - {mesh: ground.obj, material: concrete}
  - {mesh: block.obj, material: metal}
sky: {model: uniform, temperature: 40 K}
render: {spp: 64, min_spp: 4, target_error: 100 K, max_depth: 2, tile: 8, workers: 1}
""")
    res = runner.invoke(app, ["render", str(scn), "--out", str(tmp_path / "o"), "-q"])
    assert res.exit_code == 0, res.output
    line = next(ln for ln in res.stdout.splitlines() if ln.startswith("tiny:"))
    assert "48 px x 4 spp averaged (adaptive, up to 64)" in line, line
    # the control: without a target error the summary gives render.spp
    res = runner.invoke(
        app,
        ["render", str(scn), "--out", str(tmp_path / "o2"), "-q", "--set", "render.target_error=null", "--spp", "2"],
    )
    assert res.exit_code == 0, res.output
    assert "48 px x 2 spp," in res.stdout


def test_bench_leaves_the_committed_page_alone_by_default(tmp_path, monkeypatch):
    import pmmw_cli.bench
    import pmmw_cli.bench_po

    seen = []
    monkeypatch.setattr(pmmw_cli.bench, "bench", lambda *a, **k: seen.append(k["out_md"]))
    monkeypatch.setattr(pmmw_cli.bench_po, "run", lambda out, **k: seen.append(out))
    monkeypatch.chdir(tmp_path)
    for args in (
        ["bench"],
        ["bench", "--po"],
        ["bench", "--write-docs"],
        ["bench", "--po", "--write-docs"],
        ["bench", "--out", "b/x.md"],
    ):
        res = runner.invoke(app, args)
        assert res.exit_code == 0, res.output
    assert seen == [
        Path("out/bench/benchmarks.md"),
        Path("out/bench/benchmarks_po.md"),
        Path("docs/benchmarks.md"),
        Path("docs/benchmarks_po.md"),
        Path("b/x.md"),
    ]
    res = runner.invoke(app, ["bench", "--out", "b/x.md", "--write-docs"])
    assert res.exit_code == 2 and "--write-docs" in res.output


def test_po_table_shows_a_zero_cross_polarized_rcs_as_minus_infinity():
    """A flat plate lit at normal incidence with theta-polarized waves returns no phi-polarized
    field in its plane of incidence: exactly zero, which the table printed as -300.000 dBsm."""
    res = runner.invoke(
        app,
        [
            "po",
            str(ROOT / "scenes/po/beacon_plate.ply"),
            "--material",
            "metal",
            "--frequency",
            "35 GHz",
            "--theta",
            "0:10:5",
        ],
    )
    assert res.exit_code == 0, res.output
    rows = [ln.split() for ln in res.stdout.splitlines()[-3:]]
    assert [r[3] for r in rows] == ["-inf"] * 3, rows
    assert all(float(r[2]) > -100 for r in rows)  # the co-polarized column stays a number
    assert "-300" not in res.stdout
