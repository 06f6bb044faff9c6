"""The worker pool hands back exactly what one process renders: every array of every tile, with
the tiles' arrays coming back through memory shared with the forked workers (`pool._Slots`)."""

import contextlib
import platform
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pmmw.pipeline import make_job, resolve
from pmmw.trace import pool

REPO = Path(__file__).resolve().parents[2]


def _forked(monkeypatch):
    """Workers forked whatever this process rendered before (`pool._context` spawns them once it
    has built an Embree scene), for a test whose patch of the pool the workers must inherit."""
    import multiprocessing as mp

    monkeypatch.setattr(pool, "_context", lambda: mp.get_context("fork"))


def test_workers_return_every_array_of_every_tile_as_one_process_renders_it():
    # adaptive sampling (per-pixel sample counts differ), tiles of three sizes (37 x 21 in tiles
    # of 8: the slots that held a full tile then hold smaller ones), more tiles than slots
    res = resolve(
        REPO / "configs" / "cinderblocks_35ghz.yaml",
        ["imager.resolution=[37, 21]", "render.tile=8", "render.spp=16", "render.min_spp=2"],
    )
    job = make_job(res, res.scenario.frequencies[0])
    one = pool.render_tiles(job, workers=1)
    two = pool.render_tiles(job, workers=2)
    assert len(two) == len(one) == 15
    assert len({r.samples.max() for r in two}) > 1 or len({r.samples.min() for r in two}) > 1  # adaptive
    for a, b in zip(one, two):
        assert (b.index, b.box, b.rays) == (a.index, a.box, a.rays) and b.t_isect > 0.0
        for name, _ in pool._PLANES:
            x, y = getattr(a, name), getattr(b, name)
            assert y.dtype == x.dtype and y.shape == x.shape, name
            np.testing.assert_array_equal(y, x, err_msg=name)


def test_slots_round_trip_a_tile_and_leave_the_result_without_arrays():
    rng = np.random.default_rng(3)
    h, w = 3, 5
    r = pool.TileResult(
        7,
        (2, 4, 2 + w, 4 + h),
        rng.random((h, w, 4)),
        rng.random((h, w, 4)),
        rng.random((h, w)),
        rng.integers(-1, 4, (h, w)).astype(float),
        11,
        rng.integers(1, 2**31 - 1, (h, w)).astype(np.int32),
        0.5,
        rng.random((h, w, 2)),
        rng.random((h, w, 4)),
    )
    want = {name: getattr(r, name).copy() for name, _ in pool._PLANES}
    slots = pool._Slots(2, 64)
    sent = slots.put(1, r)
    assert all(getattr(sent, name) is None for name, _ in pool._PLANES)
    back = slots.take(1, sent)
    for name, a in want.items():
        assert getattr(back, name).dtype == a.dtype, name
        np.testing.assert_array_equal(getattr(back, name), a, err_msg=name)


