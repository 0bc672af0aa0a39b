"""BVH reading and writing on every shipped file, and every kind of bad file."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ALL_BVH, BANDAI, CMU, DATA, ONE_PER_SOURCE, REACTIDLE, aligned, ids

from adverbs import BVHError, format_bvh, parse_bvh, read_bvh, write_bvh
from adverbs.kinematics.fk import bone_lengths


def test_every_source_is_shipped():
    sources = {p.parent.name for p in ALL_BVH}
    assert sources == {"cmu16", "bandai", "reactidle"}
    for folder in ("cmu16", "bandai", "reactidle"):
        assert (DATA / folder / "LICENSE").exists() or (DATA / folder / "README.md").exists()



def _same_motion(a, b, atol_m=1e-7, atol_q=1e-7):
    assert a.skeleton.names == b.skeleton.names
    assert np.array_equal(a.skeleton.parents, b.skeleton.parents)
    assert a.skeleton.channels == b.skeleton.channels
    np.testing.assert_allclose(a.skeleton.offsets, b.skeleton.offsets, rtol=0, atol=atol_m)
    np.testing.assert_allclose(a.skeleton.end_site_offsets, b.skeleton.end_site_offsets, rtol=0, atol=atol_m)
    assert a.num_frames == b.num_frames
    assert a.fps == pytest.approx(b.fps, rel=1e-9)
    np.testing.assert_allclose(a.translations, b.translations, rtol=0, atol=atol_m)
    np.testing.assert_allclose(aligned(a.rotations, b.rotations), b.rotations, rtol=0, atol=atol_q)


@pytest.mark.parametrize("path", ALL_BVH, ids=ids(ALL_BVH))
def test_reads_and_bones_keep_their_length(path):
    clip = read_bvh(path)
    skel = clip.skeleton
    assert clip.num_frames > 1 and clip.fps in (24.0, 30.0)
    assert np.all(np.isfinite(clip.rotations)) and np.all(np.isfinite(clip.translations))
    np.testing.assert_allclose(np.linalg.norm(clip.rotations, axis=-1), 1.0, rtol=0, atol=1e-12)
    lengths = bone_lengths(skel.parents, clip.global_positions())  # (F, J-1)
    spread = np.ptp(lengths, axis=0)
    moved_by_motion = set(skel.ancestors(skel.body_root()))  # the root's own link to the hips is motion
    for k, j in enumerate(range(1, skel.num_joints)):
        if j in moved_by_motion:
            continue
        if skel.has_position_channels(j):
            # Position channels are printed to the file's precision (1e-6 m in ReActIdle): no more than that.
            assert spread[k] <= 2e-6, (skel.names[j], spread[k])
        else:
            assert spread[k] <= 1e-9, (skel.names[j], spread[k])


@pytest.mark.parametrize("path", ALL_BVH, ids=ids(ALL_BVH))
def test_write_then_read_is_identity(path, tmp_path):
    clip = read_bvh(path)
    out = tmp_path / "copy.bvh"
    write_bvh(clip, out)
    again = read_bvh(out)
    assert again.skeleton.units == clip.skeleton.units
    assert again.skeleton.unit_scale == clip.skeleton.unit_scale
    _same_motion(clip, again)


def test_units_are_recorded_and_restored(tmp_path):
    cm = read_bvh(CMU / "16_15_walk.bvh")
    m = read_bvh(REACTIDLE / "idle_002_genuine.bvh")
    assert (cm.skeleton.units, cm.skeleton.unit_scale) == ("cm", 0.01)
    assert (m.skeleton.units, m.skeleton.unit_scale) == ("m", 1.0)
    # Inside the library both are metres: a person's leg is 0.7–1.0 m either way.
    for clip in (cm, m):
        foot = clip.skeleton.feet()[0].ankle
        leg = np.linalg.norm(
            clip.skeleton.rest_positions()[foot] - clip.skeleton.rest_positions()[clip.skeleton.body_root()]
        )
        assert 0.6 < leg < 1.1
    # The written file keeps centimetres: the OFFSET text matches the source's numbers.
    text = format_bvh(cm)
    assert "OFFSET 0 -42.0304 0" in text
    explicit = read_bvh(CMU / "16_15_walk.bvh", units="m")
    np.testing.assert_allclose(explicit.skeleton.offsets, cm.skeleton.offsets * 100, rtol=0, atol=1e-12)


def test_tabs_crlf_blank_lines_and_spacing_read_the_same():
    path = CMU / "16_21_walk.bvh"
    raw = path.read_bytes().decode()
    assert "\r\n" in raw and "\t" in raw  # the CMU files are CRLF with tabs already
    reference = read_bvh(path)
    lf = raw.replace("\r\n", "\n")
    spaced = "\n\n".join(line.replace("\t", "   ") for line in lf.split("\n"))
    for text in (lf, spaced, lf.replace(" ", "\t"), "\n\n" + lf + "\n\n\n"):
        _same_motion(reference, parse_bvh(text), atol_m=0, atol_q=1e-15)


@pytest.mark.parametrize("order", ["XYZ", "YZX", "ZYX", "XZY"])
def test_any_channel_order_round_trips(order, tmp_path):
    clip = read_bvh(BANDAI / "dataset-2_raise-up-right-hand_normal_001.bvh")
    skel = clip.skeleton
    rot = tuple(f"{a}rotation" for a in order)
    # Mix layouts: rotations first on some joints, positions interleaved on others, 3 channels on some.
    channels = []
    for j in range(skel.num_joints):
        if j % 3 == 0:
            channels.append(rot + ("Xposition", "Yposition", "Zposition"))
        elif j % 3 == 1:
            channels.append(("Yposition",) + rot[:1] + ("Xposition",) + rot[1:] + ("Zposition",))
        else:
            channels.append(rot)
    from adverbs import Skeleton

    other = Skeleton(
        skel.names,
        skel.parents,
        skel.offsets,
        tuple(channels),
        skel.end_site_parents,
        skel.end_site_offsets,
        skel.unit_scale,
        skel.units,
    )
    fixed = np.array([not other.has_position_channels(j) for j in range(skel.num_joints)])
    trans = clip.translations.copy()
    trans[:, fixed] = skel.offsets[fixed]
    moved = clip.replace(skeleton=other, translations=trans)
    out = tmp_path / "reordered.bvh"
    write_bvh(moved, out)
    again = read_bvh(out)
    assert again.skeleton.channels == tuple(channels)
    np.testing.assert_allclose(again.global_positions(), moved.global_positions(), rtol=0, atol=1e-7)


# ----- bad files -----------------------------------------------------------------------------

GOOD = (CMU / "16_21_walk.bvh").read_text().replace("\r\n", "\n")
LINES = GOOD.split("\n")
MOTION_LINE = LINES.index("MOTION") + 1  # 1-based
FIRST_FRAME = MOTION_LINE + 3


def _bad(tmp_path, text, name="bad.bvh"):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(BVHError) as info:
        read_bvh(path)
    err = info.value
    assert err.path == str(path) and str(path) in str(err)
    return err


def test_truncated_motion(tmp_path):
    # Cut in the middle of a frame: the last line is short.
    cut = GOOD[: GOOD.index(LINES[FIRST_FRAME + 10]) + 40]
    err = _bad(tmp_path, cut)
    assert err.line == FIRST_FRAME + 11 and "truncated" in err.reason
    # Cut at a line boundary: fewer frames than declared.
    err = _bad(tmp_path, "\n".join(LINES[: FIRST_FRAME + 10]) + "\n")
    assert "truncated" in err.reason and "ends after 11 frames" in err.reason


def test_wrong_number_of_values_on_a_line(tmp_path):
    lines = list(LINES)
    lines[FIRST_FRAME + 4] += " 1.0"
    err = _bad(tmp_path, "\n".join(lines))
    assert err.line == FIRST_FRAME + 5 and "61 values" in err.reason and "60 channels" in err.reason


def test_non_numeric_value(tmp_path):
    lines = list(LINES)
    values = lines[FIRST_FRAME + 7].split()
    values[12] = "1.2.3"
    lines[FIRST_FRAME + 7] = " ".join(values)
    err = _bad(tmp_path, "\n".join(lines))
    assert err.line == FIRST_FRAME + 8 and "'1.2.3'" in err.reason
    lines[FIRST_FRAME + 7] = " ".join(["nan"] + values[1:12] + ["0"] + values[13:])
    err = _bad(tmp_path, "\n".join(lines))
    assert err.line == FIRST_FRAME + 8 and "'nan'" in err.reason


def test_non_numeric_offset(tmp_path):
    text = GOOD.replace("OFFSET 11.446000 0.000000 0.000000", "OFFSET 11.446000 zero 0.000000", 1)
    err = _bad(tmp_path, text)
    assert err.line == 8 and "'zero'" in err.reason


def test_unknown_channel(tmp_path):
    lines = list(LINES)
    n = next(i for i, line in enumerate(lines) if "lfemur" in line) + 4  # 1-based CHANNELS line of lfemur
    assert "CHANNELS" in lines[n - 1]
    lines[n - 1] = lines[n - 1].replace("Xrotation", "Wrotation")
    err = _bad(tmp_path, "\n".join(lines))
    assert err.line == n and "'Wrotation'" in err.reason and "lfemur" in err.reason


def test_unbalanced_braces(tmp_path):
    # A missing closing brace: the joint that is never closed is named.
    lines = list(LINES)
    last_close = max(i for i, line in enumerate(lines[:MOTION_LINE]) if line.strip() == "}")
    del lines[last_close]
    err = _bad(tmp_path, "\n".join(lines))
    assert "unbalanced braces" in err.reason and "pelvis" in err.reason
    # An extra closing brace: its line is named.
    lines = list(LINES)
    lines.insert(MOTION_LINE - 1, "}")
    err = _bad(tmp_path, "\n".join(lines))
    assert "unbalanced braces" in err.reason and err.line == MOTION_LINE


def test_frames_count_not_matching(tmp_path):
    lines = list(LINES)
    lines[MOTION_LINE] = "Frames: 70"  # the file has 78
    err = _bad(tmp_path, "\n".join(lines))
    assert "'Frames: 70'" in err.reason and err.line == FIRST_FRAME + 70
    lines[MOTION_LINE] = "Frames: many"
    err = _bad(tmp_path, "\n".join(lines))
    assert err.line == MOTION_LINE + 1


def test_other_header_faults(tmp_path):
    err = _bad(tmp_path, "")
    assert err.line == 1
    err = _bad(tmp_path, GOOD.replace("HIERARCHY", "HIERARCHIE", 1))
    assert err.line == 1
    err = _bad(tmp_path, GOOD.split("MOTION")[0])
    assert "MOTION" in err.reason
    err = _bad(tmp_path, GOOD.replace("Frame Time:\t0.0333333", "Frame Time: 0", 1))
    assert err.line == MOTION_LINE + 2
    err = _bad(tmp_path, GOOD.replace("CHANNELS 3", "CHANNELS 9", 1))
    assert "count" in err.reason
    # Not text at all.
    path = tmp_path / "binary.bvh"
    path.write_bytes(b"\x00\xff\xfe" * 10)
    with pytest.raises(BVHError, match="binary.bvh"):
        read_bvh(path)
    with pytest.raises(BVHError, match="missing.bvh"):
        read_bvh(tmp_path / "missing.bvh")


@pytest.mark.parametrize("path", ONE_PER_SOURCE, ids=ids(ONE_PER_SOURCE))
def test_every_prefix_of_a_real_file_reads_or_raises_bvh_error(path):
    """Truncation anywhere gives a BVHError (or, at a frame boundary before the data, still an error)."""
    text = path.read_text()
    rng = np.random.default_rng(7)
    for cut in rng.integers(0, len(text) - 1, size=40):
        with pytest.raises(BVHError):
            parse_bvh(text[:cut], source=path)


def test_two_channel_joints_write_back():
    text = (CMU / "16_21_walk.bvh").read_text().replace("\r\n", "\n")
    lines = text.split("\n")
    i = next(k for k, line in enumerate(lines) if "JOINT lfemur" in line)
    lines[i + 3] = lines[i + 3].replace("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 2 Zrotation Xrotation")
    m = lines.index("MOTION")
    for k in range(m + 3, len(lines)):
        if lines[k].strip():
            values = lines[k].split()
            values[6:9] = ["10.0", "120.0"]  # past 90°: the principal Euler solution would need the missing axis
            lines[k] = " ".join(values)
    clip = parse_bvh("\n".join(lines))
    again = parse_bvh(format_bvh(clip))
    np.testing.assert_allclose(aligned(again.rotations, clip.rotations), clip.rotations, rtol=0, atol=1e-12)


def test_frame_rates():
    text = (CMU / "16_21_walk.bvh").read_text()
    assert parse_bvh(text).fps == 30.0  # 0.0333333 is 1/30 rounded
    assert parse_bvh(text.replace("Frame Time:\t0.0333333", "Frame Time: 0.03")).fps == pytest.approx(
        100 / 3, rel=0, abs=1e-12
    )
    assert parse_bvh(text.replace("Frame Time:\t0.0333333", "Frame Time: 0.0416667")).fps == 24.0
    with pytest.raises(BVHError, match="Frame Time"):
        parse_bvh(text.replace("Frame Time:\t0.0333333", "Frame Time: 1e-320"))


@pytest.mark.parametrize("path", ONE_PER_SOURCE, ids=ids(ONE_PER_SOURCE))
def test_mutated_files_read_or_raise_bvh_error(path):
    """Seeded mutations of real files (tokens replaced, lines dropped or repeated): a clip or a BVHError, nothing else."""
    lines = path.read_text().splitlines()
    motion = next(i for i, line in enumerate(lines) if line.strip() == "MOTION")
    lines = lines[: motion + 3 + 20]  # the whole hierarchy and 20 frames keep it quick
    junk = [
        "}",
        "{",
        "JOINT",
        "End",
        "Site",
        "OFFSET",
        "CHANNELS",
        "7",
        "-1",
        "nan",
        "1e999",
        "x",
        "",
        "MOTION",
        "Frames:",
    ]
    rng = np.random.default_rng(12)
    for _ in range(150):
        mutated = list(lines)
        for _ in range(rng.integers(1, 4)):
            i = int(rng.integers(len(mutated)))
            kind = rng.integers(3)
            if kind == 0 and mutated[i].split():
                words = mutated[i].split()
                words[int(rng.integers(len(words)))] = str(rng.choice(junk))
                mutated[i] = " ".join(words)
            elif kind == 1:
                del mutated[i]
            else:
                mutated.insert(i, mutated[i])
        try:
            clip = parse_bvh("\n".join(mutated), source=path)
        except BVHError:
            continue
        assert np.all(np.isfinite(clip.rotations)) and np.all(np.isfinite(clip.translations))


def test_write_bvh_streams_the_same_bytes_format_bvh_gives(tmp_path, cmu_walk):
    """``write_bvh`` writes the frames a block at a time (a long clip's text is never held whole): the file is
    byte for byte ``format_bvh``'s text, across block boundaries too."""
    from adverbs.io.bvh import WRITE_BLOCK, format_bvh

    n = 2 * WRITE_BLOCK + 37
    reps = -(-n // cmu_walk.num_frames)
    long = cmu_walk.replace(
        rotations=np.tile(cmu_walk.rotations, (reps, 1, 1))[:n], translations=np.tile(cmu_walk.translations, (reps, 1, 1))[:n]
    )
    write_bvh(long, tmp_path / "long.bvh")
    assert (tmp_path / "long.bvh").read_bytes() == format_bvh(long).encode("utf-8")
