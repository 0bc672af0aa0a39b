"""BVH files that are hostile or damaged, and clips the writer must not write: every one is read, or refused with an
error naming the file and the line (or the field), in bounded time and memory; what the writer writes, the reader
reads, and what it refuses leaves the old file as it was (issue 14)."""

from __future__ import annotations

import math
import sys
import time
import tracemalloc
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import BANDAI, CMU, aligned
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from adverbs import Clip, format_bvh, parse_bvh, read_bvh, write_bvh
from adverbs.errors import AdverbsError, BVHError
from adverbs.io import bvh as bvh_module
from adverbs.kinematics import skeleton as skeleton_module
from adverbs.limits import BYTES_PER_JOINT_FRAME, LIMITS, LimitError

FUZZ = settings(
    derandomize=True, database=None, deadline=None, max_examples=150,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)  # fmt: skip


def chain_bvh(n: int, frames: int = 2, first_channels: int = 6, sides: bool = False) -> str:
    """A chain of ``n`` joints, each the child of the one before; ``sides``: the last two are named as feet."""
    names = ["Hips"] + [f"j{i}" for i in range(1, n)]
    if sides:
        names[-2:] = ["LeftFoot", "RightFoot"]
    out = ["HIERARCHY"]
    for i, name in enumerate(names):
        chans = (
            "6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"
            if i == 0
            else "3 Zrotation Xrotation Yrotation"
        )
        out += [f"{'ROOT' if i == 0 else 'JOINT'} {name}", "{", "OFFSET 0 1 0", f"CHANNELS {chans}"]
    out += ["End Site", "{", "OFFSET 0 1 0", "}"] + ["}"] * n
    out += ["MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    out += [" ".join(["0"] * (6 + 3 * (n - 1)))] * frames
    return "\n".join(out) + "\n"


def wide_bvh(n: int, frames: int = 3) -> str:
    """A root with ``n - 1`` children named as left and right feet (every one has a twin): the most sides to find."""
    out = [
        "HIERARCHY",
        "ROOT Hips",
        "{",
        "OFFSET 0 0 0",
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
    ]
    for i in range(n - 1):
        name = f"{'Left' if i % 2 == 0 else 'Right'}Foot{i // 2}"
        out += [
            f"JOINT {name}",
            "{",
            f"OFFSET {1 if i % 2 == 0 else -1} 0 0",
            "CHANNELS 3 Zrotation Xrotation Yrotation",
        ]
        out += ["End Site", "{", "OFFSET 0 -1 0", "}", "}"]
    out += ["}", "MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    out += [" ".join(["0"] * (6 + 3 * (n - 1)))] * frames
    return "\n".join(out) + "\n"


def short(path: Path, frames: int = 3) -> str:
    """The text of a shipped file cut to its first ``frames`` frames (the fuzz cases stay small)."""
    lines = path.read_text().splitlines()
    m = next(i for i, line in enumerate(lines) if line.strip().upper() == "MOTION")
    return "\n".join(lines[: m + 1] + [f"Frames: {frames}", lines[m + 2]] + lines[m + 3 : m + 3 + frames]) + "\n"


def assert_finite(clip: Clip) -> None:
    skel = clip.skeleton
    for array in (clip.rotations, clip.translations, skel.offsets, skel.end_site_offsets):
        assert np.all(np.isfinite(array))
    assert math.isfinite(clip.fps) and clip.fps > 0


def refused(call, *words, kind=AdverbsError) -> AdverbsError:
    with pytest.raises(kind) as info:
        call()
    for w in words:
        assert w in str(info.value), str(info.value)
    return info.value


# ----- 1. depth, joints and frames ------------------------------------------------------------------------------


def test_a_chain_thousands_deep_reads_writes_and_reads_back(tmp_path):
    n = 3000  # the recursive reader and writer stopped at 990
    clip = parse_bvh(chain_bvh(n))
    assert clip.skeleton.num_joints == n and clip.skeleton.parents[-1] == n - 2
    path = tmp_path / "deep.bvh"
    write_bvh(clip, path)
    again = read_bvh(path)
    assert again.skeleton.names == clip.skeleton.names
    assert np.array_equal(again.skeleton.parents, clip.skeleton.parents)
    # Indentation stops at WRITE_INDENT tabs: the file grows linearly with the depth.
    assert (
        max(len(line) - len(line.lstrip("\t")) for line in path.read_text().splitlines()) <= bvh_module.WRITE_INDENT + 2
    )
    assert path.stat().st_size < 400 * n  # indented fully: 4 lines × 1,500 tabs a joint on average


def test_no_recursion_left_in_the_reader_and_writer():
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(200)  # far below the depth: any recursion over joints would fail
    try:
        clip = parse_bvh(chain_bvh(400))
        text = format_bvh(clip)
    finally:
        sys.setrecursionlimit(limit)
    assert parse_bvh(text).skeleton.num_joints == 400


def test_more_joints_than_the_limit_is_refused_at_the_first_joint_past_it(tmp_path, monkeypatch):
    monkeypatch.setattr(LIMITS, "joints", 50)
    path = tmp_path / "many.bvh"
    path.write_text(chain_bvh(60))
    err = refused(lambda: read_bvh(path), str(path), "60 joints", "limit is 50", "ADVERBS_MAX_JOINTS", kind=BVHError)
    assert isinstance(err, LimitError)
    assert err.line == 2 + 4 * 50  # the line of joint 51
    parse_bvh(chain_bvh(50))  # at the limit: read
    clip = parse_bvh(chain_bvh(50))
    monkeypatch.setattr(LIMITS, "joints", 49)
    refused(lambda: write_bvh(clip, tmp_path / "out.bvh"), "out.bvh", "50 joints", kind=LimitError)
    assert not (tmp_path / "out.bvh").exists()


def _with_frames(text: str, frames_line: str) -> str:
    return "\n".join(frames_line if line.startswith("Frames:") else line for line in text.splitlines()) + "\n"


@pytest.mark.parametrize("count", ["1000000000", "9" * 400, "9" * 5000, "+300000"])
def test_a_file_claiming_too_many_frames_is_refused_before_its_numbers_are_read(tmp_path, count):
    text = _with_frames(chain_bvh(3), f"Frames: {count}")
    text = text.replace("\n0 0 0", "\nnot a number 0 0", 1)  # had the numbers been read, this would be the error
    path = tmp_path / "long.bvh"
    path.write_text(text)
    frames_line = text.splitlines().index(f"Frames: {count}") + 1
    start = time.perf_counter()
    err = refused(lambda: read_bvh(path), str(path), "frames", "ADVERBS_MAX_FRAMES", kind=BVHError)
    assert time.perf_counter() - start < 1.0
    assert isinstance(err, LimitError) and err.line == frames_line


def test_frames_past_the_memory_limit_are_refused_naming_the_frames_line(monkeypatch):
    monkeypatch.setattr(LIMITS, "memory", 300 * 3 * BYTES_PER_JOINT_FRAME - 1)  # 300 frames of 3 joints pass it
    text = chain_bvh(3, frames=300)
    err = refused(
        lambda: parse_bvh(text, source="big.bvh"),
        "big.bvh",
        "300 frames of 3 joints",
        "ADVERBS_MAX_MEMORY",
        kind=LimitError,
    )
    assert err.line == text.splitlines().index("Frames: 300") + 1


def test_a_file_bigger_than_the_memory_limit_allows_is_not_read(tmp_path, monkeypatch):
    path = tmp_path / "huge.bvh"
    path.write_text(chain_bvh(3, frames=2000))
    monkeypatch.setattr(LIMITS, "memory", bvh_module.READ_COST * 1000)
    refused(lambda: read_bvh(path), str(path), "memory limit", "ADVERBS_MAX_MEMORY", kind=LimitError)


def test_frames_zero_negative_and_malformed(tmp_path):
    base = chain_bvh(2)
    line = base.splitlines().index("Frames: 2") + 1
    for count, why in (
        ("0", "no frames"),
        ("-3", "not a frame count"),
        ("3.0", "not a frame count"),
        ("١", "not a frame count"),
    ):
        err = refused(lambda c=count: parse_bvh(_with_frames(base, f"Frames: {c}"), source="x.bvh"), why, kind=BVHError)
        assert err.line == line, (count, str(err))


# ----- 2. line numbers ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "odd",
    ["\x0c", "\u2028", "\u2029", "\x85", "\x0b", "\x1c", "\xa0"],
    ids=["ff", "u2028", "u2029", "nel", "vt", "fs", "nbsp"],
)
def test_line_numbers_are_counted_as_editors_count_them(odd, tmp_path):
    lines = chain_bvh(3).splitlines()
    lines[1] = f"ROOT Hips{odd}"  # an odd character on line 2
    bad = lines.index("OFFSET 0 1 0", 5) + 1  # the second joint's OFFSET, below it
    lines[bad - 1] = "OFFSET 0 1 oops"
    path = tmp_path / "odd.bvh"
    path.write_bytes("\n".join(lines).encode())
    err = refused(lambda: read_bvh(path), "'oops' is not a number", kind=BVHError)
    assert err.line == bad and f"{path}:{bad}:" in str(err)


def test_a_lone_carriage_return_and_crlf_end_lines():
    lines = chain_bvh(3).splitlines()
    bad = lines.index("OFFSET 0 1 0", 5) + 1
    lines[bad - 1] = "OFFSET 0 1 oops"
    mixed = "".join(line + ("\r" if i % 3 == 0 else "\r\n" if i % 3 == 1 else "\n") for i, line in enumerate(lines))
    err = refused(lambda: parse_bvh(mixed), "'oops'", kind=BVHError)
    assert err.line == bad


def test_odd_characters_inside_a_line():
    """Words are split at ASCII whitespace only: a U+2028 or a no-break space is part of a word, so a number
    holding one is not a number (on its own line), and a joint name holding one keeps it."""
    text = chain_bvh(3).replace("ROOT Hips", "ROOT Hips\u2028Top").replace("JOINT j1", "JOINT left\xa0hip")
    clip = parse_bvh(text)
    assert clip.skeleton.names[:2] == ("Hips\u2028Top", "left\xa0hip")
    assert parse_bvh(format_bvh(clip)).skeleton.names == clip.skeleton.names
    # a form feed is ASCII whitespace: between words it separates them, as a tab would
    assert parse_bvh(text.replace("OFFSET 0 1 0", "OFFSET\x0c0 1\x0b0", 1)).skeleton.num_joints == 3
    lines = text.split("\n")[:-1]  # not splitlines: it breaks at U+2028
    row = len(lines)  # the last frame
    for word in ("1\u2028", "١", "1_0", "０"):
        damaged = "\n".join(lines[:-1] + [lines[-1].replace("0", word, 1)]) + "\n"
        err = refused(lambda d=damaged: parse_bvh(d), "not a finite number", kind=BVHError)
        assert err.line == row
    err = refused(
        lambda: parse_bvh(text.replace("OFFSET 0 1 0", "OFFSET 0 1 0\u2028", 1)), "not a number", kind=BVHError
    )
    assert err.line == 4


# ----- 3. adverbs info on thousands of joints -------------------------------------------------------------------


def _calls(fn) -> int:
    """Python function calls made by ``fn()``: the work, whatever the machine's speed."""
    count = 0

    def profile(frame, event, arg):
        nonlocal count
        if event == "call":
            count += 1

    sys.setprofile(profile)
    try:
        fn()
    finally:
        sys.setprofile(None)
    return count


@pytest.mark.parametrize("shape", [wide_bvh, lambda n: chain_bvh(n, sides=True)], ids=["wide", "chain"])
def test_info_is_linear_in_the_joints(shape, tmp_path):
    from adverbs.apps.cli import info

    work = {}
    for n in (500, 1000, 2000):
        path = tmp_path / f"{n}.bvh"
        path.write_text(shape(n))
        start = time.perf_counter()
        clip = read_bvh(path)
        report = info(clip, path)
        assert time.perf_counter() - start < 10.0  # was 29 s for 2,000 joints; now well under one
        assert len(report["joints"]) == n and set(report["feet"]) == {"left", "right"}
        work[n] = _calls(lambda p=path: info(read_bvh(p), p))
    # Twice the joints, about twice the work (the quadratic version: four times, 20 million calls at 2,000).
    assert work[2000] < 2.4 * work[1000] and work[1000] < 2.4 * work[500], work
    assert work[2000] < 200 * 2000, work


def test_sides_and_feet_are_found_once_per_skeleton(monkeypatch):
    clip = parse_bvh(wide_bvh(400))
    calls = 0
    swap = skeleton_module._swap_side

    def counting(*args):
        nonlocal calls
        calls += 1
        return swap(*args)

    monkeypatch.setattr(skeleton_module, "_swap_side", counting)
    skel = clip.skeleton
    sides = [skel.side(j) for j in range(skel.num_joints)]
    skel.feet(), skel.body_root(), skel.mirror_map(), skel.mirror_frames()
    assert sides.count("left") == sides.count("right") == 199
    assert calls <= len(skeleton_module._SIDE_RULES) * skel.num_joints
    assert skel.children(0) == list(range(1, 400)) and skel.child_lists()[5] == []
    assert skel.below(0).all() and skel.below(3).sum() == 1


# ----- 4. the writer writes only what the reader reads ----------------------------------------------------------


@pytest.fixture
def small():
    return parse_bvh(short(CMU / "16_15_walk.bvh", 4), source="walk.bvh")


def _old_file(tmp_path) -> Path:
    out = tmp_path / "out.bvh"
    out.write_text("the old file\n")
    return out


def _unchanged(out: Path) -> None:
    assert out.read_text() == "the old file\n"
    assert sorted(p.name for p in out.parent.iterdir()) == ["out.bvh"]  # no temporary file left either


def test_non_finite_values_are_refused_naming_the_joint_and_the_frame(small, tmp_path):
    out = _old_file(tmp_path)
    names = small.skeleton.names
    rot = small.rotations.copy()
    rot[2, 5] = np.nan
    refused(
        lambda: write_bvh(small.replace(rotations=rot), out),
        str(out),
        f"joint {names[5]!r}",
        "rotation",
        "nan",
        "frame 2",
    )
    trans = small.translations.copy()
    trans[3, 0, 1] = np.inf
    refused(
        lambda: write_bvh(small.replace(translations=trans), out),
        str(out),
        f"joint {names[0]!r}",
        "translation",
        "inf",
        "frame 3",
    )
    huge = small.translations.copy()
    huge[1, 0, 0] = 1.7e308  # finite in metres, infinite in the file's centimetres
    refused(
        lambda: write_bvh(small.replace(translations=huge), out),
        str(out),
        f"joint {names[0]!r}",
        "non-finite value",
        "frame 1",
    )
    offsets = small.skeleton.offsets.copy()
    offsets[4, 2] = np.nan
    bad = small.replace(skeleton=replace(small.skeleton, offsets=offsets))
    refused(lambda: write_bvh(bad, out), str(out), f"joint {names[4]!r}", "OFFSET")
    _unchanged(out)


@pytest.mark.parametrize("fps", [1e-5, 9e-5, 1.00001e6, 1e9, 1e300])
def test_frame_rates_a_bvh_file_cannot_hold_are_refused(small, tmp_path, fps):
    out = _old_file(tmp_path)
    clip = Clip(small.skeleton, small.rotations, small.translations, fps, "walk")
    refused(lambda: write_bvh(clip, out), str(out), "frame time", "1e-06 to 10000 s")
    _unchanged(out)


@pytest.mark.parametrize("fps", [1e-4, 0.5, 30, 1e6])
def test_frame_rates_at_the_ends_round_trip(small, tmp_path, fps):
    clip = Clip(small.skeleton, small.rotations, small.translations, fps, "walk")
    write_bvh(clip, tmp_path / "a.bvh")
    assert read_bvh(tmp_path / "a.bvh").fps == pytest.approx(fps, rel=1e-8)


@pytest.mark.parametrize(
    "name, why",
    [
        ("", "is empty"),
        (" lhip", "whitespace"),
        ("lhip ", "whitespace"),
        ("left  hip", "whitespace"),
        ("left\thip", "whitespace"),
        ("left\nhip", "line break"),
        ("left\rhip", "line break"),
        ("a { b", "'{' as a word"),
        ("{", "'{' as a word"),
        ("bad\ud800", "lone surrogate"),
    ],
)
def test_joint_names_that_would_not_read_back_are_refused(small, tmp_path, name, why):
    out = _old_file(tmp_path)
    names = list(small.skeleton.names)
    names[3] = name
    clip = small.replace(skeleton=replace(small.skeleton, names=tuple(names)))
    refused(lambda: write_bvh(clip, out), str(out), "joint name", why)
    _unchanged(out)


def test_names_that_read_back_are_written(small, tmp_path):
    names = list(small.skeleton.names)
    names[1:5] = ["left hip", "a}b", "Hüfte\u2028links", "x{"]
    clip = small.replace(skeleton=replace(small.skeleton, names=tuple(names)))
    write_bvh(clip, tmp_path / "a.bvh")
    assert read_bvh(tmp_path / "a.bvh").skeleton.names == tuple(names)


def test_other_clips_the_reader_would_refuse(small, tmp_path):
    out = _old_file(tmp_path)
    skel = small.skeleton
    empty = Clip(skel, small.rotations[:0], small.translations[:0], 30.0, "none")
    refused(lambda: write_bvh(empty, out), str(out), "no frames")
    channels = list(skel.channels)
    channels[2] = ("Zrotation", "Wrotation", "Yrotation")
    refused(lambda: write_bvh(small.replace(skeleton=replace(skel, channels=tuple(channels))), out), "'Wrotation'")
    channels[2] = ("Zrotation", "Zrotation", "Yrotation")
    refused(lambda: write_bvh(small.replace(skeleton=replace(skel, channels=tuple(channels))), out), "Zrotation twice")
    still = replace(skel, channels=((),) * skel.num_joints)
    ident = np.broadcast_to(np.array([0.0, 0, 0, 1]), small.rotations.shape)
    offsets = np.broadcast_to(skel.offsets, small.translations.shape)
    refused(lambda: write_bvh(Clip(still, ident, offsets, 30.0), out), "no channels")
    refused(lambda: write_bvh(small, out, precision=0), "precision")
    refused(lambda: write_bvh(small, out, precision=True), "precision")
    _unchanged(out)


def _skeletons(draw) -> tuple:
    n = draw(st.integers(1, 5))
    parents = [-1] + [draw(st.integers(0, j - 1)) for j in range(1, n)]
    text = st.text(st.characters(codec="utf-8", exclude_categories=["Cs"]), min_size=1, max_size=6)
    name = st.one_of(
        st.sampled_from(["hip", "Left Leg", "a}", "x y z", "Ünïcødé", "a\u2028b", "knee", "toe", "L", "neck"]),
        text.filter(lambda t: bvh_module.name_problem(t) is None),
    )
    if draw(st.integers(0, 3)) == 0:  # a quarter of the skeletons: names that may not read back
        name = st.one_of(
            name, st.sampled_from(["tab\there", " pad", "", "{", "a { b", "two  spaces", "line\nbreak"]), text
        )
    names = draw(st.lists(name, min_size=n, max_size=n, unique=True))
    chans = st.lists(st.sampled_from(bvh_module._CHANNELS), max_size=6, unique=True).map(tuple)
    channels = tuple(draw(chans) for _ in range(n))
    return names, parents, channels


@st.composite
def clips(draw):
    names, parents, channels = _skeletons(draw)
    n = len(names)
    frames = draw(st.sampled_from([2, 1, 3, 2, 1, 3, 0]))
    number = st.floats(-360, 360)
    if draw(st.integers(0, 2)) == 0:  # a third of the clips: some hostile numbers
        number = st.one_of(number, st.sampled_from([1e300, -1.7e308, np.nan, np.inf, 1e-300]), st.floats())
    offsets = np.array(draw(st.lists(number, min_size=3 * n, max_size=3 * n))).reshape(n, 3)
    skel = skeleton_module.Skeleton(
        tuple(names), np.array(parents), offsets, channels, np.zeros(0, dtype=int), np.zeros((0, 3)),
        unit_scale=draw(st.sampled_from([1.0, 0.01, 1e-300])),
    )  # fmt: skip
    # Rotations about the joints' own channels' axes only (others cannot be written), sometimes not finite.
    angles = np.array(draw(st.lists(number, min_size=3 * n * frames, max_size=3 * n * frames))).reshape(frames, n, 3)
    from adverbs.kinematics import quat

    rot = np.empty((frames, n, 4))
    for j in range(n):
        order = skel.rotation_order(j)
        if order:
            with np.errstate(all="ignore"):
                rot[:, j] = quat.from_euler(order, np.deg2rad(angles[:, j, : len(order)]))
        else:
            rot[:, j] = [0, 0, 0, 1]
    trans = np.broadcast_to(skel.offsets, (frames, n, 3)).copy()
    for j in range(n):  # along the axes of the joint's position channels only (others cannot be written)
        for axis, c in enumerate(("Xposition", "Yposition", "Zposition")):
            if c in channels[j]:
                trans[:, j, axis] = draw(st.lists(number, min_size=frames, max_size=frames))
    fps = draw(st.one_of(st.sampled_from([30.0, 1e-5, 1e-4, 1e6, 1e9, 7.3]), st.floats(1e-7, 1e8)))
    return Clip(skel, rot, trans, fps, "fuzz")


@FUZZ
@given(clip=clips(), precision=st.integers(1, 17))
def test_what_the_writer_writes_the_reader_reads(clip, precision, tmp_path_factory):
    folder = tmp_path_factory.mktemp("rt")
    out = folder / "out.bvh"
    out.write_text("the old file\n")
    try:
        write_bvh(clip, out, precision=precision)
    except AdverbsError as e:
        assert str(out) in str(e)
        _unchanged(out)
        event("refused")
        return
    event("written")
    again = read_bvh(out, units=clip.skeleton.unit_scale)
    assert_finite(again)
    skel, back = clip.skeleton, again.skeleton
    order = [skel.index(name) for name in back.names]  # the file lists the joints depth first
    assert sorted(order) == list(range(skel.num_joints)) and order == _depth_first(skel.parents)
    assert [skel.names[skel.parents[j]] if j else None for j in order] == [
        back.names[p] if p >= 0 else None for p in back.parents
    ]
    assert back.channels == tuple(skel.channels[j] for j in order)
    assert again.num_frames == clip.num_frames
    if precision >= 7 and np.abs(clip.translations).max(initial=0) < 1e6 and skel.unit_scale == 1.0:
        # The motion too, joint by joint (a skeleton not depth first once had its columns written in index order).
        np.testing.assert_allclose(again.translations, clip.translations[:, order], rtol=0, atol=1e-4)
        np.testing.assert_allclose(
            aligned(again.rotations, clip.rotations[:, order]), clip.rotations[:, order], atol=1e-4
        )


def _depth_first(parents) -> list[int]:
    children = [[] for _ in parents]
    for j, p in enumerate(parents[1:], start=1):
        children[p].append(j)
    out, stack = [], [0]
    while stack:
        j = stack.pop()
        out.append(j)
        stack.extend(reversed(children[j]))
    return out


def test_a_skeleton_not_in_depth_first_order_is_written_with_its_motion(tmp_path):
    """Joints root, a, b, c with c hanging from a: the file lists root, a, c, b, and their channel values so."""
    from adverbs.kinematics import quat

    skel = skeleton_module.Skeleton(
        ("root", "a", "b", "c"), np.array([-1, 0, 0, 1]), np.array([[0, 0, 0], [1.0, 0, 0], [-1, 0, 0], [0, 1, 0]]),
        (bvh_module._CHANNELS, ("Zrotation", "Xrotation", "Yrotation"), ("Yrotation",), ("Xposition", "Xrotation")),
        np.zeros(0, dtype=int), np.zeros((0, 3)),
    )  # fmt: skip
    angles = np.deg2rad([[[10, 20, 30], [40, 50, 60], [0, 70, 0], [80, 0, 0]]] * 2)
    rot = np.stack(
        [quat.from_euler(order, angles[:, j]) for j, order in enumerate(["XYZ", "XYZ", "XYZ", "XYZ"])], axis=1
    )
    trans = np.broadcast_to(skel.offsets, (2, 4, 3)).copy()
    trans[:, 0] = [[1, 2, 3], [4, 5, 6]]
    trans[:, 3, 0] = [0.5, 0.25]
    clip = Clip(skel, rot, trans, 30.0)
    write_bvh(clip, tmp_path / "a.bvh")
    again = read_bvh(tmp_path / "a.bvh", units="m")
    order = [0, 1, 3, 2]
    assert again.skeleton.names == ("root", "a", "c", "b")
    np.testing.assert_allclose(again.translations, trans[:, order], atol=1e-8)
    np.testing.assert_allclose(aligned(again.rotations, rot[:, order]), rot[:, order], atol=1e-8)


def test_a_position_channel_missing_on_an_axis_the_clip_moves_is_refused(small, tmp_path):
    skel = small.skeleton
    channels = list(skel.channels)
    channels[0] = ("Xposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")  # the root, without Yposition
    clip = small.replace(skeleton=replace(skel, channels=tuple(channels)))
    refused(lambda: format_bvh(clip), f"joint {skel.names[0]!r} has no Yposition channel", "along y")


# ----- 6a. the reader on damaged files --------------------------------------------------------------------------

SOURCES = {"cmu": short(CMU / "16_15_walk.bvh"), "bandai": short(BANDAI / "dataset-1_walk_normal_001.bvh", 2)}
HOSTILE = [
    "1e308", "-1e308", "1e309", "9" * 400, "-1", "0", "-0", "nan", "-inf", "inf", "1e-400", "99999999999999", "{", "}",
    "JOINT", "ROOT", "End", "Site", "MOTION", "Frames:", "CHANNELS", "OFFSET", "7", "6", "\u2028", "\x0c", "١", "1_0",
    "Xrotation", "", "0x10", "1e5",
]  # fmt: skip


@st.composite
def damaged(draw):
    text = SOURCES[draw(st.sampled_from(sorted(SOURCES)))]
    for _ in range(draw(st.integers(1, 3))):
        lines = text.split("\n")
        kind = draw(st.sampled_from(["flip", "delete", "duplicate", "token", "token", "nest", "frames", "swap"]))
        i = draw(st.integers(0, len(lines) - 1))
        if kind == "flip":
            data = bytearray(text.encode())
            k = draw(st.integers(0, len(data) - 1))
            data[k] ^= 1 << draw(st.integers(0, 7))
            return bytes(data)  # maybe not UTF-8 any more: the last damage
        if kind == "delete":
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        elif kind == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif kind == "token":
            words = lines[i].split()
            if words:
                words[draw(st.integers(0, len(words) - 1))] = draw(st.sampled_from(HOSTILE))
                lines[i] = " ".join(words)
        elif kind == "frames":
            k = next((j for j, line in enumerate(lines) if line.startswith("Frames:")), None)
            if k is not None:
                lines[k] = (
                    f"Frames: {draw(st.sampled_from(['0', '-2', '1', '2', '4', '1000000000', '9' * 30, '3 3', 'x']))}"
                )
        else:  # nest: a chain of joints without channels, thousands deep, inside a joint
            k = next((j for j, line in enumerate(lines[i:], start=i) if line.strip().startswith("JOINT")), None)
            if k is not None:
                depth = draw(st.sampled_from([1, 50, 2000]))
                lines[k + 2 : k + 2] = [f"JOINT nest{d} {{ OFFSET 0 0 0 CHANNELS 0" for d in range(depth)] + [
                    "}"
                ] * depth
        text = "\n".join(lines)
    return text.encode()


@FUZZ
@given(data=damaged())
def test_damaged_files_are_read_or_refused_cleanly(data, tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz") / "damaged.bvh"
    path.write_bytes(data)
    tracemalloc.start()
    start = time.perf_counter()
    try:
        clip = read_bvh(path)
    except AdverbsError as e:
        assert str(path) in str(e)
        event(f"refused: {type(e).__name__}")
        clip = None
    finally:
        elapsed = time.perf_counter() - start
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    assert elapsed < 5.0
    assert peak < 64 << 20, peak  # the file is a few kB
    if clip is not None:
        event("read")
        assert_finite(clip)
        again = parse_bvh(format_bvh(clip))  # and what was read is written and read back
        assert again.skeleton.names == clip.skeleton.names and again.num_frames == clip.num_frames
