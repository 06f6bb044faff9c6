"""Atomic writes, EXR round trip, display scaling, PNG previews and the run report."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from pmmw.errors import UserError
from pmmw.io import atomic, exr
from pmmw.io.atomic import atomic_path, save_npz_atomic, write_bytes_atomic, write_text_atomic
from pmmw.io.exr import read_exr, write_exr
from pmmw.io.preview import display_range, display_scale, write_png, write_preview
from pmmw.io.report import write_report

CHANNELS = ("I", "Q", "U", "V", "Ex2", "Ey2", "ideal.I", "aux.depth")


def _leftovers(directory):
    """Temporary files left beside the destinations."""
    return [p.name for p in directory.rglob(".*tmp-*")]


def _channels(shape=(5, 7), seed=1):
    rng = np.random.default_rng(seed)
    return {n: (rng.normal(250.0, 40.0, shape) * (1 + i)).astype(np.float32) for i, n in enumerate(CHANNELS)}


# ---------------------------------------------------------------- atomic writes


def test_atomic_text_bytes_npz(tmp_path):
    p = write_text_atomic(tmp_path / "a" / "b" / "note.txt", "héllo\n")
    assert p.read_text(encoding="utf-8") == "héllo\n"
    write_bytes_atomic(tmp_path / "blob.bin", b"\x00\x01")
    assert (tmp_path / "blob.bin").read_bytes() == b"\x00\x01"
    save_npz_atomic(tmp_path / "tiles" / "tile_000001.npz", mean=np.arange(4.0), index=3)
    with np.load(tmp_path / "tiles" / "tile_000001.npz") as z:
        assert np.array_equal(z["mean"], np.arange(4.0)) and int(z["index"]) == 3
    assert _leftovers(tmp_path) == []


def test_atomic_path_is_hidden_beside_target_with_suffix(tmp_path):
    target = tmp_path / "img.exr"
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".exr" and tmp.name.startswith(".img.tmp-")
        assert not tmp.exists()
        tmp.write_bytes(b"new")
    assert target.read_bytes() == b"new"


def test_atomic_path_failure_keeps_old_content(tmp_path):
    target = tmp_path / "keep.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError, match="midway"):
        with atomic_path(target) as tmp:
            tmp.write_text("half of the new")
            raise RuntimeError("midway")
    assert target.read_text() == "old"
    assert _leftovers(tmp_path) == []


def test_atomic_path_failure_leaves_no_file(tmp_path):
    target = tmp_path / "new.txt"
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(target) as tmp:
            tmp.write_text("partial")
            raise KeyboardInterrupt
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------- EXR


def test_exr_round_trip_channels_order_values_attrs(tmp_path):
    chans = _channels()
    chans["aux.depth"][0, 0] = np.nan
    chans["aux.depth"][0, 1] = np.inf
    attrs = {
        "pmmw:frequency_hz": 94.0e9 + 0.125,  # not representable in float32: must survive exactly
        "pmmw:units": "K",
        "pmmw:spp": 64,
        "pmmw:fov_deg": 20.5,
        "pmmw:imager_position_m": [0.0, -12.5, 1.75],
        "pmmw:materials": ["air", "skin"],
        "pmmw:big": 2**40,
    }
    path = tmp_path / "out" / "scene.exr"
    write_exr(path, chans, attrs)
    got, hdr = read_exr(path)

    assert list(got) == list(CHANNELS)  # written order, although OpenEXR sorts channels by name
    for n in CHANNELS:
        assert got[n].dtype == np.float32 and got[n].shape == (5, 7)
        assert np.array_equal(got[n], chans[n], equal_nan=True)  # bit-exact float32
    assert hdr["pmmw:frequency_hz"] == 94.0e9 + 0.125
    assert hdr["pmmw:units"] == "K"
    assert hdr["pmmw:spp"] == 64
    assert hdr["pmmw:fov_deg"] == 20.5
    assert [float(v) for v in hdr["pmmw:imager_position_m"].split()] == [0.0, -12.5, 1.75]
    assert tuple(hdr["pmmw:materials"]) == ("air", "skin")
    assert hdr["pmmw:big"] == 2**40
    assert hdr["compression"] == "zip"
    assert _leftovers(tmp_path) == []


def test_exr_is_float32_on_disk(tmp_path):
    path = tmp_path / "a.exr"
    write_exr(path, {"I": np.ones((2, 3), np.float64)})
    inp = oiio.ImageInput.open(str(path))
    try:
        assert inp.spec().format == oiio.TypeDesc("float")
        assert inp.spec().channelformats in ((), (oiio.TypeDesc("float"),))
    finally:
        inp.close()


def test_exr_rejects_mismatched_channels(tmp_path):
    with pytest.raises(ValueError, match="one shape"):
        write_exr(tmp_path / "a.exr", {"I": np.zeros((2, 3)), "Q": np.zeros((3, 2))})
    with pytest.raises(ValueError):
        write_exr(tmp_path / "a.exr", {})
    assert not (tmp_path / "a.exr").exists()


def test_exr_write_failure_keeps_old_file(tmp_path, monkeypatch):
    path = tmp_path / "scene.exr"
    write_exr(path, {"I": np.full((4, 4), 1.0)})
    before = path.read_bytes()

    real_create = oiio.ImageOutput.create

    class FailingOutput:
        """Writes a partial file through a real writer, then fails like a full disk."""

        def __init__(self, fmt):
            self._out = real_create(fmt)

        def open(self, name, spec):
            self._name = name
            return self._out.open(name, spec)

        def write_image(self, pixels):
            self._out.close()
            with open(self._name, "r+b") as f:
                f.truncate(100)
            return False

        def close(self):
            return True

        def geterror(self):
            return "simulated: No space left on device"

    monkeypatch.setattr(exr.oiio.ImageOutput, "create", staticmethod(lambda fmt: FailingOutput(fmt)))
    with pytest.raises(RuntimeError, match="No space left"):
        write_exr(path, {"I": np.full((4, 4), 2.0)})
    monkeypatch.undo()

    assert path.read_bytes() == before
    got, _ = read_exr(path)
    assert np.all(got["I"] == 1.0)
    assert _leftovers(tmp_path) == []


def test_exr_failure_before_rename_leaves_nothing(tmp_path, monkeypatch):
    def boom(self_or_name, *a, **k):
        raise OSError("disk vanished")

    monkeypatch.setattr(atomic, "_fsync_path", boom)
    with pytest.raises(OSError, match="vanished"):
        write_exr(tmp_path / "new.exr", {"I": np.zeros((2, 2))})
    assert list(tmp_path.iterdir()) == []


def test_read_exr_missing_or_garbage_is_user_error(tmp_path):
    with pytest.raises(UserError) as e:
        read_exr(tmp_path / "nope.exr")
    assert e.value.file == str(tmp_path / "nope.exr")
    bad = tmp_path / "bad.exr"
    bad.write_bytes(b"not an image at all")
    with pytest.raises(UserError) as e:
        read_exr(bad, key="sky.file")
    assert e.value.file == str(bad) and e.value.key == "sky.file"


def test_read_exr_without_order_attribute_uses_file_order(tmp_path):
    path = tmp_path / "plain.exr"
    spec = oiio.ImageSpec(3, 2, 2, oiio.FLOAT)
    spec.channelnames = ("Tv", "Th")
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec)
    assert out.write_image(np.stack([np.full((2, 3), 1.0), np.full((2, 3), 2.0)], -1).astype(np.float32))
    out.close()
    got, _ = read_exr(path)
    assert sorted(got) == ["Th", "Tv"]
    assert np.all(got["Tv"] == 1.0) and np.all(got["Th"] == 2.0)


# ---------------------------------------------------------------- display scaling

CLIP = 1.0 / 256.0  # Murakowski 2014 sec. 3.2 footnote


def test_display_scale_clips_exactly_1_in_256_each_end():
    n = 256 * 256
    k = n // 256  # pixels that must clip at each end
    ramp = np.random.default_rng(3).permutation(np.arange(n, dtype=np.float64)).reshape(256, 256)
    low, high = display_range(ramp)
    assert (low, high) == (float(k), float(n - 1 - k))
    assert np.count_nonzero(ramp < low) == k and np.count_nonzero(ramp > high) == k
    u8 = display_scale(ramp)
    assert u8.dtype == np.uint8 and u8.shape == (256, 256)
    assert np.all(u8[ramp < low] == 0) and np.all(u8[ramp > high] == 255)
    # between the clip points: linear, monotone, the full grey range in equal bins
    inside = (ramp >= low) & (ramp <= high)
    order = np.argsort(ramp[inside])
    assert np.all(np.diff(u8[inside][order].astype(int)) >= 0)
    counts = np.bincount(u8[inside], minlength=256)
    assert counts[1:255].min() >= (high - low) // 256 and counts[1:255].max() <= (high - low) // 256 + 1
    assert u8[ramp == low][0] == 0 and u8[ramp == high][0] == 255


def test_display_scale_other_fraction_and_small_images():
    img = np.arange(100.0).reshape(10, 10)
    assert display_range(img, clip_fraction=0.1) == (10.0, 89.0)
    tiny = np.array([[1.0, 2.0], [3.0, 4.0]])  # fewer than 256 pixels: nothing clips
    assert display_range(tiny) == (1.0, 4.0)
    assert display_scale(tiny).tolist() == [[0, 85], [170, 255]]


def test_display_scale_constant_image_is_mid_grey():
    u8 = display_scale(np.full((8, 9), 287.5))
    assert np.all(u8 == 128)


def test_display_scale_nan_safe():
    rng = np.random.default_rng(4)
    img = rng.uniform(100.0, 300.0, (64, 64))
    with_nan = img.copy()
    with_nan[::3, ::5] = np.nan
    finite = with_nan[np.isfinite(with_nan)]
    # NaN pixels do not move the range: same range as the finite pixels alone
    assert display_range(with_nan) == display_range(finite)
    u8 = display_scale(with_nan)
    assert np.all(u8[np.isnan(with_nan)] == 0)
    assert np.array_equal(u8[~np.isnan(with_nan)], display_scale(finite))
    assert np.all(display_scale(np.full((3, 3), np.nan)) == 0)
    low, high = display_range(np.full((3, 3), np.nan))
    assert math.isnan(low) and math.isnan(high)


def test_preview_png_written_and_readable(tmp_path):
    img = np.linspace(50.0, 300.0, 40 * 30).reshape(30, 40)
    low, high = write_preview(tmp_path / "previews" / "I.png", img)
    assert (low, high) == display_range(img)
    inp = oiio.ImageInput.open(str(tmp_path / "previews" / "I.png"))
    try:
        spec = inp.spec()
        assert (spec.width, spec.height, spec.nchannels) == (40, 30, 1)
        got = inp.read_image(oiio.UINT8).reshape(30, 40)
    finally:
        inp.close()
    assert np.array_equal(got, display_scale(img))
    assert _leftovers(tmp_path) == []


def test_write_png_takes_grey_and_rgb_and_names_pmmw(tmp_path):
    """Grey (H, W) and colour (H, W, 3) arrays, pixels as given; RGBA or 1-D refused. The PNG's
    Software text names pmmw, so a later render may replace it (`made_by_pmmw`); the same pixels
    written by OpenImageIO without it are the user's (the control)."""
    from pmmw.io.rundir import made_by_pmmw

    rgb = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    write_png(tmp_path / "c.png", rgb)
    inp = oiio.ImageInput.open(str(tmp_path / "c.png"))
    assert np.array_equal(inp.read_image(oiio.UINT8), rgb)
    inp.close()
    assert made_by_pmmw(tmp_path / "c.png")
    out = oiio.ImageOutput.create("png")
    out.open(str(tmp_path / "user.png"), oiio.ImageSpec(3, 2, 3, oiio.UINT8))
    out.write_image(rgb)
    out.close()
    assert not made_by_pmmw(tmp_path / "user.png")
    for bad in (np.zeros((2, 2, 4), np.uint8), np.zeros(4, np.uint8)):
        with pytest.raises(ValueError):
            write_png(tmp_path / "x.png", bad)


