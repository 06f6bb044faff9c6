"""The Dask paths of `pmmw render` and `pmmw sweep` against real services on 127.0.0.1.

A wrong ``--scheduler`` (an HTTP server, a service that sends other bytes, a port that accepts and
says nothing, a closed port) is one ``error:`` line naming the address and the cause, exit status
2, within a deadline; a scheduler without a worker is one line, exit status 1; a real scheduler
(a subprocess) killed with SIGKILL mid-render or mid-sweep is one line saying what was finished,
exit status 1, and nothing is written into the output folder after pmmw returned, although the
orphaned worker keeps running the task it had begun.

Every command is the real ``pmmw`` in a subprocess, so a hang fails by its timeout.
"""

from __future__ import annotations

import http.server
import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

from tests.scenes import ground_and_block

#: The ``pmmw`` console entry point, run so that it imports the package of the current folder (as
#: the Dask processes, started with ``-m``, do), not whichever one is installed.
PMMW = [sys.executable, "-c", "from pmmw_cli.__main__ import main; main()"]

#: A wrong address must be told within this [s]: pmmw's deadline is 10 s of silence (then 2 s for
#: an HTTP request), plus the start of pmmw and the scene's resolution on a loaded 2-core machine.
#: Before the fix an HTTP server or a silent port held pmmw for good (> 200 s).
WRONG_ADDRESS_S = 30.0
#: A scheduler killed mid-run must be told within this [s] of the kill: Dask cancels the futures of
#: a client that lost its scheduler at once; the rest is closing the client.
LOST_SCHEDULER_S = 30.0
#: How long the output folder is watched after pmmw returned [s]: an orphaned variant renders its
#: remaining tiles (0.3 s each, `_PRELOAD`) for about this long, then commits.
WATCH_S = 8.0

_SCENE = """
name: tiny
frequency: 35 GHz
imager: {position: [0, 0, 1.5], look_at: [0, 4, 0.1], fov: 20 deg, resolution: [48, 32], noise: 1 K}
scene:
  - {mesh: ground.obj, material: concrete}
  - {mesh: block.obj, material: metal}
sky: {model: uniform, temperature: 40 K}
render: {spp: 2, max_depth: 4, tile: 8, workers: 1}
"""

# A Dask worker preload: each tile takes 0.3 s more and leaves a mark (outside the output folder),
# so that a render lasts long enough to kill its scheduler in the middle, and the test sees that the
# orphaned worker kept rendering after pmmw returned.
_PRELOAD = """
import os, time
from pathlib import Path
import pmmw.trace.integrator as integrator

if not getattr(integrator, "_test_slow", False):  # Dask may run a preload more than once
    integrator._test_slow = True
    _tile = integrator.Integrator.render_tile

    def render_tile(self, tile):
        r = _tile(self, tile)
        (Path(os.environ["PMMW_TEST_MARKS"]) / f"tile-{os.getpid()}-{time.monotonic_ns()}").touch()
        time.sleep(0.3)
        return r

    integrator.Integrator.render_tile = render_tile
"""


def _scene(tmp_path: Path) -> Path:
    ground_and_block(tmp_path)
    path = tmp_path / "tiny.yaml"
    path.write_text(_SCENE)
    return path


def _listen() -> socket.socket:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen()
    return s


