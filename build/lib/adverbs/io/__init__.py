"""Files in and out: BVH (reader and writer, portable or as read) and glTF 2.0 binary (``.glb``), into and from clips."""

from __future__ import annotations

from pathlib import Path

from ..errors import AdverbsError
from ..motion.clip import Clip
from .bvh import format_bvh, parse_bvh, read_bvh, write_bvh
from .gltf import format_glb, read_glb, write_glb
from .portable import Portable, portable

FORMATS = {".bvh": "BVH", ".glb": "glTF 2.0 binary"}


def motion_format(path: str | Path) -> str:
    """``".bvh"`` or ``".glb"``: the kind of motion file ``path`` names by its extension; any other is refused."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise AdverbsError(f"{path}: unknown motion file type {path.suffix or '(none)'!r}; use {' or '.join(FORMATS)}")
    return suffix


def read_motion(path: str | Path) -> Clip:
    """A clip from a ``.bvh`` or ``.glb`` file (by its extension)."""
    path = Path(path)
    return read_bvh(path) if motion_format(path) == ".bvh" else read_glb(path)


def write_motion(clip: Clip, path: str | Path, portable: bool = False) -> Path:
    """Write ``clip`` to ``path`` as its extension says: ``.bvh`` (``portable``: position channels on the root only,
    see :mod:`adverbs.io.portable`) or ``.glb``. Whole or not at all."""
    path = Path(path)
    if motion_format(path) == ".bvh":
        write_bvh(clip, path, portable=portable)
    else:
        write_glb(clip, path)
    return path


__all__ = [
    "FORMATS", "Portable", "format_bvh", "motion_format", "format_glb", "parse_bvh", "portable", "read_bvh", "read_glb", "read_motion",
    "write_bvh", "write_glb", "write_motion",
]  # fmt: skip