# ---------------------------------------------------------------- report


def test_report_json_and_markdown(tmp_path):
    report = {
        "name": "runway_demo",
        "version": "0.1.0",
        "frequency_hz": np.float64(94e9),
        "output_exr": str(tmp_path / "runway_demo.exr"),
        "channels": {
            "I": {"min": 80.0, "mean": 200.0, "max": 300.0, "display_low": 90.0, "display_high": 290.0},
            "Q": {"min": -5.0, "mean": float("nan"), "max": 5.0},
        },
        "timing": {"resolve_s": 0.12, "trace_s": 3.5, "total_s": 4.0},
        "rays": 1234567,
        "warnings": ["slab sky: extrapolating"],
        "scenario": {"name": "runway_demo", "frequencies": [94e9], "imager": {"fov": 0.35}},
        "extra": tmp_path,
    }
    json_path, md_path = write_report(tmp_path, report, {"I": "previews/I.png"})
    assert (json_path, md_path) == (tmp_path / "report.json", tmp_path / "report.md")

    data = json.loads(json_path.read_text())  # strict JSON: NaN became null
    assert data["channels"]["I"]["display_high"] == 290.0 and data["channels"]["Q"]["mean"] is None
    assert data["timing"]["trace_s"] == 3.5 and data["rays"] == 1234567
    assert data["extra"] == str(tmp_path)

    md = md_path.read_text()
    assert md.startswith("# runway_demo\n")
    assert "| I | 80.00 | 200.00 | 300.00 | 90.00 .. 290.00 |" in md
    assert "| Q |" in md
    assert "![I](previews/I.png)" in md
    assert "trace_s" in md and "3.500" in md
    assert "1,234,567" in md
    assert "slab sky: extrapolating" in md
    assert "```yaml\nname: runway_demo\n" in md
    assert _leftovers(tmp_path) == []


