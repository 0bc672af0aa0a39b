"""glTF 2.0 binary files (``.glb``) of a clip, for engines and the web, and back.

What :func:`write_glb` writes (the container through ``pygltflib``):

* **The skeleton as a node hierarchy**, one node per joint with the joint's name, its translation and rotation
  those of the first frame (so a viewer that does not play the animation shows the first pose).
* **An animation**, ``LINEAR`` samplers on the frame times (``frame / fps`` seconds; the frame rate is also kept in
  the animation's ``extras``): a rotation channel on every joint, and a translation channel on every joint whose
  translation changes (the root's trajectory; a joint that slides in its socket).
* **A visible body**: a box along each bone (from a joint to each child whose offset does not move, and to each
  End Site), rigidly skinned to the joint it hangs from, with one plain material; the skin's bind pose is the
  first frame. So the file shows a figure in any glTF viewer.

Units are metres, +Y up, as in a :class:`Clip`. :func:`read_glb` reads such a file (or any with one skin and one
animation sampled at the same times on every channel) back into a clip.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from ..errors import AdverbsError
from ..kinematics import quat
from ..kinematics.fk import forward_kinematics
from ..kinematics.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton
from ..limits import LIMITS, LimitError, check_frames, check_joints
from ..motion.clip import MAX_FPS, MIN_FPS, Clip
from .bvh import READ_COST, UNITS, _frame_rate
from .files import write_atomic

GENERATOR = "adverbs (https://github.com/adverbs)"
FLOAT, UINT, USHORT, UBYTE = 5126, 5125, 5123, 5121
DTYPES = {FLOAT: "<f4", UINT: "<u4", USHORT: "<u2", UBYTE: "<u1"}  # accessor component types as NumPy's
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
FLOAT32_MAX = float(np.finfo(np.float32).max)
MOVES = 1e-9  # metres: a joint whose translation changes more than this over the clip gets a translation channel
BONE_MIN = 0.01  # metres: bones shorter than this get no box
COLOR = (0.82, 0.55, 0.28, 1.0)
GLB_MAGIC, JSON_CHUNK, BIN_CHUNK = b"glTF", b"JSON", b"BIN\0"
WIDTHS = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}  # floats per element of the accessor types the reader reads
IDENTITY = np.eye(4).reshape(-1).tolist()
MIN_QUAT = 1e-6  # a rotation (quaternion) shorter than this has no direction to normalize to
ROTATION_ORDER = ("Zrotation", "Xrotation", "Yrotation")  # the channels a joint read without extras gets
CHANNEL_NAMES = set(POSITION_CHANNELS + ROTATION_CHANNELS)


def write_glb(clip: Clip, path: str | Path, body: bool = True) -> Path:
    """Write ``clip`` to ``path`` as a binary glTF 2.0 file (see the module); ``body``: with the boxes and skin.
    The file is written whole or not at all."""
    return write_atomic(path, format_glb(clip, body))


def format_glb(clip: Clip, body: bool = True) -> bytes:
    """The ``.glb`` bytes of ``clip`` (see :func:`write_glb`)."""
    from pygltflib import (
        GLTF2, Accessor, Animation, AnimationChannel, AnimationChannelTarget, AnimationSampler, Asset, Attributes,
        Buffer, BufferView, Material, Mesh, Node, PbrMetallicRoughness, Primitive, Scene, Skin,
    )  # fmt: skip

    skel = clip.skeleton
    rot = quat.make_continuous(quat.normalize(clip.rotations), axis=0)
    trans = clip.translations
    if not (np.all(np.isfinite(rot)) and np.all(np.isfinite(trans))):
        raise AdverbsError(f"clip {clip.name!r}: NaN or infinite rotations or translations cannot be written")
    with np.errstate(over="ignore", invalid="ignore"):  # a file's worth of 1e300s: refused just below
        gpos = forward_kinematics(skel.parents, rot, trans)[0]
        largest = max(float(np.abs(trans).max(initial=0.0)), float(np.abs(gpos).max(initial=0.0)))
    if not largest <= FLOAT32_MAX:
        raise AdverbsError(
            f"clip {clip.name!r}: a translation or joint position of {largest:.3g} cannot be written: glTF stores "
            f"32-bit floats, at most {FLOAT32_MAX:.3g} (it would read back as infinite)"
        )
    j_count = skel.num_joints
    blob = bytearray()
    views: list[BufferView] = []
    accessors: list[Accessor] = []

    def add(array: np.ndarray, kind: str, component: int, target: int | None = None, bounds: bool = False) -> int:
        data = np.ascontiguousarray(array, dtype=DTYPES[component])
        views.append(BufferView(buffer=0, byteOffset=len(blob), byteLength=data.nbytes, target=target))
        blob.extend(data.tobytes())
        blob.extend(b"\0" * (-len(blob) % 4))
        flat = data.reshape(len(data), -1)
        acc = Accessor(bufferView=len(views) - 1, componentType=component, count=len(data), type=kind)
        if bounds:
            acc.min, acc.max = flat.min(axis=0).tolist(), flat.max(axis=0).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    children = [skel.children(j) for j in range(j_count)]
    nodes = [
        Node(
            name=skel.names[j], translation=[float(x) for x in trans[0, j]], rotation=[float(x) for x in rot[0, j]],
            children=children[j] or None,
        )
        for j in range(j_count)
    ]  # fmt: skip
    roots = [0]
    skins, meshes, materials = [], [], []
    if body:
        gpos, grot = forward_kinematics(skel.parents, rot[:1], trans[:1])
        positions, normals, joints, indices = _boxes(skel, clip, gpos[0], grot[0])
        if len(positions):
            # Bind pose = the first frame: each joint's inverse world matrix then.
            bind = np.linalg.inv(_matrices(gpos[0], grot[0]))
            ibm = add(np.transpose(bind, (0, 2, 1)).reshape(j_count, 16), "MAT4", FLOAT)  # column-major
            pos_acc = add(positions, "VEC3", FLOAT, ARRAY_BUFFER, bounds=True)
            nrm_acc = add(normals, "VEC3", FLOAT, ARRAY_BUFFER)
            small = UBYTE if j_count <= 255 else USHORT
            jnt = np.zeros((len(joints), 4), dtype=np.int64)
            jnt[:, 0] = joints
            jnt_acc = add(jnt, "VEC4", small, ARRAY_BUFFER)
            wts = np.zeros((len(joints), 4))
            wts[:, 0] = 1.0
            wts_acc = add(wts, "VEC4", FLOAT, ARRAY_BUFFER)
            idx_acc = add(
                indices, "SCALAR", UINT if len(positions) > 65535 else USHORT, ELEMENT_ARRAY_BUFFER, bounds=True
            )
            materials.append(Material(name="body", pbrMetallicRoughness=PbrMetallicRoughness(baseColorFactor=list(COLOR), metallicFactor=0.0, roughnessFactor=0.8)))  # fmt: skip
            attrs = Attributes(POSITION=pos_acc, NORMAL=nrm_acc, JOINTS_0=jnt_acc, WEIGHTS_0=wts_acc)
            meshes.append(Mesh(name="body", primitives=[Primitive(attributes=attrs, indices=idx_acc, material=0)]))
            skins.append(Skin(name=skel.names[0], joints=list(range(j_count)), inverseBindMatrices=ibm, skeleton=0))
            nodes.append(Node(name="body", mesh=0, skin=0))
            roots.append(len(nodes) - 1)

    times = add(np.arange(clip.num_frames) / clip.fps, "SCALAR", FLOAT, bounds=True)
    samplers, channels = [], []
    for j in range(j_count):
        samplers.append(AnimationSampler(input=times, output=add(rot[:, j], "VEC4", FLOAT), interpolation="LINEAR"))
        channels.append(AnimationChannel(sampler=len(samplers) - 1, target=AnimationChannelTarget(node=j, path="rotation")))  # fmt: skip
        if np.abs(trans[:, j] - trans[:1, j]).max() > MOVES:
            samplers.append(AnimationSampler(input=times, output=add(trans[:, j], "VEC3", FLOAT), interpolation="LINEAR"))  # fmt: skip
            channels.append(AnimationChannel(sampler=len(samplers) - 1, target=AnimationChannelTarget(node=j, path="translation")))  # fmt: skip
    extras = {"fps": float(clip.fps), "channels": [list(c) for c in skel.channels], "units": skel.units}
    if len(skel.end_site_parents):
        extras["end_sites"] = {"parents": skel.end_site_parents.tolist(), "offsets": skel.end_site_offsets.tolist()}
    animation = Animation(name=clip.name or "motion", samplers=samplers, channels=channels, extras=extras)

    gltf = GLTF2(
        asset=Asset(version="2.0", generator=GENERATOR), scene=0, scenes=[Scene(name=clip.name or "scene", nodes=roots)],
        nodes=nodes, meshes=meshes, materials=materials, skins=skins, animations=[animation], accessors=accessors,
        bufferViews=views, buffers=[Buffer(byteLength=len(blob))],
    )  # fmt: skip
    gltf.set_binary_blob(bytes(blob))
    return b"".join(gltf.save_to_bytes())  # pygltflib gives the header and the two chunks as a list


def _matrices(pos: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """World matrices ``(J, 4, 4)`` of joints at ``pos (J, 3)`` turned by ``rot (J, 4)``."""
    m = np.zeros((len(pos), 4, 4))
    m[:, :3, :3] = quat.to_matrix(rot)
    m[:, :3, 3] = pos
    m[:, 3, 3] = 1.0
    return m


def _boxes(skel: Skeleton, clip: Clip, gpos: np.ndarray, grot: np.ndarray):
    """A box along every bone at the first frame: positions, normals ``(V, 3)``, the joint of each vertex ``(V,)``,
    triangle indices ``(T·3,)``."""
    moving = np.abs(clip.translations - clip.translations[:1]).max(axis=(0, 2)) > MOVES
    bones = [(int(skel.parents[j]), gpos[j]) for j in range(1, skel.num_joints) if not moving[j]]
    ends = gpos[skel.end_site_parents] + quat.rotate(grot[skel.end_site_parents], skel.end_site_offsets)
    bones += [(int(p), e) for p, e in zip(skel.end_site_parents, ends)]
    faces = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    positions, normals, joints, indices = [], [], [], []
    for joint, tip in bones:
        start = gpos[joint]
        axis = tip - start
        length = float(np.linalg.norm(axis))
        if length < BONE_MIN:
            continue
        d = axis / length
        side = np.cross(d, [0.0, 1.0, 0.0] if abs(d[1]) < 0.9 else [1.0, 0.0, 0.0])
        side /= np.linalg.norm(side)
        up = np.cross(side, d)
        half = float(np.clip(0.12 * length, 0.012, 0.05))
        a, b = start + 0.08 * axis, start + 0.92 * axis  # a little gap at each joint
        corners = np.array([c + sx * half * side + sy * half * up for c in (a, b) for sx in (-1, 1) for sy in (-1, 1)])
        for f in faces:
            quad = corners[f]
            n = np.cross(quad[1] - quad[0], quad[2] - quad[0])
            n /= np.linalg.norm(n)
            if np.dot(n, quad.mean(axis=0) - 0.5 * (a + b)) < 0:  # outward, counter-clockwise seen from outside
                quad, n = quad[::-1], -n
            base = len(positions)
            positions.extend(quad)
            normals.extend([n] * 4)
            joints.extend([joint] * 4)
            indices.extend([base, base + 1, base + 2, base, base + 2, base + 3])
    return np.array(positions).reshape(-1, 3), np.array(normals).reshape(-1, 3), np.array(joints, dtype=np.int64), np.array(indices, dtype=np.int64)  # fmt: skip


class GLTFError(AdverbsError):
    """A ``.glb`` file that cannot be read: ``path`` and ``field`` (e.g. ``accessors[5].componentType``) say where."""

    def __init__(self, path: str | Path, field: str, reason: str):
        self.path, self.field, self.reason = str(path), field, reason
        super().__init__(f"{path}: {field + ': ' if field else ''}{reason}")


class _Document:
    """The JSON of a ``.glb`` file and its binary chunk, read with every index, number and length checked: what is
    wrong raises a :class:`GLTFError` naming the field (``nodes[3].children[0]``)."""

    def __init__(self, path: Path, data: bytes):
        self.path = path
        self.json, self.blob = self._container(data)
        self._tables: dict[str, list[dict]] = {}

    def error(self, field: str, reason: str) -> GLTFError:
        return GLTFError(self.path, field, reason)

    def _container(self, data: bytes) -> tuple[dict, bytes | None]:
        """The JSON chunk, parsed, and the BIN chunk (None without one) of the GLB container (glTF 2.0, §4.4)."""
        if data[:4] != GLB_MAGIC:
            raise self.error("header", f"not a glTF binary file: it starts {data[:4]!r}, not {GLB_MAGIC!r}")
        if len(data) < 20:
            raise self.error("header", f"{len(data)} bytes: a glTF binary file has a 12-byte header and a JSON chunk")
        version, length = int.from_bytes(data[4:8], "little"), int.from_bytes(data[8:12], "little")
        if version != 2:
            raise self.error("header.version", f"{version}; only glTF 2.0 binary files (version 2) are read")
        if length != len(data):
            raise self.error("header.length", f"{length} bytes, but the file has {len(data)}: truncated or damaged")
        chunks, at = [], 12
        while at < length and len(chunks) < 2:  # JSON, then BIN; later chunks are extensions' and not read
            if at + 8 > length:
                raise self.error(f"chunk {len(chunks)}", f"a chunk header at byte {at} runs past the end of the file")
            size, kind = int.from_bytes(data[at : at + 4], "little"), data[at + 4 : at + 8]
            if at + 8 + size > length:
                raise self.error(f"chunk {len(chunks)}.length", f"{size} bytes from byte {at + 8} run past the end of the file ({length} bytes)")  # fmt: skip
            chunks.append((kind, data[at + 8 : at + 8 + size]))
            at += 8 + size
        if not chunks or chunks[0][0] != JSON_CHUNK:
            raise self.error("chunk 0.type", "the first chunk must be JSON")
        blob = None
        if len(chunks) > 1:
            if chunks[1][0] != BIN_CHUNK:
                raise self.error("chunk 1.type", f"{chunks[1][0]!r}; the second chunk must be BIN")
            blob = chunks[1][1]
        try:
            doc = json.loads(chunks[0][1].decode("utf-8"), parse_constant=self._constant)
        except UnicodeDecodeError as e:
            raise self.error("JSON", f"not UTF-8 text ({e.reason} at byte {e.start})") from None
        except RecursionError:
            raise self.error("JSON", "arrays or objects nested too deeply") from None
        except GLTFError:
            raise
        except ValueError as e:  # bad JSON, or an integer of more digits than Python converts
            raise self.error("JSON", f"not valid JSON: {e}") from None
        if not isinstance(doc, dict):
            raise self.error("JSON", f"must be an object, got {type(doc).__name__}")
        asset = doc.get("asset")
        version = asset.get("version") if isinstance(asset, dict) else None
        if not (isinstance(version, str) and version.split(".")[0] == "2"):
            raise self.error("asset.version", f'must be "2.0" (a glTF 2.0 file), got {_short(version)}')
        return doc, blob

    def _constant(self, word: str):
        raise self.error("JSON", f"{word} is not a JSON number")

    def table(self, name: str) -> list[dict]:
        """The top-level array ``name`` (empty if absent), each entry an object."""
        if name in self._tables:
            return self._tables[name]
        value = self.json.get(name, [])
        if not isinstance(value, list):
            raise self.error(name, f"must be an array, got {type(value).__name__}")
        for i, entry in enumerate(value):
            if not isinstance(entry, dict):
                raise self.error(f"{name}[{i}]", f"must be an object, got {type(entry).__name__}")
        self._tables[name] = value
        return value

    def whole(self, value, field: str, low: int = 0, high: float = math.inf) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            span = f"from {low} to {high}" if high < math.inf else f"{low} or more"
            raise self.error(field, f"must be a whole number {span}, got {_short(value)}")
        return value

    def index(self, value, table: str, field: str) -> int:
        """``value`` checked as an index into the top-level array ``table``."""
        n = len(self.table(table))
        if n == 0:
            raise self.error(field, f"{_short(value)} points into {table}, and the file has none")
        return self.whole(value, field, 0, n - 1)

    def numbers(self, value, n: int, field: str) -> np.ndarray:
        """``n`` finite numbers a 32-bit float holds (what glTF stores), as float64."""
        if not isinstance(value, list) or len(value) != n:
            raise self.error(field, f"must be an array of {n} numbers, got {_short(value)}")
        for i, x in enumerate(value):
            if isinstance(x, bool) or not isinstance(x, int | float) or not abs(x) <= FLOAT32_MAX:
                raise self.error(f"{field}[{i}]", f"must be a finite number within ±{FLOAT32_MAX:.3g} (a 32-bit float, what glTF holds), got {_short(x)}")  # fmt: skip
        return np.array(value, dtype=float)

    def accessor(self, index, field: str, kind: str) -> np.ndarray:
        """The float accessor ``index`` (named by ``field``) of type ``kind``: ``(count, width)``, every value finite."""
        k = self.index(index, "accessors", field)
        acc, where = self.table("accessors")[k], f"accessors[{k}]"
        if acc.get("componentType") != FLOAT:
            raise self.error(f"{where}.componentType", f"{_short(acc.get('componentType'))} is not a float type: animation data is read as FLOAT ({FLOAT})")  # fmt: skip
        if acc.get("type") != kind:
            raise self.error(f"{where}.type", f"{_short(acc.get('type'))}; {field} must be {kind}")
        if "sparse" in acc:
            raise self.error(f"{where}.sparse", "sparse accessors are not read")
        if "bufferView" not in acc:
            raise self.error(f"{where}.bufferView", "missing (an accessor of zeros is not read)")
        count = self.whole(acc.get("count"), f"{where}.count", 1)
        v = self.index(acc["bufferView"], "bufferViews", f"{where}.bufferView")
        view, vwhere = self.table("bufferViews")[v], f"bufferViews[{v}]"
        b = self.index(view.get("buffer"), "buffers", f"{vwhere}.buffer")
        if b != 0 or "uri" in self.table("buffers")[0] or self.blob is None:
            raise self.error(
                f"{vwhere}.buffer", "only the file's own binary chunk (buffer 0 of a .glb, no uri) is read"
            )
        view_start = self.whole(view.get("byteOffset", 0), f"{vwhere}.byteOffset")
        view_length = self.whole(view.get("byteLength"), f"{vwhere}.byteLength", 1)
        if view_start + view_length > len(self.blob):
            raise self.error(f"{vwhere}.byteLength", f"bytes {view_start} to {view_start + view_length} run past the binary chunk's {len(self.blob)}")  # fmt: skip
        width = WIDTHS[kind]
        stride = self.whole(view.get("byteStride", 4 * width), f"{vwhere}.byteStride", 4 * width, 252)
        offset = self.whole(acc.get("byteOffset", 0), f"{where}.byteOffset")
        for value, name in ((view_start, f"{vwhere}.byteOffset"), (offset, f"{where}.byteOffset"), (stride, f"{vwhere}.byteStride")):  # fmt: skip
            if value % 4:
                raise self.error(name, f"{value} is not a multiple of 4: float data must be aligned to its 4-byte components")  # fmt: skip
        if offset + (count - 1) * stride + 4 * width > view_length:
            raise self.error(f"{where}.count", f"{_short(count)} {kind} values from byte {offset} run past the end of {vwhere} ({view_length} bytes)")  # fmt: skip
        values = np.ndarray(
            (count, width), dtype="<f4", buffer=self.blob, offset=view_start + offset, strides=(stride, 4)
        )
        values = values.astype(float)
        bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
        if len(bad):
            raise self.error(where, f"value {bad[0]} is {values[bad[0]].tolist()}: not finite")
        return values


def _short(value) -> str:
    """``repr(value)`` cut to a line, for messages."""
    text = repr(value)
    return text if len(text) <= 60 else f"{text[:40]}… ({len(text)} characters)"


def read_glb(path: str | Path, animation: int = 0) -> Clip:
    """A clip from a ``.glb`` file: the joints of its (first) skin, the animation ``animation`` sampled at its own
    key times (which must be the same on every channel, evenly spaced). Joints no channel moves keep their node's
    transform. Files written by :func:`write_glb` come back with their channels, units and frame rate.

    Every fault raises a :class:`GLTFError` naming the file and the field: the container (header, chunk lengths),
    the JSON (a field of the wrong type, an index out of range), accessors (not FLOAT, the wrong type, data past
    their buffer view or not aligned to 4 bytes), the node tree (a node that is two nodes' child, a cycle, skin
    joints that are not one tree), duplicate joint names, key times that do not increase or do not match the
    values, and values that are not finite or past a 32-bit float (what glTF holds: joint positions too). A file
    over ``LIMITS.memory`` / :data:`~adverbs.io.bvh.READ_COST` bytes, or a clip past the frame and joint limits, is
    refused before it is read (:mod:`adverbs.limits`)."""
    path = Path(path)
    if isinstance(animation, bool) or not isinstance(animation, int):
        raise AdverbsError(f"{path}: animation must be a whole number, got {animation!r}")
    doc = _Document(path, _read_bytes(path))
    nodes = doc.table("nodes")
    skins = doc.table("skins")
    if not skins:
        raise doc.error("skins", "no skin (skeleton) in this file")
    animations = doc.table("animations")
    if not 0 <= animation < len(animations):
        raise doc.error("animations", f"no animation {animation} (the file has {len(animations)})")
    order, parents = _joint_order(doc, nodes, skins[0])
    check_joints(len(order), f"{path}: skins[0].joints")
    at = {n: k for k, n in enumerate(order)}
    names = []
    for n in order:
        name = nodes[n].get("name", f"joint{n}")
        if not isinstance(name, str) or not name:
            raise doc.error(f"nodes[{n}].name", f"must be a name (a string), got {_short(name)}")
        if name in names:
            raise doc.error(f"nodes[{n}].name", f"{name!r} is also the name of nodes[{order[names.index(name)]}]: joint names must be unique")  # fmt: skip
        names.append(name)
    rot, trans = np.zeros((len(order), 4)), np.zeros((len(order), 3))
    for k, n in enumerate(order):
        node = nodes[n]
        if "matrix" in node and doc.numbers(node["matrix"], 16, f"nodes[{n}].matrix").tolist() != IDENTITY:
            raise doc.error(
                f"nodes[{n}].matrix", "a joint placed by a matrix is not read: give translation and rotation"
            )
        rot[k] = doc.numbers(node.get("rotation", [0.0, 0.0, 0.0, 1.0]), 4, f"nodes[{n}].rotation")
        trans[k] = doc.numbers(node.get("translation", [0.0, 0.0, 0.0]), 3, f"nodes[{n}].translation")
        if not np.linalg.norm(rot[k]) > MIN_QUAT:
            raise doc.error(f"nodes[{n}].rotation", f"{rot[k].tolist()} is not a rotation (length 0)")
    anim, awhere = animations[animation], f"animations[{animation}]"
    times, tracks = _tracks(doc, anim, awhere, at)
    extras = anim.get("extras", {})
    if not isinstance(extras, dict):
        raise doc.error(f"{awhere}.extras", f"must be an object, got {_short(extras)}")
    fps = extras.get("fps", _frame_rate(float(np.median(np.diff(times))), "") if len(times) > 1 else 30.0)
    if isinstance(fps, bool) or not isinstance(fps, int | float) or not MIN_FPS <= fps <= MAX_FPS:
        field = f"{awhere}.extras.fps" if "fps" in extras else f"{awhere}: key times"
        raise doc.error(field, f"a frame rate of {_short(fps)}; it must be from {MIN_FPS:g} to {MAX_FPS:g} frames per second")  # fmt: skip
    f = check_frames(len(times), len(order), f"{path}: {awhere} of {len(times):,} key times")
    rotations = np.repeat(quat.normalize(rot)[None], f, axis=0)
    translations = np.repeat(trans[None], f, axis=0)
    for (k, what), values in tracks.items():
        if what == "rotation":
            rotations[:, k] = quat.normalize(values)
        else:
            translations[:, k] = values
    with np.errstate(over="ignore", invalid="ignore"):
        largest = np.abs(forward_kinematics(parents, rotations, translations)[0]).max(axis=(0, 2))
    if not np.all(largest <= FLOAT32_MAX):
        n = order[int(np.argmax(~(largest <= FLOAT32_MAX)))]
        raise doc.error(f"nodes[{n}]", f"the joint reaches {largest[at[n]]:.3g} m from the origin, past the largest 32-bit float ({FLOAT32_MAX:.3g}, what glTF holds)")  # fmt: skip
    moving = np.abs(translations - translations[:1]).max(axis=(0, 2)) > MOVES
    default = tuple(POSITION_CHANNELS + ROTATION_ORDER if k == 0 or m else ROTATION_ORDER for k, m in enumerate(moving))
    channels = _extras_channels(doc, extras, f"{awhere}.extras.channels", len(order)) or default
    site_parents, site_offsets = _end_sites(doc, extras.get("end_sites"), f"{awhere}.extras.end_sites", len(order))
    units = extras.get("units", "m")
    units = units if isinstance(units, str) and units in UNITS else "m"
    skel = Skeleton(
        names=tuple(names), parents=parents, offsets=translations[0], channels=channels, end_site_parents=site_parents,
        end_site_offsets=site_offsets, unit_scale=UNITS[units], units=units,
    )  # fmt: skip
    return Clip(skel, rotations, translations, float(fps), name=path.stem)


def _read_bytes(path: Path) -> bytes:
    """The file's bytes, refused past ``LIMITS.memory / READ_COST`` before they are read."""
    limit = LIMITS.memory // READ_COST
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size  # a regular file's size; 0 for a pipe or a device, read up to the limit
            data = f.read(limit + 1) if size <= limit else b""
    except OSError as e:
        raise GLTFError(path, "", f"cannot read: {e.strerror or e}") from None
    if max(size, len(data)) > limit:
        raise LimitError(
            f"{path}: the file is over {limit / (1 << 20):.3g} MiB; reading it would need about {READ_COST} times "
            f"that, past the memory limit (ADVERBS_MAX_MEMORY raises it: see adverbs.limits)"
        )
    return data


