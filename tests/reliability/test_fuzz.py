"""Fuzzing the command line with hypothesis: scenario dictionaries and mesh bytes.

The contract under test, for any input a user can write:
- `pmmw validate` exits 0, or exits 2 with exactly one ``error:`` line (no traceback);
- a scenario that validates renders (shrunk to a few pixels), exits 0, and gives finite images
  within the temperatures the scene contains: Ex2 and Ey2 (each the brightness temperature of one
  polarization; I = Ex2 + Ey2) are power averages of the scene's sources, so they lie in
  [0, T_max] with T_max the hottest temperature anywhere in the scene, its materials, sky, ground
  and atmosphere;
- nothing hangs: every case runs under a wall-clock alarm.
"""

import contextlib
import os
import signal
import tempfile
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from pmmw.io.exr import read_exr
from pmmw_cli.cli import app

runner = CliRunner()
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")  # numpy's warnings must not leak to users
CASE_SECONDS = 60  # a case that runs longer is a hang


@contextlib.contextmanager
def alarm(seconds: int):
    def hang(signum, frame):
        raise AssertionError(f"the case ran for more than {seconds} s")

    old = signal.signal(signal.SIGALRM, hang)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _check_refusal_or_success(res):
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in res.output and "Warning:" not in res.output, res.output
    if res.exit_code != 0:
        assert res.exit_code == 2, res.output
        lines = [line for line in res.output.splitlines() if line.strip() and not line.startswith(("warning:", "  "))]
        assert len(lines) == 1 and lines[0].startswith("error:"), res.output


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    ground = trimesh.creation.box(extents=[20, 20, 1])
    ground.apply_translation([0, 0, -0.5])
    ground.export(d / "ground.obj")
    block = trimesh.creation.box(extents=[0.6, 0.3, 0.4])
    block.apply_translation([0, 4, 0.2])
    block.export(d / "block.stl")
    block.export(d / "block.glb")
    return d


BASE = {
    "name": "fuzz",
    "frequency": "35 GHz",
    "imager": {"position": [0, 0, 1.5], "look_at": [0, 4, 0.2], "fov": "20 deg", "resolution": [12, 8]},
    "scene": [{"mesh": "ground.obj", "material": "concrete"}, {"mesh": "block.glb", "material": "metal"}],
    "sky": {"model": "uniform", "temperature": "40 K"},
    "render": {"spp": 2, "max_depth": 4, "tile": 8, "workers": 1},
}

