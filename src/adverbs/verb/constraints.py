"""Kinematic constraints of a verb: an end effector held still between two keytimes (§3.3).

A constraint names the effector joint (a foot's toe or ankle, a hand), the keytime that opens it and the
keytime that closes it. In a cyclic verb a constraint may wrap: a right foot that lands late in a
left-foot cycle stays down into the next cycle (``close < open``).

Constraints are found automatically when a spec does not name them: from keytimes named after
contact events (``"left strike"`` … ``"left toe-off"``), or, for feet that stay planted through every
example (standing motions such as a reach), from the first keytime to the last.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import AdverbsError
from ..kinematics.skeleton import Skeleton
from ..motion.clip import Clip
from ..motion.contacts import find_contacts

STANDING = 0.95  # fraction of frames a foot must be down in every example to count as planted throughout


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
    frame), at the next strike of another foot: the heel is lifting by then.
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


def phases(constraint: Constraint, keytimes: np.ndarray, duration: float, cyclic: bool) -> list[tuple[float, float]]:
    """Clock intervals ``[open, close)`` of ``constraint`` over ``duration`` seconds of a verb instance.

    ``keytimes (N,)`` are the verb's at the current adverbs; cyclic verbs repeat every ``K_N``.
    A constraint already open at time 0 (wrapping in from a previous cycle) starts at 0; one that
    closes where it opens again (a foot down all cycle) makes a single phase.
    """
    k0, k1 = float(keytimes[constraint.open]), float(keytimes[constraint.close])
    if not cyclic:
        return [(k0, min(k1, duration))] if k0 < duration else []
    cycle = float(keytimes[-1])
    length = (k1 - k0) % cycle or cycle  # open and close at the same event of the cycle: held throughout
    out = []
    start = k0 - cycle
    while start < duration:
        a, b = max(start, 0.0), min(start + length, duration)
        if b > a:
            if out and a <= out[-1][1] + 1e-9:  # held through the cycle: one long phase, never let go
                out[-1] = (out[-1][0], b)
            else:
                out.append((a, b))
        start += cycle
    return out