def test_report_minimal_and_basename(tmp_path):
    json_path, md_path = write_report(tmp_path / "run", {"name": "bare"}, {}, basename="report_35GHz")
    assert json_path.name == "report_35GHz.json" and md_path.name == "report_35GHz.md"
    assert json.loads(json_path.read_text()) == {"name": "bare"}
    assert md_path.read_text().startswith("# bare")


def test_synced_together_flushes_each_file_once_at_the_end(tmp_path, monkeypatch):
    """Inside `synced_together` an atomic write leaves out its fsyncs; at the block's end each
    file is fsync'ed once and each folder once. The control: the same write outside the block
    fsyncs its file and folder at once; a block left by an exception fsyncs nothing."""
    calls = []
    monkeypatch.setattr(atomic, "_fsync_path", lambda p, directory=False: calls.append((Path(p), directory)))
    with atomic.synced_together():
        atomic.write_text_atomic(tmp_path / "a.txt", "a")
        with atomic.synced_together():  # inside another: the outer block's
            atomic.write_text_atomic(tmp_path / "sub" / "b.txt", "b")
        atomic.write_text_atomic(tmp_path / "c.txt", "c")
        assert calls == []
    files = sorted(str(p) for p, d in calls if not d)
    assert files == sorted(str(tmp_path / n) for n in ("a.txt", "sub/b.txt", "c.txt"))
    assert sorted(str(p) for p, d in calls if d) == sorted([str(tmp_path), str(tmp_path / "sub")])
    assert (tmp_path / "sub" / "b.txt").read_text() == "b"
    calls.clear()
    atomic.write_text_atomic(tmp_path / "d.txt", "d")
    assert len(calls) == 2 and calls[1] == (tmp_path, True)
    calls.clear()
    with pytest.raises(RuntimeError), atomic.synced_together():
        atomic.write_text_atomic(tmp_path / "e.txt", "e")
        raise RuntimeError("stop")
    assert calls == []
