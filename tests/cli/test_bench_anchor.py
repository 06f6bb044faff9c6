"""`pmmw bench --anchor PYTHON` (pmmw_cli/bench_anchor.py): what it reads from each side's output, the
ratios it writes, and its error line without a Mitsuba environment. The processes themselves are
replaced by their recorded output (Mitsuba 3.9.1's line starts with its log's colour code, as it did
on this machine), so these tests run without Mitsuba and time nothing."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pmmw_cli import bench_anchor
from pmmw_cli.cli import app

MITSUBA_OUT = "\x1b[0m" + json.dumps(
    {
        "import_s": 0.8,
        "load_s": 0.03,
        "exr_written": 1000.0 + 9.5,
        "first_render_s": 8.0,
        "render_s": [7.5, 7.0],
        "paths": 4000000,
        "mitsuba": "3.9.1",
        "drjit": "1.5.0",
    }
)
PMMW_ERR = """timings:
  command started at            1.197 s after the process started
  kernels loaded at             8.036 s after the process started
  first tile sent at            8.047 s after the process started
  done at                      30.259 s after the process started
  resolve                       1.591 s
  kernels                       6.100 s
  tiles traced                 12.840 s
  trace                        19.260 s
  EXR                           0.399 s
  after the trace, together     4.798 s
