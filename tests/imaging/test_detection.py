"""The one detection criterion (`pmmw.imaging.detection`: matched-filter SNR >= 5) against
closed forms, its Monte Carlo error against the spread over seeds, and where a render reports it:
report.json/report.md (controls that must fail and must pass), the regions preview, the
ideal|sensor figure, `pmmw sweep`'s table and report."""

import csv
import json

import numpy as np
import OpenImageIO as oiio
import pytest
import yaml
from typer.testing import CliRunner

import pmmw
from pmmw import pipeline
from pmmw.imaging import detection
from pmmw.imaging.imager import psf_kernel
from pmmw.io.exr import read_exr
from pmmw.io.preview import write_figure
from pmmw_cli.cli import app
from tests.scenes import ground_and_block

runner = CliRunner()

# the tiny scene of the CLI tests with a 0.3 m aperture (a PSF about 2 px wide at 35 GHz) and 1 K
# of noise; regions: the metal block mirroring the 40 K sky, and two ground boxes mirror images of
# each other across the view's vertical mid-line (the same material at the same angles)
SCENE = {
    "name": "tiny",
    "frequency": "35 GHz",
    "imager": {
        "position": [0, 0, 1.5],
        "look_at": [0, 4, 0.1],
        "fov": "20 deg",
        "resolution": [24, 16],
        "noise": "1 K",
        "aperture_diameter": "0.3 m",
    },
    "scene": [{"mesh": "ground.obj", "material": "concrete"}, {"mesh": "block.obj", "material": "metal"}],
    "sky": {"model": "uniform", "temperature": "40 K"},
    "render": {"spp": 4, "max_depth": 4, "tile": 8, "workers": 1},
    "output": {
        "regions": {
            "block": {"center": [0, 4, 0.1], "radius": 2},
            "ground": {"box": [0, 12, 6, 16]},
            "mirror": {"box": [18, 12, 24, 16]},
        }
    },
}


@pytest.fixture
def folder(tmp_path):
    ground_and_block(tmp_path)
    (tmp_path / "tiny.yaml").write_text(yaml.safe_dump(SCENE))
    return tmp_path


def _render(folder, out, *args):
    res = runner.invoke(app, ["render", str(folder / "tiny.yaml"), "--out", str(out), "-q", *map(str, args)])
    assert res.exit_code == 0, res.output
    return json.loads((out / "report.json").read_text())


def _gaussian(s: float, radius: int) -> np.ndarray:
    y, x = np.mgrid[-radius : radius + 1, -radius : radius + 1]
    k = np.exp(-(x * x + y * y) / (2.0 * s * s))
    return k / k.sum()


# ---------------------------------------------------------------------------------------------
# the formulas against closed forms


def test_an_unblurred_region_has_snr_contrast_times_sqrt_n_over_sigma():
    """Without blur the footprint is the mask itself: SNR = |dT| sqrt(N) / sigma (Rose 1948).
    Tolerance 1e-12 relative: the two sides differ by float rounding only. The channel's noise is
    sigma for Ex2/Ey2 and sqrt(2) sigma for I."""
    rng = np.random.default_rng(3)
    for n_pixels in (1, 7, 150):
        mask = np.zeros((30, 40), bool)
        mask.ravel()[rng.choice(mask.size, n_pixels, replace=False)] = True
        for dT, sigma in ((2.5, 1.0), (-0.3, 4.0)):
            assert detection.region_snr(dT, mask, None, sigma) == pytest.approx(
                abs(dT) * np.sqrt(n_pixels) / sigma, rel=1e-12
            )
    assert detection.channel_sigma(2.0, "Ey2") == 2.0 and detection.channel_sigma(2.0, "I") == pytest.approx(
        2.0 * np.sqrt(2.0), rel=1e-15
    )
    assert detection.region_snr(3.0, mask, None, 0.0) is None and detection.detectable(None) is None
    assert detection.detectable(5.0) is True and detection.detectable(4.999) is False