# the keys a user edits, with values that are valid, borderline or nonsense
PATHS = [
    ("frequency",),
    ("imager", "fov"),
    ("imager", "resolution"),
    ("imager", "position"),
    ("imager", "noise"),
    ("imager", "aperture_diameter"),
    ("imager", "bandwidth"),
    ("sky", "temperature"),
    ("sky", "model"),
    ("sky", "ground_temperature"),
    ("render", "spp"),
    ("render", "max_depth"),
    ("render", "seed"),
    ("render", "threshold"),
    ("render", "tile"),
    ("render", "default_temperature"),
    ("render", "target_error"),
    ("atmosphere",),
    ("materials",),
    ("name",),
    ("scene", 0, "material"),
    ("scene", 1, "transform"),
    ("output", "regions"),
    ("output", "channels"),
]
numbers = st.one_of(
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1, 1e-300, 1e300, 2**63, 2**64]),
)
unit_strings = st.builds(
    lambda x, u: f"{x} {u}",
    numbers,
    st.sampled_from(
        ["GHz", "MHz", "Hz", "K", "degC", "deg", "rad", "m", "mm", "km", "dB/km", "g/m3", "mm/h", "", "furlong"]
    ),
)
leaves = st.one_of(numbers, unit_strings, st.text(max_size=30), st.none(), st.booleans())
plausible = st.sampled_from(
    [
        "95 GHz",
        "35 GHz",
        "140 GHz",
        "300 K",
        "20 degC",
        "0 K",
        "2 K",
        45,
        "30 deg",
        [0, 0, 3],
        [1, -2, 1.5],
        [24, 16],
        [1, 1],
        1,
        4,
        64,
        0.5,
        "0.1 m",
        "1 mm",
        "none",
        "uniform",
        "slab",
        "atmosphere",
        {"profile": "standard"},
        {"model": "uniform", "loss": "1 dB/km", "temperature": "290 K"},
        {"scale": 2},
        {"rotate_deg": [0, 0, 90]},
        "concrete",
        "metal",
        "human_skin",
        ["I", "Ex2"],
        {"a": {"center": [0, 4, 0.2], "radius": 2}},
        {"a": {"box": [0, 0, 4, 4]}, "b": {"box": [4, 4, 8, 8]}},
    ]
)
values = st.recursive(
    leaves,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.dictionaries(
            st.sampled_from(
                [
                    "model",
                    "temperature",
                    "loss",
                    "profile",
                    "layers",
                    "kind",
                    "eps",
                    "center",
                    "radius",
                    "box",
                    "translate",
                    "scale",
                    "rotate_deg",
                    "x",
                    "base",
                    "top",
                    "liquid_water",
                    "rain_rate",
                ]
            ),
            inner,
            max_size=4,
        ),
    ),
    max_leaves=8,
)
materials = st.dictionaries(
    st.sampled_from(["metal", "concrete", "hot", "odd"]),
    st.fixed_dictionaries(
        {},
        optional={
            "kind": st.sampled_from(["dielectric", "metal", "blackbody", "opaque", "thin", "plasma"]),
            "eps": st.one_of(st.just([4, 0.2]), st.lists(numbers, min_size=2, max_size=2), numbers, unit_strings),
            "temperature": st.one_of(st.just("310 K"), st.just("5000 K"), numbers, unit_strings),
            "thickness": st.one_of(numbers, unit_strings),
        },
    ),
    max_size=2,
)


def _set(d, path, value):
    for p in path[:-1]:
        d = d[p] if isinstance(d, list) or p in d else d.setdefault(p, {})
    d[path[-1]] = value


def _temperatures(obj):
    """Every temperature-like number in a resolved scenario or media listing [K]."""
    out = []
    if isinstance(obj, dict):
        for k, v in obj.items():
            if "temperature" in k and isinstance(v, (int, float)):
                out.append(float(v))
            elif "temperature" in k and isinstance(v, str) and v.endswith(" K"):
                out.append(float(v.split()[0]))
            else:
                out += _temperatures(v)
    elif isinstance(obj, list):
        for v in obj:
            out += _temperatures(v)
    return out


# `make test-full` (PMMW_TEST_FULL=1) hunts twice as long in the two widest searches
_FULL = os.environ.get("PMMW_TEST_FULL") == "1"


