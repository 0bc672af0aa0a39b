"""Forward kinematics, vectorized over frames and any leading batch axes."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from . import quat
from ._fk_kernel import forward


def forward_kinematics(
    parents: np.ndarray, rotations: np.ndarray, translations: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Global joint positions and rotations from local ones.

    Parameters
    ----------
    parents : (J,) int
        Parent of each joint, ``-1`` for the root, parents before children.
    rotations : (..., J, 4)
        Local joint rotations (x, y, z, w) relative to the parent.
    translations : (..., J, 3)
        Local joint translations in the parent's frame (the offsets, or position channels).

    Returns
    -------
    positions : (..., J, 3)
    global_rotations : (..., J, 4)

    ``g_j = g_parent · l_j`` and ``p_j = p_parent + g_parent · t_j``, joint after joint, compiled
    (:mod:`._fk_kernel`); :func:`forward_kinematics_reference` is the same in NumPy.
    """
    parents = np.asarray(parents)
    _levels(parents)  # checks the tree
    rotations = np.asarray(rotations, dtype=float)
    translations = np.asarray(translations, dtype=float)
    shape = np.broadcast_shapes(rotations.shape[:-1], translations.shape[:-1])
    j = shape[-1]
    rot = np.ascontiguousarray(np.broadcast_to(rotations, shape + (4,))).reshape(-1, j, 4)
    trans = np.ascontiguousarray(np.broadcast_to(translations, shape + (3,))).reshape(-1, j, 3)
    gpos = np.empty(trans.shape)
    grot = np.empty(rot.shape)
    forward(parents.astype(np.int64, copy=False), rot, trans, gpos, grot)
    return gpos.reshape(shape + (3,)), grot.reshape(shape + (4,))


def forward_kinematics_reference(
    parents: np.ndarray, rotations: np.ndarray, translations: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`forward_kinematics` in NumPy, one depth level of the tree at a time (all joints at that depth
    together), every other axis vectorized: the reference the compiled kernel is held to."""
    parents = np.asarray(parents)
    rotations = np.asarray(rotations, dtype=float)
    translations = np.asarray(translations, dtype=float)
    shape = np.broadcast_shapes(rotations.shape[:-1], translations.shape[:-1])
    rotations = np.broadcast_to(rotations, shape + (4,))
    translations = np.broadcast_to(translations, shape + (3,))
    grot = np.empty(shape + (4,))
    gpos = np.empty(shape + (3,))
    grot[..., 0, :] = rotations[..., 0, :]
    gpos[..., 0, :] = translations[..., 0, :]
    for joints, joint_parents in _levels(parents):
        gp = grot[..., joint_parents, :]
        grot[..., joints, :] = quat.mul(gp, rotations[..., joints, :])
        gpos[..., joints, :] = gpos[..., joint_parents, :] + quat.rotate(gp, translations[..., joints, :])
    return gpos, grot


@lru_cache(maxsize=64)
def _levels_cached(key: bytes) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    parents = np.frombuffer(key, dtype=np.int64)
    if (
        len(parents) == 0
        or parents[0] != -1
        or np.any(parents[1:] >= np.arange(1, len(parents)))
        or np.any(parents[1:] < 0)
    ):
        raise ValueError("parents must start with the root (-1) and list every parent before its children")
    depth = [0] * len(parents)
    for j in range(1, len(parents)):
        depth[j] = depth[parents[j]] + 1
    depth_arr = np.array(depth)
    out = []
    for d in range(1, int(depth_arr.max(initial=0)) + 1):
        joints = np.flatnonzero(depth_arr == d)
        out.append((joints, parents[joints].copy()))
    return tuple(out)


def _levels(parents: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """Joints grouped by depth below the root, with their parents, deepest last (the tree checked, once per tree)."""
    return _levels_cached(np.asarray(parents, dtype=np.int64).tobytes())


def end_site_positions(
    gpos: np.ndarray, grot: np.ndarray, site_parents: np.ndarray, site_offsets: np.ndarray
) -> np.ndarray:
    """Global positions ``(..., E, 3)`` of End Sites hanging off joints ``site_parents (E,)``."""
    return gpos[..., site_parents, :] + quat.rotate(grot[..., site_parents, :], site_offsets)


def bone_lengths(parents: np.ndarray, gpos: np.ndarray) -> np.ndarray:
    """Distance of each non-root joint from its parent, ``(..., J − 1)``."""
    child = np.flatnonzero(np.asarray(parents) >= 0)
    return np.linalg.norm(gpos[..., child, :] - gpos[..., np.asarray(parents)[child], :], axis=-1)


def path_to(parents: np.ndarray, joints) -> np.ndarray:
    """The joints ``joints`` and all their ancestors but the root (joint 0), ascending ``(K,)``: what forward kinematics
    runs through to place them (``_fk_kernel.forward_to``; a parent comes before its children in a skeleton's order)."""
    need = set()
    for j in joints:
        j = int(j)
        while j > 0:
            need.add(j)
            j = int(parents[j])
    return np.array(sorted(need), dtype=np.int64)
