#!/usr/bin/env python3
"""Mitsuba's render, pmmw's trace and the compiled path loop (bench/prototype_path_loop.py, 2 threads;
on the smooth ground also its split tree with Jones matrices), alternating on the speed anchor; one
JSON line per round and ground.

usage: anchor_with_prototype.py MITSUBA_PYTHON DIR [ROUNDS]
DIR holds the anchor (bench/anchor_landing.py DIR --write-only); run with pmmw's Python from the
repository root (docs/benchmarks_anchor.md).
"""

import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from pmmw_cli import bench_anchor  # noqa: E402


def prototype(d, ground):
    """The loop's seconds and segments [M] per kind (the second of two runs: the first compiles)."""
    cmd = [sys.executable, str(ROOT / "bench" / "prototype_path_loop.py"), str(d / "anchor_landing.yaml")]
    cmd += ["--spp", "16", "--threads", "2", "--repeats", "2"] + (["--smooth", "--split"] if ground == "smooth" else [])
    out = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, check=True).stdout
    res = {}
    for ln in out.splitlines():
        m = re.match(r"run 2 (\w+)\s*:\s+([0-9.]+) s for\s+([0-9.]+) M segments", ln)
        if m:
            res[m.group(1)] = (float(m.group(2)), float(m.group(3)))
    return res


def main():
    python, d = sys.argv[1], Path(sys.argv[2])
    for i in range(int(sys.argv[3]) if len(sys.argv) > 3 else 3):
        for g in bench_anchor.GROUNDS:
            m = bench_anchor.mitsuba(python, d, g, d / f"mitsuba_{g}.exr")
            p = bench_anchor.pmmw(d / "anchor_landing.yaml", g, d / f"pmmw_{g}")
            q = prototype(d, g)
            row = {"round": i + 1, "ground": g, "mitsuba_render_s": m["render_s"], "pmmw_trace_s": p["trace_s"]}
            row["loop_s"], row["loop_segments_M"] = q["paths"]
            row["pmmw_ratio"] = m["render_s"] / p["trace_s"]
            row["loop_ratio"] = m["render_s"] / row["loop_s"]
            if "split" in q:  # pmmw's split tree with Jones matrices in the loop (smooth faces only)
                row["split_s"], row["split_segments_M"] = q["split"]
                row["split_ratio"] = m["render_s"] / row["split_s"]
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
