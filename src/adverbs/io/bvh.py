r"""BVH reading and writing.

Reads any channel order, 0–6 channels on any joint (position channels on non-root joints replace
that joint's offset, as Blender reads them), End Sites, tabs, CRLF and blank lines. Lengths are
converted to metres; the file's unit is recorded on the skeleton and restored on writing. Every
fault raises :class:`~adverbs.errors.BVHError` naming the file and the line.

**Lines and words.** Lines end at ``\n``, ``\r\n`` or a lone ``\r`` — as editors count them — and nowhere
else: a form feed, ``U+0085``, ``U+2028`` or ``U+2029`` is a character of its line, not a line break (Python's
``str.splitlines`` would break there and put every later error on the wrong line). Words are separated by
ASCII whitespace (space, tab, vertical tab, form feed and the separators ``\x1c``–``\x1f``); any other
character, a no-break space or ``U+2028`` too, is part of a word. A number is ASCII (``1.5e-3``, ``nan``
and ``inf`` are refused as not finite; ``١``, ``1_000`` and ``１`` are not numbers).

**Limits.** A file bigger than ``LIMITS.memory`` / :data:`READ_COST` bytes (reading takes about that many
times its size; see :mod:`adverbs.limits`), a hierarchy of more joints than ``LIMITS.joints``, or a ``Frames:``
count past ``LIMITS.frames`` or whose frames would need more than ``LIMITS.memory`` is refused before the work
starts, with a :class:`BVHLimitError`: both a :class:`~adverbs.limits.LimitError` and a
:class:`~adverbs.errors.BVHError` naming the file and the line. The hierarchy is read and written without
recursion, so any depth within the joint limit is read and written.

**Writing** refuses, with an :class:`~adverbs.errors.AdverbsError` naming the file and what is wrong, every clip
whose file the reader would refuse (a NaN or infinite value, naming the joint and the frame; a frame time
outside 1e-6 to 1e4 s; a joint name that would not read back as itself; a channel that is not a BVH channel; no
frames or no channels; the limits above) or would read back otherwise (a joint moved along an axis it has no
position channel for), so that what :func:`write_bvh` writes, :func:`read_bvh` reads as written. Joints are
written depth first.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import os
import re
from collections.abc import Iterable, Iterator
from pathlib import Path

import numpy as np

from ..errors import AdverbsError, BVHError
from ..kinematics import quat
from ..kinematics.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton
from ..limits import LIMITS, LimitError, check_frames, check_joints
from ..motion.clip import Clip
from .files import atomic_path

UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
_CHANNELS = POSITION_CHANNELS + ROTATION_CHANNELS
_CHANNEL_LOOKUP = {c.lower(): c for c in _CHANNELS}
MIN_FRAME_TIME, MAX_FRAME_TIME = 1e-6, 1e4  # seconds: the Frame Time a file may give
_WHITESPACE = " \t\v\f\x1c\x1d\x1e\x1f"  # what separates words (str.split's whitespace within ASCII)
_SPACES = re.compile(f"[{re.escape(_WHITESPACE)}]+")
_FRAME_COUNT = re.compile(r"\+?[0-9]+")
READ_COST = 8  # bytes of memory per byte of a file while it is read (bytes, text, lines, words, numbers)
WRITE_BLOCK = 1024  # frames formatted and written at a time
WRITE_INDENT = 32  # the writer indents a joint by its depth, up to this many tabs (a deep chain stays linear)


class BVHLimitError(BVHError, LimitError):
    """A BVH file refused by a limit of :mod:`adverbs.limits`: both a :class:`BVHError` (it names the file and the
    line) and a :class:`LimitError`."""


def _mib(n: int) -> str:
    return f"{n / (1 << 20):,.0f} MiB"


def split_lines(text: str) -> list[str]:
    r"""``text``'s lines as editors count them: broken at ``\n``, ``\r\n`` and a lone ``\r`` only (see the
    module); a break at the very end does not start another line."""
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    return lines


def words(line: str) -> list[str]:
    """The words of one line, split at ASCII whitespace only (see the module)."""
    if line.isascii():
        return line.split()  # the same split, in C
    return [w for w in _SPACES.split(line) if w]


def _is_number(word: str) -> bool:
    """Whether ``float`` may read ``word`` as the file means it: ASCII, without Python's ``_`` digit groups."""
    return word.isascii() and "_" not in word


