"""Shared output folders: pmmw removes and overwrites only what it made, one writer at a time,
outputs committed together. Each test reproduces an attack or accident a probe found on an
earlier version (a folder outside the output deleted through a link, another scenario's tiles
or EXR replaced, two writers in one folder, an EXR beside an older report) and checks what
replaced it."""

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pmmw.io import lock as lockmod
from pmmw.io.exr import read_exr
from pmmw.io.rundir import Staging
from pmmw_cli.cli import app
from tests.scenes import ground_and_block

runner = CliRunner()


def _run(*args):
    return runner.invoke(app, [str(a) for a in args])


def _scene(
    tmp_path: Path,
    name: str = "tiny",
    frequency: str = "35 GHz",
    spp: int = 2,
    file: str = "tiny.yaml",
    resolution: str = "[24, 16]",
) -> Path:
    ground_and_block(tmp_path)
    path = tmp_path / file
    path.write_text(f"""
name: {name}
frequency: {frequency}
imager: {{position: [0, 0, 1.5], look_at: [0, 4, 0.1], fov: 20 deg, resolution: {resolution}}}
scene:
  - {{mesh: ground.obj, material: concrete}}
  - {{mesh: block.obj, material: metal}}
sky: {{model: uniform, temperature: 40 K}}
render: {{spp: {spp}, max_depth: 4, tile: 8, workers: 1}}
""")
    return path


def _one_error_line(res, *words):
    lines = [
        ln
        for ln in res.output.splitlines()
        if ln.strip() and not ln.startswith("warning:") and not re.match(r"^\S+: tiles \d+/\d+ ", ln)
    ]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.output
    assert "Traceback" not in res.output
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def _tree(root: Path) -> dict:
    """Every file under ``root`` (links not followed) with its bytes: what must stay untouched."""
    return {p.relative_to(root): p.read_bytes() for p in root.rglob("*") if p.is_file() and not p.is_symlink()}


def _victim(root: Path, name: str = "tiny-0123456789abcdef") -> Path:
    """A user's folder that happens to have a tile folder's shape of name, with files in it."""
    v = root / name
    v.mkdir(parents=True)
    (v / "thesis.tex").write_text("years of work")
    (v / "tile_000000.npz").write_bytes(b"not a tile: the user's own file")
    (v / "manifest.json").write_text('{"hash": "0123456789abcdef"}')
    return v


# -- 1. nothing removed or overwritten that pmmw did not make ---------------------------------------


def test_a_tile_root_linked_out_of_the_output_folder_never_leads_to_deletion(tmp_path):
    """The probe: `ln -s $PWD/V O/.pmmw-tiles` and a render of `tiny` deleted
    V/tiny-0123456789abcdef/ and its files. Now nothing is deleted through the link: not the
    look-alike folder (it has no pmmw manifest), not even the render's own tiles (left, and said)."""
    scn = _scene(tmp_path)
    victim_root = tmp_path / "V"
    _victim(victim_root)
    before = _tree(victim_root)
    out = tmp_path / "O"
    out.mkdir()
    (out / ".pmmw-tiles").symlink_to(victim_root)
    res = _run("render", scn, "--out", out)
    assert res.exit_code == 0, res.output
    assert "Traceback" not in res.output and "never deletes through a link" in res.output
    after = _tree(victim_root)
    assert {k: v for k, v in after.items() if k in before} == before  # every file of the user's as it was
    assert (out / ".pmmw-tiles").is_symlink() and (out / "tiny.exr").is_file()
    # a second render (other settings: the first one's tiles are stale) still deletes nothing there
    res = _run("render", scn, "--out", out, "--spp", "3")
    assert res.exit_code == 0, res.output
    assert {k: v for k, v in _tree(victim_root).items() if k in before} == before
    assert len(list(victim_root.glob("tiny-*"))) == 3  # the victim's and the two renders' kept tiles


