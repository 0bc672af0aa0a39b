"""Hostile ``.glb`` files (issue 33): every damaged container, JSON field, accessor, node tree and value ends in a
clip whose every number is finite, or in one :class:`~adverbs.io.gltf.GLTFError` (an AdverbsError) naming the file
and the field; never another exception, NaN accepted, or a hang. The files are written here from shipped capture
and then damaged, by hand (each fault the fuzz report found) and by Hypothesis."""

from __future__ import annotations

import copy
import json
import re
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
from conftest import BANDAI, CMU
from hostile import bounded, draw_field
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from test_cli import run

from adverbs import read_bvh, read_motion, write_glb
from adverbs.errors import AdverbsError
from adverbs.io.bvh import READ_COST
from adverbs.io.gltf import FLOAT32_MAX, GLTFError
from adverbs.limits import LIMITS, LimitError

FUZZ = settings(
    derandomize=True, database=None, deadline=timedelta(seconds=5), max_examples=120,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)  # fmt: skip


def pack(doc: dict | list, blob: bytes | None, version: int = 2) -> bytes:
    """A GLB container of ``doc`` (its JSON, NaN written as ``NaN``) and ``blob`` (no BIN chunk if None)."""
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    body = len(text).to_bytes(4, "little") + b"JSON" + text
    if blob is not None:
        body += len(blob).to_bytes(4, "little") + b"BIN\0" + blob
    return b"glTF" + version.to_bytes(4, "little") + (12 + len(body)).to_bytes(4, "little") + body


class Base:
    """A .glb written from a shipped take: its bytes, JSON and binary chunk, and where its animation data is."""

    def __init__(self, data: bytes):
        self.data = data
        length = int.from_bytes(data[12:16], "little")
        self.doc = json.loads(data[20 : 20 + length])
        self.blob = data[28 + length :]
        anim = self.doc["animations"][0]
        self.times = anim["samplers"][0]["input"]
        self.rotation = anim["samplers"][0]["output"]
        moved = next(c for c in anim["channels"] if c["target"]["path"] == "translation")
        self.translation = anim["samplers"][moved["sampler"]]["output"]
        self.joints = self.doc["skins"][0]["joints"]

    def copy(self) -> dict:
        return copy.deepcopy(self.doc)

    def start(self, accessor: int) -> int:
        """The byte of the binary chunk where ``accessor``'s data begins."""
        acc = self.doc["accessors"][accessor]
        return self.doc["bufferViews"][acc["bufferView"]].get("byteOffset", 0) + acc.get("byteOffset", 0)

    def poke(self, accessor: int, index: int, value: float) -> bytes:
        """The file with float ``index`` of ``accessor`` set to ``value``."""
        blob = bytearray(self.blob)
        at = self.start(accessor) + 4 * index
        blob[at : at + 4] = np.float32(value).tobytes()
        return pack(self.doc, bytes(blob))


@pytest.fixture(scope="module")
def bases(tmp_path_factory) -> list[Base]:
    out = tmp_path_factory.mktemp("glb")
    found = []
    for source in (CMU / "16_15_walk.bvh", BANDAI / "dataset-1_bow_normal_001.bvh"):
        path = out / f"{source.stem}.glb"
        write_glb(read_bvh(source), path)
        found.append(Base(path.read_bytes()))
    return found


def outcome(path, data: bytes) -> str:
    """Read ``data`` written to ``path``: "read" (every number finite, joints within a 32-bit float) or "refused: ..."
    (one AdverbsError naming the file, in one line); anything else fails the test."""
    path.write_bytes(data)
    try:
        with bounded():
            clip = read_motion(path)
    except AdverbsError as e:
        message = str(e)
        assert str(path) in message and "\n" not in message, message
        return f"refused: {type(e).__name__}"
    assert np.all(np.isfinite(clip.rotations)) and np.all(np.isfinite(clip.translations))
    np.testing.assert_allclose(np.linalg.norm(clip.rotations, axis=-1), 1.0, rtol=0, atol=1e-9)
    positions = clip.global_positions()
    assert np.all(np.isfinite(positions)) and np.abs(positions).max() <= FLOAT32_MAX
    assert clip.num_frames >= 1 and np.isfinite(clip.fps) and clip.fps > 0
    return "read"


