"""Writing files safely: whole or not at all, and errors that name the file."""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import AdverbsError


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to (with the same extension, for writers that go by it), renamed
    over ``path`` when the block ends without error and removed otherwise: a failed write (disk full, a size limit)
    leaves what was at ``path`` untouched. An ``OSError`` on the way (no space, a size limit, no permission) becomes an
    :class:`AdverbsError` naming ``path``; other errors go through as they came."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.part{path.suffix}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        yield tmp
        os.replace(tmp, path)
    except OSError as e:
        raise AdverbsError(f"{path}: cannot write: {e.strerror or e}") from None
    finally:
        tmp.unlink(missing_ok=True)


def write_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` whole or not at all (see :func:`atomic_path`); a failure is an
    :class:`AdverbsError` naming ``path``."""
    with atomic_path(path) as tmp, open(tmp, "xb") as f:  # the usual permissions, as a plain write would give
        f.write(data)
    return Path(path)