def test_a_tile_root_linked_to_an_empty_folder_renders_without_a_traceback(tmp_path):
    """`.pmmw-tiles` linked to an empty folder: a traceback after a successful render (the link
    was passed to rmdir)."""
    scn = _scene(tmp_path)
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    out = tmp_path / "O"
    out.mkdir()
    (out / ".pmmw-tiles").symlink_to(scratch)
    res = _run("render", scn, "--out", out)
    assert res.exit_code == 0 and "Traceback" not in res.output, res.output
    assert (out / ".pmmw-tiles").is_symlink() and scratch.is_dir()


def test_a_look_alike_folder_inside_the_output_is_neither_deleted_nor_written_into(tmp_path):
    """A folder named like this scenario's stale tiles but without pmmw's manifest (the probe's
    `tiny-0123456789abcdef`) was deleted as stale; one named like its current tiles was written
    into."""
    scn = _scene(tmp_path)
    out = tmp_path / "O"
    look_alike = _victim(out / ".pmmw-tiles")
    before = _tree(look_alike)
    res = _run("render", scn, "--out", out, "--keep-tiles")
    assert res.exit_code == 0, res.output
    assert _tree(look_alike) == before
    current = [d for d in (out / ".pmmw-tiles").iterdir() if d != look_alike]
    assert len(current) == 1
    # the render's own folder replaced by a look-alike of it: refused before tracing, untouched
    shutil.rmtree(current[0])
    _victim(out / ".pmmw-tiles", current[0].name)
    before = _tree(current[0])
    res = _run("render", scn, "--out", out)
    _one_error_line(res, current[0].name, "not a tile folder of this render")
    assert _tree(current[0]) == before


def test_a_tile_folder_that_is_a_link_is_refused_and_its_target_kept(tmp_path):
    scn = _scene(tmp_path)
    out = tmp_path / "O"
    assert _run("render", scn, "--out", out, "--keep-tiles").exit_code == 0
    (folder,) = (out / ".pmmw-tiles").iterdir()
    shutil.rmtree(folder)
    victim = _victim(tmp_path / "V", folder.name)
    before = _tree(victim)
    folder.symlink_to(victim)
    for args in ((), ("--resume",)):
        res = _run("render", scn, "--out", out, *args)
        _one_error_line(res, "symbolic link")
        assert _tree(victim) == before


def test_a_user_file_named_like_the_tile_root_is_refused_and_kept(tmp_path):
    """A file ``.pmmw-tiles`` in the output folder (found by the fuzzer: a NotADirectoryError
    traceback) is one error line naming it, exit 2, and keeps its bytes; the control: without it
    the same render succeeds."""
    scn = _scene(tmp_path)
    out = tmp_path / "O"
    out.mkdir()
    (out / ".pmmw-tiles").write_text("a user's notes")
    res = _run("render", scn, "--out", out)
    assert res.exit_code == 2
    _one_error_line(res, ".pmmw-tiles", "is a file")
    assert (out / ".pmmw-tiles").read_text() == "a user's notes"
    (out / ".pmmw-tiles").unlink()
    assert _run("render", scn, "--out", out).exit_code == 0


def test_stale_tiles_are_deleted_file_by_file_and_a_user_file_keeps_its_folder(tmp_path):
    """Stale tile folders used to go with `shutil.rmtree`, whatever they held."""
    scn = _scene(tmp_path)
    out = tmp_path / "O"
    assert _run("render", scn, "--out", out, "--keep-tiles").exit_code == 0
    (stale,) = (out / ".pmmw-tiles").iterdir()
    (stale / "notes.txt").write_text("mine")
    from pmmw.errors import clear_warnings, collected_warnings

    clear_warnings()
    res = _run("render", scn, "--out", out, "--spp", "3")  # another hash: the first folder is stale
    assert res.exit_code == 0, res.output
    assert (stale / "notes.txt").read_text() == "mine"
    # the warning (a `PmmwWarning`: `pmmw` prints it as a line, the test process records it)
    assert not list(stale.glob("tile_*.npz")) and any("kept 1 tile folder" in w for w in collected_warnings())


