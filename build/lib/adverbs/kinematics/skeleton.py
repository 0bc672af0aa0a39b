"""The joint hierarchy: names, parents in topological order, offsets, BVH channels, End Sites.

Also what can be read off the names: which joints are left/right twins (for mirroring), the
reflection that maps the rest pose onto itself, and where the feet are.

Every walk of the hierarchy is a loop over the joints in their order (parents come first), never a recursion,
and what is read off the names (twins, sides, children) is worked out once per skeleton and kept: any query
costs at most linear time in the number of joints, so a skeleton of thousands of joints, or thousands deep, is
no slower per joint than a person's.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..errors import AdverbsError

POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")

# (left form, right form) of side markers, tried in this order: whole words first, then affixes.
_SIDE_RULES: tuple[tuple[str, str, str], ...] = (
    ("infix", "Left", "Right"),
    ("infix", "left", "right"),
    ("infix", "LEFT", "RIGHT"),
    ("suffix", "_L", "_R"),
    ("suffix", ".L", ".R"),
    ("suffix", "_l", "_r"),
    ("suffix", ".l", ".r"),
    ("prefix", "L_", "R_"),
    ("prefix", "l_", "r_"),
    ("prefix", "L", "R"),
    ("prefix", "l", "r"),
    ("suffix", "L", "R"),
)


@dataclass(frozen=True)
class Foot:
    """One foot: its side, ankle joint, and toe point (a toe joint, or else the ankle's End Site)."""

    side: str
    ankle: int
    toe: int | None
    toe_end_site: np.ndarray | None = field(default=None, repr=False)


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint hierarchy.

    Attributes
    ----------
    names : tuple of str, (J,)
    parents : ndarray of int, (J,)
        Parent index of each joint, ``-1`` for the root; every parent comes before its children.
    offsets : ndarray, (J, 3)
        Rest translation of each joint in its parent's frame, in metres.
    channels : tuple of tuple of str, (J,)
        BVH channel names of each joint in file order, e.g. ``("Zrotation", "Xrotation", "Yrotation")``.
    end_site_parents : ndarray of int, (E,)
        The joint each End Site hangs from.
    end_site_offsets : ndarray, (E, 3)
        End Site offsets in metres.
    unit_scale : float
        Metres per unit of the file this came from (0.01 for centimetres); the writer restores it.
    units : str
        Name of the file's unit (``"cm"``, ``"m"``, ``"mm"``, ``"in"``).
    """

    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    end_site_parents: np.ndarray
    end_site_offsets: np.ndarray
    unit_scale: float = 1.0
    units: str = "m"

    def __post_init__(self) -> None:
        j = len(self.names)
        parents = np.asarray(self.parents, dtype=np.int64)
        offsets = np.asarray(self.offsets, dtype=float)
        if parents.shape != (j,) or offsets.shape != (j, 3) or len(self.channels) != j:
            raise ValueError(f"skeleton arrays disagree: {j} names, parents {parents.shape}, offsets {offsets.shape}")
        if j == 0 or parents[0] != -1 or np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, j)):
            raise ValueError("parents must start with the root (-1) and list every parent before its children")
        if len(set(self.names)) != j:
            raise ValueError("joint names must be unique")
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "end_site_parents", np.asarray(self.end_site_parents, dtype=np.int64).reshape(-1))
        object.__setattr__(self, "end_site_offsets", np.asarray(self.end_site_offsets, dtype=float).reshape(-1, 3))

    @property
    def num_joints(self) -> int:
        return len(self.names)

    @cached_property
    def _index(self) -> dict[str, int]:
        return {n: i for i, n in enumerate(self.names)}

    def index(self, name: str) -> int:
        """Index of the joint called ``name``; the error lists the joints there are."""
        try:
            return self._index[name]
        except (KeyError, TypeError):
            raise AdverbsError(f"no joint named {name!r}; joints are: {', '.join(self.names)}") from None

    @cached_property
    def _children(self) -> tuple[tuple[int, ...], ...]:
        out: list[list[int]] = [[] for _ in range(self.num_joints)]
        for j, p in enumerate(self.parents.tolist()):
            if p >= 0:
                out[p].append(j)
        return tuple(tuple(c) for c in out)

    def children(self, joint: int) -> list[int]:
        """The joints whose parent is ``joint``, in order (``[0]``, the root, for ``-1``)."""
        if joint < 0:
            return [0] if joint == -1 else []
        return list(self._children[joint])

    def child_lists(self) -> list[list[int]]:
        """``children(j)`` of every joint ``j``, in linear time."""
        return [list(c) for c in self._children]

    def below(self, joint: int) -> np.ndarray:
        """Whether each joint is ``joint`` or hangs below it, ``(J,)`` bool, in linear time."""
        mask = [False] * self.num_joints
        mask[joint] = True
        parents = self.parents.tolist()
        for j in range(joint + 1, self.num_joints):  # parents come before their children
            mask[j] = mask[parents[j]]
        return np.array(mask, dtype=bool)

    def ancestors(self, joint: int) -> list[int]:
        """``joint`` and its ancestors up to the root, in that order."""
        chain = [joint]
        while self.parents[chain[-1]] >= 0:
            chain.append(int(self.parents[chain[-1]]))
        return chain

    def rotation_order(self, joint: int) -> str:
        """Axes of the joint's rotation channels in file order, e.g. ``"ZXY"`` (may be empty)."""
        return "".join(c[0].upper() for c in self.channels[joint] if c in ROTATION_CHANNELS)

    def has_position_channels(self, joint: int) -> bool:
        return any(c in POSITION_CHANNELS for c in self.channels[joint])

    def rest_positions(self) -> np.ndarray:
        """Global joint positions ``(J, 3)`` with every rotation at identity."""
        pos = np.zeros((self.num_joints, 3))
        for j in range(self.num_joints):
            p = self.parents[j]
            pos[j] = self.offsets[j] + (pos[p] if p >= 0 else 0.0)
        return pos

    def same_structure(self, other: Skeleton, tol: float = 1e-6) -> bool:
        """True when ``other`` has the same joints, parents, channels and bones (to ``tol`` metres).

        The offsets of the body root and its ancestors are left out: they place the figure in the
        world (some files bake the take's starting position into the hips' offset), they are not bones.
        """
        return self.structure_difference(other, tol) is None

    def structure_difference(self, other: Skeleton, tol: float = 1e-3) -> str | None:
        """How ``other`` differs from this skeleton, in words naming the joint or bone; ``None`` if it does not.

        Checked in order: the joints (count, then the first name that differs), their parents, their
        channels, then the bones (offsets below the body root): the bone whose length or direction
        differs most, with both lengths — two performers, or one rig retargeted, differ there. Bones within
        ``tol`` metres (1 mm) are the same: one rig's takes exported apart can differ by rounding (Bandai's
        dataset-1 normal takes put the right knee 0.4 mm off the others).
        """
        if self.names != other.names:
            if self.num_joints != other.num_joints:
                return f"it has {other.num_joints} joints, not {self.num_joints}"
            j = next(i for i, (a, b) in enumerate(zip(self.names, other.names, strict=True)) if a != b)
            return f"joint {j + 1} is {other.names[j]!r}, not {self.names[j]!r}"
        for j in range(self.num_joints):
            if self.parents[j] != other.parents[j]:
                here, there = (
                    s.names[s.parents[j]] if s.parents[j] >= 0 else "no parent" for s in (self, other)
                )
                return f"joint {self.names[j]!r} hangs from {there!r}, not {here!r}"
            if self.channels[j] != other.channels[j]:
                return f"joint {self.names[j]!r} has channels {' '.join(other.channels[j])}, not {' '.join(self.channels[j])}"
        bones = np.ones(self.num_joints, dtype=bool)
        bones[self.ancestors(self.body_root())] = False
        gap = np.where(bones, np.abs(self.offsets - other.offsets).max(axis=1), 0.0)
        j = int(np.argmax(gap))
        if gap[j] <= tol:
            return None
        parent = self.names[self.parents[j]]
        here, there = (float(np.linalg.norm(s.offsets[j])) for s in (self, other))
        return (
            f"bone {parent!r}→{self.names[j]!r} differs by {gap[j] * 1000:.1f} mm "
            f"({there:.3f} m long, not {here:.3f} m): a different performer or rig"
        )

    # ----- sides, mirroring, feet -------------------------------------------------------------
    def side(self, joint: int) -> str | None:
        """``"left"``, ``"right"`` or ``None`` for a joint that has no twin on the other side."""
        return self._sides[joint]

    @cached_property
    def _sides(self) -> tuple[str | None, ...]:
        sides: list[str | None] = [None] * self.num_joints
        for left, right in self._side_pairs:
            sides[left], sides[right] = "left", "right"
        return tuple(sides)

    @cached_property
    def _side_pairs(self) -> tuple[tuple[int, int], ...]:
        """The (left, right) twins, found once per skeleton."""
        index = self._index
        pairs: list[tuple[int, int]] = []
        paired: set[int] = set()
        for i, name in enumerate(self.names):
            if i in paired:
                continue
            for kind, left, right in _SIDE_RULES:
                twin = _swap_side(name, kind, left, right)
                if twin is not None and twin in index and index[twin] not in paired and index[twin] != i:
                    pairs.append((i, index[twin]))
                    paired.update((i, index[twin]))
                    break
        return tuple(pairs)

    def mirror_map(self) -> np.ndarray:
        """For each joint, the index of its left/right twin (itself when it has none), ``(J,)``."""
        m = np.arange(self.num_joints)
        for a, b in self._side_pairs:
            m[a], m[b] = b, a
        return m

    def mirror_frames(self) -> tuple[np.ndarray, np.ndarray, float]:
        """What mirroring needs: each joint's twin, and how the twins' local frames correspond.

        Rigs differ: in some a left and a right bone point the same way in their own frames, in
        others opposite ways (Maya-style joint orients). For every twin pair (and every joint that is
        its own twin) this picks the improper map ``X_j`` among the three axis reflections and the
        point reflection ``−I`` that best carries the twin's child offsets onto this joint's child
        offsets, ``X_j o_m(c) ≈ o_c``. It is returned as the proper rotation ``P_j = −X_j``.

        Returns
        -------
        twin : (J,) int
        frames : (J, 4)
            ``P_j`` as quaternions (π turns about X, Y or Z, or the identity).
        mismatch : float
            The largest offset error in metres under the chosen maps (0 for a symmetric rig).
        """
        m = self.mirror_map()
        if np.all(m == np.arange(self.num_joints)):
            raise AdverbsError(
                "cannot mirror: no joint names mark a left or right side (e.g. lfemur/rfemur, Foot_L/Foot_R)"
            )
        for j in range(1, self.num_joints):
            if m[self.parents[j]] != self.parents[m[j]]:
                raise AdverbsError(
                    f"cannot mirror: {self.names[j]!r} and its twin {self.names[m[j]]!r} "
                    "hang from joints that are not twins"
                )
        candidates = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]])
        reflections = np.array([[-1.0, 1, 1], [1, -1.0, 1], [1, 1, -1.0], [-1.0, -1, -1]])
        sites: list[list[np.ndarray]] = [[] for _ in range(self.num_joints)]
        for p, o in zip(self.end_site_parents.tolist(), self.end_site_offsets, strict=True):
            sites[p].append(o)
        choice = np.full(self.num_joints, 3)
        mismatch = 0.0
        for j in range(self.num_joints):
            t = m[j]
            if t < j:
                choice[j] = choice[t]
                continue
            pairs = []
            for a, b in ((j, t), (t, j)):
                for c in self._children[a]:
                    pairs.append((self.offsets[m[c]], self.offsets[c]))
                pairs.extend(zip(sites[b], sites[a]))
            if not pairs:
                choice[j] = choice[self.parents[j]] if j > 0 else 3
                continue
            src = np.array([p[0] for p in pairs])
            dst = np.array([p[1] for p in pairs])
            err = np.abs(src[None] * reflections[:, None] - dst[None]).max(axis=(1, 2))
            best = np.flatnonzero(err <= err.min() + 1e-9)
            parent_choice = choice[self.parents[j]] if j > 0 else 3
            choice[j] = parent_choice if parent_choice in best else best[0]
            mismatch = max(mismatch, float(err[choice[j]]))
        return m, candidates[choice], mismatch

    def feet(self) -> list[Foot]:
        """The feet found from joint names: per side, the ankle ("foot"/"ankle") and toe ("toe")."""
        feet = []
        for side in ("left", "right"):
            on_side = [j for j in range(self.num_joints) if self._sides[j] == side]
            ankle = _first_named(self, on_side, ("foot", "ankle"))
            if ankle is None:
                continue
            below = self.below(ankle)
            toe = _first_named(self, [j for j in on_side if below[j]], ("toe",))
            end_site = None
            if toe is None:
                ends = np.flatnonzero(self.end_site_parents == ankle)
                if len(ends):
                    end_site = self.end_site_offsets[ends[0]].copy()
            feet.append(Foot(side, ankle, toe, end_site))
        return feet

    def foot(self, ankle: str | int, toe: str | int | None = None) -> Foot:
        """A foot given by joint names or indices (for skeletons whose names do not say)."""
        a = self.index(ankle) if isinstance(ankle, str) else int(ankle)
        t = None if toe is None else (self.index(toe) if isinstance(toe, str) else int(toe))
        return Foot(self.side(a) or self.names[a], a, t)

    def body_root(self) -> int:
        """The joint that carries the body: the nearest common ancestor of the feet (else the root)."""
        feet = self.feet()
        if len(feet) < 2:
            return 0
        chains = [self.ancestors(f.ankle)[::-1] for f in feet]
        common = 0
        for nodes in zip(*chains):
            if len(set(nodes)) != 1:
                break
            common = nodes[0]
        return int(common)


def _swap_side(name: str, kind: str, left: str, right: str) -> str | None:
    if kind == "infix":
        return name.replace(left, right, 1) if left in name else None
    if kind == "prefix":
        if not name.startswith(left) or len(name) == len(left):
            return None
        rest = name[len(left) :]
        # A one-letter prefix must be followed by a letter of the other case class (lfemur, LeftArm is infix).
        if len(left) == 1 and not re.match(r"[a-z]" if left.islower() else r"[A-Z_a-z]", rest):
            return None
        return right + rest
    if not name.endswith(left) or len(name) == len(left):
        return None
    return name[: -len(left)] + right


def _first_named(skel: Skeleton, joints: list[int], words: tuple[str, ...]) -> int | None:
    for word in words:
        for j in joints:
            if word in skel.names[j].lower():
                return j
    return None
