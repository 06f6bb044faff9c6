"""Physical optics (`pmmw po`) against references that share no code with it: the flat plate's
closed form, the phase integral over a triangle by quadrature, the Fresnel reflection of a lossy
half-space, reciprocity, and (tests/physical_optics/po_refs.py) the Mie series of spheres."""

import math
import unittest.mock

import numpy as np
import pytest
import trimesh
from scipy import integrate
from typer.testing import CliRunner

from pmmw.physical_optics import solver
from pmmw.physical_optics.command import CSV_HEADER, load_target
from pmmw_cli.cli import app

runner = CliRunner()
C0 = 299_792_458.0
F = 95e9
LAM = C0 / F
K0 = 2 * np.pi / LAM


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    """A 10 cm x 6 cm plate in the x-y plane, two triangles (an open sheet)."""
    path = tmp_path_factory.mktemp("po") / "plate.stl"
    a, b = 0.10, 0.06
    v = [[-a / 2, -b / 2, 0], [a / 2, -b / 2, 0], [a / 2, b / 2, 0], [-a / 2, b / 2, 0]]
    trimesh.Trimesh(vertices=v, faces=[[0, 1, 2], [0, 2, 3]], process=False).export(path)
    # STL stores float32: the references take the sides the file really has
    ext = np.ptp(load_target(path, "metal", None, F).vertices, axis=0)
    return path, float(ext[0]), float(ext[1])


def _plate_monostatic(a, b, theta):
    """PO closed form of a perfectly conducting a x b plate, monostatic in the x-z plane:
    sigma = 4 pi (a b / lambda)^2 cos^2 theta sinc^2(k a sin theta) (Knott, Radar Cross Section)."""
    u = K0 * a * np.sin(theta)
    return 4 * np.pi * (a * b / LAM) ** 2 * np.cos(theta) ** 2 * np.sinc(u / np.pi) ** 2


@pytest.mark.parametrize("pol", ["theta", "phi"])
def test_plate_monostatic_pattern_is_the_closed_form(plate, pol):
    """Two triangles are already exact PO: the whole sinc^2 pattern to 1e-9 of its peak (rounding
    in the phase integral; the closed form has no other approximation than PO itself)."""
    path, a, b = plate
    target = load_target(path, "metal", None, F)
    theta = np.radians(np.linspace(0.0, 60.0, 241))
    s_t, s_p, lit = solver.monostatic(target, K0, pol, theta, np.zeros_like(theta))
    ref = _plate_monostatic(a, b, theta)
    assert np.all(lit == 2)
    assert np.max(np.abs(s_t + s_p - ref)) < 1e-9 * ref.max()
    assert np.max(s_p if pol == "theta" else s_t) < 1e-12 * ref.max()  # no cross-polarization in this plane
    assert (s_t + s_p)[0] == pytest.approx(4 * np.pi * (a * b) ** 2 / LAM**2, rel=1e-12)


def test_plate_nulls_and_first_sidelobe(plate):
    """Nulls at k a sin theta = m pi; the first sidelobe of sinc^2 is -13.26 dB below the peak
    (times cos^2 theta of the projected area, 1e-4 dB here)."""
    path, a, _ = plate
    target = load_target(path, "metal", None, F)
    null = math.asin(LAM / (2 * a))  # k a sin theta = pi
    s_t, _, _ = solver.monostatic(target, K0, "theta", np.array([0.0, null, math.asin(LAM / a)]), np.zeros(3))
    assert s_t[1] < 1e-20 * s_t[0] and s_t[2] < 1e-20 * s_t[0]
    theta = np.arcsin(np.linspace(1.0, 1.9, 2001) * LAM / (2 * a))  # between the first and second null
    s_t, _, _ = solver.monostatic(target, K0, "theta", theta, np.zeros_like(theta))
    peak = 4 * np.pi * (target.area.sum()) ** 2 / LAM**2
    side = 10 * np.log10(s_t.max() / peak)
    assert side == pytest.approx(-13.26, abs=0.01)