def test_crafted_names_cannot_reach_another_scenarios_files(tmp_path):
    """`a@35GHz` was taken for a sub-band folder of `a` (its tiles deleted); a single-frequency
    `m_35GHz` and a two-frequency `m` wrote the same EXR. Such names are refused now, and a file
    named so gets a name of its own."""
    scn_a = _scene(tmp_path, name="a")
    out = tmp_path / "O"
    assert _run("render", scn_a, "--out", out, "--keep-tiles").exit_code == 0
    tiles_a = _tree(out / ".pmmw-tiles")
    for crafted in ("a@35GHz", "m_35GHz", "m_94.5GHz", "x_1e+02GHz"):
        res = _run("render", _scene(tmp_path, name=crafted, file="crafted.yaml"), "--out", out)
        _one_error_line(res, "name", "may not hold")
    assert _tree(out / ".pmmw-tiles") == tiles_a
    # control: the names pmmw's own shipped scenarios use stay valid
    assert _run("validate", _scene(tmp_path, name="landing_95ghz", file="ok.yaml")).exit_code == 0
    # a scenario without a name takes its file's stem, made safe
    path = _scene(tmp_path, file="radar_35GHz.yaml")
    path.write_text(path.read_text().replace("name: tiny\n", ""))
    res = _run("render", path, "--out", tmp_path / "R")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "R" / "radar-35GHz.exr").is_file()


def test_two_frequencies_that_would_write_the_same_files_are_refused(tmp_path):
    scn = _scene(tmp_path, frequency="[35 GHz, 35.0000001 GHz]")
    _one_error_line(_run("validate", scn), "6 digits")
    assert _run("validate", _scene(tmp_path, frequency="[35 GHz, 35.001 GHz]")).exit_code == 0  # control


def test_sub_band_tile_folders_are_distinct_however_narrow_the_band(tmp_path):
    """Sub-band folders were named by the frequency to 6 digits: a 1 kHz band's four sub-bands
    shared one folder, and a resume mixed their tiles."""
    from pmmw.config import load_scenario
    from pmmw.pipeline import tile_folders

    path = _scene(tmp_path)
    scn = load_scenario(path, ["imager.bandwidth=1 kHz", "imager.band_samples=4"])
    folders = [folder for _, _, folder in tile_folders(scn, 35e9, "0123456789abcdef")]
    assert len(set(folders)) == 4, folders


def test_a_file_pmmw_did_not_write_is_never_overwritten(tmp_path):
    """`--out .` in a folder with one's own report.md replaced it."""
    scn = _scene(tmp_path)
    out = tmp_path / "O"
    out.mkdir()
    (out / "report.md").write_text("# my notes\n")
    _one_error_line(_run("render", scn, "--out", out), "report.md", "not written by pmmw")
    assert (out / "report.md").read_text() == "# my notes\n"
    assert not (out / ".pmmw-tiles").exists() and not (out / "tiny.exr").exists()  # refused before tracing
    # control: pmmw's own outputs are replaced by the next render
    (out / "report.md").unlink()
    assert _run("render", scn, "--out", out).exit_code == 0
    assert _run("render", scn, "--out", out, "--spp", "3").exit_code == 0
    assert json.loads((out / "report.json").read_text())["spp"] == 3


def test_another_scenarios_report_is_not_replaced(tmp_path):
    out = tmp_path / "O"
    assert _run("render", _scene(tmp_path, name="a"), "--out", out).exit_code == 0
    before = (out / "report.json").read_bytes()
    _one_error_line(_run("render", _scene(tmp_path, name="b", file="b.yaml"), "--out", out), "report of scenario 'a'")
    assert (out / "report.json").read_bytes() == before


# -- 2. one writer per output folder ------------------------------------------------------------


@pytest.fixture
def live_process():
    p = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    yield p
    p.kill()
    p.wait()


def _lock_file(folder: Path, pid: int, host=None, start="own", age_s: float = 0.0, name=lockmod.LOCK_NAME):
    import socket

    rec = {
        "kind": "pmmw lock",
        "mode": "write",
        "host": host or socket.gethostname(),
        "pid": pid,
        "start": lockmod.process_start(pid) if start == "own" else start,
        "command": "pmmw render other.yaml",
        "since": "earlier",
        "token": "0123456789abcdef",
    }
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(json.dumps(rec))
    if age_s:
        t = time.time() - age_s
        os.utime(path, (t, t))
    return path


