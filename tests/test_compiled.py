"""numba's cache of the kernels follows every kernel file: a change to a callee's file alone recompiles its callers."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from adverbs import compiled

SCALARS = "from numba import njit\n\n\n@njit(cache=True)\ndef f():\n    return {}\n"
KERNEL = "from numba import njit\n\nfrom ._a_scalars import f\n\n\n@njit(cache=True)\ndef g():\n    return f() + 1\n"


def test_every_cached_kernel_is_in_a_kernel_file():
    named = set(compiled.kernel_files())
    for path in sorted(compiled.PACKAGE.rglob("*.py")):
        if "cache=True" in path.read_text(encoding="utf-8") and path != Path(compiled.__file__):
            assert path in named, f"{path.name}: cached numba functions live in files named {compiled.PATTERNS}"
    assert len(named) >= 9


def _call(root: Path, refresh: bool, cache: Path | None = None) -> int:
    """``g()`` of the package ``pkg`` under ``root``, in a new process (numba loads its cache there, or under
    ``cache`` as ``NUMBA_CACHE_DIR``, where the refresh's stamp goes too)."""
    code = "from pkg._b_kernel import g; print(g())"
    if refresh:
        stamp = "None" if cache else f"Path({str(root / 'stamp')!r})"
        pkg = str(root / "pkg")
        call = f"refresh(Path({pkg!r}), {stamp}); "
        code = "from pathlib import Path; from adverbs.compiled import refresh; " + call + code
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    if cache:
        env["NUMBA_CACHE_DIR"] = str(cache)
    out = subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True, text=True, check=True)
    return int(out.stdout.split()[-1])


def test_a_callee_changed_alone_is_compiled_afresh(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "_a_scalars.py").write_text(SCALARS.format(1))
    (pkg / "_b_kernel.py").write_text(KERNEL)
    assert _call(tmp_path, refresh=False) == 2
    assert compiled.cached(compiled.kernel_files(pkg))  # numba cached both
    time.sleep(0.01)
    (pkg / "_a_scalars.py").write_text(SCALARS.format(10))
    # numba alone: the caller's file did not change, so its cached code still has the old callee in it
    assert _call(tmp_path, refresh=False) == 2
    # refreshed: every kernel's cache is dropped once, and the caller sees the new callee
    assert _call(tmp_path, refresh=True) == 11
    assert compiled.refresh(pkg, tmp_path / "stamp") is False  # stamped: nothing more to do
    assert _call(tmp_path, refresh=True) == 11


def test_a_callee_changed_alone_is_compiled_afresh_where_numba_caches_elsewhere(tmp_path, monkeypatch):
    """Under ``NUMBA_CACHE_DIR`` numba keeps its cache in a folder of that directory named after the source's folder;
    nothing was refreshed there until session 61, and a changed callee ran old in its callers (a helper's worktree
    measured the warp's old arithmetic). The stamp and the deleted kernels are now there."""
    from numba.core.caching import _CacheLocator

    pkg, cache = tmp_path / "pkg", tmp_path / "cache"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "_a_scalars.py").write_text(SCALARS.format(1))
    (pkg / "_b_kernel.py").write_text(KERNEL)
    assert _call(tmp_path, refresh=False, cache=cache) == 2
    kernel = pkg / "_b_kernel.py"
    assert compiled.numba_folder(kernel, str(cache)) == cache / _CacheLocator.get_suitable_cache_subpath(str(kernel))
    assert compiled.cached(compiled.kernel_files(pkg), str(cache)) and not compiled.cached(compiled.kernel_files(pkg))
    time.sleep(0.01)
    (pkg / "_a_scalars.py").write_text(SCALARS.format(10))
    assert _call(tmp_path, refresh=False, cache=cache) == 2  # numba alone: the old callee
    assert _call(tmp_path, refresh=True, cache=cache) == 11
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(cache))
    assert compiled.refresh(pkg) is False  # stamped there: nothing more to do
    assert len(list(cache.glob("adverbs-kernels-*.sha256"))) == 2  # pkg's, and adverbs' own (refreshed on import)


def test_refresh_deletes_only_numba_s_files_and_only_on_a_change(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)  # (numba's cache beside the sources)
    pkg = tmp_path / "pkg"
    (pkg / "sub" / "__pycache__").mkdir(parents=True)
    (pkg / "sub" / "_x_kernel.py").write_text("x = 1\n")
    (pkg / "sub" / "other.py").write_text("y = 1\n")
    cache = pkg / "sub" / "__pycache__"
    keep = [cache / "_x_kernel.cpython-311.pyc", cache / "other.f-1.py311.nbi"]
    drop = [cache / "_x_kernel.f-3.py311.nbi", cache / "_x_kernel.f-3.py311.1.nbc"]
    for p in keep + drop:
        p.write_bytes(b"x")
    stamp = tmp_path / "stamp"
    assert compiled.refresh(pkg, stamp) is True
    assert all(p.exists() for p in keep) and not any(p.exists() for p in drop)
    for p in drop:
        p.write_bytes(b"x")
    assert compiled.refresh(pkg, stamp) is False and all(p.exists() for p in drop)
    (pkg / "sub" / "_x_kernel.py").write_text("x = 2\n")
    assert compiled.refresh(pkg, stamp) is True and not any(p.exists() for p in drop)


def test_batches_run_blas_on_one_thread_and_leave_the_process_setting():
    import scipy.linalg.cython_blas  # noqa: F401  numba's np.dot calls this BLAS
    from threadpoolctl import threadpool_info

    before = {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}
    assert before  # numpy's BLAS at least
    with compiled.one_blas_thread():
        inside = {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}
    assert inside.keys() == before.keys() and set(inside.values()) == {1}
    assert {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"} == before
