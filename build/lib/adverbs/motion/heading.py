"""The character's heading: which way it faces and travels, from the hips.

The heading is the direction the hips face, taken from the line between the left and right hip
joints, so it does not depend on how a rig orients its bones. 0 faces +Z; positive angles turn
towards +X (left, seen from above with Y up).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..kinematics import quat
from ..kinematics.skeleton import Skeleton

HEADING_SMOOTHING = 0.3  # seconds


def lateral_axis(skeleton: Skeleton, body_root: int) -> np.ndarray:
    """Unit vector ``(3,)`` from the right hip to the left hip in the body root's frame.

    Taken from the rest offsets of the nearest twin joints below the body root that stand apart;
    skeletons without side names fall back to +X.
    """
    twin = skeleton.mirror_map()
    rest = skeleton.rest_positions()
    frontier = skeleton.children(body_root)
    while frontier:
        for j in frontier:
            if twin[j] != j and skeleton.side(j) == "left":
                d = rest[j] - rest[twin[j]]
                if np.linalg.norm(d) > 1e-6:
                    return d / np.linalg.norm(d)
        frontier = [c for j in frontier for c in skeleton.children(j)]
    return np.array([1.0, 0.0, 0.0])


def heading(global_rotation: np.ndarray, lateral: np.ndarray) -> np.ndarray:
    """Heading angles ``(...)`` in radians (0 faces +Z, positive towards +X) of body-root rotations ``(..., 4)``."""
    left = quat.rotate(global_rotation, np.broadcast_to(lateral, global_rotation.shape[:-1] + (3,)))
    # forward = left × up, in the horizontal plane.
    return np.arctan2(-left[..., 2], left[..., 0])


def character_heading(
    global_rotation: np.ndarray, lateral: np.ndarray, fps: float, smoothing: float = HEADING_SMOOTHING
) -> np.ndarray:
    """The character's heading ``(F,)``, unwrapped: the hips' heading low-passed over ``smoothing`` seconds.

    The pelvis swings its yaw back and forth with every step; the character's heading is the
    direction it travels around, so the swing is filtered out (a Gaussian of standard deviation
    ``smoothing``) and left to the body root's orientation relative to the heading.

    The ends are padded by point reflection (``2 h[0] − h[k]`` before the start, likewise after the
    end), so the filtered heading equals the hips' heading at the first and last frames and a steady
    turn passes through unchanged. Repeating the end frames instead (the filter's usual "nearest"
    mode) flattens the heading near both ends: a clip turning at a known rate read about
    ``(T − 0.24 s) / T`` of it over a cycle of ``T`` seconds, and a cycle played after itself turned
    by that much less than its example did.
    """
    return low_pass(np.unwrap(heading(global_rotation, lateral)), fps, smoothing)


def low_pass(angles: np.ndarray, fps: float, smoothing: float = HEADING_SMOOTHING) -> np.ndarray:
    """Unwrapped angles ``(F,)`` low-passed over ``smoothing`` seconds, their ends kept (point reflection).

    A Gaussian of standard deviation ``smoothing``; a steady turn (angles linear in time) passes
    through unchanged, and the first and last values are kept exactly.
    """
    if smoothing <= 0 or len(angles) < 2:
        return np.asarray(angles, dtype=float)
    sigma = smoothing * fps
    pad = int(np.ceil(4.0 * sigma))  # the filter's reach (scipy truncates at 4 sigma)
    padded = np.pad(angles, pad, mode="reflect", reflect_type="odd")
    return gaussian_filter1d(padded, sigma, mode="nearest")[pad : pad + len(angles)]
