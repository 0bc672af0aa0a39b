"""BVH reading and writing.

Reads any channel order, 0–6 channels on any joint (position channels on non-root joints replace
that joint's offset, as Blender reads them), End Sites, tabs, CRLF and blank lines. Lengths are
converted to metres; the file's unit is recorded on the skeleton and restored on writing. Every
fault raises :class:`~adverbs.errors.BVHError` naming the file and the line.
"""

from __future__ import annotations

import io
import itertools
from pathlib import Path

import numpy as np

from ..errors import AdverbsError, BVHError
from ..kinematics import quat
from ..kinematics.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton
from ..motion.clip import Clip
from .files import write_atomic

UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
_CHANNELS = POSITION_CHANNELS + ROTATION_CHANNELS
_CHANNEL_LOOKUP = {c.lower(): c for c in _CHANNELS}


def read_bvh(path: str | Path, units: str | float = "auto") -> Clip:
    """Read a BVH file into a :class:`Clip` (metres, radians inside).

    ``units`` names the file's length unit (``"cm"``, ``"m"``, ``"mm"``, ``"in"``, ``"ft"``), gives
    metres per file unit as a number, or is ``"auto"``: guessed from the figure's size in the first
    frame (under 5 units tall: metres; under 500: centimetres; else millimetres).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig", errors="strict")
    except UnicodeDecodeError as e:
        raise BVHError(f"not a text file ({e.reason} at byte {e.start})", path) from None
    except OSError as e:
        raise BVHError(f"cannot read: {e.strerror}", path) from None
    return parse_bvh(text, units=units, source=path)


def parse_bvh(text: str, units: str | float = "auto", source: str | Path | None = None) -> Clip:
    """Parse BVH text; ``source`` names it in errors and becomes the clip's name."""
    lines = text.splitlines()
    parser = _HierarchyParser(lines, source)
    names, parents, offsets, channels, sites, motion_line = parser.parse()
    frame_count, frame_time, time_text, values = _parse_motion(
        lines, motion_line, sum(len(c) for c in channels), source
    )
    if frame_count < 1:
        raise BVHError("the file has no frames (Frames: 0)", source, motion_line + 2)

    raw_offsets = np.array(offsets, dtype=float)
    site_parents = np.array([p for p, _ in sites], dtype=np.int64)
    site_offsets = np.array([o for _, o in sites], dtype=float).reshape(-1, 3)
    parents_arr = np.array(parents, dtype=np.int64)
    rotations, raw_translations = _channels_to_arrays(values, raw_offsets, channels)

    if isinstance(units, str) and units == "auto":
        # The median bone of a person is 0.05–0.4 m whatever the file's placement of the figure.
        bones = np.linalg.norm(np.concatenate([raw_offsets[1:], site_offsets]), axis=1)
        typical = float(np.median(bones[bones > 0])) if np.any(bones > 0) else 1.0
        units = "m" if typical < 0.5 else "cm" if typical < 50.0 else "mm"
    scale, unit_name = _unit_scale(units)
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
    """Recursive descent over the HIERARCHY tokens, keeping each token's line number."""

    def __init__(self, lines: list[str], source: str | Path | None):
        self.source = source
        self.tokens: list[tuple[str, int]] = []
        self.motion_line = -1
        for i, line in enumerate(lines):
            words = line.split()
            if words and words[0].upper() == "MOTION":
                self.motion_line = i
                break
            self.tokens.extend((w, i + 1) for w in words)
        self.pos = 0
        self.last_line = len(lines)
        self.names: list[str] = []
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
        self.joint(-1, line)
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

    def joint(self, parent: int, line: int) -> None:
        words = []
        while self.pos < len(self.tokens) and self.tokens[self.pos][1] == line and self.tokens[self.pos][0] != "{":
            words.append(self.tokens[self.pos][0])
            self.pos += 1
        if not words:
            raise self.error("a joint needs a name", line)
        name = " ".join(words)
        if name in self.names:
            raise self.error(f"joint name {name!r} is used twice", line)
        index = len(self.names)
        self.names.append(name)
        self.parents.append(parent)
        self.offsets.append([0.0, 0.0, 0.0])
        self.channels.append([])
        self.expect("{")
        seen_offset = False
        while True:
            if self.pos >= len(self.tokens):
                raise self.error(
                    f"unbalanced braces: joint {name!r} opened at line {line} is never closed", self.last_line
                )
            tok, tline = self.next("a joint's contents")
            key = tok.upper()
            if key == "}":
                break
            if key == "OFFSET":
                self.offsets[index] = self.numbers(3, f"OFFSET of {name!r}")
                seen_offset = True
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
                self.joint(index, tline)
            elif key == "END":
                self.expect("Site")
                self.expect("{")
                self.expect("OFFSET")
                self.sites.append((index, self.numbers(3, f"End Site OFFSET of {name!r}")))
                self.expect("}")
            else:
                raise self.error(f"unexpected {tok!r} in joint {name!r}", tline)
        if not seen_offset:
            raise self.error(f"joint {name!r} has no OFFSET", line)