def read_bvh(path: str | Path, units: str | float = "auto") -> Clip:
    """Read a BVH file into a :class:`Clip` (metres, radians inside).

    ``units`` names the file's length unit (``"cm"``, ``"m"``, ``"mm"``, ``"in"``, ``"ft"``), gives
    metres per file unit as a number, or is ``"auto"``: guessed from the figure's size in the first
    frame (under 5 units tall: metres; under 500: centimetres; else millimetres).
    """
    path = Path(path)
    limit = LIMITS.memory // READ_COST
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size  # a regular file's size; 0 for a pipe or a device
            data = bytearray()
            while size <= limit and len(data) <= limit:  # bounded: a device that never ends is not read whole
                chunk = f.read(min(max(size + 1, 1 << 20), limit + 1 - len(data)))
                if not chunk:
                    break
                data += chunk
        if max(size, len(data)) > limit:
            raise BVHLimitError(
                f"the file is {_mib(max(size, len(data)))}{'' if size else ' or more'}; reading it would need about "
                f"{READ_COST} times that, past the memory limit {_mib(LIMITS.memory)} (ADVERBS_MAX_MEMORY raises "
                "it: see adverbs.limits)",
                path,
            )
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise BVHError(f"not a text file ({e.reason} at byte {e.start})", path) from None
    except OSError as e:
        raise BVHError(f"cannot read: {e.strerror or e}", path) from None
    del data
    return parse_bvh(text, units=units, source=path)


def parse_bvh(text: str, units: str | float = "auto", source: str | Path | None = None) -> Clip:
    r"""Parse BVH text; ``source`` names it in errors and becomes the clip's name. Lines are broken at ``\n``,
    ``\r\n`` and ``\r`` only (see the module)."""
    if text.startswith("\ufeff"):
        text = text[1:]
    lines = split_lines(text)
    parser = _HierarchyParser(lines, source)
    names, parents, offsets, channels, sites, motion_line = parser.parse()
    frame_count, frame_time, time_text, values = _parse_motion(
        lines, motion_line, sum(len(c) for c in channels), len(names), source
    )

    raw_offsets = np.array(offsets, dtype=float)
    site_parents = np.array([p for p, _ in sites], dtype=np.int64)
    site_offsets = np.array([o for _, o in sites], dtype=float).reshape(-1, 3)
    parents_arr = np.array(parents, dtype=np.int64)
    rotations, raw_translations = _channels_to_arrays(values, raw_offsets, channels)

    if isinstance(units, str) and units == "auto":
        # The median bone of a person is 0.05–0.4 m whatever the file's placement of the figure.
        with np.errstate(over="ignore"):  # an absurd offset: an infinite length, millimetres
            bones = np.linalg.norm(np.concatenate([raw_offsets[1:], site_offsets]), axis=1)
        typical = float(np.median(bones[bones > 0])) if np.any(bones > 0) else 1.0
        units = "m" if typical < 0.5 else "cm" if typical < 50.0 else "mm"
    scale, unit_name = _unit_scale(units)
    with np.errstate(over="ignore"):
        too_big = not (
            np.all(np.isfinite(raw_offsets * scale))
            and np.all(np.isfinite(site_offsets * scale))
            and np.all(np.isfinite(raw_translations * scale))
        )
    if too_big:
        raise BVHError(f"lengths too large to hold in metres at {scale:g} m per file unit", source)
    skel = Skeleton(
        names=tuple(names),
        parents=parents_arr,
        offsets=raw_offsets * scale,
        channels=tuple(tuple(c) for c in channels),
        end_site_parents=site_parents,
        end_site_offsets=site_offsets * scale,
        unit_scale=scale,
        units=unit_name,
    )
    name = Path(source).stem if source is not None else ""
    return Clip(skel, rotations, raw_translations * scale, _frame_rate(frame_time, time_text), name=name)


def _frame_rate(frame_time: float, text: str) -> float:
    """``1 / frame_time``, snapped to a whole rate when the printed time is that rate rounded (0.0333333 → 30).

    Only a rounding of the printed time is snapped: within 1e-4 relative, so 0.03 s stays 33.3 fps.
    """
    del text
    fps = 1.0 / frame_time
    whole = round(fps)
    if whole > 0 and abs(fps - whole) <= 1e-4 * whole:
        return float(whole)
    return fps


def _unit_scale(units: str | float) -> tuple[float, str]:
    if isinstance(units, str):
        if units not in UNITS:
            raise AdverbsError(f"unknown units {units!r}; use one of {', '.join(UNITS)}, 'auto', or metres per unit")
        return UNITS[units], units
    scale = float(units)
    if not (np.isfinite(scale) and scale > 0):
        raise AdverbsError(f"units must be a positive number of metres per file unit, got {units}")
    name = next((k for k, v in UNITS.items() if np.isclose(v, scale, rtol=1e-12, atol=0)), f"{scale:g} m")
    return scale, name


