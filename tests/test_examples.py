"""The example scripts in examples/ run as a user runs them and reach the README's conclusions:
the landing beacon stands out (3 noise sigmas) at 500 m but not at 2000 m; the concealed gun
at 4 m at 35 GHz."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _run(script: str, out: Path) -> str:
    p = subprocess.run([sys.executable, str(ROOT / "examples" / script), str(out)], capture_output=True, text=True,
                       timeout=300, cwd=out)
    assert p.returncode == 0, p.stderr[-2000:]
    return p.stdout


def test_landing_study(tmp_path):
    out = _run("landing_study.py", tmp_path)
    sigma = {tuple(line.split()[:2]): float(line.split()[3]) for line in out.splitlines()
             if line.strip()[:1].isdigit()}
    assert abs(sigma[("2000", "95")]) < 3.0 and abs(sigma[("2000", "35")]) < 3.0
    assert sigma[("500", "95")] <= -3.0  # the beacon mirrors the cold sky: darker than the runway
    assert (tmp_path / "landing_study.png").stat().st_size > 20_000


def test_cwd_study(tmp_path):
    _run("cwd_study.py", tmp_path)
    rows = [line.split(",") for line in (tmp_path / "cwd_study.csv").read_text().splitlines()[1:]]
    sigma = {(int(d), float(f)): float(s) for d, f, _, s in rows}
    assert sigma[(4, 35.0)] <= -3.0 and sigma[(4, 95.0)] <= -3.0
    assert abs(sigma[(8, 95.0)]) < abs(sigma[(8, 35.0)])  # 35 GHz sees the gun further out