def test_lossy_half_space_plate_reflects_by_fresnel(plate):
    """A plate of permittivity eps at normal incidence: sigma = |r|^2 4 pi A^2 / lambda^2 with
    r = (1 - n)/(1 + n) (Fresnel at normal incidence, independent of pmmw's Fresnel code)."""
    path, a, b = plate
    eps = 5.5 + 0.5j
    target = load_target(path, None, "5.5+0.5j", F)
    s_t, s_p, _ = solver.bistatic(target, K0, 0.0, 0.0, "theta", np.array([0.0]), np.array([0.0]))
    n = np.sqrt(eps)
    r = (1 - n) / (1 + n)
    assert s_t[0] == pytest.approx(abs(r) ** 2 * 4 * np.pi * (a * b) ** 2 / LAM**2, rel=1e-12)


@pytest.mark.parametrize(
    "q",
    [
        np.array([0.0, 0.0, 0.0]),
        np.array([1e-9, 0.0, 0.0]),
        np.array([3.0, -2.0, 0.5]),
        np.array([40.0, 10.0, 0.0]),
        np.array([1e-6, 1e-6, 1e-6]),
        np.array([0.0, 25.0, 0.0]),
    ],
)
def test_triangle_phase_integral_against_quadrature(q):
    """The closed form against adaptive quadrature of cos and sin over the triangle (scipy
    dblquad, tolerance 1e-11), including q = 0, tiny q and a q along an edge (equal phases at
    two vertices: the divided difference's degenerate case)."""
    tri = np.array([[[0.1, 0.0, 0.0], [0.4, 0.05, 0.0], [0.15, 0.3, 0.0]]])
    area = np.array([0.5 * np.linalg.norm(np.cross(tri[0, 1] - tri[0, 0], tri[0, 2] - tri[0, 0]))])
    got = solver.triangle_integral(tri, area, q[None, :])[0, 0]
    p0, e1, e2 = tri[0, 0], tri[0, 1] - tri[0, 0], tri[0, 2] - tri[0, 0]

    def part(fn):
        val, _ = integrate.dblquad(
            lambda v, u: fn(q @ (p0 + u * e1 + v * e2)), 0, 1, 0, lambda u: 1 - u, epsabs=1e-13, epsrel=1e-11
        )
        return val * 2 * area[0]

    ref = part(np.cos) + 1j * part(np.sin)
    assert abs(got - ref) < 1e-10 * area[0]


def test_triangle_phase_integral_at_large_phase():
    """A triangle thousands of wavelengths across: the closed form against the one-dimensional
    closed form for a right triangle with q along x, int_0^1 (1 - x) e^{i q x} dx."""
    tri = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])
    for qx in (1e3, 12345.678, 1e5):
        got = solver.triangle_integral(tri, np.array([0.5]), np.array([[qx, 0.0, 0.0]]))[0, 0]
        ref = (np.exp(1j * qx) - 1 - 1j * qx) / (1j * qx) ** 2
        assert abs(got - ref) < 1e-10 * abs(ref) + 1e-15


@pytest.mark.parametrize("theta_i", [0.0, 20.0, 45.0])
def test_bistatic_plate_peaks_in_the_specular_direction(plate, theta_i):
    """Incidence (theta_i, 0): the lobe peaks at the mirror direction (theta_i, 180) with the PO
    closed form sigma = 4 pi A^2 cos^2 theta_i / lambda^2 (the phase is flat over the plate there).
    (Bistatic PO is not reciprocal in general: the obliquity of J = 2 n x H_i differs when
    incidence and observation are swapped, so no reciprocity test here.)"""
    path, a, b = plate
    target = load_target(path, "metal", None, F)
    th = math.radians(theta_i)
    theta = np.radians(np.linspace(max(theta_i - 2, 0), theta_i + 2, 81))
    s_t, s_p, _ = solver.bistatic(target, K0, th, 0.0, "theta", theta, np.full(theta.size, np.pi))
    total = s_t + s_p
    # within a tenth of the lobe's width (lambda / a = 1.8 deg): the far-field obliquity tilts it
    assert np.degrees(theta[np.argmax(total)]) == pytest.approx(theta_i, abs=0.1)
    assert total[np.argmin(np.abs(theta - th))] == pytest.approx(
        4 * np.pi * (a * b) ** 2 * math.cos(th) ** 2 / LAM**2, rel=1e-9
    )