def test_a_folder_held_by_a_live_run_is_refused_at_once_naming_the_holder(tmp_path, live_process):
    scn = _scene(tmp_path)
    out = tmp_path / "O"
    held = _lock_file(out, live_process.pid)
    t0 = time.perf_counter()
    line = _one_error_line(_run("render", scn, "--out", out), f"pid {live_process.pid}", "pmmw render other.yaml")
    assert time.perf_counter() - t0 < 30.0  # at once: no tracing (a guard against waiting, not a speed test)
    assert "in use" in line and held.is_file() and not (out / "tiny.exr").exists()
    sweep = _run("sweep", scn, "--grid", "imager.noise=[1 K]", "--out", out)
    _one_error_line(sweep, f"pid {live_process.pid}")
    assert not (out / "sweep.csv").exists()


def test_a_lock_of_a_dead_run_is_taken_over(tmp_path):
    scn = _scene(tmp_path)
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    for out, kwargs in (
        (tmp_path / "dead_pid", {}),
        (tmp_path / "reused_pid", {"pid": os.getpid(), "start": 1}),
        (tmp_path / "silent_host", {"host": "node-17", "age_s": 2 * lockmod.REMOTE_STALE_S}),
    ):
        _lock_file(out, **{"pid": p.pid, **kwargs})
        res = _run("render", scn, "--out", out)
        assert res.exit_code == 0, (out.name, res.output)
        assert not (out / lockmod.LOCK_NAME).exists()  # released at the end
    # control: a lock of another host refreshed recently is a live run there
    out = tmp_path / "busy_host"
    _lock_file(out, pid=1, host="node-17", age_s=5.0)
    _one_error_line(_run("render", scn, "--out", out), "node-17")