def _joint_order(doc: _Document, nodes: list[dict], skin: dict) -> tuple[list[int], np.ndarray]:
    """The skin's joints (node indices) parents first, and each one's parent in that order ``(J,)`` (-1: the root).

    Every joint but one (the root) must hang from another joint; a node that is two nodes' child, or its own
    ancestor, is refused (the walk up from a joint is bounded by the number of nodes)."""
    joints = skin.get("joints")
    if not isinstance(joints, list) or not joints:
        raise doc.error("skins[0].joints", f"must be a non-empty array of node indices, got {_short(joints)}")
    first = {}
    for i, j in enumerate(joints):
        j = doc.index(j, "nodes", f"skins[0].joints[{i}]")
        if j in first:
            raise doc.error(f"skins[0].joints[{i}]", f"node {j} is also skins[0].joints[{first[j]}]")
        first[j] = i
    parent_of: dict[int, int] = {}
    for p, node in enumerate(nodes):
        children = node.get("children", [])
        if not isinstance(children, list):
            raise doc.error(f"nodes[{p}].children", f"must be an array of node indices, got {_short(children)}")
        for i, c in enumerate(children):
            c = doc.index(c, "nodes", f"nodes[{p}].children[{i}]")
            if c == p:
                raise doc.error(f"nodes[{p}].children[{i}]", f"node {p} is its own child")
            if c in parent_of:
                raise doc.error(f"nodes[{p}].children[{i}]", f"node {c} is already a child of nodes[{parent_of[c]}]: a node has one parent")  # fmt: skip
            parent_of[c] = p
    roots = [j for j in first if parent_of.get(j) not in first]
    if not roots:
        raise doc.error("skins[0].joints", "every joint hangs from another joint: the joints' tree has a cycle")
    if len(roots) > 1:
        raise doc.error(f"skins[0].joints[{first[roots[1]]}]", f"nodes[{roots[1]}] and nodes[{roots[0]}] both hang from no joint: a skeleton has one root")  # fmt: skip
    order, at = [], {}
    for j in first:  # in the skin's order, each joint after the ancestors not placed yet
        chain = [j]
        while chain[-1] != roots[0] and parent_of[chain[-1]] not in at:
            chain.append(parent_of[chain[-1]])
            if len(chain) > len(first):  # more steps up than there are joints: the walk has come round
                raise doc.error(f"nodes[{chain[-1]}].children", f"the joints' tree has a cycle through nodes[{chain[-1]}]")  # fmt: skip
        for n in reversed(chain):
            if n not in at:
                at[n] = len(order)
                order.append(n)
    parents = np.array([at.get(parent_of.get(n, -1), -1) for n in order], dtype=np.int64)
    return order, parents


