"""Verb files, damaged or hostile (issue 14): every fault is refused with an AdverbsError naming the file and the
member or field, before the work it would cost; a verb that loads can be used; a failed save leaves the old file."""

from __future__ import annotations

import io
import json
import os
import struct
import subprocess
import sys
import time
import tracemalloc
import warnings
import zipfile
from dataclasses import dataclass, field, replace
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
from conftest import CMU, SPECS
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from adverbs.errors import AdverbsError
from adverbs.limits import LIMITS, LimitError
from adverbs.verb.store import MEMBERS, VerbFileError, load_verb, save_verb

LOAD_SECONDS = 2.0  # one load of a damaged 90 KB verb (it takes a few milliseconds)
LOAD_MEMORY = 64 << 20  # bytes allocated at the peak of loading one (the file's arrays are 100 KB)


@dataclass
class Saved:
    """A saved verb: its path, its bytes and its members (shown by its path alone)."""

    path: Path
    data: bytes = field(repr=False)
    members: dict[str, bytes] = field(repr=False)

    def __iter__(self):
        return iter((self.path, self.data, self.members))


@pytest.fixture(scope="module")
def walk(verbs, tmp_path_factory):
    """A real saved verb."""
    verb, _ = verbs["cmu_walk"]
    path = tmp_path_factory.mktemp("verb_files") / "walk.verb"
    save_verb(verb, path)
    with zipfile.ZipFile(path) as z:
        members = {n: z.read(n) for n in z.namelist()}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        verb.synthesize(verb.points.mean(axis=0))  # compiled kernels loaded before anything is timed
    return Saved(path, path.read_bytes(), members)


def zipped(members: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in members.items():
            z.writestr(name, data)
    return buf.getvalue()


def npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.asarray(array), allow_pickle=False)
    return buf.getvalue()


def rewrite_header(data: bytes, old: bytes, new: bytes) -> bytes:
    """Npy bytes with ``old`` replaced by ``new`` in their header, its length and padding made to fit."""
    length = struct.unpack("<H", data[8:10])[0]
    header = data[10 : 10 + length].replace(old, new, 1).rstrip(b" \n")
    size = max(length, len(header) + 1)
    return data[:8] + struct.pack("<H", size) + header.ljust(size - 1) + b"\n" + data[10 + length :]


def array(members: dict[str, bytes], name: str) -> np.ndarray:
    return np.lib.format.read_array(io.BytesIO(members[f"{name}.npy"]))