def _serve(server: socket.socket, greeting: bytes | None):
    """Accept connections on ``server`` for ever: send ``greeting`` (None: nothing) and hold them."""
    held = []

    def run():
        while True:
            try:
                conn, _ = server.accept()
            except OSError:  # closed at the end of the test
                return
            held.append(conn)
            if greeting is not None:
                conn.sendall(greeting)

    threading.Thread(target=run, daemon=True).start()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def _side_by_side(runs: dict, limit: float) -> dict:
    """Run ``pmmw ARGS`` for each of ``runs`` (name -> ARGS) together; name -> (exit status,
    stderr, seconds it ran). One still running after ``limit`` [s] is killed (status None)."""
    t0 = time.monotonic()
    procs = {
        k: subprocess.Popen([*PMMW, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for k, args in runs.items()
    }
    out = {}
    for k, p in procs.items():
        try:
            _, err = p.communicate(timeout=max(1.0, limit - (time.monotonic() - t0)))
            out[k] = (p.returncode, err, time.monotonic() - t0)
        except subprocess.TimeoutExpired:
            p.kill()
            out[k] = (None, p.communicate()[1], time.monotonic() - t0)
    return out


def test_wrong_scheduler_addresses_are_one_line_within_a_deadline(tmp_path):
    """An HTTP server, an SSH-like service, a silent port and a closed port, each given as
    ``--scheduler`` to `pmmw render` (and the SSH-like one to `pmmw sweep`): exit status 2 and one
    ``error: --scheduler: tcp://127.0.0.1:PORT ...`` line with the cause, within WRONG_ADDRESS_S.
    And a real scheduler without a worker: exit status 1 and one line (it was blamed on the tile
    folder: ``cannot save the finished tiles: No valid workers found``). The commands run side by
    side, in two batches (each mostly waits on its socket)."""
    scn = _scene(tmp_path)
    lone, lone_address = _start_scheduler(tmp_path, dict(os.environ))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _QuietHandler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    garbage, silent, closed = _listen(), _listen(), _listen()
    _serve(garbage, b"SSH-2.0-OpenSSH_9.6\r\n")  # Dask read a length of 3 EiB from this: MemoryError
    _serve(silent, None)
    closed_port = closed.getsockname()[1]
    closed.close()
    port = {
        "http": httpd.server_address[1],
        "garbage": garbage.getsockname()[1],
        "silent": silent.getsockname()[1],
        "closed": closed_port,
    }
    cause = {
        "http": "is not a Dask scheduler (it answered like an HTTP server",
        "garbage": "is not a Dask scheduler (it sent 'SSH-2.0-'",
        "silent": "did not answer within 10 s",
        "closed": "refused the connection",
    }
    runs = {
        k: ["render", str(scn), "--scheduler", f"tcp://127.0.0.1:{p}", "--out", str(tmp_path / k), "-q"]
        for k, p in port.items()
    }
    runs["sweep garbage"] = [
        "sweep",
        str(scn),
        "--grid",
        "render.seed=[1, 2]",
        "--scheduler",
        f"tcp://127.0.0.1:{port['garbage']}",
        "--out",
        str(tmp_path / "sweep"),
        "-q",
    ]
    cause["sweep garbage"], port["sweep garbage"] = cause["garbage"], port["garbage"]
    want = {k: (2, f"error: --scheduler: tcp://127.0.0.1:{port[k]} {cause[k]}") for k in runs}
    runs["no worker"] = ["render", str(scn), "--scheduler", lone_address, "--out", str(tmp_path / "lone"), "-q"]
    want["no worker"] = (1, f"error: the Dask cluster at {lone_address} did not take the job")
    try:
        # the two that wait out pmmw's deadline first, then the quick ones: five pmmw starting
        # together on 2 loaded cores took longer to start than the deadline itself
        problems = []
        for batch in (("http", "silent"), ("garbage", "closed", "sweep garbage", "no worker")):
            for k, (status, err, took) in _side_by_side({k: runs[k] for k in batch}, WRONG_ADDRESS_S).items():
                lines = err.strip().splitlines()
                if (
                    status != want[k][0]
                    or len(lines) != 1
                    or not lines[0].startswith(want[k][1])
                    or took > WRONG_ADDRESS_S
                ):
                    problems.append(f"{k}: status {status} after {took:.1f} s, {len(lines)} lines: {err[-600:]!r}")
        assert not problems, "\n".join(problems)
    finally:
        httpd.shutdown()
        garbage.close()
        silent.close()
        _stop(lone)


def _start_scheduler(tmp_path: Path, env: dict):
    """A Dask scheduler on 127.0.0.1 in a subprocess (its log in ``tmp_path``); (process, address)."""
    file = tmp_path / "scheduler.json"
    with open(tmp_path / "scheduler.log", "w") as log:
        scheduler = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "distributed.cli.dask_scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(file),
            ],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    deadline = time.monotonic() + 60
    while not file.exists() and time.monotonic() < deadline and scheduler.poll() is None:
        time.sleep(0.1)
    time.sleep(0.2)  # the file is written in one go, but let it be complete
    return scheduler, json.loads(file.read_text())["address"]


def _start_cluster(tmp_path: Path):
    """A scheduler and one single-threaded worker (no nanny) in subprocesses, the worker with
    `_PRELOAD`; (scheduler, worker, address, marks folder)."""
    marks = tmp_path / "marks"
    marks.mkdir()
    preload = tmp_path / "slow_preload.py"
    preload.write_text(_PRELOAD)
    env = dict(os.environ, DASK_TEMPORARY_DIRECTORY=str(tmp_path / "scratch"), PMMW_TEST_MARKS=str(marks))
    scheduler, address = _start_scheduler(tmp_path, env)
    with open(tmp_path / "worker.log", "w") as log:
        worker = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "distributed.cli.dask_worker",
                address,
                "--nthreads",
                "1",
                "--no-nanny",
                "--no-dashboard",
            ],
            env=dict(env, DASK_DISTRIBUTED__WORKER__PRELOAD=json.dumps([str(preload)])),
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    return scheduler, worker, address, marks


