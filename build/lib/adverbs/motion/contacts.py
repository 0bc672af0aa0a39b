"""Foot contacts found in the motion: which foot is on the ground, frame by frame.

A foot is planted while its heel (ankle) or toe is both low — within ``height`` of that point's
own lowest level in the clip, so a floor that is not at y = 0 does not matter — and slow — moving
horizontally slower than ``speed``. Gaps shorter than ``max_gap`` are closed and flickers shorter
than ``min_duration`` dropped. A heel strike is the first frame of a contact, a toe-off the first
frame after one; a step runs from one heel strike to the next one of the other foot. Cutting examples
at these events: :mod:`.cutting`.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from ..errors import AdverbsError
from ..kinematics.fk import end_site_positions
from ..kinematics.floor import Floor
from ..kinematics.skeleton import Foot
from .clip import Clip


@dataclass(frozen=True, eq=False)
class Contacts:
    """Per-foot contact masks of one clip.

    Attributes
    ----------
    feet : tuple of Foot, (N,)
    planted : (F, N) bool
        True where the foot is on the ground.
    fps : float
    """

    feet: tuple[Foot, ...]
    planted: np.ndarray
    fps: float

    def foot_index(self, foot: str | int) -> int:
        if isinstance(foot, int):
            if not 0 <= foot < len(self.feet):
                raise AdverbsError(f"foot index {foot} out of range: there are {len(self.feet)} feet")
            return foot
        for i, f in enumerate(self.feet):
            if f.side == foot:
                return i
        raise AdverbsError(f"no {foot!r} foot; feet are {', '.join(f.side for f in self.feet) or 'none'}")

    def intervals(self, foot: str | int) -> list[tuple[int, int]]:
        """Contact intervals ``[start, stop)`` in frames of one foot."""
        return runs(self.planted[:, self.foot_index(foot)])

    def strikes(self, foot: str | int) -> np.ndarray:
        """Frames of the foot's heel strikes (contacts that begin inside the clip)."""
        return np.array([a for a, _ in self.intervals(foot) if a > 0], dtype=int)

    def toe_off_before(self, foot: str | int, frame: int) -> int | None:
        """The toe-off of the foot's last contact that begins before ``frame``: the first frame after it.

        It is at or after ``frame`` when the foot is still down then (the clip's length when it stays down
        to the end); None when no contact of the foot begins before ``frame``.
        """
        before = [b for a, b in self.intervals(foot) if a < frame]
        return before[-1] if before else None

    def steps(self) -> list[tuple[int, int]]:
        """Every heel strike as ``(frame, foot index)``, in time order."""
        out = [(int(fr), i) for i in range(len(self.feet)) for fr in self.strikes(i)]
        return sorted(out)

    def to_dict(self) -> dict:
        """Plain data for JSON: per foot its joints and contact intervals in frames and seconds."""
        return {
            f.side: {
                "ankle": int(f.ankle),
                "toe": None if f.toe is None else int(f.toe),
                "contacts": [[a, b] for a, b in self.intervals(i)],
                "heel_strikes_s": [round(float(s) / self.fps, 4) for s in self.strikes(i)],
            }
            for i, f in enumerate(self.feet)
        }


def foot_points(clip: Clip, feet: list[Foot] | tuple[Foot, ...]) -> np.ndarray:
    """Global heel and toe positions ``(F, N, 2, 3)`` of each foot (toe: joint, End Site, or the heel)."""
    gpos, grot = clip.forward_kinematics()
    out = np.empty((clip.num_frames, len(feet), 2, 3))
    for i, f in enumerate(feet):
        out[:, i, 0] = gpos[:, f.ankle]
        if f.toe is not None:
            out[:, i, 1] = gpos[:, f.toe]
        elif f.toe_end_site is not None:
            out[:, i, 1] = end_site_positions(gpos, grot, np.array([f.ankle]), f.toe_end_site[None])[:, 0]
        else:
            out[:, i, 1] = gpos[:, f.ankle]
    return out


def find_contacts(
    clip: Clip,
    feet: list[Foot] | None = None,
    height: float = 0.06,
    speed: float = 0.6,
    min_duration: float = 0.05,
    max_gap: float = 0.07,
    floor: Floor | None = None,
) -> Contacts:
    """Find when each foot is planted; see the module docstring for the rule.

    Parameters
    ----------
    feet : the feet to look at; found from joint names when omitted.
    height : metres above the point's lowest level (5th percentile) that still count as low.
    speed : horizontal speed in m/s below which a point counts as still.
    min_duration, max_gap : seconds, for cleaning the masks.
    floor : the ground the clip walks on, if not level (a slope, a height map): heights are measured above it.
    """
    feet = list(clip.skeleton.feet() if feet is None else feet)
    if not feet:
        raise AdverbsError(
            f"clip {clip.name!r}: no feet found from joint names; name them (ankle and toe joints) explicitly"
        )
    planted = np.any(_low_and_still(foot_points(clip, feet), clip.fps, height, speed, floor), axis=-1)  # (F, N)
    gap = round(max_gap * clip.fps)
    shortest = max(round(min_duration * clip.fps), 1)
    for i in range(len(feet)):
        planted[:, i] = _clean(planted[:, i], gap, shortest)
    return Contacts(tuple(feet), planted, clip.fps)


def point_contacts(
    clip: Clip,
    feet: list[Foot] | tuple[Foot, ...],
    height: float = 0.06,
    speed: float = 0.6,
    min_duration: float = 0.05,
    max_gap: float = 0.07,
) -> tuple[np.ndarray, np.ndarray]:
    """Heel and toe of each foot on their own: down masks ``(F, N, 2)`` (the rule of :func:`find_contacts`
    applied to each point, cleaned the same way) and the points' global positions ``(F, N, 2, 3)``.

    Where :func:`find_contacts` says when a foot bears weight, this says which part of it does: the heel
    from heel strike until it lifts, the ball (toe joint) until toe-off.
    """
    pts = foot_points(clip, feet)
    down = _low_and_still(pts, clip.fps, height, speed)
    gap = round(max_gap * clip.fps)
    shortest = max(round(min_duration * clip.fps), 1)
    for i in range(len(feet)):
        for k in range(2):
            down[:, i, k] = _clean(down[:, i, k], gap, shortest)
    return down, pts


def _low_and_still(pts: np.ndarray, fps: float, height: float, speed: float, floor: Floor | None = None) -> np.ndarray:
    """Points ``(F, ..., 3)`` within ``height`` of their own low level (5th percentile) and slower than ``speed``;
    heights above ``floor`` if given."""
    y = pts[..., 1] if floor is None else pts[..., 1] - floor.height(pts[..., [0, 2]])
    low = y - np.percentile(y, 5, axis=0) < height
    if len(pts) > 1:
        vel = np.gradient(pts[..., [0, 2]], axis=0) * fps
        still = np.linalg.norm(vel, axis=-1) < speed
    else:
        still = np.ones(low.shape, dtype=bool)
    return low & still


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The runs of ``True`` in a mask ``(F,)``, as frame ranges ``[start, stop)``."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def _clean(mask: np.ndarray, gap: int, shortest: int) -> np.ndarray:
    mask = mask.copy()
    spans = runs(mask)
    for (_, b), (c, _) in pairwise(spans):
        if c - b <= gap:
            mask[b:c] = True
    for a, b in runs(mask):
        if b - a < shortest:
            mask[a:b] = False
    return mask
