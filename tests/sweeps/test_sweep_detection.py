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


def test_a_variant_detectable_in_another_channel_says_so(tmp_path):
    """A variant's own report judges every channel (its `verdicts`); the sweep's table and report
    carry that verdict beside the lead channel's (before, a gun detectable only in Ex2 read "not
    detectable" in the sweep and its own report said "detectable in Ex2"). Control: a variant
    below the criterion in every channel is listed as not detectable."""
    import json

    from pmmw.sweeps.run import _row

    spec = SweepSpec(scenario=Path("cwd.yaml"), grid=[("materials.pc.temperature", ["310 K", "296 K"])])
    rows = []
    for i, (ex2, ey2) in enumerate([(6.66, 2.43), (3.1, 4.9)]):
        (tmp_path / f"v{i:03d}").mkdir()
        chans = {
            c: {"K": 1.0, "sigma": 0.2, "snr": s, "detectable": s >= 5, "snr_stderr": 0.04}
            for c, s in (("Ex2", ex2), ("Ey2", ey2))
        }
        report = {"regions": {"channel": "Ey2", "contrasts": {"gun - torso": chans}}}
        (tmp_path / f"v{i:03d}" / "report.json").write_text(json.dumps(report))
        rows.append(
            _row(
                spec,
                tmp_path,
                f"v{i:03d}",
                {"materials.pc.temperature": i},
                {"status": "done", "exr": "", "wall_s": 1.0},
            )
        )
    assert [r["detectable gun - torso Ey2"] for r in rows] == [False, False]
    assert [r["detectable gun - torso in any channel"] for r in rows] == [True, False]
    assert [r["best channel gun - torso"] for r in rows] == ["Ex2 (SNR 6.66)", "Ey2 (SNR 4.9)"]
    text = write_report(tmp_path, spec, rows).read_text()
    assert "- gun - torso (in any channel, each variant's own verdict): detectable in v000; not in v001" in text