def test_a_closed_body_is_lit_only_on_the_side_facing_the_wave(tmp_path):
    box = trimesh.creation.box(extents=[0.1, 0.1, 0.1])
    box.export(tmp_path / "box.stl")
    target = load_target(tmp_path / "box.stl", "metal", None, F)
    lit, _ = solver.lit_facets(target, np.array([0.0, 0.0, 1.0]))
    assert lit.sum() == 2 and np.all(target.normal[lit] @ [0, 0, 1] > 0.99)


def test_the_po_command_csv_json_and_plot(plate, tmp_path):
    path, a, b = plate
    res = runner.invoke(
        app,
        [
            "po",
            str(path),
            "--material",
            "metal",
            "--frequency",
            "95 GHz",
            "--incidence",
            "0,0",
            "--theta",
            "0:2:1",
            "--phi",
            "0,90",
            "--format",
            "csv",
            "--out",
            str(tmp_path / "o"),
            "--plot",
            str(tmp_path / "p.png"),
        ],
    )
    assert res.exit_code == 0, res.output
    lines = res.stdout.strip().splitlines()  # "wrote ..." lines go to stderr
    assert lines[0] == CSV_HEADER and len(lines) == 1 + 6
    first = [float(v) for v in lines[1].split(",")]
    assert first[:2] == [0.0, 0.0] and first[2] == pytest.approx(4 * np.pi * (a * b) ** 2 / LAM**2, rel=1e-8)
    import json

    summary = json.loads((tmp_path / "o" / "po.json").read_text())
    assert summary["facets_lit"] == 2 and len(summary["rows"]) == 6
    assert summary["backscatter_rcs_m2"] == pytest.approx(first[2], rel=1e-8)
    assert (tmp_path / "p.png").stat().st_size > 10_000
    # --out also holds the plot and a report naming the backscatter in dBsm
    assert (tmp_path / "o" / "po.png").stat().st_size > 10_000
    report = (tmp_path / "o" / "report.md").read_text()
    assert f"{10 * np.log10(first[2]):.2f}" in report and "![po](po.png)" in report


@pytest.mark.parametrize(
    "args, option",
    [
        (["--incidence", "90,0"], "--incidence"),  # edge-on: no facet lit
        (["--theta", "0:10:0"], "--theta"),
        (["--theta", "10:0:1"], "--theta"),
        (["--frequency", "95"], "--frequency"),
        (["--incidence", "30"], "--incidence"),
        (["--polarization", "x"], "--polarization"),
        (["--bounces", "0"], "--bounces"),
        (["--bounces", "2", "--tube", "1 um"], "--tube"),
        (["--eps", "5-1j"], "--eps"),
        (["--material", "no_such_material"], "--material"),
    ],
)
def test_bad_po_options_are_one_line_naming_the_option(plate, args, option):
    path, _, _ = plate
    base = {"--frequency": "95 GHz", "--incidence": "0,0"}
    flags = dict(zip(args[::2], args[1::2]))
    material = [] if "--eps" in flags or "--material" in flags else ["--material", "metal"]
    cmd = ["po", str(path), *material]
    for k, v in {**base, **flags}.items():
        cmd += [k, v]
    res = runner.invoke(app, cmd)
    assert res.exit_code == 2, res.output
    lines = [x for x in res.output.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and option in lines[0], res.output


def test_a_mesh_with_nan_vertices_is_refused(tmp_path):
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n")
    res = runner.invoke(app, ["po", str(tmp_path / "nan.obj"), "--material", "metal", "--frequency", "95 GHz"])
    assert res.exit_code == 2 and "not finite" in res.output


def _sphere(tmp_path, radius, subdivisions):
    path = tmp_path / f"sphere_{subdivisions}.ply"
    trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius).export(path)
    return path