def _stop(*procs):
    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
        p.wait()


def _snapshot(folder: Path) -> dict:
    """Every path under ``folder`` with its size and modification time [ns]."""
    out = {}
    for p in sorted(folder.rglob("*")):
        try:
            st = p.lstat()
        except FileNotFoundError:  # removed while listing: a difference shows in the next one
            continue
        out[str(p.relative_to(folder))] = (st.st_size, st.st_mtime_ns)
    return out


def _kill_scheduler_mid_run(tmp_path: Path, args: list[str]) -> dict:
    """Run ``pmmw ARGS --scheduler ADDRESS -q`` on a fresh cluster (`_start_cluster`) and SIGKILL
    the scheduler once the worker has rendered 2 tiles. Returns pmmw's ``status`` and ``stderr``,
    ``waited`` (seconds from the kill to pmmw's exit), ``address``, ``marks`` (the folder) and
    ``marks_at_exit``, and the ``worker``, left running: the caller kills it."""
    scheduler, worker, address, marks = _start_cluster(tmp_path)
    try:
        proc = subprocess.Popen(
            [*PMMW, *args, "--scheduler", address, "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        deadline = time.monotonic() + 300  # the worker may compile the kernels first (a stale numba cache)
        while len(list(marks.iterdir())) < 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        assert proc.poll() is None, f"pmmw ended before the scheduler was killed: {proc.communicate()}"
        _stop(scheduler)
        t_kill = time.monotonic()
        try:
            _, err = proc.communicate(timeout=LOST_SCHEDULER_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
        return {
            "status": proc.returncode,
            "stderr": err,
            "waited": time.monotonic() - t_kill,
            "address": address,
            "marks": marks,
            "marks_at_exit": len(list(marks.iterdir())),
            "worker": worker,
        }
    except BaseException:
        _stop(scheduler, worker)
        raise


def _assert_nothing_written_after_exit(out: Path, run: dict, orphan: bool):
    """Nothing under ``out`` changes during WATCH_S after pmmw returned; with ``orphan``, while the
    orphaned worker goes on with its task (its marks grow: else this would test nothing)."""
    before = _snapshot(out)
    time.sleep(WATCH_S)
    after = _snapshot(out)
    if orphan:
        assert len(list(run["marks"].iterdir())) > run["marks_at_exit"], "the worker stopped with pmmw: nothing tested"
    changed = sorted(k for k in before.keys() | after.keys() if before.get(k) != after.get(k))
    assert not changed, f"written into {out} after pmmw returned: {changed[:8]}"


def test_scheduler_killed_mid_render_is_one_line_and_keeps_the_tiles(tmp_path):
    """The scheduler SIGKILLed after 2 of the 24 tiles: exit status 1 within LOST_SCHEDULER_S and
    one line, ``the Dask scheduler at ADDRESS went away during the render (N of 24 tiles done;
    rerun with --resume to keep them)``, N being the tiles saved; nothing is written after (pmmw
    saves the tiles, never a task). Before: about 35 lines of Dask traceback, then a line that
    blamed a tile."""
    scn, out = _scene(tmp_path), tmp_path / "out"
    run = _kill_scheduler_mid_run(tmp_path, ["render", str(scn), "--out", str(out)])
    try:
        # a tile's task is short (one tile) and returns its tile: the worker may or may not have
        # another one queued when its scheduler dies, so it is not required to go on here
        _assert_nothing_written_after_exit(out, run, orphan=False)  # first: the watch starts at pmmw's exit
        lines = run["stderr"].strip().splitlines()
        assert run["status"] == 1 and len(lines) == 1, run["stderr"][-3000:]
        m = re.fullmatch(
            rf"error: the Dask scheduler at {re.escape(run['address'])} went away during the render "
            r"\((\d+) of 24 tiles done; rerun with --resume to keep them\)",
            lines[0],
        )
        assert m, lines[0]
        assert run["waited"] < LOST_SCHEDULER_S
        assert int(m.group(1)) == len(list(out.glob(".pmmw-tiles/*/tile_*.npz")))
    finally:
        _stop(run["worker"])


def test_scheduler_killed_mid_sweep_and_no_task_writes_after_exit(tmp_path):
    """A sweep of 3 variants, one task each on the single worker, the scheduler SIGKILLed inside
    the first: exit status 1 within LOST_SCHEDULER_S and one line, ``the Dask scheduler at ADDRESS
    went away during the sweep (0 of 3 variants done; rerun with --resume ...)``, ``sweep.csv``
    written with the 3 variants not done, and although the worker goes on rendering its variant,
    nothing changes in the sweep's folder after pmmw returned. Before: one line per variant, and
    the orphaned task kept writing tiles and then the variant's outputs into the folder."""
    scn, out = _scene(tmp_path), tmp_path / "sweep"
    run = _kill_scheduler_mid_run(tmp_path, ["sweep", str(scn), "--grid", "render.seed=[1, 2, 3]", "--out", str(out)])
    try:
        _assert_nothing_written_after_exit(out, run, orphan=True)  # first: the watch starts at pmmw's exit
        lines = run["stderr"].strip().splitlines()
        assert run["status"] == 1 and len(lines) == 1, run["stderr"][-3000:]
        assert lines[0] == (
            f"error: the Dask scheduler at {run['address']} went away during the sweep (0 of 3 "
            "variants done; rerun with --resume to keep them)"
        ), lines[0]
        assert run["waited"] < LOST_SCHEDULER_S
        rows = (out / "sweep.csv").read_text().splitlines()
        assert len(rows) == 4 and not any(",done," in r for r in rows), rows
    finally:
        _stop(run["worker"])


def test_a_connection_closed_under_a_result_is_blamed_on_the_scheduler_only_when_it_is_gone(tmp_path):
    """Under load, the scheduler's death can reach pmmw first as a ``CommClosedError`` while it
    gathers a tile's result, before the client's status changes: `scheduler_lost` then asks the
    address. A dead scheduler's address (nothing listens) is lost; a live scheduler's is not (the
    control: the tile is blamed, as for any other failure); an error that is not the connection's
    does not ask at all."""
    from types import SimpleNamespace

    from distributed.comm.core import CommClosedError

    from pmmw.distributed import scheduler_lost

    closed = _listen()
    dead = f"tcp://127.0.0.1:{closed.getsockname()[1]}"
    closed.close()
    sched, live = _start_scheduler(tmp_path, dict(os.environ))
    try:

        def client(address):
            return SimpleNamespace(status="running", scheduler=SimpleNamespace(address=address))

        err = CommClosedError("in <TCP (closed) ConnectionPool.gather>: Stream is closed")
        assert scheduler_lost(client(dead), err)
        assert not scheduler_lost(client(live), err)  # the control
        assert not scheduler_lost(client(dead), ValueError("a tile's own error"))
        assert scheduler_lost(SimpleNamespace(status="closed", scheduler=None))
    finally:
        _stop(sched)
