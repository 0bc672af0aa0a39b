"""DOF encodings: a clip as scalar curves ``(F, D)`` that can be interpolated, and back.

Glossary of the columns, in order:

| columns | meaning |
| --- | --- |
| ``root.vx``, ``root.vz`` | horizontal velocity of the body root in its own heading frame, m/s (x left, z forward) |
| ``root.turn`` | heading rate about the vertical, rad/s (positive turns left, towards +x) |
| ``root.y`` | height of the body root, m |
| ``<body root>.*`` | body root orientation relative to its heading, 3 columns |
| ``<joint>.*`` | each joint below the body root, 3 columns |
| ``<joint>.tx/ty/tz`` | translation, only for joints whose position channels move (relative to the rest value) |
| ``<body root>.tx/tz`` | an anchored encoding's body root off its feet (``ty`` is 0; see below) |

Rotations are 3 columns each in one of two encodings:

* ``"euler"`` — the paper's Euler channels (the joint's own BVH order), in radians, unwrapped along
  time so no channel jumps by more than π between frames;
* ``"logquat"`` — the rotation vector of ``ref⁻¹ q`` for a per-joint reference ``ref``, with ``q``
  kept sign-consistent along time: continuous, and free of gimbal lock near the reference.

The root is stored as velocities, so a decoded cycle can start from any position and heading and a
cycle replayed after itself keeps going forward. An *anchored* encoding (a verb standing on its feet throughout:
``in_place = "feet"`` in a spec) stores none: its root stands at the centre of the feet's stance in the first frame
(the ankles' and toes' mean), facing the way the hips face there, and never travels or turns; the body root's
horizontal offset from it (``<body root>.tx``, ``.tz``, in that facing) and its turn (in its rotation columns) are
the pose's, so a blend or a cut leaves the figure on its feet and not where the hips had swayed to.
The heading is the direction the hips face, taken from the line between the left and right hip joints, so it does
not depend on how a rig orients its bones.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import AdverbsError
from ..kinematics import quat
from ..kinematics.fk import forward_kinematics
from ..kinematics.skeleton import Skeleton
from . import _pose_kernel
from .clip import Clip
from .heading import HEADING_SMOOTHING, character_heading, lateral_axis

KINDS = ("euler", "logquat")
ROOT_COLUMNS = ("root.vx", "root.vz", "root.turn", "root.y")
_MOVING_TRANSLATION = 1e-7  # metres: position channels that vary more than this become DOFs


@dataclass(frozen=True, eq=False)
class DofEncoding:
    """A fitted DOF layout for one skeleton: use :meth:`fit`, then :meth:`encode` / :meth:`decode`.

    Attributes
    ----------
    kind : "euler" or "logquat"
    skeleton : Skeleton
    body_root : int
        The joint whose motion becomes the root columns (the hips); joints above it are folded in.
    lateral : (3,)
        Right-to-left hip direction in the body root's frame, for the heading.
    reference : (J, 4)
        Per-joint reference rotations, the mean over the fitted clips (the body root's is relative to
        its heading): the centre of the log map, and the branch every clip's Euler angles start on.
    base_translations : (J, 3)
        Translations of joints that have no translation DOFs.
    translated : (T,) int
        Joints with translation columns.
    names : tuple of str, (D,)
    smoothing : float
        Seconds over which the heading is low-passed (see :func:`character_heading`).
    """

    kind: str
    skeleton: Skeleton
    body_root: int
    lateral: np.ndarray
    reference: np.ndarray
    base_translations: np.ndarray
    translated: np.ndarray
    names: tuple[str, ...]
    smoothing: float = HEADING_SMOOTHING

    @classmethod
    def fit(
        cls,
        clips: Clip | Sequence[Clip],
        kind: str = "logquat",
        body_root: int | str | None = None,
        anchored: bool = False,
    ) -> DofEncoding:
        """Choose references and translation DOFs from ``clips`` (all on one skeleton); ``anchored``: the root stands
        on the feet (see the module docstring; the skeleton's joint names must show its feet).

        The reference of each joint is the mean rotation over every frame of every clip, so the
        log map is evaluated close to its centre.
        """
        clips = [clips] if isinstance(clips, Clip) else list(clips)
        if kind not in KINDS:
            raise AdverbsError(f"unknown DOF encoding {kind!r}; use one of {', '.join(KINDS)}")
        if not clips:
            raise AdverbsError("fit needs at least one clip")
        skel = clips[0].skeleton
        for c in clips[1:]:
            why = skel.structure_difference(c.skeleton)
            if why is not None:
                raise AdverbsError(f"clip {c.name!r} is on a different skeleton from {clips[0].name!r}: {why}")
        if body_root is None:
            root = skel.body_root()
        else:
            root = skel.index(body_root) if isinstance(body_root, str) else int(body_root)
        lateral = lateral_axis(skel, root)
        below = _below(skel, root)

        base = clips[0].translations[0].copy()
        moving = np.zeros(skel.num_joints, dtype=bool)
        for c in clips:
            moving |= np.abs(c.translations - base).max(axis=(0, 2)) > _MOVING_TRANSLATION
        moving &= below
        moving[root] = anchored
        translated = np.flatnonzero(moving)
        if anchored and not stance_joints(skel):
            raise AdverbsError(
                "an anchored encoding (in_place = \"feet\") stands on the feet, and no joint of this skeleton is named "
                "as a foot or an ankle"
            )

        reference = quat.identity((skel.num_joints,))
        samples = []
        for c in clips:
            _, grot = c.forward_kinematics()
            h = character_heading(grot[:, root], lateral, c.fps)
            if anchored:
                h = np.full_like(h, h[0])
            rel = quat.mul(quat.about_y(-h), grot[:, root])
            local = c.rotations.copy()
            local[:, root] = rel
            samples.append(local)
        local = np.concatenate(samples)
        for j in np.flatnonzero(below):
            reference[j] = _mean_rotation(local[:, j])

        names = list(ROOT_COLUMNS)
        for j in np.flatnonzero(below):
            axes = _axes(kind, skel, j)
            names.extend(f"{skel.names[j]}.{a}" for a in axes)
        for j in translated:
            names.extend(f"{skel.names[j]}.{a}" for a in ("tx", "ty", "tz"))
        return cls(kind, skel, root, lateral, reference, base, translated, tuple(names), HEADING_SMOOTHING)

    def __post_init__(self) -> None:
        j = self.skeleton.num_joints
        if self.kind not in KINDS:
            raise AdverbsError(f"unknown DOF encoding {self.kind!r}")
        if not 0 <= self.body_root < j:
            raise AdverbsError(f"body root {self.body_root} is not a joint of the skeleton ({j} joints)")
        if np.shape(self.reference) != (j, 4) or np.shape(self.base_translations) != (j, 3):
            raise AdverbsError("encoding tables do not match the skeleton")
        translated = np.asarray(self.translated, dtype=np.int64).reshape(-1)
        if np.any((translated < 0) | (translated >= j)):
            raise AdverbsError("encoding names joints the skeleton does not have")
        object.__setattr__(self, "translated", translated)
        expected = len(ROOT_COLUMNS) + 3 * len(self.rotated) + 3 * len(translated)
        if len(self.names) != expected:
            raise AdverbsError(f"encoding has {len(self.names)} column names, its layout needs {expected}")

    # ----- layout ----------------------------------------------------------------------------
    @property
    def num_dofs(self) -> int:
        return len(self.names)

    @cached_property
    def anchored(self) -> bool:
        """Whether the root stands on the feet (the body root has translation columns: its offset from them)."""
        return bool(np.any(self.translated == self.body_root))

    @cached_property
    def _offset_column(self) -> int:
        """An anchored encoding's first column of the body root's offset (``<body root>.tx``)."""
        k = int(np.flatnonzero(self.translated == self.body_root)[0])
        return len(ROOT_COLUMNS) + 3 * len(self.rotated) + 3 * k

    def _anchor(self, gpos: np.ndarray, grot: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
        """The body root's heading ``(F,)`` and an anchored encoding's anchor ``(3,)`` (the stance's centre in the first
        frame, on the floor) for a clip's global positions and rotations."""
        h = character_heading(grot[:, self.body_root], self.lateral, fps, self.smoothing)
        if not self.anchored:
            return h, gpos[0, self.body_root] * np.array([1.0, 0.0, 1.0])
        centre = gpos[0, stance_joints(self.skeleton)].mean(axis=0) * np.array([1.0, 0.0, 1.0])
        return np.full_like(h, h[0]), centre

    @cached_property
    def rotated(self) -> np.ndarray:
        """Joints with rotation columns, body root first (then skeleton order)."""
        return np.flatnonzero(_below(self.skeleton, self.body_root))

    @cached_property
    def above_body(self) -> tuple[bool, np.ndarray, np.ndarray]:
        """Whether the body root has (fixed) ancestors, the inverse of their global rotation ``(4,)`` and their
        position ``(3,)``: the frame a decoded body root is expressed in."""
        above = self.skeleton.ancestors(self.body_root)[1:]
        if not above:
            return False, quat.identity(), np.zeros(3)
        apos, arot = forward_kinematics(self.skeleton.parents, quat.identity((self.skeleton.num_joints,)), self.base_translations)
        return True, quat.inv(arot[above[0]]), apos[above[0]]

    def _check(self, clip: Clip) -> None:
        why = self.skeleton.structure_difference(clip.skeleton)
        if why is not None:
            raise AdverbsError(f"clip {clip.name!r} is not on the skeleton this encoding was fitted to: {why}")

    # ----- encode ----------------------------------------------------------------------------
    def start(self, clip: Clip) -> np.ndarray:
        """Where ``clip`` starts: ``(x, z, heading)`` of the body root in its first frame (an anchored encoding's: of
        the stance's centre, the heading the hips'; see the module docstring)."""
        gpos, grot = clip.forward_kinematics()
        h, anchor = self._anchor(gpos, grot, clip.fps)
        return np.array([anchor[0], anchor[2], h[0]])

    def encode(self, clip: Clip) -> np.ndarray:
        """DOF curves ``(F, D)`` of ``clip``; see the module's glossary for the columns."""
        self._check(clip)
        gpos, grot = clip.forward_kinematics()
        root = self.body_root
        h, anchor = self._anchor(gpos, grot, clip.fps)
        p = gpos[:, root]
        f = clip.num_frames
        out = np.empty((f, self.num_dofs))
        if self.anchored:
            vel = np.zeros((f, 3))
            turn = np.zeros(f)
        elif f > 1:
            mid = 0.5 * (h[1:] + h[:-1])
            step = quat.rotate(quat.about_y(-mid), p[1:] - p[:-1]) * clip.fps
            vel = np.concatenate([step, step[-1:]])
            turn = np.diff(h) * clip.fps
            turn = np.concatenate([turn, turn[-1:]])
        else:
            vel = np.zeros((1, 3))
            turn = np.zeros(1)
        out[:, 0] = vel[:, 0]
        out[:, 1] = vel[:, 2]
        out[:, 2] = turn
        out[:, 3] = p[:, 1]
        local = clip.rotations.copy()
        local[:, root] = quat.mul(quat.about_y(-h), grot[:, root])
        rotated = self.rotated
        out[:, 4 : 4 + 3 * len(rotated)] = self._rotations_to_dofs(local[:, rotated], rotated).reshape(f, -1)
        if len(self.translated):
            t = clip.translations[:, self.translated] - self.base_translations[self.translated]
            out[:, 4 + 3 * len(rotated) :] = t.reshape(f, -1)
        if self.anchored:  # the body root off the anchor, in its facing; its height is root.y
            off = quat.rotate(quat.about_y(-h), p - anchor)
            off[:, 1] = 0.0
            out[:, self._offset_column : self._offset_column + 3] = off
        return out

    def _rotations_to_dofs(self, q: np.ndarray, joints: np.ndarray) -> np.ndarray:
        """(F, K, 4) → (F, K, 3) continuous along frames."""
        ref = self.reference[joints]
        if self.kind == "logquat":
            rel = quat.mul(quat.inv(ref), q)
            rel = rel * np.where(rel[:1, :, 3:] < 0.0, -1.0, 1.0)
            return quat.log(quat.make_continuous(rel, axis=0))
        out = np.empty(q.shape[:-1] + (3,))
        for k, j in enumerate(joints):
            order = _euler_order(self.skeleton, j)
            # Start on the solution and 2π branch nearest the reference (the mean rotation over all
            # the fitted clips), so that every clip of a verb lands on the same one.
            out[:, k] = quat.unwrap_euler(
                order, quat.to_euler(order, q[:, k]), axis=0, near=quat.to_euler(order, ref[k])
            )
        return out

    # ----- decode ----------------------------------------------------------------------------
    def root_path(
        self, dofs: np.ndarray, fps: float, start: np.ndarray | Sequence[float] = (0.0, 0.0, 0.0)
    ) -> np.ndarray:
        """Root ``(x, z, heading)`` ``(..., F, 3)`` at every frame of DOFs ``(..., F, D)`` played at ``fps``.

        The root columns integrated from ``start`` (broadcast over the leading axes): what
        :meth:`advance_root` gives frame after frame, written as cumulative sums.
        """
        dofs = self._checked(dofs, 2)
        start = np.asarray(start, dtype=float)
        lead, f = dofs.shape[:-2], dofs.shape[-2]
        dt = 1.0 / fps
        h = start[..., 2, None] + np.concatenate(
            [np.zeros(lead + (1,)), np.cumsum(dofs[..., :-1, 2] * dt, axis=-1)], axis=-1
        )
        mid = 0.5 * (h[..., 1:] + h[..., :-1])
        v = np.stack([dofs[..., :-1, 0], np.zeros(lead + (f - 1,)), dofs[..., :-1, 1]], axis=-1)
        steps = quat.rotate(quat.about_y(mid), v) * dt
        xz = np.concatenate([np.zeros(lead + (1, 3)), np.cumsum(steps, axis=-2)], axis=-2)
        return np.stack([start[..., 0, None] + xz[..., 0], start[..., 1, None] + xz[..., 2], h], axis=-1)

    def advance_root(self, root: np.ndarray, dofs: np.ndarray, dt: float | np.ndarray) -> np.ndarray:
        """The root ``(..., 3)`` = ``(x, z, heading)`` moved on by ``dt`` seconds at the velocities of ``dofs (..., D)``.

        One step of the integration :meth:`root_path` does for a whole clip: the heading turns by
        ``root.turn · dt`` and the body travels ``(root.vx, root.vz) · dt`` in the frame of the
        heading halfway through the step (the midpoint rule). A run-time loop calls this once per
        frame, after it has blended or changed the velocities it integrates.
        """
        return advance_root(root, self._checked(dofs, 1)[..., : len(ROOT_COLUMNS) - 1], dt)

    def decode_pose(self, dofs: np.ndarray, root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations ``(..., J, 4)`` and translations ``(..., J, 3)`` of poses ``dofs (..., D)``.

        The body root stands at ``root (..., 3)`` = ``(x, z, heading)`` (from :meth:`root_path` or
        :meth:`advance_root`), at the height in its ``root.y`` column. Log-quaternion DOFs are decoded by a
        compiled loop (:mod:`._pose_kernel`), Euler ones by :meth:`_decode_pose_reference`.
        """
        dofs = self._checked(dofs, 1)
        if self.kind != "logquat":
            return self._decode_pose_reference(dofs, root)
        lead = dofs.shape[:-1]
        j = self.skeleton.num_joints
        flat = np.ascontiguousarray(dofs.reshape(-1, dofs.shape[-1]))
        roots = np.ascontiguousarray(np.broadcast_to(np.asarray(root, dtype=float), lead + (3,)).reshape(-1, 3))
        rot, trans = np.empty((len(flat), j, 4)), np.empty((len(flat), j, 3))
        self.decode_into(flat, roots, np.arange(len(flat)), rot, trans)
        return rot.reshape(lead + (j, 4)), trans.reshape(lead + (j, 3))

    def decode_into(self, dofs: np.ndarray, roots: np.ndarray, rows: np.ndarray, rot: np.ndarray, trans: np.ndarray) -> None:
        """:meth:`decode_pose` of ``dofs (n, D)`` at ``roots (n, 3)`` written into rows ``rows (n,)`` of ``rot (C, J, 4)``
        and ``trans (C, J, 3)`` (C-contiguous float arrays): how a caller gathers poses of several verbs into
        one array without copies. Log-quaternion encodings only (a run-time path); others use :meth:`decode_pose`."""
        if self.kind != "logquat":
            rot[rows], trans[rows] = self._decode_pose_reference(dofs, roots)
            return
        has_parent, parent_inv, parent_pos = self.above_body
        _pose_kernel.decode_logquat(
            np.ascontiguousarray(dofs, dtype=float), np.ascontiguousarray(roots, dtype=float),
            np.ascontiguousarray(rows, dtype=np.int64), self.rotated, self.reference, self.translated,
            self.base_translations, self.body_root, parent_inv, parent_pos, has_parent, rot, trans,
        )  # fmt: skip

    def _decode_pose_reference(self, dofs: np.ndarray, root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`decode_pose` in NumPy, for either encoding: the readable version the compiled loop follows."""
        dofs = self._checked(dofs, 1)
        root = np.asarray(root, dtype=float)
        lead = dofs.shape[:-1]
        skel, body = self.skeleton, self.body_root
        h = root[..., 2]
        p = np.stack([root[..., 0], dofs[..., 3], root[..., 1]], axis=-1)
        rotated = self.rotated
        q = self._dofs_to_rotations(dofs[..., 4 : 4 + 3 * len(rotated)].reshape(lead + (len(rotated), 3)), rotated)
        rotations = np.broadcast_to(quat.identity((skel.num_joints,)), lead + (skel.num_joints, 4)).copy()
        rotations[..., rotated, :] = q
        translations = np.broadcast_to(self.base_translations, lead + (skel.num_joints, 3)).copy()
        if len(self.translated):
            t = dofs[..., 4 + 3 * len(rotated) :].reshape(lead + (len(self.translated), 3))
            translations[..., self.translated, :] = self.base_translations[self.translated] + t

        if self.anchored:  # the body root off the anchor (its height is root.y's)
            off = dofs[..., self._offset_column : self._offset_column + 3] * np.array([1.0, 0.0, 1.0])
            p = p + quat.rotate(quat.about_y(h), off)
        # The body root's global transform, expressed below its (fixed) ancestors.
        g_root = quat.mul(quat.about_y(h), rotations[..., body, :])
        has_parent, inv_parent, parent_pos = self.above_body
        if has_parent:
            rotations[..., body, :] = quat.mul(inv_parent, g_root)
            translations[..., body, :] = quat.rotate(inv_parent, p - parent_pos)
        else:
            rotations[..., body, :] = g_root
            translations[..., body, :] = p
        return rotations, translations

    def decode(
        self, dofs: np.ndarray, fps: float, start: np.ndarray | Sequence[float] = (0.0, 0.0, 0.0)
    ) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations ``(..., F, J, 4)`` and translations ``(..., F, J, 3)`` from DOFs ``(..., F, D)``.

        The root is integrated from its velocities starting at ``start = (x, z, heading)``
        (broadcast over the leading axes): the inverse of :meth:`encode` given :meth:`start`.
        """
        return self.decode_pose(dofs, self.root_path(dofs, fps, start))

    def _checked(self, dofs: np.ndarray, ndim: int) -> np.ndarray:
        dofs = np.asarray(dofs, dtype=float)
        if dofs.ndim < ndim or dofs.shape[-1] != self.num_dofs:
            shape = "(..., F, D)" if ndim == 2 else "(..., D)"
            raise AdverbsError(f"dofs must be {shape} with D = {self.num_dofs}, got {dofs.shape}")
        return dofs

    def decode_clip(
        self, dofs: np.ndarray, fps: float, start: Sequence[float] = (0.0, 0.0, 0.0), name: str = ""
    ) -> Clip:
        """A :class:`Clip` from DOFs ``(F, D)``."""
        rotations, translations = self.decode(dofs, fps, start)
        return Clip(self.skeleton, rotations, translations, fps, name=name)

    def _dofs_to_rotations(self, d: np.ndarray, joints: np.ndarray) -> np.ndarray:
        if self.kind == "logquat":
            return quat.mul(self.reference[joints], quat.exp(d))
        out = np.empty(d.shape[:-1] + (4,))
        for k, j in enumerate(joints):
            out[..., k, :] = quat.from_euler(_euler_order(self.skeleton, j), d[..., k, :])
        return out


def advance_root(root: np.ndarray, velocity: np.ndarray, dt: float | np.ndarray) -> np.ndarray:
    """Roots ``(..., 3)`` = ``(x, z, heading)`` moved on by ``dt`` at ``velocity (..., 3)`` = (``root.vx``, ``root.vz``,
    ``root.turn``): the heading turns by ``turn · dt``, the body travels in the frame of the heading halfway
    through the step (the midpoint rule). :meth:`DofEncoding.advance_root` is this on a pose's root columns."""
    root = np.asarray(root, dtype=float)
    velocity = np.asarray(velocity, dtype=float)
    if root.ndim == 2 and velocity.shape == root.shape and root.shape[1] == 3 and np.ndim(dt) == 0:  # a crowd: compiled
        out = np.empty(root.shape)
        _pose_kernel.advance_roots(np.ascontiguousarray(root), np.ascontiguousarray(velocity), float(dt), out)
        return out
    return _advance_root_reference(root, velocity, dt)


def _advance_root_reference(root: np.ndarray, velocity: np.ndarray, dt: float | np.ndarray) -> np.ndarray:
    """:func:`advance_root` in NumPy, for any leading axes (the compiled loop writes out the same arithmetic)."""
    h0 = root[..., 2]
    h1 = h0 + velocity[..., 2] * dt
    v = np.stack([velocity[..., 0], np.zeros_like(velocity[..., 0]), velocity[..., 1]], axis=-1)
    step = quat.rotate(quat.about_y(0.5 * (h0 + h1)), v) * np.asarray(dt, dtype=float)[..., None]
    return np.stack([root[..., 0] + step[..., 0], root[..., 1] + step[..., 2], h1], axis=-1)


def stance_joints(skel: Skeleton) -> list[int]:
    """The joints whose mean is the centre of a stance: each foot's ankle and toe (those the skeleton has)."""
    return [j for foot in skel.feet() for j in (foot.ankle, foot.toe) if j is not None]


def _below(skel: Skeleton, root: int) -> np.ndarray:
    """Mask of ``root`` and its descendants."""
    mask = np.zeros(skel.num_joints, dtype=bool)
    mask[root] = True
    for j in range(root + 1, skel.num_joints):
        mask[j] = mask[skel.parents[j]]
    return mask


def _euler_order(skel: Skeleton, joint: int) -> str:
    order = skel.rotation_order(joint)
    return order if len(order) == 3 else "ZXY"


def _axes(kind: str, skel: Skeleton, joint: int) -> tuple[str, ...]:
    if kind == "logquat":
        return ("rx", "ry", "rz")
    return tuple(_euler_order(skel, joint))


def _mean_rotation(q: np.ndarray) -> np.ndarray:
    """Mean rotation ``(4,)`` of ``(N, 4)`` (scipy's chordal mean), with w ≥ 0."""
    mean = Rotation.from_quat(q).mean().as_quat()
    return mean if mean[3] >= 0 else -mean