class _HierarchyParser:
    """The HIERARCHY tokens, each with its line number, parsed without recursion (any depth)."""

    def __init__(self, lines: list[str], source: str | Path | None):
        self.source = source
        self.tokens: list[tuple[str, int]] = []
        self.motion_line = -1
        joint_lines = []
        for i, line in enumerate(lines):
            ws = words(line)
            if ws:
                key = ws[0].upper()
                if key == "MOTION":
                    self.motion_line = i
                    break
                if key in ("ROOT", "JOINT"):
                    joint_lines.append(i + 1)
            self.tokens.extend((w, i + 1) for w in ws)
        if len(joint_lines) > LIMITS.joints:
            try:
                check_joints(len(joint_lines), "the hierarchy")
            except LimitError as e:  # at the first joint past the limit
                raise BVHLimitError(str(e), source, joint_lines[LIMITS.joints]) from None
        self.pos = 0
        self.last_line = len(lines)
        self.names: list[str] = []
        self.known: set[str] = set()
        self.parents: list[int] = []
        self.offsets: list[list[float]] = []
        self.channels: list[list[str]] = []
        self.sites: list[tuple[int, list[float]]] = []

    def error(self, reason: str, line: int | None = None) -> BVHError:
        if line is None:
            line = self.tokens[self.pos][1] if self.pos < len(self.tokens) else self.last_line
        return BVHError(reason, self.source, line)

    def next(self, what: str) -> tuple[str, int]:
        if self.pos >= len(self.tokens):
            raise self.error(f"unexpected end of the hierarchy, expected {what}")
        tok = self.tokens[self.pos]
        self.pos += 1
        return tok

    def expect(self, word: str) -> int:
        tok, line = self.next(repr(word))
        if tok.upper() != word.upper():
            raise self.error(f"expected {word!r}, found {tok!r}", line)
        return line

    def numbers(self, n: int, what: str) -> list[float]:
        out = []
        for _ in range(n):
            tok, line = self.next(f"{n} numbers for {what}")
            try:
                if not _is_number(tok):
                    raise ValueError
                value = float(tok)
            except ValueError:
                raise self.error(f"{what}: {tok!r} is not a number", line) from None
            if not np.isfinite(value):
                raise self.error(f"{what}: {tok!r} is not a finite number", line)
            out.append(value)
        return out

    def parse(self):
        if not self.tokens:
            raise self.error("empty file: expected HIERARCHY", 1)
        self.expect("HIERARCHY")
        tok, line = self.next("ROOT")
        if tok.upper() != "ROOT":
            raise self.error(f"expected ROOT, found {tok!r}", line)
        self.hierarchy(line)
        if self.pos < len(self.tokens):
            tok, line = self.tokens[self.pos]
            if tok == "}":
                raise self.error("unbalanced braces: '}' closes nothing", line)
            if tok.upper() == "ROOT":
                raise self.error("a second ROOT: only one hierarchy per file is supported", line)
            raise self.error(f"unexpected {tok!r} after the hierarchy, expected MOTION", line)
        if self.motion_line < 0:
            raise self.error("no MOTION section", self.last_line)
        return self.names, self.parents, self.offsets, self.channels, self.sites, self.motion_line

    def open_joint(self, parent: int, line: int) -> list:
        """Read a joint's name (the rest of its ROOT or JOINT line) and its ``{``; ``[index, line, has OFFSET]``."""
        name_words = []
        while self.pos < len(self.tokens) and self.tokens[self.pos][1] == line and self.tokens[self.pos][0] != "{":
            name_words.append(self.tokens[self.pos][0])
            self.pos += 1
        if not name_words:
            raise self.error("a joint needs a name", line)
        name = " ".join(name_words)
        if name in self.known:
            raise self.error(f"joint name {name!r} is used twice", line)
        self.known.add(name)
        self.names.append(name)
        self.parents.append(parent)
        self.offsets.append([0.0, 0.0, 0.0])
        self.channels.append([])
        self.expect("{")
        return [len(self.names) - 1, line, False]

    def hierarchy(self, root_line: int) -> None:
        """The ROOT joint and everything in it; the joints still open are on a stack, innermost last."""
        stack = [self.open_joint(-1, root_line)]
        while stack:
            index, line, _ = top = stack[-1]
            name = self.names[index]
            if self.pos >= len(self.tokens):
                raise self.error(
                    f"unbalanced braces: joint {name!r} opened at line {line} is never closed", self.last_line
                )
            tok, tline = self.next("a joint's contents")
            key = tok.upper()
            if key == "}":
                if not top[2]:
                    raise self.error(f"joint {name!r} has no OFFSET", line)
                stack.pop()
            elif key == "OFFSET":
                self.offsets[index] = self.numbers(3, f"OFFSET of {name!r}")
                top[2] = True
            elif key == "CHANNELS":
                (count,) = self.numbers(1, f"CHANNELS count of {name!r}")
                if count != int(count) or not 0 <= count <= 6:
                    raise self.error(f"CHANNELS of {name!r}: count must be 0 to 6, got {count:g}", tline)
                chans = []
                for _ in range(int(count)):
                    ctok, cline = self.next(f"{int(count)} channel names for {name!r}")
                    c = _CHANNEL_LOOKUP.get(ctok.lower())
                    if c is None:
                        raise self.error(
                            f"unknown channel {ctok!r} on joint {name!r}; channels are {', '.join(_CHANNELS)}", cline
                        )
                    if c in chans:
                        raise self.error(f"channel {c} listed twice on joint {name!r}", cline)
                    chans.append(c)
                self.channels[index] = chans
            elif key == "JOINT":
                stack.append(self.open_joint(index, tline))
            elif key == "END":
                self.expect("Site")
                self.expect("{")
                self.expect("OFFSET")
                self.sites.append((index, self.numbers(3, f"End Site OFFSET of {name!r}")))
                self.expect("}")
            else:
                raise self.error(f"unexpected {tok!r} in joint {name!r}", tline)


