"""Adverb values measured from motion: the same function measures an example and a synthesized clip.

The heading is the hips' heading low-passed with its ends kept (see
:func:`~adverbs.motion.heading.character_heading`), so a clip turning or moving at a known rate reads
that rate, on one cycle or a whole take.

| measure | value |
| --- | --- |
| ``speed`` | body-root horizontal velocity along its direction of travel, averaged over the clip, m/s |
| ``turn_rate`` | heading change / duration, deg/s (positive turns left) |
| ``heading_change`` | heading at the end minus at the start, degrees |
| ``joint_position`` | a joint's position at a keytime, in the character's starting frame: x left, z forward (m, from the body root's starting ground point), y up (m, world height); needs ``joint``, ``axis`` and ``keytime`` (0-based index) |
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import AdverbsError
from ..kinematics import quat
from ..motion.clip import Clip
from ..motion.encoding import character_heading, lateral_axis
from ..motion.heading import low_pass

TRAVEL_SMOOTHING = 0.5  # seconds: the direction of travel is low-passed over about a step (see speed)
MEASURES = ("speed", "turn_rate", "heading_change", "joint_position")
_UNITS = {"speed": "m/s", "turn_rate": "deg/s", "heading_change": "deg", "joint_position": "m"}


def default_unit(kind: str) -> str:
    return _UNITS[kind]


def check_measure(spec: Mapping, skeleton_names: tuple[str, ...], num_keytimes: int | None, where: str) -> dict:
    """Validate a measure's description (``{"kind": ..., ...}``); errors start with ``where``."""
    kind = spec.get("kind")
    if kind not in MEASURES:
        raise AdverbsError(f"{where}: unknown measure {kind!r}; measures are {', '.join(MEASURES)}")
    out = {"kind": kind}
    if kind == "joint_position":
        for key in ("joint", "axis", "keytime"):
            if key not in spec:
                raise AdverbsError(f"{where}: measure 'joint_position' needs '{key}'")
        if spec["joint"] not in skeleton_names:
            raise AdverbsError(f"{where}: measure names joint {spec['joint']!r}, which the skeleton does not have")
        if spec["axis"] not in ("x", "y", "z"):
            raise AdverbsError(f"{where}: axis must be 'x', 'y' or 'z', got {spec['axis']!r}")
        k = spec["keytime"]
        if not isinstance(k, int) or k < 0 or (num_keytimes is not None and k >= num_keytimes):
            raise AdverbsError(f"{where}: keytime must be an index from 0 to {(num_keytimes or 1) - 1}, got {k!r}")
        out.update(joint=spec["joint"], axis=spec["axis"], keytime=k)
    unknown = set(spec) - {"kind", "joint", "axis", "keytime"}
    if unknown:
        raise AdverbsError(f"{where}: unknown field(s) {', '.join(sorted(unknown))} in measure")
    return out


def measure_all(clip: Clip, keytimes: np.ndarray, specs: list[Mapping]) -> np.ndarray:
    """Several measures of one clip ``(M,)``, its forward kinematics done once."""
    track = body_track(clip)
    return np.array([measure(clip, keytimes, s, track) for s in specs])


def body_track(clip: Clip) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Body-root positions ``(F, 3)``, unwrapped heading ``(F,)``, and global positions/rotations."""
    skel = clip.skeleton
    root = skel.body_root()
    gpos, grot = clip.forward_kinematics()
    h = character_heading(grot[:, root], lateral_axis(skel, root), clip.fps)
    return gpos[:, root], h, gpos, grot


def measure(clip: Clip, keytimes: np.ndarray, spec: Mapping, track: tuple | None = None) -> float:
    """The value of measure ``spec`` on ``clip`` with its ``keytimes (N,)`` in seconds.

    ``track`` is :func:`body_track` of the clip when the caller already has it (several measures).
    """
    root, h, gpos, _ = body_track(clip) if track is None else track
    duration = clip.duration
    kind = spec["kind"]
    if kind == "speed":
        # Along the direction of travel (low-passed like the heading, over about a step), so the
        # pelvis's side-to-side sway with every step does not count as distance (the path length read
        # 1-3% fast); exact on a curve at constant speed. Not along the heading: the hips' facing is a
        # rig's choice, a few degrees off the way the body goes. Over 0.3 s the direction followed a
        # sharp turn's sway and read up to 3.5% slower than a repeated cycle travels; over 0.6 s a
        # steady 90 deg/s turn read 1% off.
        step = np.diff(root, axis=0)
        travel = low_pass(np.unwrap(np.arctan2(step[:, 0], step[:, 2])), clip.fps, TRAVEL_SMOOTHING)
        return float(np.sum(step[:, 0] * np.sin(travel) + step[:, 2] * np.cos(travel)) / duration)
    if kind == "turn_rate":
        return float(np.rad2deg(h[-1] - h[0]) / duration)
    if kind == "heading_change":
        return float(np.rad2deg(h[-1] - h[0]))
    j = clip.skeleton.index(spec["joint"])
    x = float(keytimes[spec["keytime"]]) * clip.fps
    i0 = min(int(np.floor(x)), clip.num_frames - 2)
    u = x - i0
    p = (1.0 - u) * gpos[i0, j] + u * gpos[i0 + 1, j]
    local = quat.rotate(quat.about_y(-h[0]), p - np.array([root[0, 0], 0.0, root[0, 2]]))
    return float(local["xyz".index(spec["axis"])])
