"""``pmmw bench --anchor PYTHON``: pmmw against Mitsuba 3 on the speed anchor, alternating in one run.

The anchor (``bench/anchor_landing.py``) is a landing-like scene of 816 triangles, 500 x 500
pixels, 16 samples per pixel, depth 6, with a rough (GGX alpha 0.2) or a smooth ground. Mitsuba runs
in its own Python (``PYTHON``, a virtual environment with the ``bench`` extra), as a user's whole
script (``bench/anchor_mitsuba.py``: import, scene load, render, EXR written), and then renders
again with its kernels in memory (its render-only time). pmmw runs as the whole command,
``python -m pmmw_cli render ANCHOR.yaml --timings``, whose trace is its render-only time. The two
alternate, ground by ground, for several rounds (the order swapped every round), so that a shared
machine's load falls on both; each round gives the ratios.

Paths per second = pixels x spp / time. The ratios: *trace* = pmmw's trace paths/s over
Mitsuba's render-only paths/s; *command* = pmmw's whole command over Mitsuba's whole script (both
from process start to the EXR on disk, pmmw's including its previews and report).
"""

from __future__ import annotations

import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from pmmw.errors import EnvironmentProblem, UserError
from pmmw.trace.pool import TILES

GROUNDS = ("rough", "smooth")
#: pmmw's scenario of the anchor with a smooth ground (the anchor's own is rough)
SMOOTH_SET = "materials.rough_ground={eps: {95 GHz: [3.7, 1.2]}, temperature: 288 K}"
#: Dr.Jit's LLVM back end needs a libLLVM: Debian's libllvm19 puts it here
DEBIAN_LIBLLVM = Path("/usr/lib/x86_64-linux-gnu/libLLVM-19.so")
#: a phase of ``pmmw render --timings`` that is read: the tiles' tracing and the work after the trace
_TIMING = re.compile(rf"^\s+({re.escape(TILES)}|after the trace, together)\s+([0-9.]+) s$")
_MARK = re.compile(r"^\s+(first tile sent|kernels loaded) at\s+([0-9.]+) s after the process started$")


def bench_dir() -> Path:
    """The repository's ``bench/`` folder (the anchor's scripts), or a UserError outside a checkout."""
    d = Path(__file__).resolve().parents[1] / "bench"
    if not (d / "anchor_landing.py").is_file() or not (d / "anchor_mitsuba.py").is_file():
        raise UserError("the speed anchor's scripts are in a checkout of pmmw (bench/), not here", file="--anchor")
    return d


def _env():
    env = dict(os.environ)
    if "DRJIT_LIBLLVM_PATH" not in env and DEBIAN_LIBLLVM.is_file():
        env["DRJIT_LIBLLVM_PATH"] = str(DEBIAN_LIBLLVM)
    return env


def _run(cmd, what, env=None, cwd=None):
    """Run ``cmd``; (started [s since the epoch], ended, stdout, stderr); EnvironmentProblem on failure."""
    t0 = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd)
    t1 = time.time()
    if p.returncode != 0:
        tail = (p.stderr or p.stdout).strip().splitlines()[-3:]
        raise EnvironmentProblem(f"{what} failed (exit {p.returncode}): {' / '.join(tail)}", file="--anchor")
    return t0, t1, p.stdout, p.stderr


def mitsuba(python, scene_dir: Path, ground: str, exr: Path, repeats=2):
    """One Mitsuba whole script; dict with ``script_s`` (process start to EXR written),
    ``render_s`` (the fastest render with kernels in memory) and the script's own figures."""
    cmd = [str(python), str(bench_dir() / "anchor_mitsuba.py"), str(scene_dir), "--ground", ground]
    t0, _, out, _ = _run([*cmd, "--exr", str(exr), "--repeats", str(repeats)], "Mitsuba", env=_env())
    line = [ln[ln.index("{") :] for ln in out.splitlines() if '{"import_s"' in ln]  # (after its log's colour codes)
    if not line:
        raise EnvironmentProblem(f"Mitsuba printed no result: {out.strip()[-200:]}", file="--anchor")
    r = json.loads(line[-1])
    r["script_s"] = r["exr_written"] - t0
    r["render_all_s"] = r["render_s"]
    r["render_s"] = min(r["render_s"])
    return r