def _written(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def refused(path, data: bytes, *parts: str, error: type[AdverbsError] = AdverbsError) -> str:
    """Write ``data`` to ``path``, load it: an ``error`` whose message starts with the file and holds every part."""
    path.write_bytes(data)
    with pytest.raises(error) as info:
        load_verb(path)
    message = str(info.value)
    assert message.startswith(f"{path}: "), message
    for part in parts:
        assert part in message, message
    return message


def with_meta(members, change) -> bytes:
    """The archive with ``change(meta)`` applied to its verb.json (``change`` edits in place)."""
    meta = json.loads(members["verb.json"])
    change(meta)
    return zipped({**members, "verb.json": json.dumps(meta).encode()})


def with_array(members, name: str, change) -> bytes:
    """The archive with array ``name`` replaced by ``change(array)``."""
    return zipped({**members, f"{name}.npy": npy(change(array(members, name).copy()))})


def setting(*keys_and_value):
    *keys, value = keys_and_value

    def change(meta):
        for k in keys[:-1]:
            meta = meta[k]
        meta[keys[-1]] = value

    return change


def put(index, value):
    def change(a):
        a[index] = value
        return a

    return change


# ----- the bytes and the archive ---------------------------------------------------------------------------


def test_files_that_are_not_verb_files(walk, tmp_path):
    path, data, _ = walk
    with pytest.raises(VerbFileError, match="no such verb file"):
        load_verb(tmp_path / "missing.verb")
    with pytest.raises(VerbFileError) as info:
        load_verb(tmp_path)  # a directory
    assert str(info.value) == f"{tmp_path}: is a directory, not a verb file"
    refused(tmp_path / "empty.verb", b"", "damaged verb file: not a zip archive")
    refused(tmp_path / "text.verb", b'{"format": "adverbs-verb"}\n', "not a zip archive")
    refused(tmp_path / "cut.verb", data[: len(data) // 2], "damaged verb file")
    refused(tmp_path / "end.verb", data[:-1], "damaged verb file")
    # What a user might pass instead of a verb: said so, and how to make one.
    spec = (SPECS / "cmu_walk.toml").read_bytes()
    refused(tmp_path / "walk.toml", spec, "a spec, not a built verb: build it first (adverbs build SPEC.toml")
    bvh = (CMU / "16_15_walk.bvh").read_bytes()
    refused(tmp_path / "walk.bvh", bvh, "a BVH motion file, not a verb")


def _local_data(data: bytes, name: str) -> int:
    """Where member ``name``'s compressed bytes start in the archive ``data``."""
    info = zipfile.ZipFile(io.BytesIO(data)).getinfo(name)
    name_length, extra_length = struct.unpack("<HH", data[info.header_offset + 26 : info.header_offset + 30])
    return info.header_offset + 30 + name_length + extra_length


def test_a_flipped_byte_in_compressed_data_is_an_error_not_a_zlib_traceback(walk, tmp_path):
    _, data, _ = walk
    start = _local_data(data, "coefficients.npy")
    messages = set()
    for offset in (0, 1, 2, 7, 100, 5000):  # found by fuzzing: zlib.error from some, a bad CRC from others
        bad = bytearray(data)
        bad[start + offset] ^= 0x55
        messages.add(refused(tmp_path / "flip.verb", bytes(bad), "member 'coefficients.npy': damaged"))
    assert any("decompress" in m for m in messages), messages  # a zlib error, as a message


def test_archive_flags_methods_and_names_a_verb_file_never_has(walk, tmp_path):
    _, data, members = walk
    info = zipfile.ZipFile(io.BytesIO(data)).getinfo("verb.json")
    directory = data.index(b"PK\x01\x02")  # the first central directory entry: verb.json's
    assert data[directory + 46 : directory + 46 + 9] == b"verb.json" and info.header_offset == 0

    def patched(at: int, fmt: str, value: int) -> bytes:
        out = bytearray(data)
        struct.pack_into(fmt, out, at, value)
        return bytes(out)

    # The encryption flag made zipfile raise RuntimeError (a password is required); an unknown method NotImplementedError.
    refused(tmp_path / "a.verb", patched(directory + 8, "<H", 0x1), "member 'verb.json': encrypted")
    refused(tmp_path / "b.verb", patched(directory + 10, "<H", 99), "member 'verb.json': compressed by method 99")
    refused(tmp_path / "c.verb", zipped({**members, "extra.npy": npy([1.0])}), "unexpected member 'extra.npy'")
    refused(tmp_path / "d.verb", zipped({k: v for k, v in members.items() if k != "parents.npy"}),
            "damaged verb file: member 'parents.npy' is missing")  # fmt: skip
    twice = io.BytesIO(data)
    with warnings.catch_warnings(), zipfile.ZipFile(twice, "a") as z:
        warnings.simplefilter("ignore")  # "Duplicate name"
        z.writestr("points.npy", members["points.npy"])
    refused(
        tmp_path / "e.verb",
        twice.getvalue(),
        "member 'points.npy': damaged verb file: the member is in the archive twice",
    )


def test_declared_sizes_are_checked_before_anything_is_read(walk, tmp_path, monkeypatch):
    """A zip directory, a member or an array that claims gigabytes is refused before it is decompressed or allocated."""
    _, data, members = walk
    directory = data.index(b"PK\x01\x02")
    end = data.rindex(b"PK\x05\x06")
    bomb = bytearray(data)
    struct.pack_into("<I", bomb, directory + 24, 3 << 30)  # verb.json's uncompressed size: 3 GiB
    refused(
        tmp_path / "a.verb",
        bytes(bomb),
        "member 'verb.json' is 3,221,225,472 bytes; at most",
        "ADVERBS_MAX_MEMORY",
        error=LimitError,
    )
    huge = bytearray(data)
    struct.pack_into("<I", huge, end + 12, 1 << 30)  # the central directory: 1 GiB
    refused(tmp_path / "b.verb", bytes(huge), "zip directory claims")
    # An npy header declaring 2**40 numbers (the old reader allocated them: MemoryError) or 10**12 x 10**12.
    for shape in ((12, 1 << 40, 61), (10**12, 10**12, 61)):
        header = rewrite_header(npy(np.zeros((12, 16, 61))), b"(12, 16, 61)", repr(shape).encode())
        refused(tmp_path / "c.verb", zipped({**members, "coefficients.npy": header}),
                "member 'coefficients.npy'", "ADVERBS_MAX_MEMORY", error=LimitError)  # fmt: skip
    # Under lower limits a real verb is too big: the limits are the ones in adverbs.limits.
    monkeypatch.setattr(LIMITS, "joints", 10)
    refused(tmp_path / "d.verb", data, "field 'skeleton.names' has 19 joints; the limit is 10", error=LimitError)
    monkeypatch.setattr(LIMITS, "memory", 200_000)
    refused(tmp_path / "d.verb", data, f"the file is {len(data):,} bytes; at most 25,000 are allowed", error=LimitError)


def test_deep_json_and_json_numbers_a_verb_never_has(walk, tmp_path):
    _, _, members = walk
    deep = b"[" * 100_000 + b"]" * 100_000  # RecursionError in the old reader
    refused(
        tmp_path / "a.verb",
        zipped({**members, "verb.json": deep}),
        "member 'verb.json': damaged: JSON nested more than",
    )
    refused(
        tmp_path / "b.verb", with_meta(members, setting("name", json.loads("[" * 500 + "]" * 500))), "nested more than"
    )
    nested_in_strings = members["verb.json"].replace(b'"cmu-walk"', b'"' + b"[" * 1000 + b'"')  # brackets in a string
    assert (
        load_verb(_written(tmp_path / "c.verb", zipped({**members, "verb.json": nested_in_strings}))).name == "[" * 1000
    )
    text = members["verb.json"].replace(b'"fps": 30.0', b'"fps": NaN')
    refused(
        tmp_path / "d.verb", zipped({**members, "verb.json": text}), "member 'verb.json': damaged: not valid JSON (NaN"
    )
    text = members["verb.json"].replace(b'"fps": 30.0', b'"fps": 1e999')
    refused(
        tmp_path / "e.verb",
        zipped({**members, "verb.json": text}),
        "field 'fps': must be a number of frames per second",
    )
    text = members["verb.json"].replace(b'"fps": 30.0', b'"fps": 1' + b"0" * 400)
    refused(tmp_path / "f.verb", zipped({**members, "verb.json": text}), "field 'fps'")
    refused(
        tmp_path / "g.verb", zipped({**members, "verb.json": b"\xff\xfe{}"}), "member 'verb.json': damaged: not UTF-8"
    )


def test_npy_headers_numpy_never_writes(walk, tmp_path):
    _, _, members = walk
    good = members["parents.npy"]
    for bad, why in (
        (good.replace(b"'<i8'", b"'|O8'"), "must hold 8-byte whole numbers, holds '|O8'"),  # objects: pickles
        (good.replace(b"'<i8'", b"'<f8'"), "must hold 8-byte whole numbers, holds '<f8'"),
        (
            rewrite_header(good, b"(19,)", b"(-1,)"),
            "damaged: its npy header is not one numpy writes",
        ),  # a negative count
        (rewrite_header(good, b"(19,)", b"(19, 1)"), "must be an array of 1 axes, has shape (19, 1)"),
        (rewrite_header(good, b"'descr'", b"'descr' "), "damaged: its npy header is not one numpy writes"),
        (rewrite_header(good, b"(19,)", b"(" * 200 + b")" * 200), "damaged: its npy header is not one numpy writes"),
        (good[:5], "damaged: not an npy array"),
        (good[:6] + b"\x03\x00" + good[8:], "damaged: npy format version 3.0"),
        (good[:-8], "damaged: 144 bytes of data for shape (19,)"),
    ):
        refused(tmp_path / "x.verb", zipped({**members, "parents.npy": bad}), "member 'parents.npy': " + why)


# ----- fields and values ------------------------------------------------------------------------------------

FIELD_FAULTS = {
    "a string for a boolean": (setting("cyclic", "false"), "field 'cyclic': must be true or false, got \"false\""),
    "a number for a boolean": (setting("examples", 0, "refine", 1), "field 'examples[0].refine': must be true or false, got 1"),
    "too few control points": (setting("num_cp", 3), "field 'num_cp': must be a whole number of at least 4"),
    "a fractional count": (setting("num_cp", 16.5), "field 'num_cp': must be a whole number of at least 4"),
    "another count than the table's": (setting("num_cp", 12), "member 'coefficients.npy': has shape (12, 16, 61), must be (12, 12, 61)"),
    "fps of zero": (setting("fps", 0), "field 'fps': must be a number of frames per second above 0"),
    "fps as a string": (setting("fps", "30"), "field 'fps': must be a number"),
    "negative smoothing": (setting("smoothing", -1), "field 'smoothing': must be a finite number ≥ 0, got -1"),
    "an unknown channel": (setting("skeleton", "channels", 1, 0, "Wrotation"), "field 'skeleton.channels[1]': unknown channel \"Wrotation\""),
    "a channel twice": (setting("skeleton", "channels", 1, ["Xrotation", "Xrotation"]), "field 'skeleton.channels[1]': joint 'lfemur' lists a channel twice"),
    "a joint name BVH cannot hold": (setting("skeleton", "names", 3, "l\nfoot"), "field 'skeleton.names[3]': joint name 'l\\nfoot' holds a line break"),
    "a lone surrogate": (setting("name", "walk\ud800"), "field 'name': is not valid Unicode (it holds a lone surrogate)"),
    "joint names twice": (setting("skeleton", "names", 2, "lfemur"), "field 'skeleton.names[2]': 'lfemur' is listed twice"),
    "a negative unit": (setting("skeleton", "unit_scale", -0.01), "field 'skeleton.unit_scale': must be a positive number"),
    "an unknown measure": (setting("adverbs", 0, "measure", {"kind": "mood"}), "field 'adverbs[0].measure': unknown measure 'mood'; measures are speed, turn_rate"),
    "a measure of no joint": (setting("adverbs", 0, "measure", {"kind": "joint_position", "joint": "Hand", "axis": "x", "keytime": 1}), "names joint 'Hand', which the skeleton does not have"),
    "a measure's keytime as a boolean": (setting("adverbs", 0, "measure", {"kind": "joint_position", "joint": "lfoot", "axis": "x", "keytime": True}), "field 'adverbs[0].measure.keytime'"),
    "adverbs twice": (setting("adverbs", 1, "name", "speed"), "field 'adverbs[1].name': 'speed' is listed twice"),
    "an unknown encoding": (setting("encoding", "kind", "quaternion"), "field 'encoding.kind': unknown DOF encoding \"quaternion\""),
    "an unknown DOF": (setting("encoding", "names", 5, "pelvis.qq"), "field 'encoding.names[5]': unknown DOF 'pelvis.qq'; the encoding's column 5 is 'pelvis.ry'"),
    "a body root that is no joint": (setting("encoding", "body_root", 19), "field 'encoding.body_root': must be a whole number from 0 to 18, got 19"),
    "a negative keytime index": (setting("constraints", 0, "open", -1), "field 'constraints[0].open': must be a whole number from 0 to 2, got -1"),
    "a constraint on no joint": (setting("constraints", 0, "effector", "hand"), "field 'constraints[0].effector': names joint 'hand'"),
    "a constraint that never opens": (setting("constraints", 0, "close", 0), "field 'constraints[0]': constraint on 'ltoes': it must close after it opens"),
    "a hold out of order": (setting("holds", 0, "heel_off", 0.9), "field 'holds[0].close': 0.544208 comes before heel_off (0.9)"),
    "a hold of another foot": (setting("holds", 0, "effector", "rtoes"), "field 'holds[0].effector': must be 'ltoes'"),
    "a hold past the next cycle": (setting("holds", 1, "close", 3.0), "field 'holds[1].close': 3 is past the end of the next cycle"),
    "too few keytime names": (setting("keytime_names", ["a", "b"]), "field 'keytime_names': must list 3 names (one per keytime), lists 2"),
    "a negative error": (setting("examples", 3, "fit_error", -1.0), "field 'examples[3].fit_error': must be a finite number ≥ 0"),
    "examples twice": (setting("examples", 3, "name", "walk"), "field 'examples[3].name': 'walk' is listed twice"),
    "only refinements": (lambda m: [x.update(refine=True) for x in m["examples"]], "field 'examples': every example is a refinement"),
    "one example too many": (lambda m: m["examples"].append(dict(m["examples"][0], name="13th")), "member 'points.npy': has shape (12, 2), must be (13, 2)"),
    "an unknown timing": (setting("timing", "slow"), "field 'timing': must be one of 'extrapolate', 'clamp', got \"slow\""),
    "an unknown field": (setting("colour", "red"), "field 'colour': not a field of a verb file"),
    "a missing field": (lambda m: m["skeleton"].pop("units"), "field 'skeleton.units': missing"),
    "a list for an object": (setting("encoding", []), "field 'encoding': must be an object, got a list"),
    "another format": (setting("format", "adverbs-graph"), "not an adverbs verb file"),
    "a newer version": (setting("version", 99), "verb file version 99; this adverbs reads version 7. Rebuild it"),
    "a version as a string": (setting("version", "4"), 'verb file version "4"'),
}  # fmt: skip


@pytest.mark.parametrize("fault", FIELD_FAULTS, ids=list(FIELD_FAULTS))
def test_fields_are_checked_for_values_not_just_shapes(walk, tmp_path, fault):
    _, _, members = walk
    change, message = FIELD_FAULTS[fault]
    refused(tmp_path / "walk.verb", with_meta(members, change), message)


ARRAY_FAULTS = {
    "NaN in the coefficients": ("coefficients", put((3, 4, 5), np.nan), "member 'coefficients.npy': holds nan at [3, 4, 5]: every value must be a finite number"),
    "infinity in the points": ("points", put((0, 1), -np.inf), "member 'points.npy': holds -inf at [0, 1]"),
    "keytimes out of order": ("keytimes", put((2, 1), 5.0), "member 'keytimes.npy': each example's keytimes: keytimes must be strictly increasing"),
    "generic keytimes past 1": ("generic_keytimes", put(2, 1.5), "member 'generic_keytimes.npy': generic keytimes must be 3 increasing numbers from 0 to 1"),
    "a parent after its child": ("parents", put(3, 5), "member 'parents.npy': joint 3 ('lfoot') hangs from 5; every parent must come before its children"),
    "a second root": ("parents", put(2, -1), "member 'parents.npy': joint 2 ('ltibia') hangs from -1"),
    "a root with a parent": ("parents", put(0, 0), "member 'parents.npy': the first joint must be the root (parent -1), its parent is 0"),
    "an End Site on no joint": ("end_site_parents", put(1, 19), "member 'end_site_parents.npy': End Site 1 hangs from 19, not a joint (0 to 18)"),
    "a quaternion not of unit length": ("reference", put((4, 3), 2.0), "member 'reference.npy': row 4 has length"),
    "a translated joint it lacks": ("translated", lambda a: np.array([25]), "member 'translated.npy': must list the body root or joints below it"),
    "a joint translated twice": ("translated", lambda a: np.array([2, 2]), "member 'translated.npy': must list the body root or joints below it, each once"),
    "a hold table of the wrong shape": ("hold_table", lambda a: a[:, :1], "member 'hold_table.npy': has shape (12, 1, 3), must be (12, 2, 3)"),
    "too few control points": ("coefficients", lambda a: a[:, :3], "member 'coefficients.npy': has shape (12, 3, 61), must be (12, 16, 61)"),
    "two examples at one point": ("points", lambda a: put(1, a[0].copy())(a), "examples 'walk' and 'fast walk' are at the same adverb point"),
    "integers for numbers": ("offsets", lambda a: a.astype(np.int64), "member 'offsets.npy': must hold 8-byte numbers, holds '<i8'"),
    "single precision": ("lateral", lambda a: a.astype(np.float32), "member 'lateral.npy': must hold 8-byte numbers, holds '<f4'"),
}  # fmt: skip


@pytest.mark.parametrize("fault", ARRAY_FAULTS, ids=list(ARRAY_FAULTS))
def test_arrays_are_checked_for_values_not_just_shapes(walk, tmp_path, fault):
    _, _, members = walk
    name, change, message = ARRAY_FAULTS[fault]
    refused(tmp_path / "walk.verb", with_array(members, name, change), message)


def test_a_verb_file_may_differ_from_ours_in_ways_that_do_not_matter(walk, tmp_path):
    """Big-endian arrays, Fortran order, stored (not deflated) members: still the same verb."""
    path, _, members = walk
    verb = load_verb(path)
    coefficients = array(members, "coefficients")
    other = {**members, "coefficients.npy": npy(np.asfortranarray(coefficients).astype(">f8"))}
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as z:
        for name, data in other.items():
            z.writestr(name, data)
    again = load_verb(_written(tmp_path / "w.verb", buf.getvalue()))
    assert np.array_equal(again.coefficients, verb.coefficients) and again.coefficients.dtype == np.float64


# ----- fuzzing ---------------------------------------------------------------------------------------------

DELETE = object()
HOSTILE = st.sampled_from(
    [None, True, False, "false", "", "x" * 200, -1, 0, 1, 3, 4, 2**63, -(2**63), 10**40, 1e308, -1e308, 5e-324,
     float("nan"), float("inf"), [], {}, [[[[1]]]], {"kind": "speed"}, "Xrotation", "joint_position", DELETE]
)  # fmt: skip
JSON_VALUE = st.one_of(
    HOSTILE,
    st.integers(-(10**6), 10**6),
    st.floats(),
    st.text(max_size=12),
    st.recursive(st.none() | st.booleans() | st.integers(-5, 50) | st.text(max_size=4), lambda x: st.lists(x, max_size=3) | st.dictionaries(st.text(max_size=4), x, max_size=3), max_leaves=6),
)  # fmt: skip
NUMBER = st.sampled_from([np.nan, np.inf, -np.inf, -1.0, 0.0, 1e300, -1e300, 1e-300, 0.5, 3.0, 1000.0, -2.0, 2.0**63])
INDEX = st.integers(0, 1 << 30)
DAMAGE = st.one_of(
    st.tuples(st.just("flip"), st.lists(st.tuples(INDEX, st.integers(0, 7)), min_size=1, max_size=4)),
    st.tuples(st.just("truncate"), INDEX),
    st.tuples(st.just("insert"), INDEX, st.binary(min_size=1, max_size=16)),
    st.tuples(st.just("json"), INDEX, JSON_VALUE),
    st.tuples(st.just("json"), INDEX, JSON_VALUE),  # twice as likely: most fields are worth a look
    st.tuples(st.just("value"), st.sampled_from(sorted(MEMBERS[1:])), INDEX, NUMBER),
    st.tuples(
        st.just("shape"), st.sampled_from(sorted(MEMBERS[1:])), INDEX, st.sampled_from([-1, 1, 2, 10**6, 10**15])
    ),
)


def _places(value, at=()):
    """Every place in a JSON value, as key paths."""
    todo = [(value, at)]
    while todo:
        v, here = todo.pop()
        yield here
        if isinstance(v, dict):
            todo += [(x, here + (k,)) for k, x in v.items()]
        elif isinstance(v, list):
            todo += [(x, here + (i,)) for i, x in enumerate(v)]


def damaged(data: bytes, members: dict[str, bytes], damage) -> bytes:
    kind, *args = damage
    if kind == "flip":
        out = bytearray(data)
        for at, bit in args[0]:
            out[at % len(out)] ^= 1 << bit
        return bytes(out)
    if kind == "truncate":
        return data[: args[0] % len(data)]
    if kind == "insert":
        at = args[0] % (len(data) + 1)
        return data[:at] + args[1] + data[at:]
    if kind == "json":  # a value replaced (or deleted) inside verb.json, re-zipped so it gets past the zip layer
        meta = json.loads(members["verb.json"])
        places = sorted((p for p in _places(meta) if p), key=repr)  # every place but the whole file
        place = places[args[0] % len(places)]
        parent = meta
        for k in place[:-1]:
            parent = parent[k]
        if args[1] is DELETE:
            del parent[place[-1]]
        else:
            parent[place[-1]] = args[1]
        return zipped({**members, "verb.json": json.dumps(meta).encode()})
    name, at, value = args
    a = np.lib.format.read_array(io.BytesIO(members[name])).copy()
    if kind == "value" and a.size:  # one number of an array changed
        a.reshape(-1)[at % a.size] = (
            value if a.dtype.kind == "f" else (int(value) if np.isfinite(value) and abs(value) < 2**62 else -1)
        )
        return zipped({**members, name: npy(a)})
    if kind == "shape" and a.ndim:  # one axis of an array's header changed, the data left as it was
        shape = list(a.shape)
        shape[at % a.ndim] = value
        return zipped(
            {**members, name: rewrite_header(members[name], repr(a.shape).encode(), repr(tuple(shape)).encode())}
        )
    return data


@settings(max_examples=200, derandomize=True, database=None, deadline=timedelta(seconds=5),
          suppress_health_check=[HealthCheck.too_slow])  # fmt: skip
@given(damage=DAMAGE)
def test_damaged_verb_files_load_or_are_refused_within_bounds(walk, damage):
    """Random damage — flipped bits, truncation, inserted bytes, values and shapes changed inside the archive — either
    loads, to a verb that synthesizes (or refuses to, with an AdverbsError), or is refused with an AdverbsError naming
    the file; each load within LOAD_SECONDS and LOAD_MEMORY, each case (load and synthesis) within 5 s."""
    path, data, members = walk
    bad = path.with_name("damaged.verb")
    bad.write_bytes(damaged(data, members, damage))
    tracemalloc.start()
    start = time.perf_counter()
    try:
        verb = load_verb(bad)
    except AdverbsError as e:
        assert str(e).startswith(f"{bad}: "), e
        verb = None
    finally:
        seconds = time.perf_counter() - start
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    assert seconds < LOAD_SECONDS and peak < LOAD_MEMORY, (seconds, peak)
    if verb is not None:  # a verb that loads can be used
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                verb.synthesize(verb.points.mean(axis=0))
            except AdverbsError:
                pass


# ----- writing ---------------------------------------------------------------------------------------------

_WRITE_FAILS = """
import dataclasses, resource, signal, sys
from adverbs.errors import AdverbsError
from adverbs.verb.store import load_verb, save_verb
verb = dataclasses.replace(load_verb(sys.argv[1]), name="renamed")  # a file other than the one there
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG, not a signal
resource.setrlimit(resource.RLIMIT_FSIZE, (16384, 16384))  # the verb is 90 KB: the write fails part way
try:
    save_verb(verb, sys.argv[2])
except AdverbsError as e:
    print(e)
    sys.exit(3)
"""


def test_a_write_that_fails_part_way_leaves_the_old_file_and_names_it(walk, tmp_path):
    path, data, _ = walk
    target = _written(tmp_path / "walk.verb", data)
    r = subprocess.run([sys.executable, "-c", _WRITE_FAILS, str(path), str(target)], capture_output=True, text=True,
                       env={**os.environ, "PYTHONWARNINGS": "ignore"})  # fmt: skip
    assert r.returncode == 3, r.stderr
    assert r.stdout.strip() == f"{target}: cannot write: File too large"
    assert target.read_bytes() == data and load_verb(target).name == "cmu-walk"
    assert [p.name for p in tmp_path.iterdir()] == ["walk.verb"]  # no part-written file left beside it


def test_the_writer_refuses_what_the_reader_would(walk, tmp_path):
    path, data, _ = walk
    verb = load_verb(path)
    target = _written(tmp_path / "walk.verb", data)
    with pytest.raises(AdverbsError, match="its metadata holds a number that is not finite") as info:
        save_verb(replace(verb, floor=float("nan")), target)
    assert str(info.value).startswith(f"{target}: ")
    assert target.read_bytes() == data and [p.name for p in tmp_path.iterdir()] == ["walk.verb"]
    (tmp_path / "file").write_bytes(b"")
    with pytest.raises(AdverbsError, match="cannot write"):
        save_verb(verb, tmp_path / "file" / "walk.verb")  # a directory that is a file


def test_every_verb_round_trips_through_the_checks(verbs, tmp_path):
    for name, (verb, _) in verbs.items():
        save_verb(verb, tmp_path / f"{name}.verb")
        again = load_verb(tmp_path / f"{name}.verb")
        assert again.encoding.names == verb.encoding.names and again.holds == verb.holds
        assert np.array_equal(again.coefficients, verb.coefficients) and again.adverbs == verb.adverbs


def test_a_verb_standing_on_its_feet_round_trips(tmp_path):
    """A verb built with ``in_place = "feet"`` (its body root's offset from the feet in translation columns) saves and
    loads as it was built: the same columns, and the same poses decoded."""
    from conftest import on_their_feet

    from adverbs.verb import build_from_spec

    specs = on_their_feet(tmp_path, ["bandai_bow"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        verb = build_from_spec(specs / "bandai_bow.toml")
    assert verb.encoding.anchored and {"Hips.tx", "Hips.ty", "Hips.tz"} <= set(verb.encoding.names)
    save_verb(verb, tmp_path / "bow.verb")
    again = load_verb(tmp_path / "bow.verb")
    assert again.encoding.anchored and again.encoding.names == verb.encoding.names
    dofs = verb.dofs(verb.points[:1].repeat(5, 0), np.linspace(0, 1, 5))
    for a, b in zip(verb.encoding.decode_pose(dofs, np.zeros(3)), again.encoding.decode_pose(dofs, np.zeros(3))):
        np.testing.assert_array_equal(a, b)
