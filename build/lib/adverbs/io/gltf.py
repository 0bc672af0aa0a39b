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
from pathlib import Path

import numpy as np

from ..errors import AdverbsError
from ..kinematics import quat
from ..kinematics.fk import forward_kinematics
from ..kinematics.skeleton import POSITION_CHANNELS, Skeleton
from ..motion.clip import Clip
from .bvh import UNITS
from .files import write_atomic

GENERATOR = "adverbs (https://github.com/adverbs)"
FLOAT, UINT, USHORT, UBYTE = 5126, 5125, 5123, 5121
DTYPES = {FLOAT: "<f4", UINT: "<u4", USHORT: "<u2", UBYTE: "<u1"}  # accessor component types as NumPy's
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
FLOAT32_MAX = float(np.finfo(np.float32).max)
MOVES = 1e-9  # metres: a joint whose translation changes more than this over the clip gets a translation channel
BONE_MIN = 0.01  # metres: bones shorter than this get no box
COLOR = (0.82, 0.55, 0.28, 1.0)


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
            idx_acc = add(indices, "SCALAR", UINT if len(positions) > 65535 else USHORT, ELEMENT_ARRAY_BUFFER, bounds=True)
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


def read_glb(path: str | Path, animation: int = 0) -> Clip:
    """A clip from a ``.glb`` file: the joints of its (first) skin, the animation ``animation`` sampled at its own
    key times (which must be the same on every channel, evenly spaced). Joints no channel moves keep their node's
    transform. Files written by :func:`write_glb` come back with their channels, units and frame rate."""
    from pygltflib import GLTF2

    path = Path(path)
    try:
        gltf = GLTF2().load_binary(str(path))
    except Exception as e:  # noqa: BLE001 - pygltflib raises whatever the damage causes; name the file
        raise AdverbsError(f"{path}: not a readable glTF binary file ({type(e).__name__}: {e})") from None
    if gltf is None or not gltf.skins:
        raise AdverbsError(f"{path}: no skin (skeleton) in this file")
    if not gltf.animations or not 0 <= animation < len(gltf.animations):
        raise AdverbsError(f"{path}: no animation {animation} (the file has {len(gltf.animations or [])})")
    blob = gltf.binary_blob()

    def read(index: int) -> np.ndarray:
        acc = gltf.accessors[index]
        view = gltf.bufferViews[acc.bufferView]
        dtype = DTYPES[acc.componentType]
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc.type]
        start = (view.byteOffset or 0) + (acc.byteOffset or 0)
        return np.frombuffer(blob, dtype=dtype, count=acc.count * width, offset=start).reshape(acc.count, width).astype(float)

    joints = list(gltf.skins[0].joints)
    parent_of = {c: i for i, n in enumerate(gltf.nodes) for c in (n.children or [])}
    order, seen = [], set()
    for j in joints:  # parents before children
        chain = [j]
        while parent_of.get(chain[-1]) in joints and parent_of[chain[-1]] not in seen:
            chain.append(parent_of[chain[-1]])
        for n in reversed(chain):
            if n not in seen:
                seen.add(n)
                order.append(n)
    at = {n: k for k, n in enumerate(order)}
    anim = gltf.animations[animation]
    times = None
    rot = np.array([gltf.nodes[n].rotation or [0.0, 0.0, 0.0, 1.0] for n in order], dtype=float)
    trans = np.array([gltf.nodes[n].translation or [0.0, 0.0, 0.0] for n in order], dtype=float)
    tracks = {}
    for ch in anim.channels:
        if ch.target.node in at and ch.target.path in ("rotation", "translation"):
            s = anim.samplers[ch.sampler]
            t = read(s.input)[:, 0]
            if times is not None and (len(t) != len(times) or np.abs(t - times).max() > 1e-6):
                raise AdverbsError(f"{path}: animation channels keyed at different times: resample it in a DCC first")
            times = t
            tracks[(at[ch.target.node], ch.target.path)] = read(s.output)
    if times is None:
        raise AdverbsError(f"{path}: the animation moves none of the skin's joints")
    extras = anim.extras or {}
    fps = float(extras.get("fps") or (1.0 / np.median(np.diff(times)) if len(times) > 1 else 30.0))
    f = len(times)
    rotations = np.repeat(rot[None], f, axis=0)
    translations = np.repeat(trans[None], f, axis=0)
    for (k, what), values in tracks.items():
        if what == "rotation":
            rotations[:, k] = quat.normalize(values)
        else:
            translations[:, k] = values
    names = tuple(gltf.nodes[n].name or f"joint{n}" for n in order)
    parents = np.array([at.get(parent_of.get(n, -1), -1) for n in order])
    moving = np.abs(translations - translations[:1]).max(axis=(0, 2)) > MOVES
    default = [POSITION_CHANNELS + ("Zrotation", "Xrotation", "Yrotation") if k == 0 or moving[k] else ("Zrotation", "Xrotation", "Yrotation") for k in range(len(order))]  # fmt: skip
    channels = extras.get("channels")
    if not (isinstance(channels, list) and len(channels) == len(order)):
        channels = default
    sites = extras.get("end_sites") or {"parents": [], "offsets": []}
    units = str(extras.get("units", "m"))
    skel = Skeleton(
        names=names, parents=parents, offsets=translations[0], channels=tuple(tuple(c) for c in channels),
        end_site_parents=np.array(sites["parents"], dtype=np.int64), end_site_offsets=np.array(sites["offsets"], dtype=float),
        unit_scale=UNITS.get(units, 1.0), units=units if units in UNITS else "m",
    )  # fmt: skip
    return Clip(skel, rotations, translations, fps, name=path.stem)


def describe(path: str | Path) -> dict:
    """The JSON part of a ``.glb`` file (for tests and messages)."""
    data = Path(path).read_bytes()
    length = int.from_bytes(data[12:16], "little")
    return json.loads(data[20 : 20 + length])