def pmmw(scenario: Path, ground: str, out: Path, workers=None):
    """One pmmw whole command (this Python, this checkout); dict with ``command_s`` (process start to
    exit, EXR, previews and report written), ``trace_s`` and the marks of ``--timings``."""
    cmd = [sys.executable, "-m", "pmmw_cli", "render", str(scenario), "--out", str(out), "--timings", "-q"]
    if ground == "smooth":
        cmd += ["--set", SMOOTH_SET]
    if workers:
        cmd += ["--workers", str(workers)]
    t0, t1, _, err = _run(cmd, "pmmw render", cwd=Path(__file__).resolve().parents[1])
    r = {"command_s": t1 - t0}
    for ln in err.splitlines():
        m = _TIMING.match(ln) or _MARK.match(ln)
        if m:
            r[m.group(1)] = float(m.group(2))
    if TILES not in r:
        raise EnvironmentProblem("pmmw render --timings printed no time for its tiles", file="--anchor")
    # the tiles' tracing, as Mitsuba's render is timed with its kernels in memory; the "trace"
    # phase also holds loading the kernels from numba's cache and the job's set-up
    r["trace_s"] = r.pop(TILES)
    return r


def check(python) -> None:
    """What ``--anchor PYTHON`` needs before anything runs: ``python`` an executable file and the
    anchor's scripts (`bench_dir`); a UserError of ``--anchor`` otherwise."""
    p = Path(python)
    if not p.is_file():
        raise UserError(f"no Python at {python} (a virtual environment with pmmw's bench extra)", file="--anchor")
    if not os.access(p, os.X_OK):
        raise UserError(f"{python} is not executable (give the Python of a virtual environment)", file="--anchor")
    bench_dir()


def run(python, *, rounds=3, workers=None):
    """Alternate Mitsuba and pmmw on both grounds for ``rounds`` rounds (after one untimed run of
    each, which fills Dr.Jit's kernel cache and loads pmmw's); returns the rows, one per round and
    ground (each also logged to stderr)."""
    check(python)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        _run([sys.executable, str(bench_dir() / "anchor_landing.py"), str(d), "--write-only"], "anchor_landing.py")
        scenario = d / "anchor_landing.yaml"
        for g in GROUNDS:
            mitsuba(python, d, g, d / f"mitsuba_{g}.exr", repeats=1)
            pmmw(scenario, g, d / f"pmmw_{g}", workers)
        rows = []
        for i in range(rounds):
            for g in GROUNDS:
                order = ("mitsuba", "pmmw") if i % 2 == 0 else ("pmmw", "mitsuba")
                res = {}
                for who in order:
                    if who == "mitsuba":
                        res[who] = mitsuba(python, d, g, d / f"mitsuba_{g}.exr")
                    else:
                        res[who] = pmmw(scenario, g, d / f"pmmw_{g}", workers)
                m, p = res["mitsuba"], res["pmmw"]
                row = {
                    "round": i + 1,
                    "ground": g,
                    "order": " then ".join(order),
                    "paths": m["paths"],
                    "mitsuba_render_s": m["render_s"],
                    "mitsuba_render_all_s": m["render_all_s"],
                    "mitsuba_script_s": m["script_s"],
                    "mitsuba_first_render_s": m["first_render_s"],
                    "mitsuba_import_s": m["import_s"],
                    "pmmw_trace_s": p["trace_s"],
                    "pmmw_command_s": p["command_s"],
                    "pmmw_first_tile_s": p.get("first tile sent"),
                    "pmmw_after_trace_s": p.get("after the trace, together"),
                    "trace_ratio": m["render_s"] / p["trace_s"],
                    "command_ratio": m["script_s"] / p["command_s"],
                    "versions": f"Mitsuba {m['mitsuba']}, Dr.Jit {m['drjit']}",
                }
                rows.append(row)
                print(
                    f"anchor round {i + 1} {g}: Mitsuba render {m['render_s']:.2f} s, script {m['script_s']:.2f} s; "
                    f"pmmw trace {p['trace_s']:.2f} s, command {p['command_s']:.2f} s; "
                    f"ratios {row['trace_ratio']:.2f} (trace), {row['command_ratio']:.2f} (command)",
                    file=sys.stderr,
                )
    return rows