def test_a_region_far_smaller_than_the_psf_tends_to_n_times_the_psf_norm():
    """A region of N pixels much smaller than the PSF: the footprint is about N psf, so
    SNR -> |dT| N sqrt(sum psf^2) / sigma. Exactly, ||psf * 1_M||^2 = sum_{j,l in M} R(x_j - x_l)
    with R the PSF's autocorrelation (an independent computation: tolerance 1e-9 relative, FFT
    rounding). For a Gaussian PSF of s pixels R(d) = R(0) exp(-d^2 / 4 s^2) >= R(0) (1 - d^2 / 4s^2),
    and R(d) <= R(0) (Cauchy-Schwarz), so the ratio to the limit lies in
    [sqrt(1 - sum_{j,l} d_jl^2 / (4 s^2 N^2)), 1]: for a 2 x 2 region and s = 6 px, [0.99653, 1].
    The sampled, 5 s-truncated Gaussian departs from the continuous one by under 1e-6 (its mass
    beyond 5 s): that is the slack on the bounds."""
    from scipy.signal import fftconvolve

    s, radius = 6.0, 30
    psf = _gaussian(s, radius)
    mask = np.zeros((100, 100), bool)
    mask[50:52, 50:52] = True  # far from the borders: no mirrored padding in the footprint
    n = int(mask.sum())
    autocorr = fftconvolve(psf, psf[::-1, ::-1], mode="full")  # R(d) at offset d + 2 radius
    pts = np.argwhere(mask)
    exact = np.sqrt(sum(autocorr[2 * radius + dy, 2 * radius + dx] for dy, dx in (p - q for p in pts for q in pts)))
    norm = detection.footprint_norm(mask, psf)
    assert norm == pytest.approx(exact, rel=1e-9)
    limit = n * np.sqrt(np.sum(psf**2))
    d2 = sum(float(np.sum((p - q) ** 2)) for p in pts for q in pts)
    lower = np.sqrt(1.0 - d2 / (4.0 * s * s * n * n))
    assert lower - 1e-6 <= norm / limit <= 1.0 + 1e-6
    assert detection.region_snr(-2.0, mask, psf, 0.5) == pytest.approx(2.0 * norm / 0.5, rel=1e-12)
    # the thesis's Airy PSF: one pixel's footprint is the PSF itself, norm sqrt(sum psf^2) (1e-9:
    # rounding); a large region loses little of sqrt(N), a small one much: blur never raises the
    # norm (Young: ||psf * m||_2 <= ||psf||_1 ||m||_2 = sqrt(N); 1e-9 slack for rounding)
    airy = psf_kernel(pixel_angle=np.radians(0.2), k0=2 * np.pi * 95e9 / 299_792_458.0, aperture_diameter=0.6)
    size = airy.shape[0] + 80  # the kernel (its tail included) inside the image: no mirrored border
    one = np.zeros((size, size), bool)
    one[size // 2, size // 2] = True
    assert detection.footprint_norm(one, airy) == pytest.approx(np.sqrt(np.sum(airy**2)), rel=1e-9)
    yy, xx = np.mgrid[0:size, 0:size] - size // 2
    for r in (2, 8, 30):
        disk = yy**2 + xx**2 <= r * r
        assert detection.footprint_norm(disk, airy) <= np.sqrt(disk.sum()) * (1 + 1e-9)
    # the matched filter of a uniform target's signal is the region's SNR (same d')
    assert detection.matched_filter_snr(1.5 * detection.footprint(mask, psf), 2.0) == pytest.approx(
        detection.region_snr(1.5, mask, psf, 2.0), rel=1e-12
    )


def test_the_verdict_names_the_best_channel_first_and_the_threshold_cases():
    words = detection.contrast_verdict("beacon - runway", {"Ex2": (3.1, 0.2), "Ey2": (7.2, 0.3), "I": (None, None)})
    assert words == "beacon - runway: detectable in Ey2 (SNR 7.2 ± 0.3); not in Ex2 (SNR 3.1 ± 0.2)"
    words = detection.contrast_verdict("a - b", {"Ex2": (1.0, None), "Ey2": (5.2, 0.4)})
    assert words.startswith("a - b: detectable in Ey2") and "within the Monte Carlo error" in words
    assert detection.contrast_verdict("a - b", {"Ey2": (None, None)}) == "a - b: no imager noise: SNR undefined"


# ---------------------------------------------------------------------------------------------
# the Monte Carlo error of the SNR


@pytest.mark.slow  # 16 renders in this process (no worker start-up): about 10 s
def test_the_snr_standard_error_matches_the_spread_over_seeds(folder):
    """16 seeds of the tiny render: the sample standard deviation of block - ground's SNR against
    the root mean square of the standard errors the reports give. A 16-sample standard deviation
    lies within 0.46-1.63 of the true one with 99.9 % probability (chi-square, 15 degrees of
    freedom); the reported errors scatter too (each comes from the few edge pixels whose samples
    differ), so the bound is a factor 2 either way. A standard error without the footprint norm
    (a factor sqrt(N) = 3.5 here) or of the sensor-blurred weights would be outside it."""
    scn = pmmw.Scenario.from_dict(SCENE, base_dir=folder).set({"render.spp": 2})
    snr = {c: [] for c in ("Ex2", "Ey2")}
    err = {c: [] for c in snr}
    for seed in range(1, 17):
        ds = pmmw.render(scn, seed=seed, workers=1, quiet=True)
        pair = pmmw.regions(ds)["35 GHz"]["contrasts"]["block - ground"]
        for c in snr:
            snr[c].append(pair[c]["snr"])
            err[c].append(pair[c]["snr_stderr"])
    for c in snr:
        spread, claimed = np.std(snr[c], ddof=1), np.sqrt(np.mean(np.square(err[c])))
        assert claimed > 0.0
        assert 0.5 <= spread / claimed <= 2.0, (c, spread, claimed)


# ---------------------------------------------------------------------------------------------
# the report: fields, words, controls


def test_the_report_gives_snr_and_detectable_with_controls(folder, tmp_path):
    """report.json: per contrast and channel K, sigma, stderr_K, truncation_bound_K, snr,
    snr_stderr, detectable; the criterion and each contrast's verdict. The SNR is that of the
    IDEAL image's contrast over the target's blurred footprint: recomputed here from the EXR's
    ideal channels (float32: tolerance 1e-5 relative). Controls: the metal block mirroring the
    40 K sky against 290 K ground is detectable; two ground regions of the same material at
    mirrored angles are not, at any spp (their contrast is Monte Carlo noise alone)."""
    rep = _render(folder, tmp_path / "a")
    regions = rep["regions"]
    assert regions["criterion"] == detection.CRITERION and regions["channel"] == "Ey2"
    for pair in ("block - ground", "block - mirror", "ground - mirror"):
        for c in ("Ex2", "Ey2", "I"):
            assert set(regions["contrasts"][pair][c]) >= {
                "K",
                "sigma",
                "stderr_K",
                "truncation_bound_K",
                "snr",
                "snr_stderr",
                "detectable",
            }
    block = regions["contrasts"]["block - ground"]
    assert all(block[c]["detectable"] is True for c in ("Ex2", "Ey2", "I"))
    assert regions["verdicts"]["block - ground"].startswith("block - ground: detectable in ")
    assert regions["contrasts"]["ground - mirror"]["Ey2"]["detectable"] is False
    assert regions["verdicts"]["ground - mirror"].startswith("ground - mirror: not detectable in ")

    # the SNR from the ideal image, recomputed
    chans, _ = read_exr(tmp_path / "a" / "tiny.exr")
    res = pipeline.resolve(folder / "tiny.yaml")
    job = pipeline.make_job(res, 35e9)
    masks = pipeline.region_masks(res.scenario.output.regions, job.camera)
    kernel = psf_kernel(job.camera.pixel_angle, job.k0, 0.3)
    for c in ("Ex2", "Ey2", "I"):
        ideal = chans[f"ideal.{c}"].astype(float)
        dT = ideal[masks["block"]].mean() - ideal[masks["ground"]].mean()
        expect = detection.region_snr(dT, masks["block"], kernel, detection.channel_sigma(1.0, c))
        assert block[c]["snr"] == pytest.approx(expect, rel=1e-5)

    md = (tmp_path / "a" / "report.md").read_text()
    assert "## Detection" in md and detection.CRITERION in md and regions["verdicts"]["block - ground"] in md
    assert "[sigma]" not in md and "Ey2 SNR" in md  # the result is the criterion's SNR, not per-pixel sigmas

    for spp in (1, 16):  # the control fails at any sampling
        rep = _render(folder, tmp_path / f"spp{spp}", "--spp", spp)
        for c in ("Ex2", "Ey2", "I"):
            assert rep["regions"]["contrasts"]["ground - mirror"][c]["detectable"] is False, (spp, c)
            assert rep["regions"]["contrasts"]["block - ground"][c]["detectable"] is True, (spp, c)

    # without imager noise the criterion says nothing
    rep = _render(folder, tmp_path / "quiet", "--set", "imager.noise=0 K")
    pair = rep["regions"]["contrasts"]["block - ground"]["Ey2"]
    assert pair["snr"] is None and pair["detectable"] is None and pair["snr_stderr"] is None
    assert rep["regions"]["verdicts"]["block - ground"] == "block - ground: no imager noise: SNR undefined"


def test_the_api_carries_the_criterion(folder):
    ds = pmmw.render(pmmw.Scenario.from_dict(SCENE, base_dir=folder), quiet=True)
    regions = pmmw.regions(ds)["35 GHz"]
    assert regions["contrasts"]["block - ground"]["Ey2"]["detectable"] is True
    assert regions["verdicts"]["block - ground"].startswith("block - ground: detectable")


# ---------------------------------------------------------------------------------------------
# previews


def _png(path):
    inp = oiio.ImageInput.open(str(path))
    px = inp.read_image("uint8")
    inp.close()
    return px


def test_the_regions_preview_outlines_each_region(folder, tmp_path):
    """previews/tiny_regions.png by default: the plain grey sensor image, one pixel per image
    pixel, with each region outlined in its own colour on the ring of pixels just outside it: the
    ground box's pixels x 0-5, y 12-15 (`output.regions`) leave the ring x = 6 (y 11-15) and
    y = 11 (x 0-6), exactly green, the box's own pixels grey; the legend in the report. With
    ``--figures`` the matplotlib figure names them: each region's colour (within 40 levels per
    channel: antialiasing) on at least 50 pixels (a 2-pixel circle scaled to 480 px wide is about
    250 px of outline). None in a render without regions, or without previews (the controls)."""
    from pmmw.io.preview import REGION_COLOURS

    def rgb(colour):
        return np.array([int(colour[i : i + 2], 16) for i in (1, 3, 5)])

    _render(folder, tmp_path / "a")
    px = _png(tmp_path / "a" / "previews" / "tiny_regions.png").astype(int)
    assert px.shape == (16, 24, 3)
    ring = [(y, 6) for y in range(11, 16)] + [(11, x) for x in range(0, 7)]
    assert all((px[y, x] == rgb(REGION_COLOURS[1])).all() for y, x in ring)
    inside = px[12:16, 0:6]
    assert (inside[..., 0] == inside[..., 1]).all() and (inside[..., 1] == inside[..., 2]).all()
    for colour in REGION_COLOURS[:3]:  # the block's ring too (at least 8 pixels around one), and the mirror's
        assert (px == rgb(colour)).all(axis=-1).sum() >= 8, colour
    rep = json.loads((tmp_path / "a" / "report.json").read_text())
    assert rep["regions_preview"] == "previews/tiny_regions.png"
    assert rep["regions_outlines"] == {"block": "red", "ground": "green", "mirror": "blue"}
    md = (tmp_path / "a" / "report.md").read_text()
    assert "(previews/tiny_regions.png)" in md and "block red, ground green, mirror blue" in md
    _render(folder, tmp_path / "f", "--figures")
    px = _png(tmp_path / "f" / "previews" / "tiny_regions.png")[..., :3].astype(int)
    assert px.shape[1] >= 480
    for colour in REGION_COLOURS[:3]:
        assert (np.abs(px - rgb(colour)).max(axis=-1) <= 40).sum() >= 50, colour
    assert "regions_outlines" not in json.loads((tmp_path / "f" / "report.json").read_text())
    # no regions, or no previews: no regions preview
    _render(folder, tmp_path / "b", "--set", "output.regions={}")
    assert not (tmp_path / "b" / "previews" / "tiny_regions.png").exists()
    _render(folder, tmp_path / "c", "--set", "output.previews=false")
    assert not (tmp_path / "c" / "previews").exists()


def test_the_ideal_and_sensor_panels_each_have_their_own_range(tmp_path):
    """The ideal image (a 1 K step) beside a sensor image with 50 K of noise: each panel on its
    own display range, so the ideal panel shows its step in black and white. On one shared range
    the step would be two mid greys: the left half of the figure (the ideal panel and its bar)
    would hold no pure black but its frame, text and ticks (about a thousand pixels). At least
    10000 black pixels: the ideal's cold half, scaled up, is about 130 x 270 px."""
    from pmmw.io.preview import panel_ranges

    ideal = np.full((32, 32), 300.0)
    ideal[:, 16:] = 301.0
    sensor = 300.0 + 50.0 * np.random.default_rng(1).standard_normal((32, 32))
    low, high = write_figure(tmp_path / "pair.png", [("ideal", ideal), ("sensor", sensor)], title="pair")
    assert (low, high) == (300.0, 301.0) and panel_ranges([ideal, sensor])[1][1] > 400.0
    px = _png(tmp_path / "pair.png")[..., :3]
    left = px[:, : px.shape[1] // 2]
    assert (left.max(axis=-1) == 0).sum() >= 10_000


# ---------------------------------------------------------------------------------------------
# pmmw sweep


def test_the_sweep_table_and_report_give_snr_and_detectable(folder, tmp_path):
    """Two noise levels: at 1 K the block is detectable, at 200 K not (its SNR falls 200 times:
    below 5 for any SNR under 1000). The table has the report's SNR and verdict in the channel
    it leads with; the report states the criterion, where the block is detectable, and plots
    the SNR with the threshold."""
    out = tmp_path / "sw"
    res = runner.invoke(
        app, ["sweep", str(folder / "tiny.yaml"), "--grid", "imager.noise=[1 K, 200 K]", "--out", str(out), "-q"]
    )
    assert res.exit_code == 0, res.output
    with open(out / "sweep.csv") as f:
        rows = list(csv.DictReader(f))
    for row, variant in zip(rows, ("v000", "v001")):
        rep = json.loads((out / variant / "report.json").read_text())["regions"]["contrasts"]["block - ground"]
        assert float(row["snr block - ground Ey2"]) == pytest.approx(rep["Ey2"]["snr"], rel=1e-12)
        assert row["detectable block - ground Ey2"] == str(rep["Ey2"]["detectable"])
        assert "contrast block - ground I [sigma]" in row  # the earlier columns stay
    assert [r["detectable block - ground Ey2"] for r in rows] == ["True", "False"]
    report = (out / "report.md").read_text()
    assert detection.CRITERION in report
    assert "- block - ground (Ey2): detectable at imager.noise = 1 K; not at 200 K" in report
    assert (out / "plot_block_ground.png").stat().st_size > 5_000 and "plot_block_ground.png" in report


def test_contrasts_a_seed_would_change_are_one_warning_naming_each(tmp_path):
    """When region contrasts' Monte Carlo errors exceed what tells them apart (a tenth of the
    noise), the render says so once, naming each pair, channel and standard error, instead of a
    line per contrast (a shipped config with less noise printed nine). The control: with noise
    100 times larger the same render says nothing of it."""
    import pmmw
    from tests.scenes import tiny_scenario

    regions = "output: {regions: {block: {box: [9, 5, 15, 11]}, ground: {box: [0, 12, 24, 16]}}}"
    scn = pmmw.Scenario.load(tiny_scenario(tmp_path, regions))

    def lines(noise):
        ds = pmmw.render(scn.set({"imager.noise": noise}))
        return [w for w in ds.attrs["warnings"].splitlines() if "Monte Carlo standard error" in w]

    (line,) = lines("0.001 K")
    assert line.startswith("output.regions: seeds will differ by more than 0.0001 K"), line
    assert all(f"block - ground in {c}: " in line for c in ("Ex2", "Ey2", "I")), line
    assert lines("100 K") == []  # the control