@settings(
    max_examples=100 if _FULL else 50,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    edits=st.lists(st.tuples(st.sampled_from(PATHS), st.one_of(plausible, plausible, values)), max_size=3),
    mats=st.one_of(st.just({}), materials),
)
def test_any_scenario_is_refused_in_one_line_or_renders_within_its_temperatures(meshes, edits, mats):
    raw = yaml.safe_load(yaml.safe_dump(BASE))
    for path, value in edits:
        _set(raw, path, value)
    if mats:
        raw["materials"] = mats
    scn = Path(meshes) / "fuzz.yaml"
    scn.write_text(yaml.safe_dump(raw))
    shrink = [
        "--set",
        "imager.resolution=[12, 8]",
        "--set",
        "render.spp=2",
        "--set",
        "render.max_depth=4",
        "--set",
        "imager.noise=0",
        "--set",
        "imager.aperture_diameter=0",
        "--set",
        "imager.bandwidth=0",
        "--set",
        "render.workers=1",
    ]
    with alarm(CASE_SECONDS):
        res = runner.invoke(app, ["validate", str(scn), *shrink])
        _check_refusal_or_success(res)
        event("refused" if res.exit_code else "rendered")
        if res.exit_code != 0:
            return
        listing = yaml.safe_load(res.output)
        # a folder of its own: a fuzzed `name` is another scenario, whose report a render must not replace
        out = Path(tempfile.mkdtemp(dir=meshes, prefix="out-"))
        res = runner.invoke(app, ["render", str(scn), "--out", str(out), "-q", *shrink])
    assert res.exit_code == 0, res.output
    (exr,) = out.glob("*.exr")
    chans, _ = read_exr(exr)
    t_max = max(_temperatures(listing) + [40.0, 290.0, 330.0])  # + the profiles' warmest air
    for c in ("ideal.Ex2", "ideal.Ey2"):
        img = chans[c].astype(float)
        assert np.isfinite(img).all()
        assert img.min() >= -1e-3 and img.max() <= t_max * (1 + 1e-5) + 1e-3, (c, img.min(), img.max(), t_max)


@pytest.fixture(scope="module")
def mesh_samples():
    box = trimesh.creation.box(extents=[0.6, 0.3, 0.4])
    box.apply_translation([0, 4, 0.2])
    out = {fmt: box.export(file_type=fmt) for fmt in ("stl", "obj", "ply", "glb")}
    return {fmt: data.encode() if isinstance(data, str) else data for fmt, data in out.items()}


@settings(
    max_examples=150 if _FULL else 75,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    fmt=st.sampled_from(["stl", "obj", "ply", "glb"]),
    cut=st.floats(0, 1),
    flips=st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.integers(0, 255)), max_size=6),
    junk=st.binary(max_size=64),
)
def test_any_mesh_bytes_are_loaded_or_refused_in_one_line(meshes, mesh_samples, fmt, cut, flips, junk):
    data = bytearray(mesh_samples[fmt])
    data = data[: int(len(data) * 2 * cut)] if cut < 0.5 else data
    for where, byte in flips:
        if data:
            data[int(where * len(data))] = byte
    data += junk
    mesh = Path(meshes) / f"m.{fmt}"
    mesh.write_bytes(bytes(data))
    raw = yaml.safe_load(yaml.safe_dump(BASE))
    raw["scene"][1]["mesh"] = mesh.name
    scn = Path(meshes) / "mesh.yaml"
    scn.write_text(yaml.safe_dump(raw))
    with alarm(CASE_SECONDS):
        res = runner.invoke(app, ["validate", str(scn)])
    _check_refusal_or_success(res)
    event("refused" if res.exit_code else "loaded")
    if res.exit_code != 0:
        assert "scene[1].mesh" in res.output, res.output


# -- output folders as a careless or hostile user leaves them ---------------------------------------

OBSTACLES = ("none", "folder", "user file", "link to a file outside", "link to a folder outside")
OUTPUT_NAMES = (
    "fuzz.exr",
    "report.json",
    "report.md",
    "previews/fuzz_I.png",
    "previews",
    ".pmmw-tiles",
    ".pmmw-tiles/fuzz-0123456789abcdef",
)
LOCKS = ("none", "live here", "dead here", "another host, fresh", "another host, silent", "garbage", "a folder")


def _lock(path: Path, kind: str) -> None:
    import json
    import os
    import socket
    import time

    from pmmw.io.lock import REMOTE_STALE_S, process_start

    here, parent = socket.gethostname(), os.getppid()  # the test runner's parent: a live process
    rec = {"kind": "pmmw lock", "mode": "write", "command": "pmmw render x.yaml", "since": "then", "token": "00" * 8}
    if kind == "live here":
        rec.update(host=here, pid=parent, start=process_start(parent))
    elif kind == "dead here":
        rec.update(host=here, pid=parent, start=-1)  # the id of a process started at another time
    elif kind.startswith("another host"):
        rec.update(host="node-17", pid=1, start=None)
    if kind == "a folder":
        path.mkdir()
        return
    path.write_text("{{{ not json" if kind == "garbage" else json.dumps(rec))
    if kind == "another host, silent" or kind == "garbage":
        t = time.time() - 2 * REMOTE_STALE_S
        os.utime(path, (t, t))


