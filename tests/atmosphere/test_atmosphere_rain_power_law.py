"""A rain layer's power law A = a R^b (Murakowski 2014 sec. 3.3.4, Table 3.5: Olsen et al. 1978 at
20 C) beside ITU-R P.838-3: the model's extinction is the closed form, its scattering the Mie
albedo's share of it, a scenario's path loss through the thesis's 1.5 km of rain is the table's,
a frequency without coefficients is refused, and P.838 stays as it was where no power law is
given."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pmmw.atmosphere import Atmosphere, AtmosphereLayer, AtmosphereModel, itu
from pmmw.atmosphere.itu import NP_M_PER_DB_KM
from pmmw.atmosphere.model import rain_power_law_db_km
from pmmw.config import load_scenario
from pmmw.config.load import scenario_to_display
from pmmw.errors import UserError
from pmmw.pipeline import atmosphere_model

GHZ = 1e9
REPO = Path(__file__).resolve().parents[2]
SAR = REPO / "configs/sar_cessna_95ghz.yaml"
# Murakowski 2014 Table 3.5: (a, b) and the printed attenuation at 10 mm/h [dB/km]
TABLE_3_5 = {35: (0.235, 1.009, 2.4), 95: (1.06, 0.745, 5.9)}
POWER_LAW = "attenuation: {model: power_law, coefficients: {35 GHz: {a: 0.235, b: 1.009}, 95 GHz: {a: 1.06, b: 0.745}}}"
# Floating point: the same arithmetic in another order (exp/log of a power, Np <-> dB, cumulative
# sums over a few hundred cells) differs by a few ulp; 1e-12 relative is far below any physics.
REL = 1e-12


def _rain(rate, power_law=None, f_ghz=95):
    """Extinction, scattering and scattering x asymmetry [Np/m] of the cells below 1500 m of a model
    with 0-1500 m of rain, less those of the same cells with the layer at 0 mm/h (the same gas and
    everything else): the rain alone, shape (K,) each."""

    def model(r):
        layer = AtmosphereLayer("rain", 0.0, 1500.0, rain_rate=r, power_law=power_law)
        return AtmosphereModel(Atmosphere(layers=(layer,)), f_ghz * GHZ)

    wet = model(rate)
    edges = wet.edges[wet.edges <= 1500.0]
    # the cells of the wet model (split where the rain scatters) for both
    wet_cells, dry_cells = wet._cells(edges), model(0.0)._cells(edges)
    return tuple(w - d for w, d in zip(wet_cells[3:], dry_cells[3:]))


@pytest.mark.parametrize("f_ghz", sorted(TABLE_3_5))
def test_power_law_extinction_is_a_r_to_the_b(f_ghz):
    """Inside the layer the rain adds exactly a R^b dB/km of extinction (Table 3.5's closed form),
    at 10 mm/h the table's printed 2.4 / 5.9 dB/km to its rounding (0.05 dB/km)."""
    a, b, printed = TABLE_3_5[f_ghz]
    for rate in (1.0, 10.0, 50.0):
        extinction, _, _ = _rain(rate, (a, b), f_ghz)
        assert extinction / NP_M_PER_DB_KM == pytest.approx(np.full(extinction.size, a * rate**b), rel=REL)
    assert float(rain_power_law_db_km(10.0, a, b)) == pytest.approx(printed, abs=0.05)
    assert rain_power_law_db_km(np.array([0.0, 4.0]), a, b) == pytest.approx([0.0, a * 4.0**b], rel=REL)


def test_power_law_keeps_the_mie_split_into_absorption_and_scattering():
    """The power law sets the total; its scattering is the Mie albedo's fraction of that total and
    its asymmetry parameter the drops' (`itu.rain_single_scattering_albedo`,
    `itu.rain_asymmetry_parameter`), as for P.838."""
    a, b, _ = TABLE_3_5[95]
    extinction, scattering, scattering_g = _rain(10.0, (a, b))
    omega = np.asarray(itu.rain_single_scattering_albedo(95 * GHZ, 10.0)).item()
    g = np.asarray(itu.rain_asymmetry_parameter(95 * GHZ, 10.0)).item()
    assert extinction == pytest.approx(np.full(extinction.size, a * 10.0**b * NP_M_PER_DB_KM), rel=REL)
    assert scattering == pytest.approx(extinction * omega, rel=REL)
    assert scattering_g == pytest.approx(scattering * g, rel=REL)


def test_p838_is_unchanged_without_a_power_law():
    """No `power_law`: the rain's extinction is P.838-3's k R^alpha, exactly as before."""
    extinction, scattering, _ = _rain(10.0, None)
    p838 = float(itu.rain_specific_attenuation_db_km(10.0, 95 * GHZ))
    assert extinction / NP_M_PER_DB_KM == pytest.approx(np.full(extinction.size, p838), rel=REL)
    assert scattering == pytest.approx(
        extinction * np.asarray(itu.rain_single_scattering_albedo(95 * GHZ, 10.0)).item(), rel=REL
    )


def _sar(layers, *extra):
    return load_scenario(SAR, [f"atmosphere.layers={layers}", *extra])


@pytest.mark.parametrize("f_ghz", sorted(TABLE_3_5))
def test_scenario_rain_path_loss_through_1500_m_is_table_3_5(f_ghz):
    """Sec. 3.3.4: rain 10 mm/h up to 1500 m. Straight down through it the power-law layer adds
    1.5 km x a 10^b dB (8.84 dB at 95 GHz; 1.5 x the printed 5.9 = 8.85 to the table's rounding)
    to the path loss, against the same scene with the layer at 0 mm/h."""
    a, b, printed = TABLE_3_5[f_ghz]
    wet = _sar(f"[{{kind: rain, base: 0 m, top: 1500 m, rain_rate: 10 mm/h, {POWER_LAW}}}]")
    dry = _sar(f"[{{kind: rain, base: 0 m, top: 1500 m, rain_rate: 0 mm/h, {POWER_LAW}}}]")
    loss = [float(atmosphere_model(s, f_ghz * GHZ).path_loss_db(1500.0, 0.0, 1500.0)) for s in (wet, dry)]
    # 1e-3 dB: the rain's cells are split (scattering) where the dry model's are not, and the gas
    # is taken at each cell's midpoint: the two grids' gas differ by ~1e-5 dB over 1.5 km
    assert loss[0] - loss[1] == pytest.approx(1.5 * a * 10.0**b, abs=1e-3)
    assert loss[0] - loss[1] == pytest.approx(1.5 * printed, abs=1.5 * 0.05)


def test_a_frequency_without_coefficients_is_refused_naming_the_key():
    """A scenario frequency the power law does not list is one error naming the file and the key,
    not a silent fallback to P.838."""
    layers = (
        "[{kind: rain, base: 0 m, top: 1500 m, rain_rate: 10 mm/h, "
        "attenuation: {model: power_law, coefficients: {95 GHz: {a: 1.06, b: 0.745}}}}]"
    )
    load_scenario(SAR, [f"atmosphere.layers={layers}"])  # 95 GHz: listed
    with pytest.raises(UserError) as e:
        load_scenario(SAR, [f"atmosphere.layers={layers}", "frequency=[35 GHz, 95 GHz]"])
    assert e.value.key == "atmosphere.layers[0].attenuation.coefficients"
    assert str(SAR) in str(e.value) and "35 GHz" in e.value.message and "\n" not in str(e.value)


@pytest.mark.parametrize(
    "attenuation, key, words",
    [
        ("{model: power_law}", "atmosphere.layers[0].attenuation", "needs coefficients"),
        ("{model: p838, coefficients: {95 GHz: {a: 1, b: 1}}}", "atmosphere.layers[0].attenuation", "power_law"),
        (
            "{model: power_law, coefficients: {95 GHz: {a: 0, b: 0.7}}}",
            'atmosphere.layers[0].attenuation.coefficients."95 GHz".a',
            "> 0",
        ),
        (
            "{model: power_law, coefficients: {95 GHz: {a: 1.06, b: 2.5}}}",
            'atmosphere.layers[0].attenuation.coefficients."95 GHz".b',
            "0 < b <= 2",
        ),
        (
            "{model: power_law, coefficients: {95: {a: 1.06, b: 0.745}}}",
            "atmosphere.layers[0].attenuation.coefficients",
            "unit",
        ),
        (
            "{model: power_law, coefficients: {95 GHz: {a: 1.06, b: 0.745}, 95000 MHz: {a: 1, b: 1}}}",
            "atmosphere.layers[0].attenuation.coefficients",
            "same frequency",
        ),
    ],
)
def test_bad_power_laws_name_the_key(attenuation, key, words):
    layers = f"[{{kind: rain, base: 0 m, top: 1500 m, rain_rate: 10 mm/h, attenuation: {attenuation}}}]"
    with pytest.raises(UserError) as e:
        load_scenario(SAR, [f"atmosphere.layers={layers}"])
    assert e.value.key == key and words in e.value.message, str(e.value)


def test_attenuation_is_for_rain_only():
    with pytest.raises(UserError) as e:
        _sar("[{kind: cloud, base: 1000 m, top: 2000 m, liquid_water: 1 g/m3, attenuation: {model: p838}}]")
    assert e.value.key == "atmosphere.layers[0]" and "rain" in e.value.message


def test_an_entry_holds_across_the_imager_band():
    """With a bandwidth the sub-bands (f +- B/2) take their band's entry; without one 96 GHz is not
    95 GHz."""
    layers = f"[{{kind: rain, base: 0 m, top: 1500 m, rain_rate: 10 mm/h, {POWER_LAW}}}]"
    banded = _sar(layers, "imager.bandwidth=4 GHz")
    a, b, _ = TABLE_3_5[95]
    dry = _sar("[{kind: rain, base: 0 m, top: 1500 m, rain_rate: 0 mm/h}]", "imager.bandwidth=4 GHz")
    wet_model, dry_model = atmosphere_model(banded, 96.9 * GHZ), atmosphere_model(dry, 96.9 * GHZ)
    added = wet_model.specific_attenuation_db_km(10.0) - dry_model.specific_attenuation_db_km(10.0)
    assert added == pytest.approx(a * 10.0**b, rel=1e-9)
    with pytest.raises(UserError, match="96 GHz"):
        atmosphere_model(_sar(layers), 96 * GHZ)


def test_display_keeps_the_power_law_and_omits_the_default():
    """The resolved scenario's display (which `scenario_hash` hashes) carries the power law and loads
    back to it; a P.838 layer's display is what it was (no new key: earlier renders keep their hash)."""
    pl = _sar(f"[{{kind: rain, base: 0 m, top: 1500 m, rain_rate: 10 mm/h, {POWER_LAW}}}]")
    shown = scenario_to_display(pl)["atmosphere"]["layers"][0]
    assert shown["attenuation"] == {
        "model": "power_law",
        "coefficients": {"35 GHz": {"a": 0.235, "b": 1.009}, "95 GHz": {"a": 1.06, "b": 0.745}},
    }
    p838 = _sar("[{kind: rain, base: 0 m, top: 1500 m, rain_rate: 10 mm/h}]")
    assert set(scenario_to_display(p838)["atmosphere"]["layers"][0]) == {"kind", "base", "top", "rain_rate"}


def test_pmmw_sky_takes_the_power_law_and_refuses_an_unlisted_frequency():
    """`pmmw sky` / `pmmw.sky` read the same layers: the power law's zenith loss through 1.5 km of
    10 mm/h makes the sky warmer than without rain, and an unlisted frequency is one error."""
    import pmmw

    rain = {
        "kind": "rain",
        "base": "0 m",
        "top": "1500 m",
        "rain_rate": "10 mm/h",
        "attenuation": {"model": "power_law", "coefficients": {"95 GHz": {"a": 1.06, "b": 0.745}}},
    }
    wet = float(pmmw.sky("95 GHz", {"layers": [rain]}, [90])["Tv"][0])
    dry = float(pmmw.sky("95 GHz", {"layers": [dict(rain, rain_rate="0 mm/h")]}, [90])["Tv"][0])
    assert wet > dry + 50.0  # 8.8 dB of rain at ~280 K over a ~50 K clear zenith
    with pytest.raises(UserError) as e:
        pmmw.sky("35 GHz", {"layers": [rain]}, [90])
    assert e.value.key == "atmosphere.layers[0].attenuation.coefficients" and "35 GHz" in e.value.message


def test_rain_without_scattering_absorbs_all_its_extinction():
    """`scattering: false` (the thesis's rain, sec. 3.3.1): the same extinction (the two models'
    cell grids differ: a scattering layer is cut finer), no scattering, so the path loss is unchanged and the layer emits as a pure absorber (its
    brightness seen from below, optically thick, tends to its temperature; scattering drops reflect
    the cold sky and look colder). Closed forms: equal extinction to rounding; zero scattering."""
    wet = AtmosphereLayer("rain", 0.0, 1500.0, rain_rate=50.0)
    dry = AtmosphereLayer("rain", 0.0, 1500.0, rain_rate=50.0, scattering=False)
    a = AtmosphereModel(Atmosphere(layers=(wet,)), 95e9)
    b = AtmosphereModel(Atmosphere(layers=(dry,)), 95e9)
    assert np.all(b.omega == 0.0) and np.any(a.omega > 0.3)  # 95 GHz, 50 mm/h: albedo about 0.5
    np.testing.assert_allclose(b.alpha_absorption, b.alpha, rtol=0)
    # the same extinction through the layer; the grids' piecewise-constant gas differ by 1.3e-6 of
    # the total (29.388 dB): 1e-5 allows that and would catch a lost or doubled share (0.3-0.5)
    assert float(a.path_loss_db(1500.0, 0.0, 1500.0)) == pytest.approx(
        float(b.path_loss_db(1500.0, 0.0, 1500.0)), rel=1e-5
    )
    # control: scattering drops, seen from the ground, are colder than absorbing ones (they mirror some sky)
    assert float(a.sky_temperature(np.pi / 2)) < float(b.sky_temperature(np.pi / 2)) - 1.0


def test_scattering_is_a_rain_layers_key(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text("""
name: s
frequency: 95 GHz
imager: {position: [0, 0, 10], look_at: [0, 10, 0], fov: 10 deg, resolution: [8, 8]}
scene: [{mesh: m.obj, material: metal}]
atmosphere: {layers: [{kind: fog, base: 0 m, top: 100 m, liquid_water: 0.1 g/m3, scattering: false}]}
""")
    with pytest.raises(UserError, match="scattering is a rain layer's"):
        load_scenario(p)