def test_two_renders_into_one_folder_one_is_refused_and_the_other_finishes(tmp_path):
    """Two renders into one folder were never refused (and two sweeps both reported success,
    the first one's results silently replaced)."""
    scn = _scene(tmp_path, spp=64, resolution="[96, 64]")
    out = tmp_path / "O"
    first = subprocess.Popen(
        [str(Path(sys.executable).parent / "pmmw"), "render", str(scn), "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    deadline = time.time() + 120
    while not (out / lockmod.LOCK_NAME).exists() and first.poll() is None and time.time() < deadline:
        time.sleep(0.05)
    assert first.poll() is None, "the first render ended before the second could try"
    second = _run("render", scn, "--out", out, "--spp", "2")
    line = _one_error_line(second, f"pid {first.pid}")
    assert first.poll() is None, f"the first render finished during the check ({line}): make it longer"
    output, _ = first.communicate(timeout=300)
    assert first.returncode == 0, output
    assert json.loads((out / "report.json").read_text())["spp"] == 64


def test_shards_share_a_folder_and_a_writer_waits_for_them(tmp_path, live_process):
    scn = _scene(tmp_path)
    out = tmp_path / "O"
    shard = _lock_file(out, live_process.pid, name=f"{lockmod.SHARD_PREFIX}h-{live_process.pid}-0123456789abcdef")
    rec = json.loads(shard.read_text())
    shard.write_text(json.dumps({**rec, "mode": "shard"}))
    # another shard joins the live one; a render that writes the image is refused while it lives
    assert _run("render", scn, "--out", out, "--shard", "1/2").exit_code == 0
    _one_error_line(_run("render", scn, "--out", out, "--resume"), "a shard of a render")
    live_process.kill()
    live_process.wait()
    res = _run("render", scn, "--out", out, "--resume")  # the dead shard's hold is cleared
    assert res.exit_code == 0, res.output
    assert not shard.exists() and (out / "tiny.exr").is_file()
    # and a shard is refused while a writer holds the folder
    p = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        _lock_file(out, p.pid)
        _one_error_line(_run("render", scn, "--out", out, "--shard", "2/2"), f"pid {p.pid}")
    finally:
        p.kill()
        p.wait()


def test_a_run_that_lost_its_lock_commits_nothing(tmp_path):
    """A run stopped longer than the staleness limit on a shared folder may find its lock taken
    over: it must not commit over the new holder's outputs."""
    out = tmp_path / "O"
    out.mkdir()
    lock = lockmod.FolderLock(out).acquire()
    try:
        lock.check()  # control: held
        (out / lockmod.LOCK_NAME).unlink()
        _lock_file(out, 1, host="node-17")  # another run took it over
        with Staging(out) as st:
            st.path("a.txt").write_text("new")
            with pytest.raises(lockmod.EnvironmentProblem, match="took over the lock"):
                st.commit(["a.txt"], check=lock.check)
        assert not (out / "a.txt").exists()
    finally:
        lock.release()
    assert (out / lockmod.LOCK_NAME).is_file()  # the other run's lock is not removed on release


# -- 4. outputs written together or not at all --------------------------------------------------


def test_an_output_path_that_is_a_folder_is_refused_before_tracing(tmp_path):
    """`tiny.exr/` as a folder: the new EXR failed after tracing, and with `report.json` as a
    folder the new EXR landed beside the old report."""
    scn = _scene(tmp_path)
    out = tmp_path / "O"
    assert _run("render", scn, "--out", out).exit_code == 0
    before = _tree(out)
    for name in ("tiny.exr", "report.json", "previews/tiny_I.png"):
        (out / name).unlink()
        (out / name).mkdir()
        t0 = time.perf_counter()
        _one_error_line(_run("render", scn, "--out", out, "--spp", "4"), name, "is a folder")
        assert time.perf_counter() - t0 < 30.0
        assert not (out / ".pmmw-tiles").exists()
        (out / name).rmdir()
        (out / name).write_bytes(before[Path(name)])
    assert _tree(out) == before


def test_previews_on_another_file_system_are_committed_with_the_rest(tmp_path):
    """`previews/` linked to another file system: the rename of a preview failed with EXDEV
    after the EXR was moved, leaving an spp-4 EXR beside an spp-2 report."""
    other = Path("/dev/shm")
    if not other.is_dir() or os.stat(other).st_dev == os.stat(tmp_path).st_dev:
        pytest.skip("no second file system to put previews/ on")
    scn = _scene(tmp_path)
    out = tmp_path / "O"
    elsewhere = Path(os.path.join(other, f"pmmw-test-previews-{os.getpid()}"))
    elsewhere.mkdir()
    try:
        out.mkdir()
        (out / "previews").symlink_to(elsewhere)
        for spp in (2, 4):
            res = _run("render", scn, "--out", out, "--spp", spp)
            assert res.exit_code == 0, res.output
            assert json.loads((out / "report.json").read_text())["spp"] == spp
            assert read_exr(out / "tiny.exr")[1]["pmmw:spp"] == spp
        assert (elsewhere / "tiny_I.png").is_file()
        assert not [p for p in elsewhere.iterdir() if p.name.startswith(".pmmw-staging")]
    finally:
        shutil.rmtree(elsewhere)


def test_a_commit_that_fails_half_way_puts_back_what_it_replaced(tmp_path, monkeypatch):
    out = tmp_path / "O"
    out.mkdir()
    for name in ("a.exr", "b.png", "report.json"):
        (out / name).write_text(f"old {name}")
    real_replace = os.replace

    def failing(src, dst):
        if str(dst).endswith("report.json"):
            raise OSError(28, "No space left on device", str(dst))
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", failing)
    with Staging(out) as st:
        for name in ("a.exr", "b.png", "report.json", "c.md"):
            st.path(name).write_text(f"new {name}")
        with pytest.raises(lockmod.EnvironmentProblem, match="no space left"):
            st.commit(["a.exr", "b.png", "c.md"], last=["report.json"])
    monkeypatch.setattr(os, "replace", real_replace)
    assert {p.name: p.read_text() for p in out.iterdir()} == {n: f"old {n}" for n in ("a.exr", "b.png", "report.json")}
