"""A sweep's detection limit in its report (`sweep_report`, `imaging.detection.detection_limit`),
from a results table: no rendering."""

from pathlib import Path

from pmmw.sweeps.report import write_report
from pmmw.sweeps.spec import SweepSpec


def _table(ranges, snrs, err=0.2):
    return [
        {
            "variant": f"v{i:03d}",
            "imager.position[1]": r,
            "status": "done",
            "snr gun - torso Ey2": s,
            "snr_stderr gun - torso Ey2": err,
            "detectable gun - torso Ey2": s >= 5,
            "contrast gun - torso Ey2 [K]": -5.0,
        }
        for i, (r, s) in enumerate(zip(ranges, snrs))
    ]


def test_report_states_the_detection_range_and_draws_it(tmp_path):
    ranges = ["5 m", "10 m", "15 m", "20 m"]
    spec = SweepSpec(scenario=Path("cwd.yaml"), grid=[("imager.position[1]", ranges)])
    # SNR = 150 / r^1.2: 21.9, 9.5, 5.8, 4.1 -> crossed between 15 and 20 m
    snrs = [150 / x**1.2 for x in (5, 10, 15, 20)]
    text = write_report(tmp_path, spec, _table(ranges, snrs)).read_text()
    line = next(ln for ln in text.splitlines() if ln.startswith("- gun - torso"))
    assert "detection limit (largest imager.position[1] [m] detected)" in line
    assert "between 15, detected, and 20" in line and "from the Monte Carlo" in line
    assert (tmp_path / "plot_gun_torso.png").stat().st_size > 5_000


def test_control_a_target_below_the_criterion_has_no_range(tmp_path):
    ranges = ["5 m", "10 m", "15 m"]
    spec = SweepSpec(scenario=Path("cwd.yaml"), grid=[("imager.position[1]", ranges)])
    text = write_report(tmp_path, spec, _table(ranges, [4.0, 2.0, 1.0])).read_text()
    line = next(ln for ln in text.splitlines() if ln.startswith("- gun - torso"))
    assert "detected nowhere" in line and "detection limit" not in line
