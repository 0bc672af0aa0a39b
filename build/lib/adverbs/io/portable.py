"""A clip every BVH reader reads the same way: position channels on the root only.

BVH leaves open what a position channel on a joint other than the root means. Blender and bvhio replace the
joint's offset with it; three.js's ``BVHLoader`` adds it to the offset (so a figure with position channels on
every joint, like Bandai Namco's or ReActIdle's, stands twice as tall there); pybvh refuses such files. And
readers disagree on whether the root's OFFSET adds to its position channels. A *portable* clip avoids all of it:

* **The root carries the world trajectory**, with its OFFSET zero, so adding and replacing agree. Top joints that
  never move (Bandai's ``joint_Root``, a fixed point on the floor above which ``Hips`` travels) are folded away:
  their fixed transform goes into the new root's channels, and they no longer appear in the file.
* **Every other joint has rotation channels only** (in its own order), and its OFFSET is where its position
  channels, constant over the clip, put it — the rest skeleton the motion was recorded on.
* **A joint whose position channels do change** (ReActIdle's thighs slide up to 3 mm in their socket) is given a
  parent of its own, ``<name>_offset``, at zero length: its rotation turns the joint's fixed offset to where the
  channels put it at each frame, and the joint's own rotation is corrected by the inverse, so every kept joint is
  exactly where it was. Only a change of a joint's *distance* from its parent cannot be carried by rotations; that
  warns, naming the joint and how far off it leaves it.

:func:`portable` returns the new clip; the joints of the original keep their names, and their global positions
and rotations are the original's (to rounding, about 1e-12 m).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import AdverbsError, AdverbsWarning
from ..kinematics import quat
from ..kinematics.skeleton import POSITION_CHANNELS, Skeleton
from ..motion.clip import Clip

STILL = 2e-6  # metres (or radians): a channel that moves less than this over the clip is constant (rounding)
HELPER = "_offset"  # the name suffix of a joint added to carry another's sliding offset
DEFAULT_ORDER = "ZXY"  # rotation channels of a joint that had fewer than three and now needs all three


@dataclass(frozen=True)
class Portable:
    """A portable clip and how it was made: ``joints`` maps each of its joints to the original's (−1 for an added
    one), ``folded`` names the top joints folded away, ``added`` the joints added, ``error`` the largest distance
    (metres) between a kept joint here and in the original over every frame."""

    clip: Clip
    joints: np.ndarray
    folded: tuple[str, ...]
    added: tuple[str, ...]
    error: float


def _moves(x: np.ndarray) -> bool:
    """Whether ``x (F, ...)`` changes over its frames by more than :data:`STILL`."""
    return bool(np.abs(x - x[:1]).max(initial=0.0) > STILL)


def _turns(q: np.ndarray) -> bool:
    """Whether rotations ``q (F, 4)`` change over the frames by more than :data:`STILL` radians."""
    return bool(np.abs(quat.log(quat.mul(q, quat.inv(q[:1])))).max(initial=0.0) > STILL)


def portable(clip: Clip) -> Portable:
    """``clip`` on a skeleton with position channels only on its root (see the module)."""
    skel = clip.skeleton
    rot, trans = clip.rotations, clip.translations
    children = [skel.children(j) for j in range(skel.num_joints)]
    sites = set(skel.end_site_parents.tolist())

    # Fold fixed top joints: while the root never moves, has one child and no End Site, its child is the root.
    top, fixed_rot, fixed_pos = 0, quat.identity((clip.num_frames,)), np.zeros((clip.num_frames, 3))
    while len(children[top]) == 1 and top not in sites:
        child = children[top][0]
        if (_moves(trans[:, top]) or _turns(rot[:, top])) and not skel.has_position_channels(child):
            break  # a moving top joint is folded only into a child that has its own trajectory
        fixed_pos = fixed_pos + quat.rotate(fixed_rot, trans[:, top])
        fixed_rot = quat.mul(fixed_rot, rot[:, top])
        top = child
    folded = tuple(skel.names[:top])  # parents come before children: the folded chain is joints 0 .. top − 1

    names, parents, offsets, channels, source = [], [], [], [], []
    new_rot, new_trans = [], []
    index = {}  # original joint → its index in the new skeleton
    added, worst = [], 0.0
    for j in range(top, skel.num_joints):
        order = skel.rotation_order(j)
        if j == top:  # the root: the world trajectory, then the rotation
            r = quat.mul(fixed_rot, rot[:, j])
            p = fixed_pos + quat.rotate(fixed_rot, trans[:, j])
            index[j] = len(names)
            names.append(skel.names[j])
            parents.append(-1)
            offsets.append(np.zeros(3))
            channels.append(POSITION_CHANNELS + _rotation_channels(order if len(order) == 3 else DEFAULT_ORDER))
            source.append(j)
            new_rot.append(r)
            new_trans.append(p)
            continue
        parent = index[int(skel.parents[j])]
        t = trans[:, j]
        r = rot[:, j]
        if skel.has_position_channels(j) and _moves(t):
            # A sliding offset: a zero-length parent turns the fixed offset to where the channels put it.
            length = np.linalg.norm(t, axis=-1)
            mean = 0.5 * (t.min(axis=0) + t.max(axis=0))
            if not np.linalg.norm(mean) > STILL:
                raise AdverbsError(
                    f"clip {clip.name!r}: joint {skel.names[j]!r} moves through its parent's origin: a portable BVH "
                    "(position channels on the root only) cannot carry it"
                )
            middle = 0.5 * (length.min() + length.max())
            offset = mean / np.linalg.norm(mean) * middle
            turn = quat.between(offset, t)
            miss = float(np.abs(length - middle).max())
            if miss > 1e-6:
                warnings.warn(
                    f"clip {clip.name!r}: joint {skel.names[j]!r} changes its distance from its parent by "
                    f"{1000 * np.ptp(length):.3f} mm over the clip; a portable BVH carries only rotations below the "
                    f"root, so it is up to {1000 * miss:.3f} mm off",
                    AdverbsWarning,
                    stacklevel=2,
                )
            worst = max(worst, miss)
            helper = _unique(skel.names[j] + HELPER, skel.names, names)
            names.append(helper)
            parents.append(parent)
            offsets.append(np.zeros(3))
            channels.append(_rotation_channels(DEFAULT_ORDER))
            source.append(-1)
            new_rot.append(turn)
            new_trans.append(np.zeros_like(t))
            added.append(helper)
            parent = len(names) - 1
            r = quat.mul(quat.inv(turn), r)
            t = np.broadcast_to(offset, t.shape)
            order = order if len(order) == 3 else DEFAULT_ORDER
        else:
            offset = 0.5 * (t.min(axis=0) + t.max(axis=0))  # the middle of the channels' rounding
            t = np.broadcast_to(offset, t.shape)
        index[j] = len(names)
        names.append(skel.names[j])
        parents.append(parent)
        offsets.append(offset)
        channels.append(_rotation_channels(order))
        source.append(j)
        new_rot.append(r)
        new_trans.append(t)

    site_parents = np.array([index[int(p)] for p in skel.end_site_parents if p >= top], dtype=np.int64)
    site_offsets = skel.end_site_offsets[skel.end_site_parents >= top]
    new_skel = Skeleton(
        names=tuple(names), parents=np.array(parents), offsets=np.array(offsets), channels=tuple(channels),
        end_site_parents=site_parents, end_site_offsets=site_offsets, unit_scale=skel.unit_scale, units=skel.units,
    )  # fmt: skip
    out = Clip(new_skel, np.stack(new_rot, axis=1), np.stack(new_trans, axis=1), clip.fps, clip.name)
    kept = np.array(source)
    before = clip.global_positions()[:, kept[kept >= 0]]
    after = out.global_positions()[:, kept >= 0]
    worst = max(worst, float(np.linalg.norm(after - before, axis=-1).max(initial=0.0)))
    return Portable(out, kept, folded, tuple(added), worst)


def _rotation_channels(order: str) -> tuple[str, ...]:
    return tuple(f"{a}rotation" for a in order)


def _unique(name: str, *taken: tuple[str, ...] | list[str]) -> str:
    """``name``, or ``name`` with a number after it, so it is none of ``taken``."""
    used = {n for group in taken for n in group}
    out, k = name, 2
    while out in used:
        out, k = f"{name}{k}", k + 1
    return out