def section(rows, machine: str, command: str) -> str:
    """The Markdown section of ``docs/benchmarks.md`` for the rows of `run`."""
    mpath = rows[0]["paths"] / 1e6
    lines = [
        "\n## Against Mitsuba 3 on the speed anchor\n",
        f"`{command}` ({rows[0]['versions']}, `llvm_ad_mono_polarized`; machine: {machine}). The anchor "
        "(`bench/anchor_landing.py`): 816 triangles, 500 x 500 pixels x 16 spp, depth 6, a rough (GGX "
        "alpha 0.2) or smooth ground. Mitsuba and pmmw alternate in one run, ground by ground, the order "
        "swapped each round. *Mitsuba render* is a render with its kernels in memory (fastest of 2 in "
        "its process), *script* its whole script from process start to the EXR on disk "
        "(`bench/anchor_mitsuba.py`: import, scene load, kernels from Dr.Jit's cache, render, EXR); "
        "*pmmw trace* is its tiles' tracing (`tiles traced` of `pmmw render --timings`: from the tiles' "
        "sending, its kernels loaded, to the last tile back, the workers' start-up included), *command* "
        "the whole command from process "
        f"start to its exit (EXR, previews and report written). M paths/s = {mpath:g} M paths / time; "
        "*trace ratio* = pmmw's trace paths/s over Mitsuba's render paths/s (goal: 1 or more), "
        "*command ratio* = Mitsuba's script time over pmmw's command time (goal: 0.5 or more). Mitsuba "
        "has no thermal emission, lossy transmission or atmosphere, and follows one path per sample "
        "where pmmw splits each interaction: per path pmmw does more work; the ratio is still the pace "
        "a user compares.\n",
        "| round | ground | order | Mitsuba render [s] | Mitsuba script [s] | pmmw trace [s] | pmmw command [s] "
        "| trace ratio | command ratio |",
        "| ---: | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        lines.append(
            f"| {r['round']} | {r['ground']} | {r['order']} | {r['mitsuba_render_s']:.2f} | "
            f"{r['mitsuba_script_s']:.2f} | {r['pmmw_trace_s']:.2f} | {r['pmmw_command_s']:.2f} | "
            f"{r['trace_ratio']:.2f} | {r['command_ratio']:.2f} |"
        )
    lines += ["", "| ground | Mitsuba M paths/s | pmmw trace M paths/s | trace ratio | command ratio |"]
    lines.append("| --- | --- | --- | --- | --- |")
    for g in GROUNDS:
        rs = [r for r in rows if r["ground"] == g]
        if not rs:
            continue

        def span(vals, fmt="{:.2f}"):
            return f"{fmt.format(min(vals))}-{fmt.format(max(vals))} (median {fmt.format(statistics.median(vals))})"

        lines.append(
            f"| {g} | {span([mpath / r['mitsuba_render_s'] for r in rs])} | "
            f"{span([mpath / r['pmmw_trace_s'] for r in rs])} | {span([r['trace_ratio'] for r in rs])} | "
            f"{span([r['command_ratio'] for r in rs])} |"
        )
    lines.append(
        "\nWhere the trace's time goes against Mitsuba's (profiles) and what design would reach its pace: "
        "[benchmarks_anchor.md](benchmarks_anchor.md)."
    )
    return "\n".join(lines) + "\n"
