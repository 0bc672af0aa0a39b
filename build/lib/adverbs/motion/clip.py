"""A clip: a skeleton and its motion as arrays, with the edits that keep it a clip.

Resampling to another frame rate, cutting a frame range, and mirroring left/right (the paper made
left turns by mirroring right ones).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import AdverbsError
from ..kinematics import quat
from ..kinematics.fk import forward_kinematics
from ..kinematics.skeleton import Skeleton
from ..limits import check_frames

MIN_FPS, MAX_FPS = 1e-4, 1e6  # frame rates a BVH file can hold (its Frame Time from 1e-6 s to 1e4 s)


@dataclass(eq=False)
class Clip:
    """Motion of one skeleton.

    Attributes
    ----------
    skeleton : Skeleton
    rotations : (F, J, 4)
        Local joint rotations, quaternions (x, y, z, w).
    translations : (F, J, 3)
        Local joint translations in metres: the position channels where a joint has them, its
        offset otherwise. ``translations[:, 0]`` is the root trajectory.
    fps : float
        Frames per second.
    name : str
        Where the clip came from (a file stem), for messages.
    """

    skeleton: Skeleton
    rotations: np.ndarray
    translations: np.ndarray
    fps: float
    name: str = ""

    def __post_init__(self) -> None:
        self.rotations = np.asarray(self.rotations, dtype=float)
        self.translations = np.asarray(self.translations, dtype=float)
        j = self.skeleton.num_joints
        f = self.rotations.shape[0] if self.rotations.ndim == 3 else -1
        if self.rotations.shape != (f, j, 4) or self.translations.shape != (f, j, 3):
            raise AdverbsError(
                f"clip {self.name!r}: rotations {self.rotations.shape} and translations "
                f"{self.translations.shape} must be (F, {j}, 4) and (F, {j}, 3)"
            )
        if not (np.isfinite(self.fps) and self.fps > 0):
            raise AdverbsError(f"clip {self.name!r}: fps must be positive, got {self.fps}")

    @property
    def num_frames(self) -> int:
        return self.rotations.shape[0]

    @property
    def duration(self) -> float:
        """Seconds from the first frame to the last."""
        return (self.num_frames - 1) / self.fps

    @property
    def root_positions(self) -> np.ndarray:
        """Root trajectory ``(F, 3)``."""
        return self.translations[:, 0]

    def global_positions(self) -> np.ndarray:
        """Global joint positions ``(F, J, 3)``."""
        return forward_kinematics(self.skeleton.parents, self.rotations, self.translations)[0]

    def forward_kinematics(self) -> tuple[np.ndarray, np.ndarray]:
        """Global joint positions ``(F, J, 3)`` and rotations ``(F, J, 4)``."""
        return forward_kinematics(self.skeleton.parents, self.rotations, self.translations)

    def replace(self, **changes) -> Clip:
        fields = {
            "skeleton": self.skeleton,
            "rotations": self.rotations,
            "translations": self.translations,
            "fps": self.fps,
            "name": self.name,
        }
        fields.update(changes)
        return Clip(**fields)

    def frames(self, start: int | None = None, stop: int | None = None) -> Clip:
        """Frames ``start:stop`` (Python slice rules); an empty range is an error."""
        idx = np.arange(self.num_frames)[slice(start, stop)]
        if len(idx) == 0:
            raise AdverbsError(
                f"clip {self.name!r}: frame range {start}:{stop} is empty (clip has {self.num_frames} frames)"
            )
        return self.replace(rotations=self.rotations[idx], translations=self.translations[idx])

    def resample(self, fps: float) -> Clip:
        """The same motion at another frame rate: slerp for rotations, linear for translations.

        The new clip starts at the same instant and has every new frame that falls within the
        old clip's duration.
        """
        if not (np.isfinite(fps) and MIN_FPS <= fps <= MAX_FPS):
            raise AdverbsError(f"fps must be a number from {MIN_FPS:g} to {MAX_FPS:g} (a frame time BVH can hold), got {fps}")
        n = check_frames(np.floor(self.duration * fps + 1e-9) + 1, self.skeleton.num_joints, f"{self.duration:.4g} s at {fps:g} fps")
        return self.at(np.arange(n) * (self.fps / fps), fps)

    def at(self, positions: np.ndarray, fps: float | None = None) -> Clip:
        """The motion at fractional frame indices ``positions (G,)`` (clipped to the clip), as a clip at ``fps``
        (default this one's): slerp for rotations, linear for translations."""
        x = np.asarray(positions, dtype=float)
        if x.ndim != 1 or not np.all(np.isfinite(x)):
            raise AdverbsError(f"clip {self.name!r}: frame positions must be a 1-D array of finite numbers, got shape {x.shape}")
        check_frames(len(x), self.skeleton.num_joints, f"clip {self.name!r} at {len(x)} positions")
        x = np.clip(x, 0.0, self.num_frames - 1.0)
        rot = quat.slerp_frames(self.rotations, x)
        i0 = np.minimum(np.floor(x).astype(int), max(self.num_frames - 2, 0))
        i1 = np.minimum(i0 + 1, self.num_frames - 1)
        u = (x - i0)[:, None, None]
        trans = (1.0 - u) * self.translations[i0] + u * self.translations[i1]
        return self.replace(rotations=rot, translations=trans, fps=float(self.fps if fps is None else fps))

    def mirror(self, axis: int = 0) -> Clip:
        """Left/right mirror image on the same skeleton, reflected across the world plane ``axis = 0``.

        With ``M`` the world reflection, ``m(j)`` the twin of joint ``j`` and ``P_j`` the frame map of
        :meth:`Skeleton.mirror_frames`, the mirrored clip has local rotation ``P_parent R_j P_j`` on
        joint ``m(j)``, translation ``−P_parent t_j``, and root ``M p``, ``P_M R_root P_root``: every global
        joint position is reflected by ``M``, so turns to the right become turns to the left by the
        same angle. Mirroring twice is the identity.
        """
        skel = self.skeleton
        if axis not in (0, 1, 2):
            raise AdverbsError(f"mirror axis must be 0, 1 or 2 (X, Y, Z), got {axis}")
        twin, frames, _ = skel.mirror_frames()
        p_world = np.zeros(4)
        p_world[axis] = 1.0
        parent_frames = np.concatenate([p_world[None], frames[skel.parents[1:]]])
        rot = np.empty_like(self.rotations)
        rot[:, twin] = quat.mul(quat.mul(parent_frames, self.rotations), frames)
        trans = np.empty_like(self.translations)
        trans[:, twin] = -quat.rotate(parent_frames, self.translations)
        fixed = np.array([not skel.has_position_channels(j) for j in range(skel.num_joints)])
        trans[:, fixed] = skel.offsets[fixed]
        return self.replace(rotations=rot, translations=trans, name=f"{self.name} (mirrored)" if self.name else "")
