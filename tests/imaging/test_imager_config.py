"""``imager.receiver`` and ``imager.antenna`` in a scenario: choices, errors with their key, the
resolved receiver, and the display that loads back."""

import pytest
import yaml

from pmmw import pipeline
from pmmw.config import load_scenario, scenario_to_display
from pmmw.errors import UserError

BASE = """
name: t
frequency: 95 GHz
imager: {position: [0, -10, 1], look_at: [0, 0, 1], fov: 10 deg, resolution: [8, 6], aperture_diameter: 0.6 m,
         bandwidth: 4 GHz}
scene:
  - {mesh: m.obj, material: concrete}
"""


def _load(tmp_path, *sets):
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    p = tmp_path / "s.yaml"
    p.write_text(BASE)
    return load_scenario(p, list(sets))


@pytest.mark.parametrize(
    "sets, words",
    [
        (["imager.noise=2 K", "imager.receiver={noise_temperature: 500 K, integration_time: 1 ms}"], "not both"),
        (["imager.receiver={integration_time: 1 ms}"], "one of noise_temperature"),
        (
            ["imager.receiver={noise_figure: 5 dB, noise_temperature: 500 K, integration_time: 1 ms}"],
            "one of noise_temperature",
        ),
        (["imager.receiver={noise_figure: 5 dB}"], "one of integration_time"),
        (["imager.receiver={noise_figure: 5 dB, integration_time: 1 ms, receivers: 4}"], "go with frame_rate"),
        (["imager.bandwidth=0", "imager.receiver={noise_figure: 5 dB, integration_time: 1 ms}"], "needs a bandwidth"),
        (["imager.aperture_diameter=0", "imager.antenna={blockage: 0.1}"], "aperture_diameter > 0"),
        (["imager.antenna={edge_taper: 10 dB}"], "needs illumination"),
        (["imager.antenna={illumination: gaussian}"], "needs an edge_taper"),
        (["imager.antenna={blockage: 0.95}"], "less than 0.9"),
    ],
)
def test_refused_with_the_key(tmp_path, sets, words):
    with pytest.raises(UserError) as e:
        _load(tmp_path, *sets)
    assert e.value.key.startswith("imager") and words in str(e.value), str(e.value)


def test_scanned_receiver_dwell_and_noise_figure(tmp_path):
    # 48 pixels over 4 receivers: 12 each; 10 frames/s -> 1/120 s per pixel. 3.0103 dB -> 290 K.
    s = _load(tmp_path, "imager.receiver={noise_figure: 3.0103 dB, frame_rate: 10 Hz, receivers: 4}")
    rx = pipeline.receiver_of(s)
    assert rx.tau == pytest.approx(1 / 120, rel=1e-12)
    assert rx.t_rec == pytest.approx(290.0, rel=1e-4)  # 3.0103 dB is a factor 2 to 5 digits
    assert rx.bandwidth == 4e9  # imager.bandwidth when the receiver gives none


def test_display_loads_back_to_the_same_hardware(tmp_path):
    s = _load(
        tmp_path,
        "imager.receiver={noise_figure: 5 dB, bandwidth: 2 GHz, frame_rate: 15 Hz, receivers: 8, "
        "mode: dicke, gain_fluctuation: 0.001}",
        "imager.antenna={illumination: parabolic, edge_taper: 12 dB, blockage: 0.1, spillover: 0.04}",
    )
    shown = scenario_to_display(s)
    shown.pop("source_file")
    (tmp_path / "back.yaml").write_text(yaml.safe_dump(shown))
    back = load_scenario(tmp_path / "back.yaml", [])
    assert back.imager.receiver == s.imager.receiver and back.imager.antenna == s.imager.antenna
    # and a scenario without them displays as before (its hash unchanged)
    plain = scenario_to_display(_load(tmp_path))
    assert "receiver" not in plain["imager"] and "antenna" not in plain["imager"]
    assert "false_alarm" not in plain["output"]


def test_report_states_netd_beam_and_pd():
    import numpy as np

    from pmmw.imaging.antenna import Aperture, beam_report
    from pmmw.imaging.receiver import Receiver
    from pmmw.io.report import render_markdown

    rx = Receiver(t_rec=865.0, bandwidth=1e10, tau=1e-3)
    beam = beam_report(Aperture(), 2 * np.pi / 3.2e-3, 0.5, 4e-3)  # 4 mrad > lambda / 2D = 3.2 mrad
    contrast = {"K": -5.0, "snr": 6.0, "snr_stderr": 0.5, "detectable": True, "pd": 0.994}
    text = render_markdown(
        {
            "name": "t",
            "imager": {"receiver": rx.summary(), "beam": beam},
            "regions": {
                "criterion": "c",
                "channel": "Ey2",
                "noise_K": 0.37,
                "false_alarm": 1e-3,
                "verdicts": {"gun - torso": "gun - torso: detectable"},
                "contrasts": {"gun - torso": {"Ey2": contrast}},
            },
        },
        {},
    )
    # NETD = (300 + 865) / sqrt(1e7) = 0.368 K
    assert "NETD: 0.368 K at a 300 K scene" in text
    assert "under-sampled" in text and "energy budget: main beam 0.838" in text
    assert "false-alarm probability of 0.001" in text and "gun - torso 0.994" in text
    assert "the receiver's, pixel by pixel" in text