@settings(
    max_examples=25,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    obstacles=st.dictionaries(st.sampled_from(OUTPUT_NAMES), st.sampled_from(OBSTACLES), max_size=3),
    lock=st.sampled_from(LOCKS),
    long_out=st.sampled_from([0, 0, 0, 300, 5000]),
    keep=st.booleans(),
)
def test_any_output_folder_is_rendered_into_or_refused_and_nothing_else_is_touched(
    meshes, tmp_path_factory, obstacles, lock, long_out, keep
):
    """Whatever a user (or another user of a shared folder) left in the output folder: the render
    exits 0 with a consistent EXR and report, or 1/2 with one line; files and folders outside it,
    and files in it that pmmw did not make, keep every byte; nothing hangs."""
    import json
    import shutil

    from pmmw.io.lock import LOCK_NAME

    root = tmp_path_factory.mktemp("outfuzz")
    outside = root / "outside"
    (outside / "fuzz-0123456789abcdef").mkdir(parents=True)
    (outside / "fuzz-0123456789abcdef" / "tile_000000.npz").write_bytes(b"the user's")
    (outside / "notes.txt").write_text("the user's")
    out = (
        root / ("o" * long_out if long_out <= 255 else "/".join(["o" * 250] * (long_out // 250))) / "out"
        if long_out
        else root / "out"
    )
    users = {}
    try:
        out.mkdir(parents=True, exist_ok=True)
        made = True
    except OSError:
        made = False  # too long to make: the render must say so in one line
    if made:
        for name, kind in sorted(obstacles.items()):
            p = out / name
            if kind == "none" or p.exists() or p.is_symlink() or not p.parent.is_dir():
                continue
            if kind == "folder":
                p.mkdir()
                (p / "inside.txt").write_text("the user's")
            elif kind == "user file":
                p.write_text("the user's")
                users[p] = b"the user's"
            elif kind == "link to a file outside":
                p.symlink_to(outside / "notes.txt")
            else:
                p.symlink_to(outside)
        if lock != "none":
            _lock(out / LOCK_NAME, lock)
        for p in list(out.rglob("*")):
            if p.is_file() and not p.is_symlink() and p.name != LOCK_NAME:
                users.setdefault(p, p.read_bytes())
    before = {p: p.read_bytes() for p in outside.rglob("*") if p.is_file()}
    scn = Path(meshes) / "fuzz.yaml"
    scn.write_text(yaml.safe_dump(BASE))
    with alarm(CASE_SECONDS):
        res = runner.invoke(app, ["render", str(scn), "--out", str(out), "-q", *(["--keep-tiles"] if keep else [])])
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in res.output, res.output
    event("rendered" if res.exit_code == 0 else f"refused ({res.exit_code})")
    if res.exit_code != 0:
        assert res.exit_code in (1, 2), res.output
        lines = [ln for ln in res.output.splitlines() if ln.strip() and not ln.startswith(("warning:", "  "))]
        assert len(lines) == 1 and lines[0].startswith("error:"), res.output
    else:
        assert lock in ("none", "dead here", "another host, silent", "garbage"), (lock, res.output)
        report = json.loads((out / "report.json").read_text())
        _, attrs = read_exr(out / "fuzz.exr")
        assert attrs["pmmw:spp"] == report["spp"] and not (out / LOCK_NAME).exists()
    assert {p: p.read_bytes() for p in outside.rglob("*") if p.is_file()} == before
    for p, data in users.items():
        assert p.read_bytes() == data, p
    shutil.rmtree(root, ignore_errors=True)


# -- sizes declared in headers, and cluster addresses ------------------------------------------------

SIDES = st.sampled_from([1, 2, 64, 1000, 32768, 32769, 100000, 2**31 - 1])


@settings(
    max_examples=20,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(width=SIDES, height=SIDES, command=st.sampled_from(["validate", "view"]))
def test_any_image_size_a_header_declares_is_refused_in_one_line_or_read(meshes, monkeypatch, width, height, command):
    """An EXR whose header declares any size (a few hundred bytes on disk: no pixel data), as a sky
    texture or in `pmmw view`: refused in one line (the size limit, or the memory a 200 MB machine
    has) or read, never allocated blindly; an 837 kB header-declared 20000 x 10000 image took 21.5
    GB."""
    import OpenImageIO as oiio

    from pmmw import memory, pipeline

    path = Path(meshes) / "sky.exr"
    path.unlink(missing_ok=True)
    spec = oiio.ImageSpec(width, height, 2, oiio.FLOAT)
    spec.channelnames = ("Th", "Tv")
    spec.tile_width = spec.tile_height = 64
    out = oiio.ImageOutput.create("exr")
    if not out.open(str(path), spec):  # OpenImageIO itself refuses to write some sizes
        event("not writable")
        return
    out.close()
    for module in (memory, pipeline):
        monkeypatch.setattr(module, "available_memory", lambda: 200e6)
    raw = yaml.safe_load(yaml.safe_dump(BASE))
    raw["sky"] = {"model": "texture", "file": "sky.exr"}
    scn = Path(meshes) / "sized.yaml"
    scn.write_text(yaml.safe_dump(raw))
    args = (
        ["validate", str(scn)]
        if command == "validate"
        else ["view", str(path), "-c", "Tv", "--out", str(Path(meshes) / "v.png")]
    )
    with alarm(CASE_SECONDS):
        res = runner.invoke(app, args)
    _check_refusal_or_success(res)
    event("read" if res.exit_code == 0 else "refused")
    if width * height * 4 > 200e6:  # more than the machine has for it: refused whatever reads it
        assert res.exit_code == 2, res.output


def _closed_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.full  # test_reliability_dask's wrong addresses (a fixed list of every kind) check the same
@settings(
    max_examples=25,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    address=st.one_of(
        st.text(max_size=40),
        st.builds(
            lambda scheme, host, port: f"{scheme}{host}:{port}",
            st.sampled_from(["tcp://", "", "http://", "tls://", "ws://", "inproc://", "ucx://", "tcp:/"]),
            st.sampled_from(["127.0.0.1", "localhost", "256.1.1.1", "no-such-host.invalid", "[::1]", "", "::"]),
            st.one_of(st.sampled_from(["0", "1", "65535", "70000", "-1", "abc", ""]), st.just("CLOSED")),
        ),
    )
)
def test_any_scheduler_address_is_refused_in_one_line_within_a_deadline(meshes, address):
    """Whatever is given as `--scheduler`, with nothing listening there: one `error:` line naming
    the address, exit 2, well within the connection deadlines (an HTTP server's address hung a
    render for over 200 s; garbage replies were a 181-line MemoryError traceback:
    `tests/reliability/test_reliability_dask.py` runs those services)."""
    import time

    address = address.replace("CLOSED", str(_closed_port()))
    scn = Path(meshes) / "fuzz.yaml"
    scn.write_text(yaml.safe_dump(BASE))
    t0 = time.perf_counter()
    with alarm(CASE_SECONDS):
        res = runner.invoke(app, ["render", str(scn), "--out", str(Path(meshes) / "addr"), "--scheduler", address])
    _check_refusal_or_success(res)
    assert time.perf_counter() - t0 < 40.0, address  # the probe's 10 s deadline, twice, and start-up
    if address.strip():
        assert res.exit_code == 2, (address, res.output)
