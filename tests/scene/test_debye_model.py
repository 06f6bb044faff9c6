"""The ``debye`` permittivity model: a published sum of Debye relaxations entered as printed.

Checked against the Debye form's closed forms (Debye 1929): at omega tau = 1 a single relaxation
gives eps' = eps_inf + d_eps / 2 and eps'' = d_eps / 2; far below every relaxation eps' is the
static eps_inf + sum d_eps; conduction adds sigma / (eps0 omega) to eps'' (eps0 from scipy, not
pmmw). Outside the entry's stated range the value is warned once; inside it is not.
"""

from __future__ import annotations

import math

import pytest
from scipy.constants import epsilon_0

from pmmw.errors import UserError, clear_warnings, collected_warnings
from pmmw.scene.materials import MaterialDB

# Closed forms evaluated in double precision: agreement to rounding (1e-12 relative) is expected.
REL = 1e-12


def _db(model):
    return MaterialDB.load().with_overrides({"fit": {"model": model, "source": "pmmw: test entry"}}, file="s.yaml")


def test_single_relaxation_at_its_frequency():
    tau = 8e-12  # [s]
    m = _db({"name": "debye", "eps_inf": 2.0, "terms": [[10.0, "8 ps"]], "valid": ["10 GHz", "1 THz"]}).get("fit")
    eps = m.eps_at(1.0 / (2.0 * math.pi * tau))
    assert eps.real == pytest.approx(2.0 + 5.0, rel=REL) and eps.imag == pytest.approx(5.0, rel=REL)


def test_static_limit_and_two_relaxations():
    """Far below both relaxations (omega tau1 = 1e-7) eps' is eps_inf + sum d_eps to (omega tau)^2."""
    m = _db(
        {"name": "debye", "eps_inf": 3.0, "terms": [[50.0, "10 ps"], [2.0, "200 fs"]], "valid": ["1 kHz", "2 THz"]}
    ).get("fit")
    f = 1e-7 / (2.0 * math.pi * 10e-12)
    assert m.eps_at(f).real == pytest.approx(55.0, rel=1e-12)
    # far above both (omega tau2 = 1e4) eps' -> eps_inf to 1/(omega tau)^2
    assert m._lookup(1e4 / (2.0 * math.pi * 200e-15))[0].real == pytest.approx(3.0, rel=1e-6)


def test_conduction_adds_sigma_over_eps0_omega():
    m = _db(
        {
            "name": "debye",
            "eps_inf": 2.0,
            "terms": [[10.0, "8 ps"]],
            "conductivity": "0.5 S/m",
            "valid": ["10 GHz", "1 THz"],
        }
    ).get("fit")
    f, tau = 100e9, 8e-12
    x = 2.0 * math.pi * f * tau
    expected = 10.0 * x / (1.0 + x * x) + 0.5 / (epsilon_0 * 2.0 * math.pi * f)
    assert m.eps_at(f).imag == pytest.approx(expected, rel=1e-9)  # EPS0 digits against CODATA's


def test_outside_the_stated_range_warns_once_and_inside_does_not():
    m = _db({"name": "debye", "eps_inf": 2.0, "terms": [[10.0, "8 ps"]], "valid": ["35 GHz", "300 GHz"]}).get("fit")
    clear_warnings()
    m.eps_at(94e9)  # the control: inside, no warning
    assert collected_warnings() == []
    for _ in range(2):
        m.eps_at(400e9)
    w = collected_warnings()
    assert len(w) == 1 and "'fit': 400 GHz" in w[0] and "35-300 GHz (the entry's stated range)" in w[0], w
    assert m.outside_note(400e9) == "the fit is extrapolated"


@pytest.mark.parametrize(
    "model, key, words",
    [
        ({"name": "debye", "eps_inf": 2, "terms": [[10, "8 qs"]], "valid": ["10 GHz", "1 THz"]}, "terms.0.1", "'8 ps'"),
        ({"name": "debye", "eps_inf": 2, "terms": [[10]], "valid": ["10 GHz", "1 THz"]}, "terms.0", "pair"),
        ({"name": "debye", "eps_inf": 2, "terms": [[10, "8 ps"]], "valid": ["1 THz", "10 GHz"]}, "valid", "lo < hi"),
        ({"name": "debye", "eps_inf": 2, "terms": [[10, "8 ps"]]}, "", "needs valid"),
        (
            {"name": "debye", "eps_inf": 0.5, "terms": [[10, "8 ps"]], "valid": ["10 GHz", "1 THz"]},
            "eps_inf",
            "above 1",
        ),
    ],
)
def test_errors_name_the_key(model, key, words):
    with pytest.raises(UserError) as ei:
        _db(model)
    assert ei.value.key == "materials.fit.model" + (f".{key}" if key else "") and words in ei.value.message


def test_show_gives_the_parameters_and_the_range():
    m = _db(
        {"name": "debye", "eps_inf": 2.0, "terms": [[10.0, "8 ps"], [1.0, "200 fs"]], "valid": ["10 GHz", "1 THz"]}
    ).get("fit")
    text = m.model.describe()
    assert "relaxations 10 at tau 8 ps + 1 at tau 0.2 ps" in text and "valid 10-1000 GHz" in text


@pytest.mark.parametrize("f_ghz", [35.0, 94.0, 140.0, 220.0, 300.0])
def test_a_published_double_debye_entered_as_printed_gives_itur(f_ghz):
    """Liebe, Hufford & Manabe 1991's water as ITU-R P.840-8 eqs. 4-10 print it, at 20 C: theta =
    300/T, eps0 = 77.66 + 103.3 (theta - 1), eps1 = 0.0671 eps0, eps2 = 3.52, f_p = 20.20 - 146
    (theta - 1) + 316 (theta - 1)^2 GHz, f_s = 39.8 f_p: a double Debye with d_eps = eps0 - eps1 at
    tau = 1/(2 pi f_p) and eps1 - eps2 at 1/(2 pi f_s). Entered in the ``debye`` model, it must
    give the `itur` package's P.840 liquid-water K_l = 0.819 f / (eps'' (1 + eta^2)), eta = (2 +
    eps') / eps'' [(dB/km)/(g/m^3)]. The same published equations in double precision: 1e-9."""
    import itur.models.itu840 as p840

    t_k = 293.15
    th = 300.0 / t_k - 1.0
    eps0 = 77.66 + 103.3 * th
    eps1, eps2 = 0.0671 * eps0, 3.52
    fp = (20.20 - 146.0 * th + 316.0 * th**2) * 1e9  # [Hz]
    fs = 39.8 * fp
    m = _db(
        {
            "name": "debye",
            "eps_inf": eps2,
            "valid": ["1 GHz", "1 THz"],
            "terms": [[eps0 - eps1, 1.0 / (2.0 * math.pi * fp)], [eps1 - eps2, 1.0 / (2.0 * math.pi * fs)]],
        }
    ).get("fit")
    e = m.eps_at(f_ghz * 1e9)
    eta = (2.0 + e.real) / e.imag
    ours = 0.819 * f_ghz / (e.imag * (1.0 + eta**2))
    theirs = float(p840.specific_attenuation_coefficients(f_ghz, t_k - 273.15))
    assert ours == pytest.approx(theirs, rel=1e-9)
