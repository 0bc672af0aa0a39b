"""Built verbs on disk: one zip file holding ``verb.json`` (metadata) and ``.npy`` arrays; no pickles.

Versioned: a file of another version is refused with a message saying to rebuild it from its spec.
Written next to its destination and renamed into place (:func:`adverbs.io.files.atomic_path`), so a
crash or a full disk never leaves half a verb and never touches the file that was there.

Reading trusts nothing in the file. Every fault — damaged bytes, a field of the wrong type or out of
range, arrays whose shapes disagree, a name the code does not know, sizes past :mod:`adverbs.limits` —
raises :class:`VerbFileError` (or :class:`~adverbs.limits.LimitError`) naming the file and the member or
field at fault, before any work it would cost: declared sizes in the zip directory and the ``.npy``
headers are checked before anything is decompressed or allocated, and the JSON's nesting depth before
it is parsed.
"""

from __future__ import annotations

import io
import json
import math
import re
import stat
import struct
import sys
import zipfile
import zlib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import AdverbsError
from ..interp import bspline, timewarp
from ..io.bvh import name_problem
from ..io.files import atomic_path
from ..kinematics.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton
from ..limits import LIMITS, LimitError, check_joints
from ..motion.encoding import KINDS, ROOT_COLUMNS, DofEncoding, _axes
from .constraints import Constraint, Hold, check_constraint
from .measures import check_measure
from .sampling import LONGEST_CYCLE
from .synthesis import MAX_FPS
from .tables import TIMINGS, Adverb, ExampleRecord, Verb

FORMAT = "adverbs-verb"  # 2 added keytime names, constraints, floor; 3 generic keytimes, smoothing; 4 holds; 5 goal;
# 6 timing; 7 the time warp's rate continuous (curves fitted under the paper's warp play differently)
VERSION = 7

# The arrays of a verb file: member name (without ".npy") → (element kind, number of axes).
ARRAYS = {
    "points": ("f", 2),
    "keytimes": ("f", 2),
    "generic_keytimes": ("f", 1),
    "hold_table": ("f", 3),
    "coefficients": ("f", 3),
    "parents": ("i", 1),
    "offsets": ("f", 2),
    "end_site_parents": ("i", 1),
    "end_site_offsets": ("f", 2),
    "lateral": ("f", 1),
    "reference": ("f", 2),
    "base_translations": ("f", 2),
    "translated": ("i", 1),
}
MEMBERS = ("verb.json",) + tuple(f"{k}.npy" for k in ARRAYS)
MAX_JSON_DEPTH = 16  # verb.json nests 4 deep (an adverb's measure, a joint's channels); deeper is not a verb's
MAX_DIRECTORY = 1 << 20  # bytes of zip directory: a verb file lists 14 members in about 1 KB
UNIT_TOLERANCE = 1e-6  # how far a stored unit vector or unit quaternion's length may be from 1
TIME_TOLERANCE = 1e-9  # generic time: how far a hold's times may be out of order by rounding
READ_COPIES = 8  # the verb holds its arrays several times over (read, frozen, by control point, ...)
JSON_SHARE = 256  # verb.json may take 1/256 of the memory limit: parsed, JSON takes up to some 20 times its text

_EPOCH = (1980, 1, 1, 0, 0, 0)  # the date of every member: zip's earliest, so equal verbs are equal bytes
_FIELDS = {
    "format", "version", "name", "cyclic", "fps", "num_cp", "keytime_names", "constraints", "holds", "floor",
    "smoothing", "shrinkage", "goal_chain", "timing", "adverbs", "examples", "encoding", "skeleton",
}  # fmt: skip
_ZIP_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, NotImplementedError, RuntimeError, struct.error)  # fmt: skip


class VerbFileError(AdverbsError):
    """A verb file that cannot be read; ``path``, ``member`` (of the zip archive) and ``field`` (of its
    ``verb.json``, e.g. ``"examples[2].fit_error"``) say where, ``reason`` what is wrong."""

    def __init__(self, path: str | Path, reason: str, member: str | None = None, field: str | None = None):
        self.path, self.member, self.field, self.reason = str(path), member, field, reason
        where = str(path)
        if member is not None:
            where += f": member {member!r}"
        if field is not None:
            where += f": field {field!r}"
        super().__init__(f"{where}: {reason}")


def save_verb(verb: Verb, path: str | Path) -> None:
    """Write the verb as one zip file: ``verb.json`` (metadata) and ``.npy`` arrays; no pickles.

    The file is written beside its destination and renamed into place, so a crash never leaves half
    a verb and a failed write (disk full, a size limit) leaves the file that was there untouched; the
    failure is an :class:`~adverbs.errors.AdverbsError` naming the file.
    """
    path = Path(path)
    text, arrays = _contents(verb, path)
    try:
        with atomic_path(path) as tmp, open(tmp, "xb") as f:
            _write_archive(f, text, arrays)
    except OSError as e:
        raise AdverbsError(f"{path}: cannot write: {e.strerror or e}") from None