def _parse_motion(
    lines: list[str], motion_line: int, num_channels: int, source: str | Path | None
) -> tuple[int, float, str, np.ndarray]:
    header: dict[str, tuple[str, int]] = {}
    i = motion_line + 1
    while i < len(lines) and len(header) < 2:
        text = lines[i].strip()
        i += 1
        if not text:
            continue
        key, sep, value = text.partition(":")
        key = " ".join(key.split()).lower()
        if not sep or key not in ("frames", "frame time"):
            raise BVHError(f"expected 'Frames:' and 'Frame Time:' after MOTION, found {text[:40]!r}", source, i)
        header[key] = (value.strip(), i)
    for key in ("frames", "frame time"):
        if key not in header:
            raise BVHError(f"MOTION section has no '{key.title()}:' line", source, i)
    frames_text, frames_line = header["frames"]
    try:
        frame_count = int(frames_text)
        if frame_count < 0:
            raise ValueError
    except ValueError:
        raise BVHError(f"Frames: {frames_text!r} is not a frame count", source, frames_line) from None
    time_text, time_line = header["frame time"]
    try:
        frame_time = float(time_text)
    except ValueError:
        raise BVHError(f"Frame Time: {time_text!r} is not a number", source, time_line) from None
    if not (np.isfinite(frame_time) and 1e-6 <= frame_time <= 1e4):
        raise BVHError(
            f"Frame Time must be a positive number of seconds (1e-6 to 1e4), got {time_text!r}", source, time_line
        )

    rows = []
    numbers = []
    for n in range(i, len(lines)):
        words = lines[n].split()
        if words:
            if len(words) != num_channels:
                kind = "truncated motion: " if n == len(lines) - 1 and len(words) < num_channels else ""
                raise BVHError(
                    f"{kind}frame {len(rows) + 1} has {len(words)} values, the hierarchy has {num_channels} channels",
                    source,
                    n + 1,
                )
            rows.append(n + 1)
            numbers.append(words)
    if len(rows) != frame_count:
        if len(rows) < frame_count:
            raise BVHError(
                f"truncated motion: 'Frames: {frame_count}' but the file ends after {len(rows)} frames",
                source,
                len(lines),
            )
        raise BVHError(
            f"'Frames: {frame_count}' (line {frames_line}) but frame {frame_count + 1} follows",
            source,
            rows[frame_count],
        )
    try:
        values = np.array(list(itertools.chain.from_iterable(numbers)), dtype=float)
    except ValueError:
        values = None
    if values is None or not np.all(np.isfinite(values)):
        for line_no, words in zip(rows, numbers):
            for w in words:
                try:
                    ok = np.isfinite(float(w))
                except ValueError:
                    ok = False
                if not ok:
                    raise BVHError(f"{w!r} is not a finite number", source, line_no)
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

    The file is written whole or not at all: a failed write leaves what was at ``path`` as it was.
    """
    write_atomic(path, format_bvh(clip, precision, portable).encode("utf-8"))


def format_bvh(clip: Clip, precision: int = 9, portable: bool = False) -> str:
    """The BVH text of ``clip``; Euler angles are unwrapped so every channel is continuous. ``portable``: see
    :func:`write_bvh`."""
    if portable:
        from .portable import portable as make_portable

        clip = make_portable(clip).clip
    skel = clip.skeleton
    out = io.StringIO()
    out.write("HIERARCHY\n")
    children = [skel.children(j) for j in range(skel.num_joints)]
    sites = {int(p): [] for p in skel.end_site_parents}
    for p, o in zip(skel.end_site_parents, skel.end_site_offsets):
        sites[int(p)].append(o / skel.unit_scale)
    fmt = f"%.{precision}g"

    def vec(v) -> str:
        return " ".join(fmt % x for x in v)

    def joint(j: int, depth: int) -> None:
        pad = "\t" * depth
        out.write(f"{pad}{'ROOT' if depth == 0 else 'JOINT'} {skel.names[j]}\n{pad}{{\n")
        out.write(f"{pad}\tOFFSET {vec(skel.offsets[j] / skel.unit_scale)}\n")
        out.write(f"{pad}\tCHANNELS {len(skel.channels[j])}{''.join(' ' + c for c in skel.channels[j])}\n")
        for c in children[j]:
            joint(c, depth + 1)
        for o in sites.get(j, []):
            out.write(f"{pad}\tEnd Site\n{pad}\t{{\n{pad}\t\tOFFSET {vec(o)}\n{pad}\t}}\n")
        out.write(f"{pad}}}\n")

    joint(0, 0)
    values = channel_values(clip)
    out.write(f"MOTION\nFrames: {clip.num_frames}\nFrame Time: {fmt % (1.0 / clip.fps)}\n")
    np.savetxt(out, values, fmt=fmt, delimiter=" ")
    return out.getvalue()


def channel_values(clip: Clip) -> np.ndarray:
    """The BVH channel values ``(F, C)`` of ``clip``: file units and degrees, Euler angles unwrapped."""
    skel = clip.skeleton
    cols = []
    for j, chans in enumerate(skel.channels):
        order = skel.rotation_order(j)
        angles = _euler_for_channels(clip.rotations[:, j], order, skel.names[j]) if order else None
        r = 0
        for c in chans:
            if c in POSITION_CHANNELS:
                cols.append(clip.translations[:, j, POSITION_CHANNELS.index(c)] / skel.unit_scale)
            else:
                cols.append(np.rad2deg(angles[:, r]))
                r += 1
        if not order and not np.allclose(np.abs(clip.rotations[:, j, 3]), 1.0, atol=1e-9):
            raise AdverbsError(f"joint {skel.names[j]!r} has no rotation channels but the clip rotates it")
        if not skel.has_position_channels(j) and not np.allclose(clip.translations[:, j], skel.offsets[j], atol=1e-9):
            raise AdverbsError(
                f"joint {skel.names[j]!r} has no position channels but the clip moves it from its offset"
            )
    return np.stack(cols, axis=1) if cols else np.zeros((clip.num_frames, 0))


def _euler_for_channels(q: np.ndarray, order: str, name: str) -> np.ndarray:
    """Unwrapped Euler angles ``(F, len(order))`` in radians; joints with fewer than 3 axes must not need more.

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
    return quat.unwrap_euler(full, angles, axis=0)[:, : len(order)]
