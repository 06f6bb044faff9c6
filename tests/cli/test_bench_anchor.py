"""`pmmw bench --anchor PYTHON` (pmmw_cli/bench_anchor.py): what it reads from each side's output, the
ratios it writes, and its error line without a Mitsuba environment. The processes themselves are
replaced by their recorded output (Mitsuba 3.9.1's line starts with its log's colour code, as it did
on this machine), so these tests run without Mitsuba and time nothing."""

from __future__ import annotations

import json

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
