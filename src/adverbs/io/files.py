"""Writing files safely: whole or not at all, and errors that name the file."""

from __future__ import annotations

import os
import secrets
from pathlib import Path

from ..errors import AdverbsError


def write_atomic(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder, renamed over ``path`` once complete:
    a failed write (disk full, a size limit) leaves what was at ``path`` untouched, and says which file failed."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.part")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "xb") as f:  # the usual permissions, as a plain write would give
            f.write(data)
        os.replace(tmp, path)
    except OSError as e:
        raise AdverbsError(f"{path}: cannot write: {e.strerror or e}") from None
    finally:
        tmp.unlink(missing_ok=True)
    return path