def _contents(verb: Verb, path: Path | str) -> tuple[str, dict[str, np.ndarray]]:
    """``verb.json``'s text and the arrays of a verb file; a number that is not finite is refused naming ``path``."""
    enc, skel = verb.encoding, verb.skeleton
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "name": verb.name,
        "cyclic": verb.cyclic,
        "fps": verb.fps,
        "num_cp": verb.num_cp,
        "keytime_names": list(verb.keytime_names),
        "constraints": [c.to_dict() for c in verb.constraints],
        "holds": [h.to_dict() for h in verb.holds],
        "floor": verb.floor,
        "smoothing": verb.smoothing,
        "shrinkage": verb.shrinkage,
        "goal_chain": list(verb.goal_chain),
        "timing": verb.timing,
        "adverbs": [{"name": a.name, "unit": a.unit, "measure": a.measure} for a in verb.adverbs],
        "examples": [
            {
                "name": x.name,
                "source": x.source,
                "part": x.part,
                "fit_error": x.fit_error,
                "refine": x.refine,
                "fine_error": x.fine_error,
            }
            for x in verb.examples
        ],
        "encoding": {
            "kind": enc.kind,
            "body_root": enc.body_root,
            "names": list(enc.names),
            "heading_smoothing": enc.smoothing,
        },
        "skeleton": {
            "names": list(skel.names),
            "channels": [list(c) for c in skel.channels],
            "unit_scale": skel.unit_scale,
            "units": skel.units,
        },
    }
    arrays = {
        "points": verb.points,
        "keytimes": verb.keytimes_table,
        "generic_keytimes": verb.generic_keytimes,
        "hold_table": verb.hold_table,
        "coefficients": verb.coefficients,
        "parents": skel.parents,
        "offsets": skel.offsets,
        "end_site_parents": skel.end_site_parents,
        "end_site_offsets": skel.end_site_offsets,
        "lateral": enc.lateral,
        "reference": enc.reference,
        "base_translations": enc.base_translations,
        "translated": enc.translated,
    }
    try:
        text = json.dumps(meta, indent=1, allow_nan=False)
    except ValueError:  # NaN or infinity: the reader refuses them, so refuse to write them
        raise AdverbsError(
            f"{path}: cannot write verb {verb.name!r}: its metadata holds a number that is not finite"
        ) from None
    return text, arrays


def _write_archive(f, text: str, arrays: dict[str, np.ndarray]) -> None:
    """The zip archive of a verb file into the open binary file ``f``: the same bytes for the same verb (every member
    dated 1980-01-01, so a verb built twice, or shipped to another machine, is one file)."""
    with zipfile.ZipFile(f, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr(zipfile.ZipInfo("verb.json", _EPOCH), text, zipfile.ZIP_DEFLATED)
        for key, value in arrays.items():
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.ascontiguousarray(value), allow_pickle=False)
            z.writestr(zipfile.ZipInfo(f"{key}.npy", _EPOCH), buf.getvalue(), zipfile.ZIP_DEFLATED)


def verb_bytes(verb: Verb) -> bytes:
    """The bytes :func:`save_verb` writes, in memory: a built verb as data, to ship (to a worker) or to hash."""
    buf = io.BytesIO()
    _write_archive(buf, *_contents(verb, f"<verb {verb.name!r}>"))
    return buf.getvalue()


def verb_from_bytes(data: bytes, name: str | Path = "<verb bytes>") -> Verb:
    """A verb from the bytes of a verb file (:func:`verb_bytes`), checked as :func:`load_verb` checks a file; ``name``
    stands for the file in messages."""
    path = Path(name)
    if len(data) > _budget():
        raise _too_big(f"{path}: the file", len(data))
    archive = _Archive(path, bytes(data))
    with archive.zip:
        return _read_archive(path, archive)


def load_verb(path: str | Path) -> Verb:
    """Read a verb written by :func:`save_verb`.

    Every fault in the file — another version, damaged bytes, a missing or malformed field, values out
    of range, sizes past :mod:`adverbs.limits` — raises :class:`VerbFileError` (or
    :class:`~adverbs.limits.LimitError`), naming the file and the member or field; so does a file that
    cannot be read.
    """
    path = Path(path)
    archive = _Archive(path, _read_file(path))
    with archive.zip:
        return _read_archive(path, archive)