def _tracks(doc: _Document, anim: dict, awhere: str, at: dict[int, int]) -> tuple[np.ndarray, dict]:
    """The key times ``(F,)`` shared by the animation's channels on the skin's joints, and each channel's values
    ``(F, 4)`` (rotation) or ``(F, 3)`` (translation) by ``(joint, path)``."""
    samplers = anim.get("samplers", [])
    channels = anim.get("channels", [])
    for name, value in (("samplers", samplers), ("channels", channels)):
        if not isinstance(value, list) or not all(isinstance(x, dict) for x in value):
            raise doc.error(f"{awhere}.{name}", f"must be an array of objects, got {_short(value)}")
    times, time_field, tracks = None, "", {}
    for i, ch in enumerate(channels):
        cwhere = f"{awhere}.channels[{i}]"
        target = ch.get("target")
        if not isinstance(target, dict):
            raise doc.error(f"{cwhere}.target", f"must be an object, got {_short(target)}")
        if "node" not in target:
            continue  # a channel an extension targets
        node = doc.index(target["node"], "nodes", f"{cwhere}.target.node")
        what = target.get("path")
        if not isinstance(what, str):
            raise doc.error(f"{cwhere}.target.path", f"must be a string, got {_short(what)}")
        if node not in at or what not in ("rotation", "translation"):
            continue
        if (at[node], what) in tracks:
            raise doc.error(cwhere, f"a second {what} channel on nodes[{node}]")
        if "sampler" not in ch:
            raise doc.error(f"{cwhere}.sampler", "missing")
        s = doc.whole(ch["sampler"], f"{cwhere}.sampler", 0, len(samplers) - 1)
        sampler, swhere = samplers[s], f"{awhere}.samplers[{s}]"
        how = sampler.get("interpolation", "LINEAR")
        if how not in ("LINEAR", "STEP"):
            raise doc.error(f"{swhere}.interpolation", f"{_short(how)}; LINEAR or STEP keys are read (resample CUBICSPLINE in a DCC first)")  # fmt: skip
        t = doc.accessor(sampler.get("input"), f"{swhere}.input", "SCALAR")[:, 0]
        if np.any(np.diff(t) <= 0):
            k = int(np.argmax(np.diff(t) <= 0)) + 1
            raise doc.error(f"{swhere}.input", f"key time {k} ({t[k]:g} s) does not come after key {k - 1} ({t[k - 1]:g} s)")  # fmt: skip
        if times is not None and (len(t) != len(times) or np.abs(t - times).max() > 1e-6):
            raise doc.error(f"{swhere}.input", f"key times differ from those of {time_field}: resample the animation in a DCC first")  # fmt: skip
        times, time_field = t, f"{swhere}.input"
        values = doc.accessor(sampler.get("output"), f"{swhere}.output", "VEC4" if what == "rotation" else "VEC3")
        if len(values) != len(t):
            raise doc.error(f"{swhere}.output", f"{len(values)} values for {len(t)} key times")
        if what == "rotation" and not np.all(np.linalg.norm(values, axis=1) > MIN_QUAT):
            k = int(np.argmax(~(np.linalg.norm(values, axis=1) > MIN_QUAT)))
            raise doc.error(f"{swhere}.output", f"key {k} is {values[k].tolist()}: not a rotation (length 0)")
        tracks[(at[node], what)] = values
    if times is None:
        raise doc.error(f"{awhere}.channels", "the animation moves none of the skin's joints")
    return times, tracks


