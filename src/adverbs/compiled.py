"""numba's on-disk cache of the compiled kernels, kept in step with every kernel source file.

numba caches each ``cache=True`` function next to its source (``__pycache__/*.nbi``, ``*.nbc``) and checks only
that one file's time stamp and size before loading it. Our kernels call one another across files (the planter
calls IK, forward kinematics and the scalar helpers; the graph's kernels call the planter's helpers), and numba
compiles a callee into its caller: after a change to a callee's file alone (a ``git pull``, an edit), the
caller's cached machine code would still run the old callee, silently.

:func:`refresh` (run when this module is imported, which ``adverbs`` does first, before any kernel module) hashes the kernel files together
and, when the hash differs from the one stamped beside the cache, deletes the cached kernels of every one of
them, so numba compiles them afresh once. It costs a fraction of a millisecond when nothing changed. Kernel
files are named ``_*kernel.py`` or ``_*scalars.py`` (``tests/test_compiled.py`` checks that every
``cache=True`` function lives in one). Nothing is done where numba keeps its cache elsewhere
(``NUMBA_CACHE_DIR``) or the package's folder cannot be written (numba then caches per user, and an install
writes every file anew).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
PATTERNS = ("_*kernel.py", "_*scalars.py")
STAMP = PACKAGE / "__pycache__" / "numba-kernels.sha256"


def kernel_files(package: Path = PACKAGE) -> list[Path]:
    """The kernel source files under ``package``, in a fixed order."""
    return sorted({p for pattern in PATTERNS for p in package.rglob(pattern) if "__pycache__" not in p.parts})


def sources_hash(files: list[Path]) -> str:
    """One hash of the files' names and contents."""
    h = hashlib.sha256()
    for f in files:
        h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def cached(files: list[Path]) -> list[Path]:
    """numba's cache files (index and data) of the functions in ``files``."""
    out = []
    for f in files:
        folder = f.parent / "__pycache__"
        if folder.is_dir():
            out += [p for p in folder.glob(f"{f.stem}.*") if p.suffix in (".nbi", ".nbc")]
    return out


def refresh(package: Path = PACKAGE, stamp: Path = STAMP) -> bool:
    """Delete every cached kernel if any kernel file changed since the cache was stamped; True if it did."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return False
    try:
        files = kernel_files(package)
        digest = sources_hash(files)
        if stamp.is_file() and stamp.read_text(encoding="ascii").strip() == digest:
            return False
        for p in cached(files):
            p.unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        tmp = stamp.with_name(f"{stamp.name}.{os.getpid()}")
        tmp.write_text(digest + "\n", encoding="ascii")
        os.replace(tmp, stamp)
        return True
    except OSError:  # a read-only install: numba caches elsewhere
        return False


refresh()
