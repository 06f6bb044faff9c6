"""Previews a person reads: a colour bar in kelvin, a title, the ideal|sensor pair labelled and
only when the imager changes something, small images scaled up; `pmmw view` for any channel."""

import json

import numpy as np
import OpenImageIO as oiio
from typer.testing import CliRunner

from pmmw.io.exr import write_exr
from pmmw.io.preview import MIN_DISPLAY_WIDTH, display_range, write_figure
from pmmw_cli.cli import app

runner = CliRunner()


def _png(path):
    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    pixels = inp.read_image("uint8")
    inp.close()
    return spec, pixels


def test_a_small_image_is_scaled_up_with_its_own_display_range(tmp_path):
    """A 20 x 12 image: the figure is wider than MIN_DISPLAY_WIDTH (scaled, not smoothed: a step
    edge stays one step) and black/white are the thesis's clipped range of the pixels."""
    img = np.full((12, 20), 280.0)
    img[:, 10:] = 300.0
    low, high = write_figure(tmp_path / "p.png", [(None, img)], title="t: I, 95 GHz")
    assert (low, high) == display_range(img)
    spec, px = _png(tmp_path / "p.png")
    assert spec.width >= MIN_DISPLAY_WIDTH and spec.nchannels >= 3
    # the colour bar adds grey levels between black and white: more than the image's two
    greys = {tuple(p[:3]) for p in px.reshape(-1, spec.nchannels) if p[0] == p[1] == p[2]}
    assert len(greys) > 20


def test_each_panel_of_a_pair_has_its_own_range(tmp_path):
    """The ideal image beside the sensor image: each on its own display range (the thesis's
    clipping of each image), the first panel's returned."""
    from pmmw.io.preview import panel_ranges

    a, b = np.full((8, 8), 250.0), np.full((8, 8), 340.0)
    a[:, 4:], b[:, 4:] = 260.0, 360.0
    low, high = write_figure(tmp_path / "pair.png", [("ideal", a), ("sensor", b)], title="pair")
    assert (low, high) == (250.0, 260.0)
    assert panel_ranges([a, b]) == [(250.0, 260.0), (340.0, 360.0)]


def test_render_previews_are_figures_and_the_pair_only_with_an_imager(tmp_path):
    import trimesh

    ground = trimesh.creation.box(extents=[40, 40, 1])
    ground.apply_translation([0, 0, -0.5])
    ground.export(tmp_path / "ground.obj")
    scn = tmp_path / "s.yaml"
    scn.write_text("""
name: s
frequency: 35 GHz
imager: {position: [0, 0, 1.5], look_at: [0, 4, 0], fov: 20 deg, resolution: [24, 16]}
scene: [{mesh: ground.obj, material: concrete}]
sky: {model: uniform, temperature: 40 K}
render: {spp: 1, max_depth: 4, tile: 8, workers: 1}
""")
    res = runner.invoke(app, ["render", str(scn), "--out", str(tmp_path / "a"), "-q"])
    assert res.exit_code == 0, res.output
    assert not list((tmp_path / "a" / "previews").glob("*_ideal_sensor.png"))  # ideal imager: no pair
    spec, _ = _png(tmp_path / "a" / "previews" / "s_I.png")
    assert spec.width >= MIN_DISPLAY_WIDTH
    # with output.previews: quick, I alone; by default (true, as "all") every channel and the ideal|sensor pairs
    res = runner.invoke(
        app,
        [
            "render",
            str(scn),
            "--out",
            str(tmp_path / "b"),
            "-q",
            "--set",
            "imager.noise=2 K",
            "--set",
            "output.previews=quick",
        ],
    )
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in (tmp_path / "b" / "previews").iterdir()) == ["s_I.png"]
    res = runner.invoke(app, ["render", str(scn), "--out", str(tmp_path / "c"), "-q", "--set", "imager.noise=2 K"])
    assert res.exit_code == 0, res.output
    drawn = sorted(p.name for p in (tmp_path / "c" / "previews").iterdir())
    assert drawn == sorted(
        [f"s_{c}.png" for c in ("I", "Q", "U", "V", "Ex2", "Ey2")]
        + ["s_Ex2_ideal_sensor.png", "s_Ey2_ideal_sensor.png"]
    )
    report = json.loads((tmp_path / "c" / "report.json").read_text())
    assert len(report["previews"]) == 6 and len(report["side_by_side"]) == 2
    assert all("display_low" in report["channels"][c] for c in report["channels"])
    report = json.loads((tmp_path / "b" / "report.json").read_text())
    assert list(report["previews"]) == ["I"] and "side_by_side" not in report
    assert "display_low" in report["channels"]["I"] and "display_low" not in report["channels"]["Q"]


def test_the_default_previews_are_every_channel_and_quick_is_i_or_the_first():
    from types import SimpleNamespace

    from pmmw.pipeline import preview_channels

    def scn(channels, previews):
        return SimpleNamespace(output=SimpleNamespace(channels=channels, previews=previews))

    assert preview_channels(scn(("I", "Q", "U", "V", "Ex2", "Ey2"), True)) == ("I", "Q", "U", "V", "Ex2", "Ey2")
    assert preview_channels(scn(("I", "Q", "U", "V", "Ex2", "Ey2"), "quick")) == ("I",)
    assert preview_channels(scn(("Ey2", "Ex2"), "quick")) == ("Ey2",)
    assert preview_channels(scn(("Q", "I"), "all")) == ("Q", "I")
    assert preview_channels(scn(("Q", "I"), False)) == ()


def test_view_writes_any_channel(tmp_path):
    exr = tmp_path / "x.exr"
    write_exr(
        exr,
        {"I": np.full((6, 9), 300.0, np.float32), "aux.depth": np.full((6, 9), 12.0, np.float32)},
        {"pmmw:frequency_hz": 95e9},
    )
    res = runner.invoke(app, ["view", str(exr), "--channel", "aux.depth"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "x_aux_depth.png").is_file() and "m)" in res.output
    res = runner.invoke(app, ["view", str(exr), "--channel", "Q"])
    assert res.exit_code == 2 and "no channel 'Q'" in res.output


def test_a_z_up_gltf_is_warned_about_and_validate_prints_bounds(tmp_path):
    """trimesh writes its Z-up coordinates into glTF as they are: a flat ground then stands on its
    edge. validate warns, naming up_axis: z, and prints each object's bounds and file up axis;
    with up_axis: z the warning is gone and the ground lies flat."""
    import trimesh
    import yaml

    trimesh.creation.box(extents=[40, 40, 1]).export(tmp_path / "ground.glb")
    scn = tmp_path / "z.yaml"
    scn.write_text(
        "name: z\nfrequency: 35 GHz\nimager: {position: [0, -10, 5], look_at: [0, 0, 0], fov: 20 deg, "
        "resolution: [8, 8]}\nscene: [{mesh: ground.glb, material: concrete}]\n"
    )
    res = runner.invoke(app, ["validate", str(scn)])
    assert res.exit_code == 0 and "up_axis: z" in res.output and "on its edge" in res.output, res.output
    res = runner.invoke(app, ["validate", str(scn), "--set", "scene[0].up_axis=z"])
    assert res.exit_code == 0 and "on its edge" not in res.output
    obj = yaml.safe_load(res.output)["geometry"]["objects"]["scene[0]:ground.glb"]
    assert obj["file_up_axis"] == "z" and obj["bounds_m"] == [[-20.0, -20.0, -0.5], [20.0, 20.0, 0.5]]