def _extras_channels(doc: _Document, extras: dict, field: str, joints: int) -> tuple[tuple[str, ...], ...] | None:
    """The BVH channels :func:`write_glb` keeps in the animation's extras (None when there are none)."""
    channels = extras.get("channels")
    if channels is None:
        return None
    if not isinstance(channels, list) or len(channels) != joints:
        raise doc.error(field, f"must be an array of {joints} joints' BVH channels, got {_short(channels)}")
    for k, c in enumerate(channels):
        known = isinstance(c, list) and all(isinstance(x, str) and x in CHANNEL_NAMES for x in c)
        if not (known and len(set(c)) == len(c)):
            raise doc.error(f"{field}[{k}]", f"must be an array of distinct BVH channel names, got {_short(c)}")
    return tuple(tuple(c) for c in channels)


def _end_sites(doc: _Document, sites, field: str, joints: int) -> tuple[np.ndarray, np.ndarray]:
    """The End Sites :func:`write_glb` keeps in the animation's extras: parents ``(E,)`` and offsets ``(E, 3)``."""
    if sites is None:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    parents = sites.get("parents") if isinstance(sites, dict) else None
    offsets = sites.get("offsets") if isinstance(sites, dict) else None
    if not (isinstance(parents, list) and isinstance(offsets, list) and len(parents) == len(offsets)):
        raise doc.error(field, 'must be {"parents": [...], "offsets": [[x, y, z], ...]} of one length')
    out_parents = [doc.whole(p, f"{field}.parents[{i}]", 0, joints - 1) for i, p in enumerate(parents)]
    out_offsets = [doc.numbers(o, 3, f"{field}.offsets[{i}]") for i, o in enumerate(offsets)]
    return np.array(out_parents, dtype=np.int64), np.array(out_offsets, dtype=float).reshape(-1, 3)


def describe(path: str | Path) -> dict:
    """The JSON part of a ``.glb`` file (for tests and messages)."""
    data = Path(path).read_bytes()
    length = int.from_bytes(data[12:16], "little")
    return json.loads(data[20 : 20 + length])