def _parse_motion(
    lines: list[str], motion_line: int, num_channels: int, num_joints: int, source: str | Path | None
) -> tuple[int, float, str, np.ndarray]:
    header: dict[str, tuple[str, int]] = {}
    i = motion_line + 1
    while i < len(lines) and len(header) < 2:
        text = lines[i].strip(_WHITESPACE)
        i += 1
        if not text:
            continue
        key, sep, value = text.partition(":")
        key = " ".join(words(key)).lower()
        if not sep or key not in ("frames", "frame time"):
            raise BVHError(f"expected 'Frames:' and 'Frame Time:' after MOTION, found {text[:40]!r}", source, i)
        if key in header:
            raise BVHError(f"a second '{key.title()}:' line", source, i)
        header[key] = (value.strip(_WHITESPACE), i)
    for key in ("frames", "frame time"):
        if key not in header:
            raise BVHError(f"MOTION section has no '{key.title()}:' line", source, i)
    frames_text, frames_line = header["frames"]
    if _FRAME_COUNT.fullmatch(frames_text) is None:
        raise BVHError(f"Frames: {frames_text[:40]!r} is not a frame count", source, frames_line)
    digits = frames_text.lstrip("+0")
    if len(digits) > 18:  # past any limit, and past what a float (in check_frames) holds exactly
        raise BVHLimitError(
            f"the motion is a {len(digits)}-digit number of frames; the limit is {LIMITS.frames:,} per clip "
            "(ADVERBS_MAX_FRAMES raises it: see adverbs.limits)",
            source,
            frames_line,
        )
    frame_count = int(frames_text)
    if frame_count < 1:
        raise BVHError("the file has no frames (Frames: 0)", source, frames_line)
    try:  # before a number is read: a file may claim a billion frames
        check_frames(frame_count, num_joints, "the motion")
    except LimitError as e:
        raise BVHLimitError(str(e), source, frames_line) from None
    time_text, time_line = header["frame time"]
    try:
        if not _is_number(time_text):
            raise ValueError
        frame_time = float(time_text)
    except ValueError:
        raise BVHError(f"Frame Time: {time_text[:40]!r} is not a number", source, time_line) from None
    if not (np.isfinite(frame_time) and MIN_FRAME_TIME <= frame_time <= MAX_FRAME_TIME):
        raise BVHError(
            f"Frame Time must be a positive number of seconds ({MIN_FRAME_TIME:g} to {MAX_FRAME_TIME:g}), "
            f"got {time_text[:40]!r}",
            source,
            time_line,
        )

    rows = []
    numbers = []
    for n in range(i, len(lines)):
        row = words(lines[n])
        if not row:
            continue
        if len(rows) == frame_count:
            raise BVHError(
                f"'Frames: {frame_count}' (line {frames_line}) but frame {frame_count + 1} follows", source, n + 1
            )
        if len(row) != num_channels:
            kind = "truncated motion: " if n == len(lines) - 1 and len(row) < num_channels else ""
            raise BVHError(
                f"{kind}frame {len(rows) + 1} has {len(row)} values, the hierarchy has {num_channels} channels",
                source,
                n + 1,
            )
        rows.append(n + 1)
        numbers.append(row)
    if len(rows) < frame_count:
        raise BVHError(
            f"truncated motion: 'Frames: {frame_count}' but the file ends after {len(rows)} frames",
            source,
            len(lines),
        )
    values = None
    if all(_is_number(lines[n - 1]) for n in rows):
        try:
            values = np.array(list(itertools.chain.from_iterable(numbers)), dtype=float)
        except ValueError:
            pass
    if values is None or not np.all(np.isfinite(values)):
        for line_no, row in zip(rows, numbers):
            for w in row:
                try:
                    ok = _is_number(w) and np.isfinite(float(w))
                except ValueError:
                    ok = False
                if not ok:
                    raise BVHError(f"{w[:40]!r} is not a finite number", source, line_no)
    return frame_count, frame_time, time_text, values.reshape(frame_count, num_channels)


