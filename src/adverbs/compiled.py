"""The compiled machinery: numba's on-disk cache of the kernels, kept in step with every kernel source file, and
BLAS kept to one thread for the kernels' many small matrix products.

numba caches each ``cache=True`` function next to its source (``__pycache__/*.nbi``, ``*.nbc``) and checks only
that one file's time stamp and size before loading it. Our kernels call one another across files (the planter
calls IK, forward kinematics and the scalar helpers; the graph's kernels call the planter's helpers), and numba
compiles a callee into its caller: after a change to a callee's file alone (a ``git pull``, an edit), the
caller's cached machine code would still run the old callee, silently.

:func:`refresh` (run when this module is imported, which ``adverbs`` does first, before any kernel module) hashes the kernel files together
and, when the hash differs from the one stamped beside the cache, deletes the cached kernels of every one of
them, so numba compiles them afresh once. It costs about a millisecond when nothing changed. Kernel
files are named ``_*kernel.py`` or ``_*scalars.py``, in a layer's folder (``tests/test_compiled.py`` checks that every
``cache=True`` function lives in one). Where numba keeps its cache elsewhere (``NUMBA_CACHE_DIR``) the stamp and the
deleted kernels are there (until session 61 nothing was done then, and a change to a callee's file left its callers'
old machine code running). Nothing is done where the folder cannot be written (numba then caches per user, and an
install writes every file anew).

:func:`one_blas_thread` runs a block with OpenBLAS (numpy's and scipy's, which numba's ``np.dot`` calls) on
one thread. The sampling kernel groups a crowd's queries by B-spline segment into products of a few hundred rows
by ``4E`` columns by ``D``: far too small to share. On an idle 2-core machine OpenBLAS's threads neither help
nor hurt them; with anything else running (a game's other threads, the viewer, another process), its worker
threads spin waiting for a core and the products take 5 to 50 times longer (10,000 creatures of the Bandai reach
under load: median 96 ms a frame, up to 144 ms, against 10 ms on one thread; ``dofs`` of 10,000 points up to
660 ms against 14 ms). It costs about 30 µs, so it wraps batches only. The limit is lifted when the block ends;
the rest of the process keeps its own setting.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
PATTERNS = ("_*kernel.py", "_*scalars.py")
STAMP = PACKAGE / "__pycache__" / "numba-kernels.sha256"


def kernel_files(package: Path = PACKAGE) -> list[Path]:
    """The kernel source files in ``package`` and its subpackages (one level down, where the layers are), in a
    fixed order. Not a recursive walk: numba's cache folders hold hundreds of files."""
    found = (p for pattern in PATTERNS for where in ("", "*/") for p in package.glob(where + pattern))
    return sorted({p for p in found if "__pycache__" not in p.parts})


def sources_hash(files: list[Path]) -> str:
    """One hash of the files' names and contents."""
    h = hashlib.sha256()
    for f in files:
        h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def numba_folder(source: Path, where: str | None) -> Path:
    """Where numba caches the functions of ``source``: its ``__pycache__``, or under ``where`` (``NUMBA_CACHE_DIR``)
    a folder named after the source's folder and the SHA-1 of its path (numba's ``_CacheLocator``'s subpath)."""
    if not where:
        return source.parent / "__pycache__"
    folder = os.path.dirname(os.path.abspath(source))
    return Path(where) / f"{os.path.split(folder)[-1]}_{hashlib.sha1(folder.encode()).hexdigest()}"


def cached(files: list[Path], where: str | None = None) -> list[Path]:
    """numba's cache files (index and data) of the functions in ``files``, cached beside them or under ``where``."""
    out = []
    for f in files:
        folder = numba_folder(f, where)
        if folder.is_dir():
            out += [p for p in folder.glob(f"{f.stem}.*") if p.suffix in (".nbi", ".nbc")]
    return out


def refresh(package: Path = PACKAGE, stamp: Path | None = None) -> bool:
    """Delete every cached kernel if any kernel file changed since the cache was stamped; True if it did. Where
    numba caches under ``NUMBA_CACHE_DIR``, the stamp (one per package folder) and the cached kernels are there."""
    where = os.environ.get("NUMBA_CACHE_DIR") or None
    if stamp is None:
        name = hashlib.sha1(str(package.resolve()).encode()).hexdigest()
        stamp = Path(where) / f"adverbs-kernels-{name}.sha256" if where else STAMP
    try:
        files = kernel_files(package)
        digest = sources_hash(files)
        if stamp.is_file() and stamp.read_text(encoding="ascii").strip() == digest:
            return False
        for p in cached(files, where):
            p.unlink(missing_ok=True)
        stamp.parent.mkdir(parents=True, exist_ok=True)
        tmp = stamp.with_name(f"{stamp.name}.{os.getpid()}")
        tmp.write_text(digest + "\n", encoding="ascii")
        os.replace(tmp, stamp)
        return True
    except OSError:  # a read-only install: numba caches elsewhere
        return False


_BLAS = None  # threadpoolctl's controller, made on first use (after the BLAS libraries it controls are loaded)


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with every loaded BLAS on one thread (see the module docstring)."""
    global _BLAS
    if _BLAS is None:
        import scipy.linalg.cython_blas  # noqa: F401  the BLAS numba's np.dot calls: loaded, so it is controlled
        from threadpoolctl import ThreadpoolController

        _BLAS = ThreadpoolController()
    with _BLAS.limit(limits=1, user_api="blas"):
        yield


refresh()