def refused(path, data: bytes, field: str, *words: str) -> GLTFError:
    path.write_bytes(data)
    with bounded(), pytest.raises(GLTFError) as info:
        read_motion(path)
    err = info.value
    assert err.path == str(path) and err.field == field, str(err)
    assert str(err).startswith(f"{path}: {field}: ") and "\n" not in str(err)
    for w in words:
        assert w in err.reason, err.reason
    return err


def test_the_undamaged_files_read_back(bases, tmp_path):
    for base in bases:
        assert outcome(tmp_path / "x.glb", base.data) == "read"


# ----- each fault of the report, named --------------------------------------------------------------------------


def _set(doc: dict, path: tuple, value) -> dict:
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    parent[path[-1]] = value
    return doc


def _cycle(doc: dict) -> dict:
    """nodes[1] and nodes[2] each the other's child (and nodes[1] no longer the root's)."""
    doc["nodes"][0]["children"].remove(1)
    doc["nodes"][2].setdefault("children", []).append(1)
    return doc


CASES = [
    # (name, damage(doc, base), field, words in the reason)
    (
        "a node its own child (hung)",
        lambda d, b: _set(d, ("nodes", 3, "children"), [3]),
        "nodes[3].children[0]",
        "its own child",
    ),
    ("two nodes each other's child (hung)", lambda d, b: _cycle(d), "nodes[2].children", "cycle"),
    (
        "a node two nodes' child",
        lambda d, b: _set(d, ("nodes", 2, "children"), [3, 1]),
        "nodes[2].children[1]",
        "already a child",
    ),
    (
        "duplicate joint names (ValueError)",
        lambda d, b: _set(d, ("nodes", 2, "name"), d["nodes"][1]["name"]),
        "nodes[2].name",
        "unique",
    ),
    (
        "a skin joint -1 (ValueError)",
        lambda d, b: _set(d, ("skins", 0, "joints", 2), -1),
        "skins[0].joints[2]",
        "whole number from 0",
    ),
    (
        "a skin joint out of range (IndexError)",
        lambda d, b: _set(d, ("skins", 0, "joints", 1), 10**6),
        "skins[0].joints[1]",
        "1000000",
    ),
    ("a skin joint twice", lambda d, b: _set(d, ("skins", 0, "joints", 3), 2), "skins[0].joints[3]", "node 2 is also"),
    (
        "a child out of range (ValueError)",
        lambda d, b: _set(d, ("nodes", 1, "children"), [2, 999]),
        "nodes[1].children[1]",
        "999",
    ),
    ("two roots", lambda d, b: d["nodes"][0]["children"].remove(1) or d, "skins[0].joints[1]", "one root"),
    ("no nodes (IndexError)", lambda d, b: d.pop("nodes") and d, "skins[0].joints[0]", "has none"),
    (
        "componentType 5130 (KeyError)",
        lambda d, b: _set(d, ("accessors", b.rotation, "componentType"), 5130),
        "accessors[{rotation}].componentType",
        "5130 is not a float type",
    ),
    (
        "componentType 5120",
        lambda d, b: _set(d, ("accessors", b.rotation, "componentType"), 5120),
        "accessors[{rotation}].componentType",
        "5120",
    ),
    (
        "type VEC2 (KeyError)",
        lambda d, b: _set(d, ("accessors", b.rotation, "type"), "VEC2"),
        "accessors[{rotation}].type",
        "must be VEC4",
    ),
    (
        "type MAT2 on the times",
        lambda d, b: _set(d, ("accessors", b.times, "type"), "MAT2"),
        "accessors[{times}].type",
        "must be SCALAR",
    ),
    (
        "a sampler input out of range (IndexError)",
        lambda d, b: _set(d, ("animations", 0, "samplers", 0, "input"), 99999),
        "animations[0].samplers[0].input",
        "99999",
    ),
    (
        "key times one more than the data (ValueError)",
        lambda d, b: _set(d, ("accessors", b.times, "count"), d["accessors"][b.times]["count"] + 1),
        "accessors[{times}].count",
        "run past the end",
    ),
    (
        "values one fewer than the key times",
        lambda d, b: _set(d, ("accessors", b.rotation, "count"), d["accessors"][b.rotation]["count"] - 1),
        "animations[0].samplers[0].output",
        "values for",
    ),
    (
        "count 0",
        lambda d, b: _set(d, ("accessors", b.rotation, "count"), 0),
        "accessors[{rotation}].count",
        "1 or more",
    ),
    (
        "count -5",
        lambda d, b: _set(d, ("accessors", b.rotation, "count"), -5),
        "accessors[{rotation}].count",
        "1 or more",
    ),
    (
        "count 10^9",
        lambda d, b: _set(d, ("accessors", b.rotation, "count"), 10**9),
        "accessors[{rotation}].count",
        "run past the end",
    ),
    (
        "count of 400 digits",
        lambda d, b: _set(d, ("accessors", b.rotation, "count"), 10**400),
        "accessors[{rotation}].count",
        "characters",
    ),
    (
        'count "10"',
        lambda d, b: _set(d, ("accessors", b.rotation, "count"), "10"),
        "accessors[{rotation}].count",
        "'10'",
    ),
    ("count 2.5", lambda d, b: _set(d, ("accessors", b.rotation, "count"), 2.5), "accessors[{rotation}].count", "2.5"),
    (
        "an accessor 2 bytes off (NaN read)",
        lambda d, b: _set(d, ("accessors", b.rotation, "byteOffset"), 2),
        "accessors[{rotation}].byteOffset",
        "multiple of 4",
    ),
    (
        "a buffer view 1 byte off",
        lambda d, b: _set(
            d, ("bufferViews", d["accessors"][b.rotation]["bufferView"], "byteOffset"), b.start(b.rotation) + 1
        ),
        "bufferViews[{view}].byteOffset",
        "multiple of 4",
    ),
    (
        "a buffer view past the chunk",
        lambda d, b: _set(d, ("bufferViews", d["accessors"][b.rotation]["bufferView"], "byteLength"), 10**12),
        "bufferViews[{view}].byteLength",
        "run past",
    ),
    (
        "a stride shorter than an element",
        lambda d, b: _set(d, ("bufferViews", d["accessors"][b.rotation]["bufferView"], "byteStride"), 8),
        "bufferViews[{view}].byteStride",
        "from 16",
    ),
    (
        "a rotation of 5 numbers (ValueError)",
        lambda d, b: _set(d, ("nodes", 1, "rotation"), [0, 0, 0, 1, 0]),
        "nodes[1].rotation",
        "4 numbers",
    ),
    (
        "a rotation of length 0",
        lambda d, b: _set(d, ("nodes", 1, "rotation"), [0, 0, 0, 0]),
        "nodes[1].rotation",
        "length 0",
    ),
    (
        "a joint 1e300 m away (accepted)",
        lambda d, b: _set(d, ("nodes", 5, "translation"), [1e300, 0, 0]),
        "nodes[5].translation[0]",
        "32-bit float",
    ),
    (
        "joints that add up past a 32-bit float",
        lambda d, b: [_set(d, ("nodes", k, "translation"), [3e38, 0, 0]) for k in (1, 2, 3)] and d,
        "nodes[2]",
        "past the largest 32-bit float",
    ),
    ("NaN in the JSON", lambda d, b: _set(d, ("nodes", 1, "translation"), [float("nan"), 0, 0]), "JSON", "NaN"),
    ("a name that is a number", lambda d, b: _set(d, ("nodes", 3, "name"), 5), "nodes[3].name", "a string"),
    ("children not an array", lambda d, b: _set(d, ("nodes", 0, "children"), "abc"), "nodes[0].children", "array"),
    ("nodes an object", lambda d, b: _set(d, ("nodes",), {"a": 1}), "nodes", "must be an array"),
    (
        "a frame rate of 'abc'",
        lambda d, b: _set(d, ("animations", 0, "extras", "fps"), "abc"),
        "animations[0].extras.fps",
        "frame rate",
    ),
    (
        "a frame rate of 1e300",
        lambda d, b: _set(d, ("animations", 0, "extras", "fps"), 1e300),
        "animations[0].extras.fps",
        "frame rate",
    ),
    (
        "a channel that is not BVH's",
        lambda d, b: _set(d, ("animations", 0, "extras", "channels", 1), ["Xrotation", 5]),
        "animations[0].extras.channels[1]",
        "BVH channel",
    ),
    (
        "an End Site on no joint",
        lambda d, b: _set(d, ("animations", 0, "extras", "end_sites"), {"parents": [99], "offsets": [[0, 0, 0]]}),
        "animations[0].extras.end_sites.parents[0]",
        "99",
    ),
    (
        "a channel on node '0'",
        lambda d, b: _set(d, ("animations", 0, "channels", 0, "target", "node"), "0"),
        "animations[0].channels[0].target.node",
        "'0'",
    ),
    (
        "a sampler out of range",
        lambda d, b: _set(d, ("animations", 0, "channels", 0, "sampler"), 999),
        "animations[0].channels[0].sampler",
        "999",
    ),
    (
        "CUBICSPLINE keys",
        lambda d, b: _set(d, ("animations", 0, "samplers", 0, "interpolation"), "CUBICSPLINE"),
        "animations[0].samplers[0].interpolation",
        "CUBICSPLINE",
    ),
    (
        "a joint placed by a matrix",
        lambda d, b: _set(d, ("nodes", 3, "matrix"), [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
        "nodes[3].matrix",
        "matrix",
    ),
    (
        "an external buffer",
        lambda d, b: _set(d, ("buffers", 0, "uri"), "x.bin"),
        "bufferViews[{times_view}].buffer",
        "binary chunk",
    ),
    ("no asset", lambda d, b: d.pop("asset") and d, "asset.version", "2.0"),
    ("no skin", lambda d, b: d.pop("skins") and d, "skins", "no skin"),
    ("no animation", lambda d, b: d.pop("animations") and d, "animations", "no animation 0"),
]


@pytest.mark.parametrize("name, damage, field, word", CASES, ids=[c[0] for c in CASES])
def test_each_damaged_field_is_refused_naming_it(bases, tmp_path, name, damage, field, word):
    base = bases[0]
    view = base.doc["accessors"][base.rotation]["bufferView"]
    times_view = base.doc["accessors"][base.times]["bufferView"]  # the first read
    field = field.format(rotation=base.rotation, times=base.times, view=view, times_view=times_view)
    refused(tmp_path / "x.glb", pack(damage(base.copy(), base), base.blob), field, word)


def test_damaged_containers_are_refused_naming_the_part(bases, tmp_path):
    base = bases[0]
    path = tmp_path / "x.glb"
    short = bytearray(base.data)
    short[8:12] = (len(base.data) - 100).to_bytes(4, "little")  # pygltflib returned no blob: TypeError
    refused(path, bytes(short), "header.length", "truncated")
    refused(path, base.data[:-7], "header.length")
    refused(path, pack(base.doc, base.blob, version=1), "header.version", "version 2")
    refused(path, pack(base.doc, None), f"bufferViews[{base.doc['accessors'][base.times]['bufferView']}].buffer")
    refused(path, b"glTF\x02\x00\x00\x00garbage", "header")
    refused(path, b"PK\x03\x04" + bytes(100), "header", "not a glTF binary file")
    refused(path, pack([1, 2], base.blob), "JSON", "object")
    bad_chunk = bytearray(base.data)
    bad_chunk[12:16] = (10**6).to_bytes(4, "little")  # the JSON chunk's length past the file
    refused(path, bytes(bad_chunk), "chunk 0.length", "run past the end")
    text = b"[" * 200_000 + b"]" * 200_000  # JSON nested past the parser's recursion
    nested = b"glTF\x02\x00\x00\x00" + (20 + len(text)).to_bytes(4, "little") + len(text).to_bytes(4, "little") + b"JSON" + text  # fmt: skip
    refused(path, nested, "JSON", "nested too deeply")


def test_a_file_past_the_memory_limit_or_endless_is_not_read(bases, tmp_path, monkeypatch):
    path = tmp_path / "x.glb"
    path.write_bytes(bases[0].data)
    monkeypatch.setattr(LIMITS, "memory", READ_COST * len(bases[0].data) - 1)
    with bounded(), pytest.raises(LimitError, match=rf"^{re.escape(str(path))}: the file is over .*ADVERBS_MAX_MEMORY"):
        read_motion(path)
    monkeypatch.setattr(LIMITS, "memory", READ_COST * (1 << 20))
    if Path("/dev/zero").exists():  # a device has no size: read up to the limit, not for ever
        (tmp_path / "zero.glb").symlink_to("/dev/zero")
        with bounded(), pytest.raises(LimitError, match="the file is over 1 MiB"):
            read_motion(tmp_path / "zero.glb")


def test_non_finite_values_in_the_binary_chunk_are_refused(bases, tmp_path):
    base = bases[0]
    path = tmp_path / "x.glb"
    refused(path, base.poke(base.rotation, 5, np.nan), f"accessors[{base.rotation}]", "value 1", "not finite")
    refused(path, base.poke(base.translation, 7, np.inf), f"accessors[{base.translation}]", "value 2", "not finite")
    refused(path, base.poke(base.times, 3, np.nan), f"accessors[{base.times}]", "value 3")
    refused(path, base.poke(base.times, 3, 0.0), "animations[0].samplers[0].input", "key time 3")
    zero = bytearray(base.blob)  # a rotation key of length 0: NaN once normalized
    at = base.start(base.rotation) + 16 * 4
    zero[at : at + 16] = bytes(16)
    refused(path, pack(base.doc, bytes(zero)), "animations[0].samplers[0].output", "key 4", "length 0")


def test_the_command_line_says_one_line_where_it_hung_or_took_1e300(bases, tmp_path):
    base = bases[0]
    looped = tmp_path / "looped.glb"
    looped.write_bytes(pack(_set(base.copy(), ("nodes", 3, "children"), [3]), base.blob))
    far = tmp_path / "far.glb"
    far.write_bytes(pack(_set(base.copy(), ("nodes", 5, "translation"), [1e300, 0, 0]), base.blob))
    for args, said in (
        (("info", looped), f"{looped}: nodes[3].children[0]: node 3 is its own child"),
        (("convert", far, tmp_path / "far.bvh"), f"{far}: nodes[5].translation[0]: must be a finite number within"),
    ):
        r = run(*args, timeout=60)
        assert r.returncode == 1 and r.stdout == "", r.stderr
        (line,) = r.stderr.splitlines()  # no traceback, no NumPy warning
        assert line.startswith(f"adverbs: error: {said}"), line
    assert not (tmp_path / "far.bvh").exists()


# ----- fuzzing ---------------------------------------------------------------------------------------------------

HOSTILE = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-3, 40),
    st.sampled_from([-1, 2**31, 2**63, 10**400, 5126, 5120, 5130, 0]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e300, -1e300, 3.5e38, 1e-320, 0.5, 2.5]),
    st.text(max_size=6),
    st.sampled_from(["SCALAR", "VEC2", "VEC3", "VEC4", "MAT4", "rotation", "translation", "scale", "LINEAR", "STEP"]),
    st.lists(st.one_of(st.integers(-2, 30), st.floats(allow_nan=True), st.booleans()), max_size=5),
    st.dictionaries(st.sampled_from(["a", "node", "path", "fps", "parents"]), st.integers(-2, 5), max_size=2),
)