def _channels_to_arrays(
    values: np.ndarray, offsets: np.ndarray, channels: list[list[str]]
) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations ``(F, J, 4)`` and translations ``(F, J, 3)`` (file units) from channel values."""
    f, j = values.shape[0], len(channels)
    translations = np.broadcast_to(offsets, (f, j, 3)).copy()
    rotations = quat.identity((f, j))
    by_order: dict[str, tuple[list[int], list[list[int]]]] = {}
    col = 0
    for joint, chans in enumerate(channels):
        rot_cols = []
        for c in chans:
            if c in POSITION_CHANNELS:
                translations[:, joint, POSITION_CHANNELS.index(c)] = values[:, col]
            else:
                rot_cols.append(col)
            col += 1
        order = "".join(c[0] for c in chans if c in ROTATION_CHANNELS)
        if order:
            joints, cols = by_order.setdefault(order, ([], []))
            joints.append(joint)
            cols.append(rot_cols)
    for order, (joints, cols) in by_order.items():
        angles = np.deg2rad(values[:, np.array(cols)])  # (F, n_joints, len(order))
        rotations[:, joints] = quat.from_euler(order, angles)
    return rotations, translations


# ----- writing -------------------------------------------------------------------------------


def write_bvh(clip: Clip, path: str | Path, precision: int = 9, portable: bool = False) -> None:
    """Write ``clip`` as BVH in its skeleton's channels and unit, ``precision`` significant digits; ``portable``: with
    position channels on the root only, which every reader reads alike (see :mod:`adverbs.io.portable`).

    The file is written whole or not at all: a failed write leaves what was at ``path`` as it was. A clip whose file
    :func:`read_bvh` would refuse is refused (see :func:`format_bvh`), naming ``path``, and nothing is written. The
    frames are written a block at a time (the text of a long clip is never held whole in memory).
    """
    write_bvh_blocks(path, [clip], clip.num_frames, precision, portable)


def write_bvh_blocks(
    path: str | Path, blocks: Iterable[Clip], frames: int, precision: int = 9, portable: bool = False
) -> Path:
    """Write as BVH one motion given as consecutive ``blocks`` (clips of one skeleton and frame rate, ``frames`` in
    all; ``portable``: each made portable, see :func:`write_bvh`), each checked, converted and written as it comes,
    its Euler angles unwrapped on from the block before: the bytes :func:`write_bvh` writes of the whole clip, with
    one block in memory at a time (a long recording). Whole or not at all, as :func:`write_bvh`."""
    with _naming(path):
        check_frames(frames, 1, f"{frames} frames")
    with atomic_path(path) as tmp, open(tmp, "x", encoding="utf-8", newline="\n") as f:
        near, total = None, 0
        for block in blocks:
            with _naming(path):
                header, values, fmt, near = _bvh_parts(block, precision, portable, near, frames)
            if total == 0:
                f.write(header)
            for start in range(0, len(values), WRITE_BLOCK):
                np.savetxt(f, values[start : start + WRITE_BLOCK], fmt=fmt, delimiter=" ")
            total += block.num_frames
        if total != frames:
            raise AdverbsError(f"{path}: {frames} frames were to be written, the blocks held {total}")
    return Path(path)


@contextlib.contextmanager
def _naming(path: str | Path) -> Iterator[None]:
    """Errors of the block (a clip the reader would refuse, a limit passed) say which file they are about."""
    try:
        yield
    except LimitError as e:
        raise LimitError(f"{path}: {e}") from None
    except AdverbsError as e:
        raise AdverbsError(f"{path}: {e}") from None


def format_bvh(clip: Clip, precision: int = 9, portable: bool = False) -> str:
    """The BVH text of ``clip``; Euler angles are unwrapped so every channel is continuous. ``portable``: see
    :func:`write_bvh`. The joints are written depth first, children in the order of their indices: a skeleton whose
    joints are not in that order (one built by hand, or from glTF) reads back with its joints in that order.

    Refuses, with an :class:`AdverbsError` saying what is wrong, a clip whose text :func:`parse_bvh` would refuse:
    a NaN or infinite rotation, translation, offset or value (naming the joint and the frame), a frame time outside
    1e-6 to 1e4 s once printed, a joint name that would not read back as itself (empty, spaces at its ends or runs
    of whitespace, a line break, ``{`` as a word), a channel that is not a BVH channel, no frames or no channels,
    and a clip past the limits of :mod:`adverbs.limits`.
    """
    header, values, fmt, _ = _bvh_parts(clip, precision, portable)
    out = io.StringIO()
    out.write(header)
    np.savetxt(out, values, fmt=fmt, delimiter=" ")
    return out.getvalue()


def _bvh_parts(
    clip: Clip, precision: int, portable: bool, near: dict | None = None, frames: int | None = None
) -> tuple[str, np.ndarray, str, dict]:
    """:func:`format_bvh`'s work: the text up to the first frame (saying ``frames`` frames, default the clip's), the
    channel values ``(F, C)`` in the file's column order, the number format, and the last frame's unwrapped angles
    (``near`` of the next block of the same motion: see :func:`write_bvh_blocks`)."""
    if isinstance(precision, bool) or not isinstance(precision, int | np.integer) or not 1 <= precision <= 17:
        raise AdverbsError(f"precision must be a whole number of significant digits from 1 to 17, got {precision!r}")
    if portable:
        from .portable import portable as make_portable

        clip = make_portable(clip).clip
    skel = clip.skeleton
    fmt = f"%.{precision}g"
    frame_time = _check_writable(clip, fmt)
    out = io.StringIO()
    out.write("HIERARCHY\n")
    children = skel.child_lists()
    sites: dict[int, list[np.ndarray]] = {}
    for p, o in zip(skel.end_site_parents, skel.end_site_offsets):
        sites.setdefault(int(p), []).append(o / skel.unit_scale)

    def vec(v) -> str:
        return " ".join(fmt % x for x in v)

    # Depth first without recursion (any depth): an entry (j, depth) opens joint j, (~j, depth) closes it. The file
    # lists the joints in that order, which is the skeleton's own when it is depth first (as every BVH file's is).
    written: list[int] = []
    stack = [(0, 0)]
    while stack:
        j, depth = stack.pop()
        pad = "\t" * min(depth, WRITE_INDENT)
        if j < 0:
            for o in sites.get(~j, []):
                out.write(f"{pad}\tEnd Site\n{pad}\t{{\n{pad}\t\tOFFSET {vec(o)}\n{pad}\t}}\n")
            out.write(f"{pad}}}\n")
            continue
        written.append(j)
        out.write(f"{pad}{'ROOT' if depth == 0 else 'JOINT'} {skel.names[j]}\n{pad}{{\n")
        out.write(f"{pad}\tOFFSET {vec(skel.offsets[j] / skel.unit_scale)}\n")
        out.write(f"{pad}\tCHANNELS {len(skel.channels[j])}{''.join(' ' + c for c in skel.channels[j])}\n")
        stack.append((~j, depth))
        stack.extend((c, depth + 1) for c in reversed(children[j]))
    values, last = _channel_values(clip, near)
    _check_finite(values, _column_joints(skel), skel, fmt, "value")
    if written != list(range(skel.num_joints)):  # the motion's columns in the joints' order in the file
        starts = np.concatenate([[0], np.cumsum([len(c) for c in skel.channels])])
        values = values[:, np.concatenate([np.arange(starts[j], starts[j + 1]) for j in written])]
    out.write(f"MOTION\nFrames: {clip.num_frames if frames is None else frames}\nFrame Time: {frame_time}\n")
    return out.getvalue(), values, fmt, last


def name_problem(name: object) -> str | None:
    """Why a joint called ``name`` would not read back from a BVH file as itself, or ``None`` when it would."""
    if not isinstance(name, str):
        return f"is a {type(name).__name__}, not a string"
    if not name:
        return "is empty"
    if "\n" in name or "\r" in name:
        return "holds a line break"
    ws = words(name)
    if " ".join(ws) != name:
        return "has whitespace at its ends, or other than single spaces between its words"
    if "{" in ws:
        return "has '{' as a word"
    if not name.isascii():
        try:
            name.encode("utf-8")
        except UnicodeEncodeError:
            return "is not valid Unicode (it holds a lone surrogate)"
    return None


def _column_joints(skel: Skeleton) -> np.ndarray:
    """The joint of each channel column, ``(C,)``."""
    return np.repeat(np.arange(skel.num_joints), [len(c) for c in skel.channels])


def _check_finite(
    values: np.ndarray, joint_of: np.ndarray, skel: Skeleton, fmt: str, what: str, frames: bool = True
) -> None:
    """Refuse ``values (F, K, ...)`` (axis 1: ``joint_of``'s joints; axis 0: frames when ``frames``) that are not
    finite, or not once printed with ``fmt``."""
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(values)
        big = np.abs(values) > 1e300  # printed to fewer digits, a value near the largest float may round up to inf
    if np.any(big & ~bad):
        for idx in zip(*np.nonzero(big & ~bad), strict=True):
            bad[idx] = not np.isfinite(float(fmt % values[idx]))
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        value = float(values[idx])
        shown = f"{value}" if not np.isfinite(value) else f"{fmt % value}, infinite once printed"
        raise AdverbsError(
            f"joint {skel.names[joint_of[idx[1]]]!r} has a non-finite {what} ({shown})"
            + (f" in frame {idx[0]} (counting from 0)" if frames else "")
            + ": a BVH file holds finite numbers only"
        )


def _check_writable(clip: Clip, fmt: str) -> str:
    """Refuse a clip whose BVH file the reader would refuse (see :func:`format_bvh`); the Frame Time as printed."""
    skel = clip.skeleton
    j = skel.num_joints
    check_joints(j, "the skeleton")
    if clip.num_frames < 1:
        raise AdverbsError("the clip has no frames: a BVH file needs at least one")
    check_frames(clip.num_frames, j, f"clip {clip.name!r}")
    for name in skel.names:
        why = name_problem(name)
        if why is not None:
            raise AdverbsError(f"joint name {name!r} {why}: it would not read back from a BVH file")
    for name, chans in zip(skel.names, skel.channels, strict=True):
        for k, c in enumerate(chans):
            if c not in _CHANNELS:
                raise AdverbsError(f"joint {name!r} has channel {c!r}; BVH channels are {', '.join(_CHANNELS)}")
            if c in chans[:k]:
                raise AdverbsError(f"joint {name!r} lists channel {c} twice")
    if not any(skel.channels):
        raise AdverbsError("the skeleton has no channels: a BVH file's frames need at least one value")
    scale = skel.unit_scale
    if not (np.isfinite(scale) and scale > 0):
        raise AdverbsError(f"unit_scale must be a positive number of metres per file unit, got {scale}")
    sp = skel.end_site_parents
    if len(sp) and not (sp.min() >= 0 and sp.max() < j):
        raise AdverbsError(f"an End Site hangs from joint {int(sp[(sp < 0) | (sp >= j)][0])}, which does not exist")
    with np.errstate(over="ignore"):
        _check_finite(skel.offsets[None] / scale, np.arange(j), skel, fmt, "OFFSET", frames=False)
        if len(sp):
            _check_finite((skel.end_site_offsets / scale)[None], sp, skel, fmt, "End Site OFFSET", frames=False)
    _check_finite(clip.rotations, np.arange(j), skel, fmt, "rotation")
    _check_finite(clip.translations, np.arange(j), skel, fmt, "translation")
    with np.errstate(divide="ignore", over="ignore"):
        text = fmt % (1.0 / clip.fps)
    frame_time = float(text)
    if not (np.isfinite(frame_time) and MIN_FRAME_TIME <= frame_time <= MAX_FRAME_TIME):
        raise AdverbsError(
            f"clip {clip.name!r} at {clip.fps:g} fps has a frame time of {text} s; a BVH file holds "
            f"{MIN_FRAME_TIME:g} to {MAX_FRAME_TIME:g} s ({1 / MAX_FRAME_TIME:g} to {1 / MIN_FRAME_TIME:g} fps)"
        )
    return text


def channel_values(clip: Clip) -> np.ndarray:
    """The BVH channel values ``(F, C)`` of ``clip``: file units and degrees, Euler angles unwrapped.

    Joints with three rotation channels are converted together, one batch per rotation order (linear in the joints,
    with few numpy calls)."""
    return _channel_values(clip, None)[0]


def _channel_values(clip: Clip, near: dict | None) -> tuple[np.ndarray, dict]:
    """:func:`channel_values`, the first frame's angles unwrapped from ``near`` (the last frame's of the block before,
    as this returns them; None: the first block), and this block's last frame's."""
    near = near or {}
    last: dict = {}
    skel = clip.skeleton
    rot, trans = clip.rotations, clip.translations
    counts = [len(c) for c in skel.channels]
    starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    values = np.empty((clip.num_frames, int(starts[-1])))
    orders = [skel.rotation_order(j) for j in range(skel.num_joints)]
    position_cols, position_joints, position_axes = [], [], []
    groups: dict[str, tuple[list[int], list[list[int]]]] = {}
    for j, chans in enumerate(skel.channels):
        rot_cols = []
        for k, c in enumerate(chans):
            if c in POSITION_CHANNELS:
                position_cols.append(starts[j] + k)
                position_joints.append(j)
                position_axes.append(POSITION_CHANNELS.index(c))
            else:
                rot_cols.append(starts[j] + k)
        if len(orders[j]) == 3:
            joints, cols = groups.setdefault(orders[j], ([], []))
            joints.append(j)
            cols.append(rot_cols)
        elif orders[j]:
            angles = _euler_for_channels(rot[:, j], orders[j], skel.names[j], near.get(j))
            last[j] = angles[-1]
            values[:, rot_cols] = np.rad2deg(angles[:, : len(orders[j])])
    for order, (joints, cols) in groups.items():
        angles = quat.unwrap_euler(order, quat.to_euler(order, rot[:, joints]), axis=0, near=near.get(order))  # (F, n, 3)
        last[order] = angles[-1]
        values[:, np.array(cols)] = np.rad2deg(angles)
    if position_cols:
        with np.errstate(over="ignore"):  # past the largest float in file units: refused by the caller
            values[:, position_cols] = trans[:, position_joints, position_axes] / skel.unit_scale
    still = [j for j in range(skel.num_joints) if not orders[j]]
    turning = ~np.all(np.isclose(np.abs(rot[:, still, 3]), 1.0, atol=1e-9), axis=0)
    if np.any(turning):
        name = skel.names[still[int(np.argmax(turning))]]
        raise AdverbsError(f"joint {name!r} has no rotation channels but the clip rotates it")
    # An axis without its position channel is read back as the offset's: the clip must not move the joint along it.
    free = np.array([[c in chans for c in POSITION_CHANNELS] for chans in skel.channels], dtype=bool).reshape(-1, 3)
    moved = ~np.all(np.isclose(trans, skel.offsets, atol=1e-9), axis=0) & ~free  # (J, 3)
    if np.any(moved):
        j, axis = (int(i) for i in np.argwhere(moved)[0])
        if not free[j].any():
            raise AdverbsError(
                f"joint {skel.names[j]!r} has no position channels but the clip moves it from its offset"
            )
        raise AdverbsError(
            f"joint {skel.names[j]!r} has no {POSITION_CHANNELS[axis]} channel but the clip moves it along "
            f"{'xyz'[axis]} from its offset"
        )
    return values, last


def _euler_for_channels(q: np.ndarray, order: str, name: str, near: np.ndarray | None = None) -> np.ndarray:
    """Unwrapped Euler angles ``(F, 3)`` in radians, the channels' first (the first frame's unwrapped from ``near``,
    the previous frame's angles as this returns them); joints with fewer than 3 axes must not need more.

    With fewer channels, the missing axes are appended and, of the two Tait–Bryan solutions, the one
    whose extra angles are nearest zero (mod 2π) is kept.
    """
    full = order + "".join(a for a in "XYZ" if a not in order)
    angles = quat.to_euler(full, q)
    if len(order) < 3:
        alt = np.stack([angles[:, 0] + np.pi, np.pi - angles[:, 1], angles[:, 2] + np.pi], axis=-1)
        wrap = lambda x: np.abs(np.angle(np.exp(1j * x)))  # noqa: E731 - distance from 0 mod 2π
        use_alt = wrap(alt[:, len(order) :]).max(axis=1) < wrap(angles[:, len(order) :]).max(axis=1)
        angles = np.where(use_alt[:, None], alt, angles)
        extra = wrap(angles[:, len(order) :]).max(initial=0.0)
        if extra > 1e-7:
            raise AdverbsError(f"joint {name!r} has only channels {order} but the clip rotates it about other axes")
        angles[:, len(order) :] = 0.0
    return quat.unwrap_euler(full, angles, axis=0, near=near)