"""


def test_each_side_read_from_its_output(monkeypatch, tmp_path):
    """Mitsuba: whole script = EXR written - process start (10.0 -> 1009.5: 9.5 s), render = the
    faster of its warm renders (7.0 s); pmmw: the tiles' tracing (12.84 s: not the trace phase's
    19.26 s, which holds loading the kernels, as Mitsuba's render does not), the marks of
    --timings, the command's wall time (1000 -> 1030: 30 s). Exact: the canned output's numbers."""

    def fake_run(cmd, what, env=None, cwd=None):
        return (1000.0, 1030.0, MITSUBA_OUT, "") if what == "Mitsuba" else (1000.0, 1030.0, "", PMMW_ERR)

    monkeypatch.setattr(bench_anchor, "_run", fake_run)
    m = bench_anchor.mitsuba("python", tmp_path, "rough", tmp_path / "m.exr")
    assert m["script_s"] == pytest.approx(9.5) and m["render_s"] == 7.0 and m["render_all_s"] == [7.5, 7.0]
    p = bench_anchor.pmmw(tmp_path / "a.yaml", "smooth", tmp_path / "out")
    assert p["trace_s"] == 12.84 and p["command_s"] == 30.0
    assert p["first tile sent"] == 8.047 and p["after the trace, together"] == 4.798


def test_pmmw_without_a_trace_line_is_an_error(monkeypatch, tmp_path):
    """A pmmw whose --timings lost its tiles' line stops the bench (no ratio of nothing); the
    control is the test above, which reads it."""
    monkeypatch.setattr(
        bench_anchor, "_run", lambda *a, **k: (0.0, 1.0, "", PMMW_ERR.replace("  tiles traced ", "  tiles "))
    )
    with pytest.raises(bench_anchor.EnvironmentProblem, match="no time for its tiles"):
        bench_anchor.pmmw(tmp_path / "a.yaml", "rough", tmp_path / "out")


def test_section_ratios():
    """Trace ratio = Mitsuba's render time / pmmw's trace time (paths/s of pmmw over Mitsuba's),
    command ratio = Mitsuba's script / pmmw's command: 1/2 and 3/12 here, printed to 2 decimals."""
    row = {
        "round": 1,
        "ground": "rough",
        "order": "mitsuba then pmmw",
        "paths": 4000000,
        "mitsuba_render_s": 1.0,
        "mitsuba_script_s": 3.0,
        "pmmw_trace_s": 2.0,
        "pmmw_command_s": 12.0,
        "trace_ratio": 0.5,
        "command_ratio": 0.25,
        "versions": "Mitsuba 3.9.1, Dr.Jit 1.5.0",
    }
    text = bench_anchor.section([row], "a machine", "pmmw bench --anchor py")
    assert "| 1 | rough | mitsuba then pmmw | 1.00 | 3.00 | 2.00 | 12.00 | 0.50 | 0.25 |" in text
    assert "| rough | 4.00-4.00 (median 4.00) | 2.00-2.00 (median 2.00) | 0.50-0.50" in text


def test_no_python_is_one_error_line(tmp_path):
    """`--anchor` naming no Python: exit 2 and one error line naming the option, before anything
    runs; the page is not written."""
    out = tmp_path / "b.md"
    res = CliRunner().invoke(app, ["bench", "--anchor", str(tmp_path / "nopython"), "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert "--anchor" in res.output and "no Python at" in res.output
    assert not out.exists()


def _forbid_benchmarks(monkeypatch, seen):
    """The scenario benchmark's first step (resolving a scenario) and the anchor's run, recorded;
    the scenario's stops the command with a line of its own, so a test sees whether it was reached."""
    import pmmw_cli.bench

    def resolve(path, overrides):
        seen.append(("scenario", path))
        raise bench_anchor.UserError("the scenario benchmark was reached", file=str(path))

    def run(python, **kw):
        seen.append(("anchor", python))
        return []

    monkeypatch.setattr(pmmw_cli.bench, "resolve", resolve)
    monkeypatch.setattr(bench_anchor, "run", run)


def _error_lines(res):
    return [ln for ln in res.output.splitlines() if ln.strip()]


def test_a_wrong_python_stops_bench_before_any_scenario(monkeypatch, tmp_path):
    """`pmmw bench SCENARIO --anchor PYTHON` where PYTHON is missing, or is not executable: one
    `error: --anchor:` line, exit 2, and no scenario was benchmarked (it was, minutes of it, before
    the Python was looked at); the output folder is not even made. The control: the same command
    with this Python reaches the scenario benchmark."""
    seen = []
    _forbid_benchmarks(monkeypatch, seen)
    scn, out = tmp_path / "s.yaml", tmp_path / "o" / "b.md"
    not_exec = tmp_path / "python3"
    not_exec.write_text("#!/bin/sh\n")
    not_exec.chmod(0o644)
    for python, why in ((tmp_path / "nopython", "no Python at"), (not_exec, "is not executable")):
        res = CliRunner().invoke(app, ["bench", str(scn), "--anchor", str(python), "--out", str(out)])
        assert res.exit_code == 2, res.output
        assert len(_error_lines(res)) == 1 and _error_lines(res)[0].startswith("error: --anchor: "), res.output
        assert why in res.output
        assert seen == [] and not out.parent.exists()
    # the control: a Python that is there gets past the check, to the scenario
    res = CliRunner().invoke(app, ["bench", str(scn), "--anchor", sys.executable, "--out", str(out)])
    assert res.exit_code == 2 and "the scenario benchmark was reached" in res.output, res.output
    assert seen == [("scenario", scn)]


def test_a_checkout_without_the_anchor_scripts_is_refused_first(monkeypatch, tmp_path):
    """An installed pmmw (no bench/ folder beside the package) given --anchor: one error line before
    anything runs. The control: in this checkout the same command runs the anchor (replaced here)."""
    seen = []
    _forbid_benchmarks(monkeypatch, seen)
    out = tmp_path / "b.md"
    monkeypatch.setattr(bench_anchor, "section", lambda rows, machine, command: "\n## anchor\n")
    res = CliRunner().invoke(app, ["bench", "--anchor", sys.executable, "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert seen == [("anchor", Path(sys.executable))] and out.is_file()
    # without the scripts (the module as if installed elsewhere)
    seen.clear()
    monkeypatch.setattr(bench_anchor, "__file__", str(tmp_path / "site" / "pmmw_cli" / "bench_anchor.py"))
    res = CliRunner().invoke(app, ["bench", "--anchor", sys.executable, "--out", str(tmp_path / "c.md")])
    assert res.exit_code == 2, res.output
    assert len(_error_lines(res)) == 1 and "error: --anchor: " in res.output and "checkout" in res.output
    assert seen == [] and not (tmp_path / "c.md").exists()


def test_po_with_anchor_is_refused(monkeypatch, tmp_path):
    """`--po --anchor PYTHON`: the physical-optics bench has no anchor, and it was silently dropped;
    now one error line and exit 2, the physical-optics bench not run. The control: --po alone runs it."""
    import pmmw_cli.bench_po

    ran = []
    monkeypatch.setattr(pmmw_cli.bench_po, "run", lambda out, **k: ran.append(out))
    out = tmp_path / "po.md"
    res = CliRunner().invoke(app, ["bench", "--po", "--anchor", sys.executable, "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert len(_error_lines(res)) == 1 and _error_lines(res)[0].startswith("error: --anchor: "), res.output
    assert "--po" in res.output and ran == []
    res = CliRunner().invoke(app, ["bench", "--po", "--out", str(out)])
    assert res.exit_code == 0 and ran == [out], res.output