@st.composite
def json_damage(draw, bases) -> bytes:
    """The JSON of a real file with 1-3 fields (anywhere: nodes, skins, animations, accessors, buffer views,
    extras) replaced by a hostile value, deleted, or given an index far out of range."""
    base = draw(st.sampled_from(bases))
    doc = base.copy()
    for _ in range(draw(st.integers(1, 3))):
        top = draw(st.sampled_from(["nodes", "skins", "animations", "accessors", "bufferViews", "buffers", "asset"]))
        if top not in doc:
            continue
        parent, key, path = draw_field(draw, st, doc, (top,))
        action = draw(st.sampled_from(["replace", "replace", "replace", "delete", "index"]))
        if action == "delete" and len(path) > 1:
            del parent[key]
        elif action == "index":
            parent[key] = draw(st.sampled_from([-1, 10**6, len(doc.get("nodes", [])), len(doc["accessors"])]))
        else:
            parent[key] = draw(HOSTILE)
        event(f"{action} in {top}")
    return pack(doc, base.blob)


@st.composite
def node_damage(draw, bases) -> bytes:
    """The node tree rewired: children added or taken away (cycles, self links, a node with two parents), skin
    joints dropped, repeated or reordered."""
    base = draw(st.sampled_from(bases))
    doc = base.copy()
    nodes = doc["nodes"]
    for _ in range(draw(st.integers(1, 4))):
        a, b = draw(st.integers(0, len(nodes) - 1)), draw(st.integers(0, len(nodes) - 1))
        what = draw(st.sampled_from(["link", "unlink", "joints", "shuffle"]))
        if what == "link":
            nodes[a].setdefault("children", []).append(b)
        elif what == "unlink" and nodes[a].get("children"):
            nodes[a]["children"].pop(draw(st.integers(0, len(nodes[a]["children"]) - 1)))
        elif what == "joints":
            doc["skins"][0]["joints"] = draw(st.lists(st.integers(-1, len(nodes)), min_size=0, max_size=len(nodes) + 1))
        elif what == "shuffle":
            doc["skins"][0]["joints"] = draw(st.permutations(doc["skins"][0]["joints"]))
        event(what)
    return pack(doc, base.blob)


