"""The guard against stale numba caches (`pmmw.jit.clear_stale_caches`): a cached kernel
keeps the machine code of the compiled functions it calls in other files, so an edit to any
source with compiled code must drop every cached file (tests/trace/test_compiled_tracer.py relies on
it when physics code changes under a warm cache)."""

from __future__ import annotations

from pmmw import jit


def test_stale_caches_are_dropped_when_any_compiled_source_changes(tmp_path, monkeypatch):
    (tmp_path / "physics").mkdir()
    (tmp_path / "trace").mkdir()
    src_a, src_b = tmp_path / "physics" / "fresnel.py", tmp_path / "trace" / "kernels.py"
    src_a.write_text("x = 1\n")
    src_b.write_text("y = 2\n")
    cache = tmp_path / "trace" / "__pycache__"
    cache.mkdir()
    monkeypatch.setattr(jit, "ROOT", tmp_path)
    monkeypatch.setattr(jit, "SOURCES", ("physics/fresnel.py", "trace/kernels.py"))
    monkeypatch.setattr(jit, "_STAMP", tmp_path / "__pycache__" / "numba-sources.sha256")

    def cached():
        for name in ("kernels.scatter-301.py311.nbi", "kernels.scatter-301.py311.1.nbc"):
            (cache / name).write_bytes(b"machine code")
        (cache / "kernels.cpython-311.pyc").write_bytes(b"bytecode")  # not numba's: kept

    cached()
    assert jit.clear_stale_caches() is True  # no stamp yet: whatever is there is of unknown sources
    assert sorted(p.name for p in cache.iterdir()) == ["kernels.cpython-311.pyc"]
    cached()
    assert jit.clear_stale_caches() is False  # unchanged sources: caches kept
    assert len(list(cache.glob("*.nb[ic]"))) == 2
    src_a.write_text("x = 3\n")  # a callee's file: the caller's cache in trace/ is stale
    assert jit.clear_stale_caches() is True
    assert not list(cache.glob("*.nb[ic]"))
    assert jit.clear_stale_caches() is False


def test_every_module_with_compiled_code_is_watched():
    """A module that compiles with `pmmw.jit` (or numba directly) but is missing from
    `SOURCES` would leave its callers' caches stale after an edit: the list must be complete."""
    import re

    found = sorted(
        str(p.relative_to(jit.ROOT))
        for p in jit.ROOT.rglob("*.py")
        if p.name != "jit.py" and re.search(r"from pmmw\.jit import|numba\.njit", p.read_text())
    )
    assert found == sorted(jit.SOURCES)


def test_is_cached_tells_one_function_of_a_file(tmp_path, monkeypatch):
    # a smooth scene's first render caches `scatter` but not the rough surfaces' `settle`: a rough
    # scene after it still compiles (`pool.prepare_kernels` says so). Control: `settle` cached.
    cache = tmp_path / "surface" / "__pycache__"
    cache.mkdir(parents=True)
    monkeypatch.setattr(jit, "ROOT", tmp_path)
    (cache / "kernels.scatter-358.py311.nbi").write_bytes(b"index")
    (cache / "kernels.settle_x-9.py311.nbi").write_bytes(b"index")  # another function's name starts the same
    assert jit.is_cached("surface/kernels.py")
    assert not jit.is_cached("surface/kernels.py", "settle")
    (cache / "kernels.settle-736.py311.nbi").write_bytes(b"index")
    assert jit.is_cached("surface/kernels.py", "settle")