@pytest.mark.parametrize("ka, sub, eps", [(50, 5, None), (100, 6, None), (50, 5, 5.5 + 0.5j)])
def test_sphere_backscatter_against_mie(tmp_path, ka, sub, eps):
    """A faceted sphere against the exact Mie series (tests/physical_optics/po_refs.py, no shared code): PO's
    backscatter error at these sizes is the O(1/ka) creeping-wave and edge terms PO lacks
    (PO exact for a PEC sphere: 1 - sin(2ka)/ka + ..., i.e. within 1/ka = 0.09 dB at ka 50) plus
    the facets' (sagitta < lambda/100 here); the issue's bound is a few tenths of a dB. The lossy
    sphere (eps 5.5+0.5j absorbs ~20 Np across its diameter) returns only its front-face
    reflection, which PO has exactly."""
    from tests.physical_optics.po_refs import sphere_backscatter_rcs

    radius = ka / K0
    target = load_target(
        _sphere(tmp_path, radius, sub),
        "metal" if eps is None else None,
        None if eps is None else f"{eps.real}+{eps.imag}j",
        F,
    )
    s_t, s_p, _ = solver.bistatic(target, K0, 0.0, 0.0, "theta", np.array([0.0]), np.array([0.0]))
    ours = 10 * np.log10(s_t[0] + s_p[0])
    mie = 10 * np.log10(sphere_backscatter_rcs(radius, LAM, eps))
    assert ours == pytest.approx(mie, abs=0.3)


def test_sphere_bistatic_lit_region_against_mie(tmp_path):
    """Bistatic PEC sphere at ka 50, observation 0-55 deg from the backscatter direction (specular
    points well inside the lit region), both cuts: within 1 dB of Mie (the issue's bound; measured
    0.5 dB). Farther out PO lacks the shadow boundary's diffraction and creeping waves: the
    difference oscillates by up to +-2 dB at 80-100 deg (docs/validation.md), the same with 4x
    the facets, so it is PO's and not the mesh's."""
    from tests.physical_optics.po_refs import sphere_bistatic_rcs

    radius = 50 / K0
    target = load_target(_sphere(tmp_path, radius, 5), "metal", None, F)
    theta = np.radians(np.linspace(0.0, 55.0, 12))
    for phi in (0.0, np.pi / 2):
        s_t, s_p, _ = solver.bistatic(target, K0, 0.0, 0.0, "theta", theta, np.full(theta.size, phi))
        m_t, m_p = sphere_bistatic_rcs(radius, LAM, None, np.degrees(theta), np.degrees(phi))
        assert np.max(np.abs(10 * np.log10((s_t + s_p) / (m_t + m_p)))) < 1.0


def _corner(tmp_path, name, vertices, faces):
    path = tmp_path / f"{name}.ply"
    trimesh.Trimesh(vertices=vertices, faces=faces, process=False).export(path)
    return load_target(path, "metal", None, F)


@pytest.mark.parametrize("pol", ["theta", "phi"])
def test_dihedral_peak_needs_two_bounces(tmp_path, pol):
    """A 90-degree metal dihedral (faces 5 cm from the fold, 5 cm long) seen along its bisector:
    single-bounce PO misses the corner return by 37 dB; with --bounces 2 the ray tubes give the
    closed form 8 pi a^2 b^2 / lambda^2 (Knott et al. 2004) within 0.3 dB (measured 0.08 and
    0.15 dB: the tube grid's quarter-wavelength edges)."""
    from tests.physical_optics.po_refs import dihedral_peak_rcs

    a = b = 0.05
    v = [[0, -b / 2, 0], [a, -b / 2, 0], [a, b / 2, 0], [0, b / 2, 0], [0, -b / 2, a], [0, b / 2, a]]
    target = _corner(tmp_path, "dihedral", v, [[0, 1, 2], [0, 2, 3], [0, 3, 5], [0, 5, 4]])
    ref = 10 * np.log10(dihedral_peak_rcs(a, b, LAM))
    th = np.array([np.pi / 4])
    one = solver.bistatic(target, K0, np.pi / 4, 0.0, pol, th, np.zeros(1))
    two = solver.bistatic(target, K0, np.pi / 4, 0.0, pol, th, np.zeros(1), bounces=2)
    assert 10 * np.log10(one[0][0] + one[1][0]) < ref - 20
    assert 10 * np.log10(two[0][0] + two[1][0]) == pytest.approx(ref, abs=0.3)


