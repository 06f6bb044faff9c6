"""`pmmw brdf` as a user runs it: the copper case of Optics Express 2016, --eps against --n, the files
written, --method analytic, polarized input, database materials and stack files, and user errors.

The physics is tested in tests/reflectance/test_brdf.py; here each tolerance is the command's own Monte Carlo
standard error (5 sigma: the runs are seeded, so this is a statement about the estimator, not a
flaky margin) or the spread of a fixed quadrature, as stated at each assertion.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from pmmw.io.exr import read_exr
from pmmw.reflectance import projected_solid_angle
from pmmw_cli.cli import app

runner = CliRunner()

COPPER_N = 0.23 + 3.46j  # Optics Express 2016 sec. 4.2, 635 nm
COPPER = ["--n", "0.23+3.46j", "--incidence", "40", "--ex", "15", "--ey", "15"]
# pmmw's Monte Carlo for this case with 1e6 rays: 0.92664 +- 0.00002 (docs/brdf.md, and the slow
# test in tests/reflectance/test_brdf.py asserts it to 1e-4).
COPPER_MC_1E6 = 0.92664
# Allowance for that reference value itself (its standard error 2e-5 and rounding to 5 digits).
REFERENCE_SLACK = 1e-4


def _run(*args):
    res = runner.invoke(app, ["brdf", *[str(a) for a in args]])
    assert "Traceback" not in res.output
    return res


def _json(*args):
    res = _run(*args, "--json")
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def _flat_fresnel(n, theta_deg):
    """(Rs, Rp) of a smooth interface from vacuum, written out here as an independent reference."""
    c = math.cos(math.radians(theta_deg))
    q = np.sqrt(complex(n * n - (1.0 - c * c)))
    rs = (c - q) / (c + q)
    rp = (n * n * c - q) / (n * n * c + q)
    return abs(rs) ** 2, abs(rp) ** 2


def test_minimal_copper_call_prints_the_json_summary(tmp_path):
    out = tmp_path / "o"
    summary = _json(*COPPER, "--samples", 20_000, "--out", out, "--no-plots")
    mc = summary["methods"]["mc"]
    stderr = mc["total_reflectance_stderr"]
    # 2e4 rays: the 1e6-ray standard error (2e-5) times sqrt(50) = 1.4e-4; guard the tolerance
    # below against a silently inflated error estimate
    assert 0.0 < stderr < 2e-4
    assert summary["total_reflectance"] == mc["total_reflectance"]
    assert mc["total_reflectance"] == pytest.approx(COPPER_MC_1E6, abs=5 * stderr + REFERENCE_SLACK)
    # the orders of facet interactions partition the total (same paths, rounding only)
    assert sum(mc["reflectance_by_order"]) == pytest.approx(mc["total_reflectance"], rel=1e-12)
    # flat copper, (Rs + Rp) / 2 at 40 degrees: a closed form, so rounding only
    rs, rp = _flat_fresnel(COPPER_N, 40.0)
    assert summary["flat_reflectance"] == pytest.approx((rs + rp) / 2, rel=1e-12)
    assert summary["flat_reflectance"] == pytest.approx(0.93033, abs=5e-6)  # docs/brdf.md
    # rough copper reflects 0.0037 less than flat at 40 degrees (docs/brdf.md): ~30 sigma here
    assert mc["total_reflectance"] < summary["flat_reflectance"] - 5 * stderr
    # what is printed is what is written
    assert json.loads((out / "brdf.json").read_text()) == summary


def test_eps_is_n_squared_including_a_leading_minus_sign(tmp_path):
    """eps = n^2 = -11.9187 + 1.5916i for copper: the same surface, so with the same seed the
    same paths and the same numbers. A value with a leading '-' is taken as the option's value,
    with or without '='."""
    eps = COPPER_N**2
    eps_text = f"{eps.real!r}+{eps.imag!r}j"
    assert eps_text.startswith("-")
    rest = ["--incidence", 40, "--ex", 15, "--samples", 5_000, "--seed", 7, "--no-plots"]
    by_n = _json("--n", "0.23+3.46j", *rest, "--out", tmp_path / "n")
    by_eps = _json("--eps", eps_text, *rest, "--out", tmp_path / "eps")
    by_eps_eq = _json(f"--eps={eps_text}", *rest, "--out", tmp_path / "eq")
    for other in (by_eps, by_eps_eq):
        assert other["stack"]["layers"][0]["eps"] == pytest.approx(by_n["stack"]["layers"][0]["eps"], rel=1e-15)
        a, b = by_n["methods"]["mc"], other["methods"]["mc"]
        assert b["total_reflectance"] == pytest.approx(a["total_reflectance"], rel=1e-12)
        np.testing.assert_allclose(b["hemispherical_mueller"], a["hemispherical_mueller"], rtol=1e-12, atol=1e-15)
    # a different seed gives a different (statistically equal) estimate: the seed is passed on
    other_seed = _json("--n", "0.23+3.46j", *rest[:-3], "--seed", 8, "--no-plots", "--out", tmp_path / "s8")
    assert other_seed["total_reflectance"] != by_n["total_reflectance"]


def test_out_writes_the_exr_channels_and_pngs(tmp_path):
    out = tmp_path / "copper"
    res = _run(*COPPER, "--samples", 20_000, "--mueller", "--out", out)
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "brdf.json").read_text())
    channels, attrs = read_exr(out / "brdf_mc.exr")
    expected = ["I", "Q", "U", "V", "DoP", "AoP"] + [f"M{a}{b}" for a in range(4) for b in range(4)]
    assert sorted(channels) == sorted(expected)
    assert all(channels[c].shape == (91, 360) for c in expected)
    # I is the BRDF [1/sr]: its integral over projected solid angle is the total reflectance
    # (float32 storage of 32760 cells: 1e-5 relative)
    total = float(np.sum(channels["I"].astype(np.float64) * projected_solid_angle()))
    assert total == pytest.approx(summary["total_reflectance"], rel=1e-5)
    assert attrs["pmmw:brdf:total_reflectance"] == pytest.approx(summary["total_reflectance"])
    # unpolarized input: I = M00, DoP within [0, 1]
    np.testing.assert_allclose(channels["I"], channels["M00"], rtol=1e-6, atol=0)
    assert np.all((channels["DoP"] >= 0) & (channels["DoP"] <= 1 + 1e-6))
    for png in ("brdf_mc.png", "brdf_inplane.png"):
        data = (out / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    # the text summary: total per method with its error, flat reflectance, files written
    text = res.stdout
    assert f"{summary['total_reflectance']:.5f} +- " in text
    assert f"flat reflectance:            {summary['flat_reflectance']:.5f}" in text
    for name in ("brdf_mc.exr", "brdf_mc.png", "brdf_inplane.png", "brdf.json"):
        assert str(out / name) in text


def test_method_analytic(tmp_path):
    """Seed 003's single + double reflection: docs/brdf.md gives 0.88498 + 0.03976 (single to
    5e-5: its facet-space quadrature moves by < 2e-5 between seeds; double to 3e-4: that much
    between Sobol seeds at the default 65536 points, as in tests/reflectance/test_brdf.py)."""
    out = tmp_path / "an"
    summary = _json(*COPPER, "--method", "analytic", "--double-samples", 16, "--no-plots", "--out", out)
    assert list(summary["methods"]) == ["analytic"]
    an = summary["methods"]["analytic"]
    assert an["shadowing"] == "smith" and an["double"] is True
    assert an["single_reflectance"] == pytest.approx(0.88498, abs=5e-5)
    assert an["double_reflectance"] == pytest.approx(0.03976, abs=3e-4)
    assert an["total_reflectance"] == pytest.approx(an["single_reflectance"] + an["double_reflectance"], rel=1e-12)
    assert summary["total_reflectance"] == an["total_reflectance"]
    assert (out / "brdf_analytic.exr").exists() and not (out / "brdf_mc.exr").exists()


def test_polarized_input_over_a_flat_dielectric(tmp_path):
    """--stokes 1,1,0,0 is h = s over a flat surface, 1,-1,0,0 is p: glass (n = 1.5) at 60
    degrees, near Brewster, reflects Rs = 0.177 and Rp = 0.0018. The Monte Carlo picks the
    branch by unpolarized power, so the polarized totals are noisy: 5 standard errors."""
    rs, rp = _flat_fresnel(1.5, 60.0)
    for stokes, expected in (("1,1,0,0", rs), ("1,-1,0,0", rp)):
        s = _json(
            "--n",
            "1.5",
            "--incidence",
            60,
            "--stokes",
            stokes,
            "--samples",
            20_000,
            "--no-plots",
            "--out",
            tmp_path / stokes,
        )
        mc = s["methods"]["mc"]
        assert s["stokes_in"] == [float(v) for v in stokes.split(",")]
        assert mc["total_reflectance"] == pytest.approx(expected, abs=5 * mc["total_reflectance_stderr"])
        assert s["flat_reflectance"] == pytest.approx((rs + rp) / 2, rel=1e-12)  # unpolarized


def test_database_material_and_stack_file(tmp_path):
    # `metal` is a perfect conductor: a rough one returns every path (white furnace, rounding)
    s = _json(
        "--material",
        "metal",
        "--frequency",
        "95 GHz",
        "--incidence",
        60,
        "--ex",
        5,
        "--samples",
        5_000,
        "--no-plots",
        "--out",
        tmp_path / "metal",
    )
    assert s["stack"]["layers"][0]["metal"] is True
    assert s["total_reflectance"] == pytest.approx(1.0, abs=1e-12)
    stack = tmp_path / "glass_on_copper.yaml"
    stack.write_text(
        "wavelength: 635 nm\n"
        "layers:\n"
        "  - {n: 1.5, roughness: {model: ashikhmin_shirley, ex: 15, ey: 15}}\n"
        "  - {n: 0.23+3.46j, roughness: {model: ashikhmin_shirley, ex: 15, ey: 15}}\n"
    )
    s = _json("--stack", stack, "--incidence", 40, "--samples", 5_000, "--no-plots", "--out", tmp_path / "stack")
    assert len(s["stack"]["layers"]) == 2
    assert 0.0 < s["total_reflectance"] < 1.0


@pytest.mark.parametrize(
    "args, option",
    [
        (["--n", "abc"], "--n"),
        (["--n", "1.5", "--incidence", "95"], "--incidence"),
        (["--n", "0.23+3.46j", "--eps", "2"], "--eps"),
        (["--n", "1.5", "--model", "phong", "--m", "3"], "--model"),
        (["--n", "1.5", "--model", "ggx", "--ex", "3"], "--ex"),
        (["--n", "1.5", "--alpha", "-0.1"], "--alpha"),
        (["--eps", "5.5-0.3j"], "--eps"),  # eps'' < 0 is gain in pmmw's exp(-i w t) convention
        (["--n", "1.5", "--stokes", "1,0,0"], "--stokes"),
        (["--n", "1.5", "--stokes", "1,2,0,0"], "--stokes"),
        (["--n", "1.5", "--samples", "1.5"], "--samples"),
        (["--n", "1.5", "--method", "exact"], "--method"),
        (["--n", "1.5", "--shadowing", "v_groove"], "--shadowing"),
        (["--material", "concrete"], "--material"),
        (["--material", "unobtainium", "--frequency", "95 GHz"], "--material"),
        (["--n", "1.5", "--frequency", "95"], "--frequency"),
        (["--n", "1.5", "--stack", "stack.yaml"], "--stack"),
        (["--stack", "no_such_stack.yaml"], "no_such_stack.yaml"),
    ],
)
def test_user_errors_name_the_option_without_traceback(tmp_path, args, option):
    fast = [] if "--samples" in args else ["--samples", 100]
    res = _run(*args, *fast, "--out", tmp_path / "o")
    assert res.exit_code == 2, res.output
    assert res.output.startswith(f"error: {option}")
    assert "\n" not in res.output.strip()  # one line
    assert not (tmp_path / "o").exists()


def test_option_type_errors_exit_2_without_traceback(tmp_path):
    res = _run("--n", "1.5", "--ex", "abc", "--out", tmp_path / "o")
    assert res.exit_code == 2 and "--ex" in res.output
