"""Examples cut out of long captures at contact events: heel strikes, toe-offs, gait cycles.

A step runs from one heel strike to the next one of the other foot, so two steps are one gait cycle.
The frames of the events inside a cut become its keytimes (§3.2).
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from ..errors import AdverbsError
from .clip import Clip
from .contacts import Contacts, find_contacts
from .heading import character_heading, lateral_axis


def step_events(contacts: Contacts, start: int, stop: int, toe_offs: bool = True) -> tuple[np.ndarray, list[str]]:
    """Contact events from frame ``start`` to ``stop`` (both included), in time order.

    Returns their frames and names: ``"<side> strike"`` for a heel strike (a contact's first frame)
    and, with ``toe_offs``, ``"<side> toe-off"`` (the first frame after a contact). These are the
    keytimes that open and close a foot's constraint.
    """
    events = []
    for i, foot in enumerate(contacts.feet):
        for a, b in contacts.intervals(i):
            if start <= a <= stop and a > 0:
                events.append((a, 0, f"{foot.side} strike"))
            if toe_offs and start < b < stop:
                events.append((b, 1, f"{foot.side} toe-off"))
    events.sort()
    return np.array([e[0] for e in events], dtype=float), [e[2] for e in events]


def step_range(contacts: Contacts, foot: str = "left", k: int = 0, n: int = 2, name: str = "") -> np.ndarray:
    """Frames of the ``n + 1`` heel strikes from the ``k``-th (0-based) of ``foot``, alternating feet.

    Raises an error naming the clip when there are not enough strikes or they do not alternate.
    """
    if n < 1:
        raise AdverbsError(f"n (steps) must be at least 1, got {n}")
    if k < 0:
        raise AdverbsError(f"k (heel strike) must be 0 or more, got {k}")
    which = contacts.foot_index(foot)
    steps = contacts.steps()
    mine = [i for i, (_, f) in enumerate(steps) if f == which]
    if k >= len(mine):
        raise AdverbsError(
            f"clip {name!r}: asked for heel strike {k} of the {foot} foot, the clip has {len(mine)} "
            f"(at frames {[steps[i][0] for i in mine]})"
        )
    first = mine[k]
    if first + n >= len(steps):
        raise AdverbsError(
            f"clip {name!r}: {n} steps from heel strike {k} of the {foot} foot (frame {steps[first][0]}) "
            f"run past the clip's last heel strike (frame {steps[-1][0]})"
        )
    chosen = steps[first : first + n + 1]
    for (fa, a), (fb, b) in pairwise(chosen):
        if a == b:
            raise AdverbsError(
                f"clip {name!r}: heel strikes at frames {fa} and {fb} are of the same foot; "
                "the steps do not alternate there"
            )
    return np.array([fr for fr, _ in chosen], dtype=int)


def cut_steps(
    clip: Clip, foot: str = "left", k: int = 0, n: int = 2, contacts: Contacts | None = None
) -> tuple[Clip, np.ndarray]:
    """Cut an example from the ``k``-th heel strike (0-based) of ``foot``, ``n`` steps long.

    Steps alternate feet, so ``n = 2`` is one gait cycle, ending at the foot's next heel strike.
    Returns the clip (both end frames included) and its keytimes ``(n + 1,)`` in seconds: the heel
    strikes, from 0 to the clip's duration.
    """
    contacts = find_contacts(clip) if contacts is None else contacts
    strikes = step_range(contacts, foot, k, n, clip.name)
    start, stop = int(strikes[0]), int(strikes[-1])
    return clip.frames(start, stop + 1), (strikes - start) / clip.fps


def most_turning(clip: Clip, foot: str, steps: int, contacts: Contacts | None = None) -> np.ndarray:
    """Heel-strike frames ``(steps + 1,)`` of the cut whose heading changes most: where a turn clip actually turns.

    The heading change of each candidate cut is that of the cut alone (its own smoothed heading,
    end minus start), as :mod:`adverbs.verb.measures` reads ``heading_change``.
    """
    contacts = find_contacts(clip) if contacts is None else contacts
    skel = clip.skeleton
    root = skel.body_root()
    lateral = lateral_axis(skel, root)
    _, grot = clip.forward_kinematics()
    best = None
    k = 0
    while True:
        try:
            strikes = step_range(contacts, foot, k, steps, clip.name)
        except AdverbsError:
            break
        h = character_heading(grot[int(strikes[0]) : int(strikes[-1]) + 1, root], lateral, clip.fps)
        turn = abs(h[-1] - h[0])
        if best is None or turn > best[0]:
            best = (turn, strikes)
        k += 1
    if best is None:
        step_range(contacts, foot, 0, steps, clip.name)  # raises the informative error
    return best[1]
