"""The kernel cache is dropped when any kernel source changes (numba keys a function on its own file only)."""

from bayestissue.mechanics._jit import drop_stale_cache


def test_cache_dropped_when_a_callee_changes(tmp_path):
    (tmp_path / "laws").mkdir()
    (tmp_path / "solver.py").write_text("# caller\n")
    law = tmp_path / "laws" / "law.py"
    law.write_text("# callee\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    cached = [cache / "solver.solve-1.py312.nbi", cache / "solver.solve-1.py312.0.nbc"]
    assert drop_stale_cache(tmp_path)  # no stamp yet: dropped
    for f in cached:
        f.write_bytes(b"x")
    assert not drop_stale_cache(tmp_path)  # unchanged sources: kept
    assert all(f.exists() for f in cached)
    law.write_text("# callee, edited\n")
    assert drop_stale_cache(tmp_path)
    assert not any(f.exists() for f in cached)
    assert not drop_stale_cache(tmp_path)
