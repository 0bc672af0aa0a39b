"""Kinematic constraints of a verb: an end effector held still between two keytimes (§3.3).

A constraint names the effector joint (a foot's toe or ankle, a hand), the keytime that opens it and the
keytime that closes it. In a cyclic verb a constraint may wrap: a right foot that lands late in a
left-foot cycle stays down into the next cycle (``close < open``).

Constraints are found automatically when a spec does not name them: from keytimes named after
contact events (``"left strike"`` … ``"left toe-off"``), or, for feet that stay planted through every
example (standing motions such as a reach), from the first keytime to the last.

A :class:`Hold` is what the planter does with a constraint on a foot, measured from the examples'
contacts at build (:func:`derive_holds`): when the foot lands, is flat, lifts its heel and leaves the
ground, in generic time, and how high its toe and ankle joints sit above the floor while down.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import AdverbsError
from ..interp import timewarp
from ..kinematics.skeleton import Skeleton
from ..motion.clip import Clip
from ..motion.contacts import find_contacts, point_contacts, runs

STANDING = 0.95  # fraction of frames a foot must be down in every example to count as planted throughout
HEEL_LIFTS = 0.015  # metres: a heel this far above its contact level has lifted (heel-off)
TOE_DOWN = 0.005  # metres: a ball this close to its contact height is down (the foot is flat)
NEAR_OPEN = 2  # frames: an example's contact must begin this close to the opening keytime to be its contact


@dataclass(frozen=True)
class Constraint:
    """``effector`` held in place from keytime ``open`` to keytime ``close`` (indices into the keytimes)."""

    effector: str
    open: int
    close: int

    def to_dict(self) -> dict:
        return {"effector": self.effector, "open": self.open, "close": self.close}


def check_constraint(c: Constraint, skeleton: Skeleton, num_keytimes: int, cyclic: bool) -> None:
    """Raise an error naming the field when ``c`` cannot be enforced on ``skeleton``."""
    j = skeleton.index(c.effector)
    if len(skeleton.ancestors(j)) < 3:
        raise AdverbsError(f"constraint on {c.effector!r}: the effector needs two joints above it (a hip and a knee)")
    for field in ("open", "close"):
        k = getattr(c, field)
        if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < num_keytimes:
            raise AdverbsError(f"constraint on {c.effector!r}: '{field}' must be a keytime index 0..{num_keytimes - 1}")
    if cyclic and c.open == num_keytimes - 1:
        raise AdverbsError(
            f"constraint on {c.effector!r}: in a cycle the last keytime is the first one again; open at 0"
        )
    if c.open == c.close or (c.close < c.open and not cyclic):
        raise AdverbsError(
            f"constraint on {c.effector!r}: it must close after it opens (open {c.open}, close {c.close})"
            + ("" if cyclic else "; only cyclic verbs may wrap")
        )


def auto_constraints(keytime_names: Sequence[str], clips: Sequence[Clip], cyclic: bool) -> list[Constraint]:
    """Constraints from contact-event keytimes, or feet planted throughout; see the module docstring.

    A foot's constraint opens at its first ``"<side> strike"`` and closes at its next ``"<side> toe-off"``
    or, where toe-offs are not keytimes (at 30 fps a fast walk's double support can be shorter than a
    frame), at the next strike of another foot; the hold the planter uses then closes at the toe-off
    measured in each example (:func:`derive_holds`), so a run is never held through its flight.
    """
    skel = clips[0].skeleton
    feet = skel.feet()
    names = list(keytime_names)
    n = len(names)
    out = []
    for foot in feet:
        strike = f"{foot.side} strike"
        if strike not in names:
            continue
        k = names.index(strike)
        # Keytimes after this one; in a cycle the last keytime is the first one again, so wrap to it.
        order = list(range(k + 1, n - 1)) + list(range(k)) if cyclic else list(range(k + 1, n))
        close = next((i for i in order if names[i] == f"{foot.side} toe-off"), None)
        if close is None:
            close = next((i for i in order if names[i].endswith(" strike") and names[i] != strike), None)
        if close is not None:
            out.append(Constraint(skel.names[_effector(foot)], k, close))
    if out or not feet:
        return out
    planted = np.stack([find_contacts(c).planted.mean(axis=0) for c in clips])  # (E, feet)
    for i, foot in enumerate(feet):
        if np.all(planted[:, i] >= STANDING):
            out.append(Constraint(skel.names[_effector(foot)], 0, n - 1))
    return out


def _effector(foot) -> int:
    """The point of a foot that stays put while it is down: the ball (toe joint), else the ankle.

    From heel strike to toe-off the foot rolls over its ball, so the ball moves least; holding the
    ankle instead would drag the toes backwards while the heel rises.
    """
    return foot.toe if foot.toe is not None else foot.ankle


@dataclass(frozen=True)
class Hold:
    """How a constraint's effector is held, in generic time (0 to 1 over a cycle or the whole motion).

    A foot lands at ``open`` (heel strike): its heel (the ankle) is held while the foot rolls down
    onto its ball; from ``toe_down`` the effector (the ball, or toe joint) is held too, and with it the
    foot's orientation, until ``heel_off``; then the foot turns back to the verb's orientation about
    the held ball, which is let go at ``close`` (toe-off; ``close > 1`` wraps into the next cycle).
    ``height`` and ``heel_height`` are the effector's and the ankle's heights above the floor while
    they are down (the toe joint sits above the sole), measured from the examples; ``None`` for an
    effector that is not a foot's: it is held from ``open`` and keeps the height the verb gives it.
    """

    effector: str
    open: float
    close: float
    heel_off: float
    height: float | None
    toe_down: float | None = None  # None: the effector is held from ``open``
    heel_height: float | None = None

    def __post_init__(self) -> None:
        if self.toe_down is None:
            object.__setattr__(self, "toe_down", self.open)

    def to_dict(self) -> dict:
        return {"effector": self.effector, "open": self.open, "close": self.close, "heel_off": self.heel_off,
                "height": self.height, "toe_down": self.toe_down, "heel_height": self.heel_height}  # fmt: skip

    @classmethod
    def from_dict(cls, d: dict) -> Hold:
        def num(x):
            return None if x is None else float(x)

        return cls(str(d["effector"]), float(d["open"]), float(d["close"]), float(d["heel_off"]), num(d["height"]),
                   num(d["toe_down"]), num(d["heel_height"]))  # fmt: skip

    @property
    def times(self) -> tuple[float, float, float]:
        """Generic times of the foot flat, the heel-off and the toe-off."""
        return (self.toe_down, self.heel_off, self.close)


def default_holds(constraints: Sequence[Constraint], generic: np.ndarray, cyclic: bool) -> list[Hold]:
    """Holds read from the constraints' keytimes alone (no examples to measure): the effector held from
    its opening keytime to its closing one, orientation following the verb, height following the verb."""
    out = []
    for c in constraints:
        a, b = float(generic[c.open]), float(generic[c.close])
        if b <= a:
            b += 1.0
        out.append(Hold(c.effector, a, b if (cyclic or c.close < len(generic) - 1) else 1.0, a, None))
    return out


def derive_holds(
    constraints: Sequence[Constraint],
    clips: Sequence[Clip],
    keytimes: np.ndarray,
    generic: np.ndarray,
    keytime_names: Sequence[str],
    cyclic: bool,
    floor: float,
    auto: bool,
    example_names: Sequence[str] | None = None,
) -> tuple[list[Hold], np.ndarray, list[str]]:
    """Holds of ``constraints`` measured from the examples' own contacts, each example's, and warnings.

    For a foot's effector, in each example: the ball's (toe joint's) contact that begins at the opening
    keytime gives the toe-off (and the frame its height comes within ``TOE_DOWN`` of contact, the foot
    flat), the heel's contact over it the heel-off, as generic times after the opening: ``table (E, L, 3)``
    holds each example's (foot flat, heel-off, toe-off); the verb blends them with its weights as it
    blends keytimes, and the holds have their means. ``height`` is the median height of the effector above
    ``floor`` over those contacts, averaged. Where the closing keytime is a toe-off it is kept exactly;
    constraints found automatically (``auto``) otherwise close at the measured toe-off, so a run's flight
    is free. A constraint given by hand that holds the foot well past the examples' toe-off (by more
    than ``NEAR_OPEN`` frames on average) is kept, with a warning naming it.
    """
    skel = clips[0].skeleton
    names = list(keytime_names)
    ex_names = list(example_names) if example_names is not None else [c.name for c in clips]
    feet = skel.feet()
    contacts = [point_contacts(c, feet) for c in clips]
    out, tables, warns = [], [], []
    base = default_holds(constraints, generic, cyclic)
    for c, hold in zip(constraints, base):
        j = skel.index(c.effector)
        foot = next((i for i, f in enumerate(feet) if j in (f.toe, f.ankle)), None)
        if foot is None:
            out.append(hold)
            tables.append(np.tile([0.0, 0.0, hold.close - hold.open], (len(clips), 1)))
            continue
        point = 1 if feet[foot].toe == j else 0
        e_count = len(clips)
        table = np.full((e_count, 3), np.nan)  # per example: foot flat, heel-off, toe-off, generic time after open
        heights, heel_heights, slack = [], [], []
        for e, (clip, (down, pts)) in enumerate(zip(clips, contacts)):
            k = keytimes[e]
            f = clip.num_frames
            g = timewarp.generic_time(np.arange(f) / clip.fps, k, generic)
            toe, heel = down[:, foot, point], down[:, foot, 0]
            if cyclic:  # one cycle after the other: a contact at the end goes on at the start
                g, toe, heel = np.concatenate([g, g + 1.0, [2.0]]), np.tile(toe, 2), np.tile(heel, 2)
            else:
                g = np.concatenate([g, [1.0]])
            o = min(int(round(k[c.open] * clip.fps)), f - 1)
            run = _run_near(toe, o)
            if run is None:
                warns.append(
                    f"constraint on {c.effector!r}: in example {ex_names[e]!r} the foot is not down at keytime "
                    f"{c.open} ({names[c.open]!r}); its hold is measured from the other examples"
                )
                continue
            a, b = run
            span = g[b] - g[o]
            hr = _run_overlapping(heel, o, b)
            heel_span = 0.0
            if hr is not None:  # the heel lifts after the last frame it is within HEEL_LIFTS of its own level
                hy = pts[np.arange(o, b) % f, foot, 0, 1] - floor
                heel_heights.append(float(np.percentile(pts[np.arange(*hr) % f, foot, 0, 1], 20)) - floor)
                low = np.flatnonzero(hy <= heel_heights[-1] + HEEL_LIFTS)
                heel_span = min(g[o + low[-1] + 1] - g[o], span) if len(low) else 0.0
            heights.append(float(np.median(pts[np.arange(a, b) % f, foot, point, 1])) - floor)
            # The ball is down once within TOE_DOWN of that height.
            y = pts[np.arange(o, b) % f, foot, point, 1] - floor
            landing = min(g[o + int(np.argmax(y < heights[-1] + TOE_DOWN))] - g[o], heel_span)
            table[e] = landing if point == 1 else 0.0, heel_span, span
            slack.append(((hold.close - hold.open) - span) * f)  # frames the hand-set hold runs past toe-off
        if not heights:
            out.append(hold)
            tables.append(np.tile([0.0, 0.0, hold.close - hold.open], (e_count, 1)))
            continue
        table = np.where(np.isnan(table), np.nanmean(table, axis=0), table)
        closes_at_toe_off = names[c.close].endswith("toe-off")
        if closes_at_toe_off or not auto:
            fixed = hold.close - hold.open
            if not auto and not closes_at_toe_off and np.mean(slack) > NEAR_OPEN:
                warns.append(
                    f"constraint on {c.effector!r} holds the foot until keytime {c.close} ({names[c.close]!r}), "
                    f"{np.mean(slack):.1f} frames on average after the examples' foot leaves the ground: it will be "
                    "held through their swing (close it at a toe-off keytime, or let the build find constraints)"
                )
            table[:, 2] = fixed
        if not cyclic and c.close == len(names) - 1:
            table[:, 2] = np.maximum(table[:, 2], 1.0 - hold.open)  # held to the end of a one-shot motion
        table[:, 1] = np.minimum(table[:, 1], table[:, 2])
        table[:, 0] = np.minimum(table[:, 0], table[:, 1])
        mean = table.mean(axis=0)
        heel_height = float(np.mean(heel_heights)) if heel_heights and point == 1 else None
        # A close kept at its keytime is that keytime, not open + (close - open), which can differ in the last bit.
        close = hold.close if np.all(table[:, 2] == hold.close - hold.open) else hold.open + mean[2]
        out.append(Hold(c.effector, hold.open, close, hold.open + mean[1], float(np.mean(heights)), hold.open + mean[0],
                        heel_height))  # fmt: skip
        tables.append(table)
    return out, np.stack(tables, axis=1) if tables else np.zeros((len(clips), 0, 3)), warns



def _run_near(mask: np.ndarray, frame: int) -> tuple[int, int] | None:
    """The run of ``mask`` that contains ``frame`` or begins within ``NEAR_OPEN`` frames after it."""
    return next(((a, b) for a, b in runs(mask) if a <= frame < b or frame < a <= frame + NEAR_OPEN), None)


def _run_overlapping(mask: np.ndarray, start: int, stop: int) -> tuple[int, int] | None:
    """The first run of ``mask`` that overlaps frames ``[start, stop)``."""
    return next(((a, b) for a, b in runs(mask) if a < stop and b > start), None)