_REFAULTS = """
import resource, sys
import numpy as np
from pmmw.trace import pool
if sys.argv[1] == "keep":
    pool._reuse_freed_memory()
faults = []
for _ in range(3):  # a wave's worth of arrays (eight of 8 MiB) made, written and freed, three times
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    arrays = [np.empty(1 << 20) for _ in range(8)]
    for a in arrays:
        a[:] = 1.0
    faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
    del arrays, a
print(faults[-1])
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc", reason="glibc's mallopt")
def test_a_rendering_process_reuses_the_memory_of_freed_arrays():
    """With `pool._reuse_freed_memory` (what every rendering process calls first) the arrays of the
    next wave land on memory the process already has: writing them faults in no page. By glibc's
    default the 64 MiB freed at the top of the heap go back to the system (its trim threshold is
    twice the largest array freed so far) and every round faults them in again, about 4000 pages
    here (the cost that was 15 % of the landing scene's trace on the workers)."""

    def faults(mode):
        out = subprocess.run([sys.executable, "-c", _REFAULTS, mode], capture_output=True, text=True, check=True)
        return int(out.stdout)

    assert faults("default") >= 1000
    assert faults("keep") < 64


def _tiles_and_what_they_see(*overrides):
    """The cinderblocks' tiles at 64 x 64 pixels in tiles of 16, in `pool._by_cost` order, and the
    media that an 8 x 8 grid of camera rays per tile hits (Embree)."""
    from pmmw.trace.intersect import make_intersector

    res = resolve(
        REPO / "configs" / "cinderblocks_35ghz.yaml", ["imager.resolution=[64, 64]", "render.tile=16", *overrides]
    )
    job = make_job(res, res.scenario.frequencies[0])
    tiles = job.tiles()
    order = [t[0] for t in pool._by_cost(job, tiles)]
    assert sorted(order) == list(range(16))
    isect = make_intersector(job.vertices, job.faces)
    hits = {}
    for i, x0, y0, x1, y1 in tiles:
        u, v = np.meshgrid(np.linspace(x0, x1, 8, endpoint=False), np.linspace(y0, y1, 8, endpoint=False))
        o, d, _, _ = job.camera.rays(u.ravel(), v.ravel(), np.arange(64), 1)
        _, prim = isect.intersect(o, d)
        hits[i] = set(job.media.ids[k] for k in job.face_medium[prim[prim >= 0]])
    return order, hits


def test_workers_take_the_tiles_with_most_of_the_scene_first_and_the_sky_last():
    """`pool._by_cost` orders the work by the triangles each tile's screen area holds: on the
    cinderblocks as shipped (looking down: every tile sees the sand) the six tiles that see a
    block come first; looking level, the tiles that see only sky come last, in index order."""
    order, hits = _tiles_and_what_they_see()
    with_block = [n for n, i in enumerate(order) if "cinderblock" in hits[i]]
    assert len(with_block) >= 4 and with_block == list(range(len(with_block)))
    order, hits = _tiles_and_what_they_see("imager.look_at=[0.05, 5.25, 1.5]")
    sky = [i for i in order if not hits[i]]
    assert len(sky) >= 4 and order[-len(sky) :] == sorted(sky)


def test_a_first_run_says_the_kernels_are_compiling_and_times_the_tiles_after(monkeypatch):
    """With the kernels not cached (`jit.is_cached` False; compiling stood in for by 1.5 s of
    waiting), `render_tiles` tells ``notify`` before and after, and the progress clock starts after
    the compile: the first tile's elapsed time is below the 1.5 s (it was counted in, and the first
    estimate read `6118 s left`). The control: cached kernels say nothing."""
    import time

    from pmmw import jit
    from pmmw.trace import kernels

    res = resolve(
        REPO / "configs" / "cinderblocks_35ghz.yaml", ["imager.resolution=[16, 8]", "render.tile=8", "render.spp=1"]
    )
    job = make_job(res, res.scenario.frequencies[0])
    real_warm = kernels.warm

    def slow_warm(stack_size=8, rough=True):
        real_warm(stack_size, rough)
        time.sleep(1.5)

    monkeypatch.setattr(kernels, "warm", slow_warm)
    images = []
    for cached in (False, True):
        monkeypatch.setattr(jit, "is_cached", lambda rel, function=None, cached=cached: cached)
        said, elapsed = [], []
        tiles = pool.render_tiles(
            job, workers=1, notify=said.append, progress=lambda d, t, r, e, left: elapsed.append(e)
        )
        images.append([t.mean for t in tiles])
        if cached:
            assert said == []
        else:
            assert len(said) == 2 and "compiling the tracer's kernels" in said[0] and "compiled in" in said[1]
        assert len(elapsed) == 2 and elapsed[0] < 1.5, elapsed
    for a, b in zip(*images):  # the pixel traced to compile the rest changes no random number of the image
        np.testing.assert_array_equal(a, b)


def test_a_smooth_scene_warms_only_what_it_runs(monkeypatch):
    """`prepare_kernels` asks `kernels.warm` for the rough surfaces' kernels only when the scene
    has rough faces, bump maps or rough layers (the landing's first render after an install
    compiled in 49 s instead of 80 s, docs/benchmarks_command.md); the control: the rough
    cinderblocks ask for them. Either way the images are the kernels', whatever was warmed."""
    from pmmw import jit
    from pmmw.trace import kernels

    asked = []
    monkeypatch.setattr(kernels, "warm", lambda stack_size=8, rough=True: asked.append(rough))
    monkeypatch.setattr(
        jit, "is_cached", lambda rel, function=None: True
    )  # one `warm`, not the two processes' (`compile`)
    for cfg, rough in (("cinderblocks_35ghz.yaml", False), ("cinderblocks_rough_35ghz.yaml", True)):
        res = resolve(REPO / "configs" / cfg, ["imager.resolution=[8, 8]", "render.spp=1"])
        job = make_job(res, res.scenario.frequencies[0])
        assert job.media.any_rough is rough
        pool.prepare_kernels(job)
    assert asked == [False, True]


def test_a_rough_scene_after_smooth_ones_compiles_and_says_so(monkeypatch):
    """The rough surfaces' kernels are left out of a smooth scene's compile: the first rough scene
    after smooth ones compiles them, so `prepare_kernels` says so (it was silent before). The
    controls: with `settle` cached too, or for a smooth scene, nothing compiles."""
    from pmmw import jit

    jobs = {}
    for cfg in ("cinderblocks_35ghz.yaml", "cinderblocks_rough_35ghz.yaml"):
        res = resolve(REPO / "configs" / cfg, ["imager.resolution=[8, 8]", "render.spp=1"])
        jobs[cfg] = make_job(res, res.scenario.frequencies[0])
    for settle_cached in (False, True):
        monkeypatch.setattr(jit, "is_cached", lambda rel, function=None, s=settle_cached: function is None or s)
        assert pool.kernels_to_compile(jobs["cinderblocks_rough_35ghz.yaml"]) is not settle_cached
        assert pool.kernels_to_compile(jobs["cinderblocks_35ghz.yaml"]) is False


def test_time_left_from_the_tiles_own_durations():
    """`_Pace`: the mean seconds per tile times the tiles left over the workers; the workers'
    number caps at the tiles left; without durations (Dask) the pace since the first tile back,
    None after one tile. Exact arithmetic, so equality to 1e-12."""
    p = pool._Pace(todo=10, workers=2)
    p.add(0.4, elapsed=5.0)  # the first tile came back 5 s in: 4.6 s of it was the workers' start-up
    assert p.left() == pytest.approx(0.4 * 9 / 2, rel=1e-12)
    p.add(0.2, elapsed=5.1)
    assert p.left() == pytest.approx(0.3 * 8 / 2, rel=1e-12)
    for _ in range(7):
        p.add(0.3, elapsed=6.0)
    assert p.left() == pytest.approx(0.3 * 1 / 1, rel=1e-12)  # one tile left: one worker renders it
    p.add(0.3, elapsed=6.2)
    assert p.left() == 0.0
    dask = pool._Pace(todo=5, workers=4)
    dask.add(None, elapsed=3.0)
    assert dask.left() is None
    dask.add(None, elapsed=3.5)
    assert dask.left() == pytest.approx(0.5 * 3, rel=1e-12)


def test_the_first_estimate_leaves_out_the_workers_start_up(monkeypatch):
    """The workers' start-up (their Embree scenes) stood in for by 2 s of waiting in each: the
    first tile comes back after it, and the estimate then made from the elapsed time (as before,
    the control) exceeds 2 s x the tiles left, while the tiles' own durations (a few ms each for
    8 x 8 pixels at 1 spp; even 100 times slower, under 1 s for the 3 tiles on 2 workers) give
    an estimate below 2 s."""
    import time

    res = resolve(
        REPO / "configs" / "cinderblocks_35ghz.yaml", ["imager.resolution=[16, 16]", "render.tile=8", "render.spp=1"]
    )
    job = make_job(res, res.scenario.frequencies[0])
    real_init = pool._init_worker

    def slow_init(job, kind):
        time.sleep(2.0)
        return real_init(job, kind)

    monkeypatch.setattr(pool, "_init_worker", slow_init)
    _forked(monkeypatch)
    calls = []
    pool.render_tiles(job, workers=2, progress=lambda d, t, r, e, left: calls.append((d, t, e, left)))
    done, total, elapsed, left = calls[0]
    assert done == 1 and total == 4
    assert elapsed / done * (total - done) > 2.0 * (total - done)  # the control: start-up counted in
    assert left is not None and left < 2.0, calls[0]
    assert calls[-1][3] == 0.0


def test_the_report_times_the_tiles_apart_from_loading_the_kernels(monkeypatch, tmp_path):
    """report.json's ``timing.tiles_s`` (and the summary line's "s trace") is the tiles' tracing
    alone; ``trace_s`` also holds loading the kernels. With loading stood in for by 1.5 s of
    waiting, ``trace_s`` exceeds ``tiles_s`` by at least those 1.5 s. The control: without the
    wait (the kernels loaded before it, by `kernels.warm` as the render calls it) the gap is
    under 1.5 s, so the check can fail."""
    import json
    import time

    from pmmw.pipeline import render as run
    from pmmw.trace import kernels
    from tests.scenes import tiny_scenario

    real_warm = kernels.warm

    def slow_warm(stack_size=8, rough=True):
        real_warm(stack_size, rough)
        time.sleep(1.5)

    scn = tiny_scenario(tmp_path)
    res = resolve(scn, [])
    job = make_job(res, res.scenario.frequencies[0])
    # the kernels in memory before the control, as `pool.prepare_kernels` loads them: its trace_s
    # then holds no first load from disk
    kernels.warm(job.settings.stack_size, rough=job.media.any_rough)
    run(scn, [], out=tmp_path / "control", workers=1, quiet=True)
    control = json.loads((tmp_path / "control" / "report.json").read_text())["timing"]
    assert control["trace_s"] - control["tiles_s"] < 1.5, control
    monkeypatch.setattr(kernels, "warm", slow_warm)
    run(scn, [], out=tmp_path / "out", workers=1, quiet=True)
    timing = json.loads((tmp_path / "out" / "report.json").read_text())["timing"]
    assert 0.0 < timing["tiles_s"] and timing["trace_s"] - timing["tiles_s"] >= 1.5, timing


def test_a_hung_worker_is_stopped_and_its_tile_rendered_again(tmp_path, monkeypatch):
    """A worker that stops using CPU while holding a tile (as one did, forked while the parent's
    Embree thread pool held a lock: it waited in rtcCommitScene for good) is killed after
    `_STALL_S` without CPU time, with a warning, and its tile rendered by a new worker: the image is
    what one process renders. Here the first tile sent hangs in a sleep (no CPU), once (a marker
    file), with the watch shortened to 1 s. Control: a worker that computes is never stopped
    (the same render without the hang gives no warning)."""
    import time

    from pmmw.errors import clear_warnings, collected_warnings

    res = resolve(REPO / "configs" / "cinderblocks_35ghz.yaml", ["imager.resolution=[24, 16]", "render.tile=8"])
    job = make_job(res, res.scenario.frequencies[0])
    monkeypatch.setattr(pool, "_STALL_S", 1.0)
    monkeypatch.setattr(pool, "_WATCH_S", 0.2)
    clear_warnings()
    pool.render_tiles(job, workers=2)  # the control, forked before this test renders in-process
    assert not [w for w in collected_warnings() if "hung" in w]
    one = pool.render_tiles(job, workers=1)
    marker = tmp_path / "hung-once"
    render = pool._render

    def hang_once(tile):
        if not marker.exists():
            marker.touch()
            time.sleep(3600)  # a hung worker: no CPU
        return render(tile)

    monkeypatch.setattr(pool, "_render", hang_once)  # the forked workers inherit it
    _forked(monkeypatch)  # this process rendered in-process just before
    two = pool.render_tiles(job, workers=2)
    assert marker.exists() and [w for w in collected_warnings() if "used no CPU for 1 s" in w]
    for a, b in zip(one, two):
        for name, _ in pool._PLANES:
            np.testing.assert_array_equal(getattr(b, name), getattr(a, name), err_msg=name)


def test_a_tile_that_hangs_twice_stops_the_render_naming_the_hang(monkeypatch):
    """A tile whose worker hangs on each try (here: always, in a sleep) stops the render with one
    line naming the tile and the hang, not the lack of memory a killed worker usually means."""
    import time

    from pmmw.errors import EnvironmentProblem

    res = resolve(REPO / "configs" / "cinderblocks_35ghz.yaml", ["imager.resolution=[16, 8]", "render.tile=8"])
    job = make_job(res, res.scenario.frequencies[0])
    monkeypatch.setattr(pool, "_STALL_S", 1.0)
    monkeypatch.setattr(pool, "_WATCH_S", 0.2)
    monkeypatch.setattr(pool, "_render", lambda tile: time.sleep(3600))
    _forked(monkeypatch)
    with pytest.raises(EnvironmentProblem, match=r"hung \(no CPU for 1 s; stopped\)") as ex:
        pool.render_tiles(job, workers=2)
    assert "memory" not in str(ex.value)


_AFTER_EMBREE = """
import contextlib, sys
import numpy as np
from pmmw.pipeline import make_job, resolve
from pmmw.trace import intersect, pool
if sys.argv[1:] == ["unguarded"]:  # the control: the spawned workers get the main script
    pool._spawning = contextlib.nullcontext
print("main script runs", flush=True)
if __name__ == "__mp_main__":  # a worker running this script (the control): no further
    sys.exit(0)
res = resolve(%r, ["imager.resolution=[24, 16]", "render.tile=8", "render.spp=1"])
job = make_job(res, res.scenario.frequencies[0])
a = pool.render_tiles(job, workers=2)
print("after a pooled render:", intersect.embree_used(), pool._context().get_start_method(), flush=True)
b = pool.render_tiles(job, workers=1)
print("after an in-process one:", intersect.embree_used(), pool._context().get_start_method(), flush=True)
c = pool.render_tiles(job, workers=2)
same = all(np.array_equal(getattr(x, n), getattr(y, n)) for r in (b, c) for x, y in zip(a, r) for n, _ in pool._PLANES)
print("the same image:", same)
other = make_job(resolve(%r, ["imager.resolution=[24, 16]", "render.tile=8", "render.spp=1", "render.seed=9"]), job.frequency)
d = pool.render_tiles(other, workers=2)  # the control of "the same": another seed's image differs
print("another seed's differs:", not all(np.array_equal(x.mean, y.mean) for x, y in zip(a, d)))
"""


def test_after_building_an_embree_scene_a_process_spawns_its_workers_without_its_main_script(tmp_path):
    """A process that has built an Embree scene (an in-process render, as the Python API and the
    tests do) spawns its render workers rather than forking them: a fork copies Embree's thread
    pool without its threads, and a worker once waited for good on a lock they held. The command
    line's own renders never build one in the parent, so they fork (the first render here). The
    spawned workers render the same image, and do not run the parent's main script: read from
    stdin (`python -`, which multiprocessing's spawn cannot re-run) here, printed once. Control: with
    the main script given to the workers (multiprocessing's default), a script file run so prints
    its line again in each worker."""
    script = _AFTER_EMBREE % ((str(REPO / "configs" / "cinderblocks_35ghz.yaml"),) * 2)
    out = subprocess.run([sys.executable, "-"], input=script, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stdout.splitlines()
    assert lines.count("main script runs") == 1, out.stdout
    assert "after a pooled render: False fork" in lines and "after an in-process one: True spawn" in lines
    assert "the same image: True" in lines and "another seed's differs: True" in lines, out.stdout
    path = tmp_path / "unguarded.py"
    path.write_text(script)
    control = subprocess.run(
        [sys.executable, str(path), "unguarded"], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )
    assert control.stdout.splitlines().count("main script runs") > 1, (control.stdout, control.stderr[-2000:])


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads /proc (Linux)")
def test_a_spawned_worker_ignores_ctrl_c_from_its_start():
    """A spawned worker starts a new interpreter, which does not keep the parent's blocked signals
    (`interrupt.deferred`): a Ctrl-C while it imports pmmw would end it with a traceback before
    `interrupt.as_worker` ignores SIGINT. Started within `_spawning` it ignores SIGINT from its
    fork on, through its exec (the kernel's SigIgn mask in /proc). Control: started without it, it
    does not (it has the parent's handler, then the default, then its interpreter's own)."""
    import multiprocessing as mp
    import time

    from pmmw import interrupt

    seen = []
    for quiet in (True, False):
        p = mp.get_context("spawn").Process(target=time.sleep, args=(5,), daemon=True)
        with interrupt.deferred(), pool._spawning() if quiet else contextlib.nullcontext():
            p.start()
        try:
            fields = dict(line.split(":", 1) for line in Path(f"/proc/{p.pid}/status").read_text().splitlines())
            seen.append(bool(int(fields["SigIgn"], 16) & (1 << (signal.SIGINT - 1))))
        finally:
            p.kill()
            p.join()
    assert seen == [True, False]