def _read_archive(path: Path, archive: _Archive) -> Verb:
    """verb.json first (its version decides whether the rest is ours to read), then the arrays, then the verb."""
    meta = _parse_json(path, archive.read("verb.json", LIMITS.memory // JSON_SHARE))
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise VerbFileError(path, "not an adverbs verb file")
    if meta.get("version") != VERSION:
        raise VerbFileError(
            path,
            f"verb file version {_show(meta.get('version'))}; this adverbs reads version {VERSION}. "
            "Rebuild it from its spec with `adverbs build`.",
        )
    archive.check_members()
    budget = _budget()
    arrays = {}
    for key, (kind, ndim) in ARRAYS.items():
        arrays[key] = _parse_npy(path, f"{key}.npy", archive.read(f"{key}.npy", budget), kind, ndim, budget)
        budget -= arrays[key].nbytes
    return _Reader(path, arrays).verb(meta)


# ----- bytes, zip members, JSON, npy -------------------------------------------------------------


def _budget() -> int:
    """Bytes of arrays (and of file) one verb file may hold: the loaded verb keeps several copies of them."""
    return LIMITS.memory // READ_COPIES


def _too_big(what: str, size: int, limit: int | None = None) -> LimitError:
    """``what``, ``size`` bytes, refused: more than ``limit`` (default: all a verb file may hold)."""
    limit = _budget() if limit is None else limit
    return LimitError(
        f"{what} is {size:,} bytes; at most {limit:,} are allowed under the memory limit of {LIMITS.memory:,} bytes "
        "(ADVERBS_MAX_MEMORY raises it: see adverbs.limits)"
    )


def _read_file(path: Path) -> bytes:
    try:
        st = path.stat()
        if stat.S_ISDIR(st.st_mode):
            raise VerbFileError(path, "is a directory, not a verb file")
        if not stat.S_ISREG(st.st_mode):
            raise VerbFileError(path, "not a regular file")
        if st.st_size > _budget():
            raise _too_big(f"{path}: the file", st.st_size)
        with open(path, "rb") as f:
            data = f.read(st.st_size + 1)
    except FileNotFoundError:
        raise VerbFileError(path, "no such verb file") from None
    except (OSError, ValueError) as e:
        if isinstance(e, AdverbsError):
            raise
        raise VerbFileError(path, f"cannot read: {getattr(e, 'strerror', None) or e}") from None
    if len(data) != st.st_size:
        raise VerbFileError(path, "changed while it was read")
    return data


def _not_a_verb(path: Path, data: bytes) -> str:
    """Why ``data``, with no zip directory, is not a verb file: what it looks like instead, if it is something we read."""
    head = data[:4096].lstrip()
    motion = "BVH" if head.startswith(b"HIERARCHY") else "glTF" if head.startswith(b"glTF") else None
    if motion is not None:
        return f"a {motion} motion file, not a verb: a verb is built from a spec of examples (adverbs build SPEC.toml -o VERB.verb)"
    if path.suffix.lower() == ".toml":
        return "a spec, not a built verb: build it first (adverbs build SPEC.toml -o VERB.verb)"
    return "damaged verb file: not a zip archive (no end of central directory)"


def _check_directory(path: Path, data: bytes) -> None:
    """Refuse a zip directory too large for a verb's 14 members, before :mod:`zipfile` reads it.

    The end record is found as :mod:`zipfile` finds it (the last 22 bytes, else the last signature
    in the 64 KB a comment may take); a ZIP64 directory, which a verb file never needs, is refused.
    """
    end = len(data) - 22
    if not (end >= 0 and data[end : end + 4] == b"PK\x05\x06" and data[-2:] == b"\0\0"):
        start = max(len(data) - (1 << 16) - 22, 0)
        end = data.rfind(b"PK\x05\x06", start)
        if end < 0 or len(data) - end < 22:
            raise VerbFileError(path, _not_a_verb(path, data))
    entries, size = struct.unpack("<HI", data[end + 10 : end + 16])
    if end >= 20 and data[end - 20 : end - 16] == b"PK\x06\x07":
        raise VerbFileError(path, "damaged verb file: a ZIP64 archive, which adverbs never writes")
    if size > MAX_DIRECTORY:
        raise VerbFileError(
            path,
            f"damaged verb file: its zip directory claims {entries:,} members in {size:,} bytes; a verb has {len(MEMBERS)}",
        )


class _Archive:
    """The members of a verb file's zip archive, each checked (size, method) before it is read."""

    def __init__(self, path: Path, data: bytes):
        _check_directory(path, data)
        self.path = path
        try:
            self.zip = zipfile.ZipFile(io.BytesIO(data))
            infos = self.zip.infolist()
        except _ZIP_ERRORS as e:
            raise VerbFileError(path, f"damaged verb file: not a readable zip archive ({e})") from None
        self.infos: dict[str, zipfile.ZipInfo] = {}
        for info in infos:
            if info.filename in self.infos:
                raise VerbFileError(path, "damaged verb file: the member is in the archive twice", info.filename)
            self.infos[info.filename] = info

    def check_members(self) -> None:
        """Refuse members a verb file does not have, missing ones, and more content than the memory limit allows."""
        for name in self.infos:
            if name not in MEMBERS:
                raise VerbFileError(self.path, f"damaged verb file: unexpected member {name!r}")
        missing = [m for m in MEMBERS if m not in self.infos]
        if missing:
            raise VerbFileError(self.path, f"damaged verb file: member {missing[0]!r} is missing")
        total = sum(info.file_size for info in self.infos.values())
        if total > _budget():
            raise _too_big(f"{self.path}: the archive's content", total)

    def read(self, name: str, limit: int) -> bytes:
        """Member ``name``, refused before it is decompressed when the archive says it is over ``limit`` bytes."""
        info = self.infos.get(name)
        if info is None:
            raise VerbFileError(self.path, f"damaged verb file: member {name!r} is missing")
        if info.file_size > limit:
            raise _too_big(f"{self.path}: member {name!r}", info.file_size, limit)
        if info.flag_bits & 0x1:
            raise VerbFileError(self.path, "encrypted; adverbs never encrypts a verb file", name)
        if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            raise VerbFileError(self.path, f"compressed by method {info.compress_type}; a verb file uses deflate", name)
        try:
            with self.zip.open(info) as f:
                data = f.read()
        except _ZIP_ERRORS as e:
            raise VerbFileError(self.path, f"damaged ({e})", name) from None
        if len(data) != info.file_size:
            raise VerbFileError(self.path, f"damaged: {len(data)} bytes, the archive says {info.file_size}", name)
        return data


_JSON_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_OPEN, _CLOSE = np.frombuffer(b"[{", np.uint8), np.frombuffer(b"]}", np.uint8)


def _json_depth(text: bytes) -> int:
    """How deep the arrays and objects of JSON ``text`` nest (brackets in strings skipped), without recursion."""
    b = np.frombuffer(_JSON_STRING.sub(b'""', text), np.uint8)
    step = np.isin(b, _OPEN).astype(np.int64) - np.isin(b, _CLOSE)
    return int(np.cumsum(step).max(initial=0))


def _parse_json(path: Path, data: bytes) -> Any:
    member = "verb.json"

    def no_constant(name: str):
        raise VerbFileError(path, f"damaged: not valid JSON ({name} is not a number a verb file holds)", member)

    if _json_depth(data) > MAX_JSON_DEPTH:
        raise VerbFileError(path, f"damaged: JSON nested more than {MAX_JSON_DEPTH} deep", member)
    try:
        return json.loads(data.decode("utf-8"), parse_constant=no_constant)
    except UnicodeDecodeError:
        raise VerbFileError(path, "damaged: not UTF-8 text", member) from None
    except ValueError as e:  # JSONDecodeError, and integers of thousands of digits
        if isinstance(e, AdverbsError):
            raise
        raise VerbFileError(path, f"damaged: not valid JSON ({e})", member) from None


# The header numpy writes (``np.lib.format.write_array``, format 1.0 or 2.0): a Python dict literal of fixed form,
# padded with spaces to a newline. Read by this pattern alone: nothing in it is evaluated.
_NPY_MAGIC = b"\x93NUMPY"
_NPY_HEADER = re.compile(
    rb"\{'descr': '([<>|=])([a-zA-Z])([0-9]{1,2})', 'fortran_order': (True|False), 'shape': \(((?:[0-9]{1,20}, )*[0-9]{1,20},?|)\), \} *\n"
)
_NPY_KINDS = {"f": "numbers", "i": "whole numbers"}


def _parse_npy(path: Path, member: str, data: bytes, kind: str, ndim: int, budget: int) -> np.ndarray:
    """One ``.npy`` array of 8-byte ``kind`` ("f" or "i") numbers and ``ndim`` axes; its header is checked
    (type, axes, declared size against ``budget`` bytes) before any data is allocated."""
    head = data[:12]
    if len(head) < 10 or head[:6] != _NPY_MAGIC:
        raise VerbFileError(path, "damaged: not an npy array", member)
    version = (head[6], head[7])
    if version not in ((1, 0), (2, 0)):
        raise VerbFileError(path, f"damaged: npy format version {version[0]}.{version[1]}; adverbs writes 1.0", member)
    start, length = (
        (10, struct.unpack("<H", head[8:10])[0])
        if version == (1, 0)
        else (12, struct.unpack("<I", head[8:12].ljust(4, b"\0"))[0])
    )
    header = _NPY_HEADER.fullmatch(data[start : start + length])
    if header is None:
        raise VerbFileError(path, "damaged: its npy header is not one numpy writes", member)
    order, dkind, size, fortran, dims = header.groups()
    shape = tuple(int(n) for n in dims.split(b",") if n.strip())
    if dkind.decode() != kind or size != b"8":
        raise VerbFileError(
            path, f"must hold 8-byte {_NPY_KINDS[kind]}, holds {(order + dkind + size).decode()!r}", member
        )
    if len(shape) != ndim:
        raise VerbFileError(path, f"must be an array of {ndim} axes, has shape {shape}", member)
    nbytes = 8 * math.prod(shape)
    if nbytes > budget:
        raise _too_big(f"{path}: member {member!r} (shape {shape})", nbytes, budget)
    start += length
    if len(data) - start != nbytes:
        raise VerbFileError(path, f"damaged: {len(data) - start} bytes of data for shape {shape}", member)
    dtype = np.dtype((order + dkind + size).decode())
    flat = np.frombuffer(data, dtype, nbytes // 8, start)
    return flat.reshape(shape, order="F" if fortran == b"True" else "C").astype(dtype.newbyteorder("="))


def _show(value: Any) -> str:
    """A field's value for a message, as the file has it (strings in double quotes), kept short."""
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list):
        return "a list"
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


# ----- fields and arrays into a verb --------------------------------------------------------------


def _number(x: Any) -> bool:
    """A finite JSON number (not a boolean; an integer too large for a float is not one)."""
    if isinstance(x, float):
        return math.isfinite(x)
    return isinstance(x, int) and not isinstance(x, bool) and abs(x) <= sys.float_info.max


class _Reader:
    """Reads the checked ``verb.json`` fields and arrays of one file into a :class:`Verb`; every fault
    raises :class:`VerbFileError` naming the field or member."""

    def __init__(self, path: Path, arrays: dict[str, np.ndarray]):
        self.path, self.arrays = path, arrays

    # ----- typed fields ------------------------------------------------------------------------
    def fail(self, field: str, reason: str) -> VerbFileError:
        return VerbFileError(self.path, reason, field=field)

    def bad(self, member: str, reason: str) -> VerbFileError:
        return VerbFileError(self.path, reason, member=f"{member}.npy")

    def table(self, value: Any, field: str, keys: set[str]) -> dict:
        if not isinstance(value, dict):
            raise self.fail(field, f"must be an object, got {_show(value)}")
        missing = sorted(keys - value.keys())
        if missing:
            raise self.fail(f"{field}.{missing[0]}" if field else missing[0], "missing")
        unknown = sorted(set(value) - keys)
        if unknown:
            raise self.fail(f"{field}.{unknown[0]}" if field else unknown[0], "not a field of a verb file")
        return value

    def items(self, value: Any, field: str, count: int | None = None, what: str = "") -> list:
        if not isinstance(value, list):
            raise self.fail(field, f"must be a list, got {_show(value)}")
        if count is not None and len(value) != count:
            raise self.fail(field, f"must list {count} {what}, lists {len(value)}")
        return value

    def string(self, value: Any, field: str, empty: bool = True) -> str:
        if not isinstance(value, str) or (not empty and not value):
            raise self.fail(field, f"must be {'a' if empty else 'a non-empty'} string, got {_show(value)}")
        if not value.isascii():
            try:
                value.encode("utf-8")
            except UnicodeEncodeError:
                raise self.fail(field, f"is not valid Unicode (it holds a lone surrogate): {_show(value)}") from None
        return value

    def names(self, value: Any, field: str, count: int | None = None, what: str = "names") -> tuple[str, ...]:
        out = tuple(
            self.string(v, f"{field}[{i}]", empty=False) for i, v in enumerate(self.items(value, field, count, what))
        )
        self.unique(out, field)
        return out

    def unique(self, names: Sequence[str], field: str, suffix: str = "") -> None:
        seen: set[str] = set()
        for i, n in enumerate(names):
            if n in seen:
                raise self.fail(f"{field}[{i}]{suffix}", f"{n!r} is listed twice")
            seen.add(n)

    def boolean(self, value: Any, field: str) -> bool:
        if not isinstance(value, bool):
            raise self.fail(field, f"must be true or false, got {_show(value)}")
        return value

    def number(
        self, value: Any, field: str, ok: Callable[[float], bool] = lambda x: True, what: str = "a finite number"
    ) -> float:
        if not _number(value) or not ok(value):
            raise self.fail(field, f"must be {what}, got {_show(value)}")
        return float(value)

    def integer(self, value: Any, field: str, lo: int, hi: int) -> int:
        if not isinstance(value, int) or isinstance(value, bool) or not lo <= value <= hi:
            raise self.fail(field, f"must be a whole number from {lo} to {hi}, got {_show(value)}")
        return value

    # ----- arrays ------------------------------------------------------------------------------
    def array(self, key: str, shape: tuple[int | None, ...], what: str = "") -> np.ndarray:
        """Array ``key`` of ``shape`` (``None``: any length on that axis), finite."""
        a = self.arrays[key]
        if any(want is not None and n != want for n, want in zip(a.shape, shape)):
            want = "(" + ", ".join("any" if n is None else str(n) for n in shape) + ")"
            raise self.bad(key, f"has shape {a.shape}, must be {want}{what}")
        if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            i = tuple(int(x) for x in np.argwhere(~np.isfinite(a))[0])
            raise self.bad(key, f"holds {a[i]} at {list(i)}: every value must be a finite number")
        return a

    def unit_vectors(self, key: str, a: np.ndarray) -> None:
        with np.errstate(over="ignore"):  # a length past the largest float is infinite, and refused as such
            length = np.linalg.norm(a.reshape(-1, a.shape[-1]), axis=-1)
        bad = np.flatnonzero(np.abs(length - 1.0) > UNIT_TOLERANCE)
        if len(bad):
            raise self.bad(key, f"row {bad[0]} has length {length[bad[0]]:.6g}; it must be a unit vector")

    # ----- the verb ----------------------------------------------------------------------------
    def verb(self, meta: dict) -> Verb:
        meta = self.table(meta, "", _FIELDS)
        skel = self.skeleton(meta["skeleton"])
        enc = self.encoding(meta["encoding"], skel)

        name = self.string(meta["name"], "name")
        cyclic = self.boolean(meta["cyclic"], "cyclic")
        fps = self.number(
            meta["fps"],
            "fps",
            lambda x: 0 < x <= MAX_FPS,
            f"a number of frames per second above 0 and up to {MAX_FPS:g}",
        )
        num_cp = meta["num_cp"]
        bad_num_cp = self.fail(
            "num_cp", f"must be a whole number of at least 4 (control points per DOF), got {_show(num_cp)}"
        )
        if isinstance(num_cp, bool) or not isinstance(num_cp, int):
            raise bad_num_cp
        try:
            bspline.check_num_cp(num_cp)  # the B-splines' own rule: at least one cubic segment
        except AdverbsError:
            raise bad_num_cp from None
        floor = self.number(meta["floor"], "floor")
        smoothing = self.number(meta["smoothing"], "smoothing", lambda x: x >= 0, "a finite number ≥ 0")
        shrinkage = self.number(meta["shrinkage"], "shrinkage", lambda x: x >= 0, "a finite number ≥ 0")
        goal_chain = self.names(meta["goal_chain"], "goal_chain")
        timing = meta["timing"]
        if timing not in TIMINGS:
            raise self.fail("timing", f"must be one of {', '.join(map(repr, TIMINGS))}, got {_show(timing)}")

        examples = self.items(meta["examples"], "examples")
        adverbs = self.items(meta["adverbs"], "adverbs")
        e, a = len(examples), len(adverbs)
        if e == 0:
            raise self.fail("examples", "a verb needs at least one example")
        if e > 1 and a == 0:
            raise self.fail("adverbs", f"{e} examples need at least one adverb to tell them apart")
        need = 8 * e * e * (a + 8)  # the interpolator's (E, E) tables, and (E, E, A) distances while fitting
        if need > LIMITS.memory:
            raise LimitError(
                f"{self.path}: field 'examples': {e:,} examples of {a} adverbs need about {need:,} bytes to interpolate; "
                f"the limit is {LIMITS.memory:,} (ADVERBS_MAX_MEMORY raises it: see adverbs.limits)"
            )
        points = self.array(
            "points", (e, a), ": one row per example (field 'examples'), one column per adverb (field 'adverbs')"
        )
        keytimes = self.array("keytimes", (e, None), ": one row per example (field 'examples')")
        try:
            keytimes = timewarp.check_keytimes(keytimes, "each example's keytimes")
        except AdverbsError as err:
            raise self.bad("keytimes", str(err)) from None
        n = keytimes.shape[1]
        generic = self.array("generic_keytimes", (n,), " (one per keytime, as in keytimes.npy)")
        try:
            timewarp.check_generic(generic, n)
        except AdverbsError as err:
            raise self.bad("generic_keytimes", str(err)) from None
        keytime_names = tuple(
            self.string(v, f"keytime_names[{i}]")
            for i, v in enumerate(self.items(meta["keytime_names"], "keytime_names", n, "names (one per keytime)"))
        )

        records = [self.example(x, f"examples[{i}]") for i, x in enumerate(examples)]
        self.unique([x.name for x in records], "examples", ".name")
        if all(x.refine for x in records):
            raise self.fail("examples", "every example is a refinement; at least one must take part in the linear fit")
        adverb_list = [self.adverb(x, f"adverbs[{i}]", skel, n) for i, x in enumerate(adverbs)]
        self.unique([x.name for x in adverb_list], "adverbs", ".name")

        constraints = [
            self.constraint(c, f"constraints[{i}]", skel, n, cyclic)
            for i, c in enumerate(self.items(meta["constraints"], "constraints"))
        ]
        holds_raw = self.items(meta["holds"], "holds", len(constraints), "holds (one per constraint)")
        holds = [self.hold(h, f"holds[{i}]", c, cyclic) for i, (h, c) in enumerate(zip(holds_raw, constraints))]
        hold_table = self.array("hold_table", (e, len(holds), 3), ": one row per example, one per hold, 3 times each")

        coefficients = self.array(
            "coefficients", (e, num_cp, enc.num_dofs), " (examples, field 'num_cp', DOFs of field 'encoding.names')"
        )
        try:
            return Verb(name, enc, adverb_list, records, points, keytimes, coefficients, cyclic, fps, keytime_names,
                        constraints, floor, generic, smoothing, shrinkage, holds, hold_table, goal_chain, timing)  # fmt: skip
        except AdverbsError as err:  # what only the verb can check: distinct example points, the goal's joints
            raise VerbFileError(self.path, str(err), field="goal_chain" if ": goal:" in str(err) else None) from None

    def skeleton(self, value: Any) -> Skeleton:
        sk = self.table(value, "skeleton", {"names", "channels", "unit_scale", "units"})
        names = self.names(sk["names"], "skeleton.names")
        for i, n in enumerate(names):
            why = name_problem(n)  # a joint name must write to a BVH file and read back as itself
            if why is not None:
                raise self.fail(f"skeleton.names[{i}]", f"joint name {n!r} {why}")
        j = len(names)
        if j == 0:
            raise self.fail("skeleton.names", "a skeleton needs at least one joint")
        check_joints(j, f"{self.path}: field 'skeleton.names'")
        known = POSITION_CHANNELS + ROTATION_CHANNELS
        channels = []
        for i, c in enumerate(self.items(sk["channels"], "skeleton.channels", j, "channel lists (one per joint)")):
            field = f"skeleton.channels[{i}]"
            chans = tuple(self.string(x, f"{field}[{k}]") for k, x in enumerate(self.items(c, field)))
            for ch in chans:
                if ch not in known:
                    raise self.fail(field, f"unknown channel {_show(ch)}; channels are {', '.join(known)}")
            if len(set(chans)) != len(chans):
                raise self.fail(field, f"joint {names[i]!r} lists a channel twice")
            channels.append(chans)
        unit_scale = self.number(
            sk["unit_scale"], "skeleton.unit_scale", lambda x: x > 0, "a positive number (metres per unit)"
        )
        units = self.string(sk["units"], "skeleton.units", empty=False)

        parents = self.array("parents", (j,), " (one per joint, field 'skeleton.names')")
        if parents[0] != -1:
            raise self.bad("parents", f"the first joint must be the root (parent -1), its parent is {parents[0]}")
        bad = 1 + np.flatnonzero((parents[1:] < 0) | (parents[1:] >= np.arange(1, j)))
        if len(bad):
            k = int(bad[0])
            raise self.bad(
                "parents",
                f"joint {k} ({names[k]!r}) hangs from {parents[k]}; every parent must come before its children",
            )
        offsets = self.array("offsets", (j, 3), " (one row per joint)")
        site_parents = self.array("end_site_parents", (None,))
        if np.any((site_parents < 0) | (site_parents >= j)):
            k = int(np.flatnonzero((site_parents < 0) | (site_parents >= j))[0])
            raise self.bad("end_site_parents", f"End Site {k} hangs from {site_parents[k]}, not a joint (0 to {j - 1})")
        site_offsets = self.array("end_site_offsets", (len(site_parents), 3), " (one row per End Site)")
        return Skeleton(names, parents, offsets, tuple(channels), site_parents, site_offsets, unit_scale, units)

    def encoding(self, value: Any, skel: Skeleton) -> DofEncoding:
        e = self.table(value, "encoding", {"kind", "body_root", "names", "heading_smoothing"})
        kind = e["kind"]
        if kind not in KINDS:
            raise self.fail("encoding.kind", f"unknown DOF encoding {_show(kind)}; encodings are {', '.join(KINDS)}")
        j = skel.num_joints
        root = self.integer(e["body_root"], "encoding.body_root", 0, j - 1)
        smoothing = self.number(
            e["heading_smoothing"], "encoding.heading_smoothing", lambda x: 0 <= x <= LONGEST_CYCLE,
            f"a number of seconds from 0 to {LONGEST_CYCLE:g}",
        )  # fmt: skip
        lateral = self.array("lateral", (3,))
        self.unit_vectors("lateral", lateral)
        reference = self.array("reference", (j, 4), " (a quaternion per joint)")
        self.unit_vectors("reference", reference)
        base = self.array("base_translations", (j, 3), " (one row per joint)")
        translated = self.array("translated", (None,))
        below = np.zeros(j, dtype=bool)  # the body root's descendants: the joints that may move
        for k in range(root + 1, j):
            below[k] = below[skel.parents[k]] or skel.parents[k] == root
        movable = below.copy()
        movable[root] = True  # an anchored encoding's body root: its offset from the feet (DofEncoding.anchored)
        if np.any(np.diff(translated) <= 0) or not np.all(
            movable[np.clip(translated, 0, j - 1)] & (translated >= 0) & (translated < j)
        ):
            raise self.bad("translated", "must list the body root or joints below it, each once, in skeleton order")
        enc_names = self.names(e["names"], "encoding.names")
        rotated = [root] + [k for k in range(j) if below[k]]
        expected = list(ROOT_COLUMNS)
        for k in rotated:
            expected += [f"{skel.names[k]}.{axis}" for axis in _axes(kind, skel, k)]
        for k in translated:
            expected += [f"{skel.names[k]}.{axis}" for axis in ("tx", "ty", "tz")]
        if list(enc_names) != expected:
            if len(enc_names) != len(expected):
                raise self.fail(
                    "encoding.names", f"lists {len(enc_names)} DOFs; this skeleton and encoding have {len(expected)}"
                )
            i = next(i for i, (x, y) in enumerate(zip(enc_names, expected)) if x != y)
            raise self.fail(
                f"encoding.names[{i}]", f"unknown DOF {enc_names[i]!r}; the encoding's column {i} is {expected[i]!r}"
            )
        return DofEncoding(kind, skel, root, lateral, reference, base, translated, enc_names, smoothing)

    def example(self, value: Any, field: str) -> ExampleRecord:
        x = self.table(value, field, {"name", "source", "part", "fit_error", "refine", "fine_error"})
        positive = (lambda v: v >= 0, "a finite number ≥ 0 (metres)")
        return ExampleRecord(
            self.string(x["name"], f"{field}.name", empty=False),
            self.string(x["source"], f"{field}.source"),
            self.string(x["part"], f"{field}.part"),
            self.number(x["fit_error"], f"{field}.fit_error", *positive),
            self.boolean(x["refine"], f"{field}.refine"),
            self.number(x["fine_error"], f"{field}.fine_error", *positive),
        )

    def adverb(self, value: Any, field: str, skel: Skeleton, n: int) -> Adverb:
        x = self.table(value, field, {"name", "unit", "measure"})
        measure = x["measure"]
        if measure is not None:
            if not isinstance(measure, dict):
                raise self.fail(f"{field}.measure", f"must be an object or null, got {_show(measure)}")
            if isinstance(measure.get("keytime"), bool):
                raise self.fail(f"{field}.measure.keytime", f"must be a keytime index, got {_show(measure['keytime'])}")
            measure = check_measure(measure, skel.names, n, f"{self.path}: field '{field}.measure'")
        return Adverb(
            self.string(x["name"], f"{field}.name", empty=False), self.string(x["unit"], f"{field}.unit"), measure
        )

    def constraint(self, value: Any, field: str, skel: Skeleton, n: int, cyclic: bool) -> Constraint:
        x = self.table(value, field, {"effector", "open", "close"})
        effector = self.string(x["effector"], f"{field}.effector")
        if effector not in skel.names:
            raise self.fail(f"{field}.effector", f"names joint {effector!r}, which the skeleton does not have")
        c = Constraint(
            effector,
            self.integer(x["open"], f"{field}.open", 0, n - 1),
            self.integer(x["close"], f"{field}.close", 0, n - 1),
        )
        try:
            check_constraint(c, skel, n, cyclic)
        except AdverbsError as err:
            raise self.fail(field, str(err)) from None
        return c

    def hold(self, value: Any, field: str, c: Constraint, cyclic: bool) -> Hold:
        x = self.table(value, field, {"effector", "open", "close", "heel_off", "height", "toe_down", "heel_height"})
        if x["effector"] != c.effector:
            raise self.fail(
                f"{field}.effector",
                f"must be {c.effector!r}, the effector of the constraint it holds, got {_show(x['effector'])}",
            )
        opens = self.number(x["open"], f"{field}.open", lambda v: 0 <= v <= 1, "a generic time from 0 to 1")
        times = {}
        last = ("open", opens)
        for key in ("toe_down", "heel_off", "close"):
            times[key] = self.number(x[key], f"{field}.{key}")
            if times[key] < last[1] - TIME_TOLERANCE:
                raise self.fail(f"{field}.{key}", f"{times[key]:g} comes before {last[0]} ({last[1]:g})")
            last = (key, times[key])
        end = opens + 2.0 if cyclic else 1.0  # in a cycle, a foot down throughout is held into the next one
        if times["close"] > end + TIME_TOLERANCE:
            raise self.fail(
                f"{field}.close", f"{times['close']:g} is past the end of the {'next cycle' if cyclic else 'motion'}"
            )
        heights = [None if x[k] is None else self.number(x[k], f"{field}.{k}") for k in ("height", "heel_height")]
        return Hold(c.effector, opens, times["close"], times["heel_off"], heights[0], times["toe_down"], heights[1])