def test_trihedral_peak_needs_three_bounces(tmp_path):
    """A triangular trihedral (edges 10 cm, 32 wavelengths) along its symmetry axis: the closed
    form 4 pi a^4 / (3 lambda^2) (Knott et al. 2004) within 0.2 dB with --bounces 3 (measured
    0.03 dB; a 5 cm one is 0.5 dB low at quarter-wavelength tubes and converges with finer ones:
    the tubes cut by the edges)."""
    from tests.physical_optics.po_refs import trihedral_peak_rcs

    a = 0.10
    target = _corner(
        tmp_path, "trihedral", [[0, 0, 0], [a, 0, 0], [0, a, 0], [0, 0, a]], [[0, 1, 2], [0, 3, 1], [0, 2, 3]]
    )
    th, ph = math.acos(1 / math.sqrt(3)), math.pi / 4
    ref = 10 * np.log10(trihedral_peak_rcs(a, LAM))
    two = solver.bistatic(target, K0, th, ph, "theta", np.array([th]), np.array([ph]), bounces=2)
    three = solver.bistatic(target, K0, th, ph, "theta", np.array([th]), np.array([ph]), bounces=3)
    assert 10 * np.log10(two[0][0] + two[1][0]) < ref - 20
    assert 10 * np.log10(three[0][0] + three[1][0]) == pytest.approx(ref, abs=0.2)


def test_more_bounces_change_nothing_where_nothing_reflects_twice(plate):
    path, _, _ = plate
    target = load_target(path, "metal", None, F)
    theta = np.radians(np.linspace(0, 40, 9))
    one = solver.bistatic(target, K0, 0.3, 0.0, "theta", theta, np.zeros(9))
    three = solver.bistatic(target, K0, 0.3, 0.0, "theta", theta, np.zeros(9), bounces=3)
    assert np.array_equal(one[0], three[0]) and np.array_equal(one[1], three[1])


def test_octree_and_direct_agree_through_the_command(tmp_path):
    """`--method octree` against `--method direct` on a sphere's full bistatic grid: within 1e-3
    of the peak field (2e-3 of the peak RCS, as sigma goes with |f|^2)."""
    import json

    path = _sphere(tmp_path, 20 / K0, 3)  # ka 20
    got = {}
    for method in ("direct", "octree"):
        res = runner.invoke(
            app,
            [
                "po",
                str(path),
                "--material",
                "metal",
                "--frequency",
                "95 GHz",
                "--theta",
                "0:180:6",
                "--phi",
                "0,45,90,135,180,225,270,315",
                "--method",
                method,
                "--format",
                "json",
            ],
        )
        assert res.exit_code == 0, res.output
        rows = json.loads(res.output)["rows"]
        got[method] = np.array([[r["rcs_theta_m2"], r["rcs_phi_m2"]] for r in rows])
    peak = got["direct"].max()
    assert np.max(np.abs(got["octree"] - got["direct"])) < 2e-3 * peak


def test_what_an_interrupt_says_after_po_is_back_to_the_next_commands(plate, tmp_path):
    """`pmmw po --out` and a job say, while they write, which of their files are complete; after
    they return, a command run in the same process (a notebook, a test) must not say it: an
    interrupted render said "files already written in .../o are complete" of the po's folder.
    The control: while po writes, the line is po's."""
    from pmmw import interrupt
    from pmmw.physical_optics import command

    path, _, _ = plate
    seen = []
    original = command.write_run

    def spy(*args, **kwargs):
        seen.append(interrupt._outcome)
        return original(*args, **kwargs)

    before = interrupt._outcome
    args = ["po", str(path), "--material", "metal", "--frequency", "95 GHz", "--incidence", "0,0"]
    with unittest.mock.patch.object(command, "write_run", spy):
        res = runner.invoke(app, [*args, "--theta", "0:2:1", "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert seen and str(tmp_path / "o") in seen[0]  # the control
    assert interrupt._outcome == before
