"""Forward kinematics, vectorized over frames and any leading batch axes."""

from __future__ import annotations

import numpy as np

from . import quat


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

    ``g_j = g_parent · l_j`` and ``p_j = p_parent + g_parent · t_j``: one loop over joints, every
    other axis vectorized.
    """
    rotations = np.asarray(rotations, dtype=float)
    translations = np.asarray(translations, dtype=float)
    shape = np.broadcast_shapes(rotations.shape[:-1], translations.shape[:-1])
    grot = np.empty(shape + (4,))
    gpos = np.empty(shape + (3,))
    rotations = np.broadcast_to(rotations, shape + (4,))
    translations = np.broadcast_to(translations, shape + (3,))
    for j, p in enumerate(parents):
        if p < 0:
            grot[..., j, :] = rotations[..., j, :]
            gpos[..., j, :] = translations[..., j, :]
        else:
            grot[..., j, :] = quat.mul(grot[..., p, :], rotations[..., j, :])
            gpos[..., j, :] = gpos[..., p, :] + quat.rotate(grot[..., p, :], translations[..., j, :])
    return gpos, grot


def end_site_positions(
    gpos: np.ndarray, grot: np.ndarray, site_parents: np.ndarray, site_offsets: np.ndarray
) -> np.ndarray:
    """Global positions ``(..., E, 3)`` of End Sites hanging off joints ``site_parents (E,)``."""
    return gpos[..., site_parents, :] + quat.rotate(grot[..., site_parents, :], site_offsets)


def bone_lengths(parents: np.ndarray, gpos: np.ndarray) -> np.ndarray:
    """Distance of each non-root joint from its parent, ``(..., J − 1)``."""
    child = np.flatnonzero(np.asarray(parents) >= 0)
    return np.linalg.norm(gpos[..., child, :] - gpos[..., np.asarray(parents)[child], :], axis=-1)