@st.composite
def value_damage(draw, bases) -> bytes:
    """Numbers of the animation data or the nodes replaced: NaN, infinities, the largest floats, denormals, zeros."""
    base = draw(st.sampled_from(bases))
    bad = st.sampled_from([np.nan, np.inf, -np.inf, 3.4e38, -3.4e38, 1e-45, 0.0, 1e30, -1.0])
    blob = bytearray(base.blob)
    doc = base.copy()
    for _ in range(draw(st.integers(1, 4))):
        if draw(st.booleans()):
            acc = draw(st.sampled_from([base.times, base.rotation, base.translation]))
            count = base.doc["accessors"][acc]["count"] * {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[base.doc["accessors"][acc]["type"]]  # fmt: skip
            at = base.start(acc) + 4 * draw(st.integers(0, count - 1))
            blob[at : at + 4] = np.float32(draw(bad)).tobytes()
            event("accessor value")
        else:
            node = doc["nodes"][draw(st.sampled_from(base.joints))]
            key, n = draw(st.sampled_from([("translation", 3), ("rotation", 4)]))
            node[key] = [float(draw(bad)) if draw(st.booleans()) else x for x in node.get(key, [0.0] * n)]
            event(f"node {key}")
    return pack(doc, bytes(blob))


@st.composite
def byte_damage(draw, bases) -> bytes:
    """The container's bytes overwritten, cut or extended: header, chunk headers, JSON text, binary data."""
    base = draw(st.sampled_from(bases))
    data = bytearray(base.data)
    json_end = 20 + int.from_bytes(data[12:16], "little")
    for _ in range(draw(st.integers(1, 4))):
        where = draw(st.sampled_from(["header", "chunk", "json", "bin", "cut", "grow"]))
        if where == "cut":
            del data[draw(st.integers(0, max(len(data) - 1, 0))) :]
        elif where == "grow":
            data += draw(st.binary(min_size=1, max_size=64))
        else:
            lo, hi = {"header": (0, 12), "chunk": (12, 20), "json": (20, json_end), "bin": (json_end, len(data))}[where]
            if lo >= min(hi, len(data)):
                continue
            at = draw(st.integers(lo, min(hi, len(data)) - 1))
            patch = draw(st.binary(min_size=1, max_size=8))
            data[at : at + len(patch)] = patch
        event(where)
    return bytes(data)


@pytest.mark.parametrize("kind", [json_damage, node_damage, value_damage, byte_damage], ids=lambda k: k.__name__)
def test_fuzzed_files_are_read_finite_or_refused_in_one_line(bases, tmp_path, kind):
    @FUZZ
    @given(data=kind(bases))
    def check(data):
        event(outcome(tmp_path / "fuzz.glb", data))

    check()
