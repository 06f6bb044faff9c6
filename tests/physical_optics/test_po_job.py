"""`pmmw po JOB.yaml`: the job file's keys, its outputs, and its errors named by file and key."""

import json
import math

import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from pmmw.io.exr import read_exr
from pmmw_cli.cli import app

runner = CliRunner()
C0 = 299_792_458.0


@pytest.fixture()
def job(tmp_path):
    v = [[-0.05, -0.03, 0], [0.05, -0.03, 0], [0.05, 0.03, 0], [-0.05, 0.03, 0]]
    trimesh.Trimesh(vertices=v, faces=[[0, 1, 2], [0, 2, 3]], process=False).export(tmp_path / "plate.ply")

    def write(body: str):
        path = tmp_path / "job.yaml"
        path.write_text(
            "name: plate\ntargets:\n  - {mesh: plate.ply, material: metal, "
            "transform: {translate: [0, 0, 1 m]}}\n" + body
        )
        return path

    return write


def test_a_job_writes_every_run_a_report_and_a_full_sphere_map(job, tmp_path):
    path = job(
        "frequency: [35 GHz, 95 GHz]\npolarization: [theta, phi]\nincidence: [0 deg, 0 deg]\n"
        "observation: {theta: '0:180:30', phi: '0:300:60'}\n"
    )
    res = runner.invoke(app, ["po", str(path), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    out = tmp_path / "o"
    for f in (35, 95):
        for pol in ("theta", "phi"):
            stem = f"plate_{f}GHz_{pol}"
            rows = (out / f"{stem}.csv").read_text().splitlines()
            assert rows[0] == "theta_deg,phi_deg,rcs_theta_m2,rcs_phi_m2" and len(rows) == 1 + 7 * 6
            summary = json.loads((out / f"{stem}.json").read_text())
            lam = C0 / (f * 1e9)
            # the translation moves the phase, not the magnitude: 4 pi A^2 / lambda^2 straight back
            assert summary["backscatter_rcs_m2"] == pytest.approx(4 * np.pi * (0.1 * 0.06) ** 2 / lam**2, rel=1e-5)
            chans, attrs = read_exr(out / f"{stem}.exr")
            assert chans["rcs_theta"].shape == (7, 6)
            assert (out / f"{stem}.png").stat().st_size > 10_000
    report = (out / "report.md").read_text()
    assert report.count("| plate_") == 4 and "![plate_95GHz_phi](plate_95GHz_phi.png)" in report


def test_monostatic_job_azimuth_cut(job, tmp_path):
    path = job(
        "frequency: 95 GHz\nmonostatic: true\nobservation: {theta: 30, phi: '0:350:10'}\n"
        f"output: {{dir: '{tmp_path / 'm'}', plot: false}}\n"
    )
    res = runner.invoke(app, ["po", str(path)])
    assert res.exit_code == 0, res.output
    rows = (tmp_path / "m" / "plate_95GHz_theta.csv").read_text().splitlines()[1:]
    assert len(rows) == 36 and all(r.startswith("30,") for r in rows)
    assert not list((tmp_path / "m").glob("*.png")) and not list((tmp_path / "m").glob("*.exr"))


@pytest.mark.parametrize(
    "body, key",
    [
        ("frequency: 95 GHz\n", "incidence"),  # neither monostatic nor incidence
        ("frequency: 95 GHz\nmonostatic: true\nincidence: [0, 0]\n", "incidence"),
        ("frequency: 2000 GHz\nmonostatic: true\n", "frequency"),
        ("frequency: 95 GHz\nmonostatic: true\nbounces: 0\n", "bounces"),
        ("frequency: 95 GHz\nmonostatic: true\npolarisation: theta\n", "polarisation"),
        ("frequency: 95 GHz\nmonostatic: true\nobservation: {theta: '0:90:0'}\n", "observation.theta"),
        ("frequency: 95 GHz\nmonostatic: true\nmaterials: {metal: {kind: plasma}}\n", "materials.metal"),
    ],
)
def test_job_errors_name_the_file_and_key(job, body, key):
    res = runner.invoke(app, ["po", str(job(body))])
    assert res.exit_code == 2, res.output
    lines = [x for x in res.output.splitlines() if x.strip() and not x.startswith("warning:")]
    assert lines[0].startswith("error:") and "job.yaml" in lines[0] and key in res.output, res.output
    assert "Traceback" not in res.output


@pytest.mark.parametrize("name", ["po_beacon_plate", "po_angle_bracket", "po_handgun", "po_sphere"])
def test_shipped_po_jobs_validate(name):
    """Each shipped job loads (its meshes exist and its keys are right); the renders themselves
    are run for the README (`pmmw po configs/po_*.yaml`)."""
    from pathlib import Path

    from pmmw.physical_optics.job import _targets, load_job

    job = load_job(Path("configs") / f"{name}.yaml")
    target = _targets(job, job.frequencies[0])
    assert len(target.faces) > 0 and math.isfinite(float(target.area.sum()))


@pytest.mark.parametrize("theta_deg", [0.0, 30.0])
def test_a_coated_plate_reflects_as_its_multilayer(job, tmp_path, theta_deg):
    """A plate of skin under 0.8 mm of lossy film (a job's material override with a coating):
    at the specular direction sigma = |r|^2 4 pi A^2 cos^2 / lambda^2 with r the film-on-substrate
    reflection computed by `tmm` (an independent multilayer code) for the incident polarization
    (theta-polarized in the plane of incidence is p; tmm's r_p sign convention differs, |r| not)."""
    import tmm

    f = 95e9
    lam = C0 / f
    body = (
        f"frequency: 95 GHz\nincidence: [{theta_deg} deg, 0 deg]\npolarization: [theta, phi]\n"
        f"observation: {{theta: {theta_deg}, phi: 180}}\n"
        "materials:\n  film: {eps: [3.0, 0.4]}\n"
        "  coated: {eps: [5.9, 9.4], coating: [{material: film, thickness: 0.8 mm}]}\n"
    )
    path = job(body)
    path.write_text(path.read_text().replace("material: metal", "material: coated"))
    res = runner.invoke(app, ["po", str(path), "--out", str(tmp_path / "c")])
    assert res.exit_code == 0, res.output
    n_list = [1.0, np.sqrt(3.0 + 0.4j), np.sqrt(5.9 + 9.4j)]
    d_list = [np.inf, 0.8e-3 * 1e9, np.inf]  # tmm takes one length unit: nm here
    area = 0.1 * 0.06
    for pol, tmm_pol in (("theta", "p"), ("phi", "s")):
        r = tmm.coh_tmm(tmm_pol, n_list, d_list, math.radians(theta_deg), lam * 1e9)["r"]
        row = (tmp_path / "c" / f"plate_95GHz_{pol}.csv").read_text().splitlines()[1].split(",")
        sigma = float(row[2]) + float(row[3])
        ref = abs(r) ** 2 * 4 * np.pi * area**2 * math.cos(math.radians(theta_deg)) ** 2 / lam**2
        assert sigma == pytest.approx(ref, rel=1e-6)
