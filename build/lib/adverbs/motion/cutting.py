"""Examples cut out of long captures at contact events: heel strikes, toe-offs, gait cycles.

A step runs from one heel strike to the next one of the other foot, so two steps are one gait cycle.
The frames of the events inside a cut become its keytimes (§3.2).

**Toe-offs.** Every step of a cut holds one toe-off, but not always of the same foot. In a walk (and in
a jog without a flight phase) the other foot is still down when a foot lands, and lifts after it: each
step is ``<A> strike, <B> toe-off``. In a run the landing foot lifts again before the other lands (a
flight phase): each step is ``<A> strike, <A> toe-off``. These are the two *orders* a cut's events can
take, ``"walk"`` and ``"run"``; all the examples of a verb share one (:func:`gait_order`).

At 30 fps, with contacts found by thresholds, a toe-off within :data:`AMBIGUOUS` frame of the other
foot's strike cannot be put before or after it reliably (a fast walk shows a one-frame "flight", a
tired run a one-frame double support, and a toe-off often falls on the very frame of the strike). Such
a toe-off is placed :data:`NUDGE` frame on the side the order wants, so keytimes stay strictly
increasing; one farther on the wrong side is a different gait, and :func:`step_events` raises an error
naming the foot, the event, the frame and why. The toe-off that belongs to a cut's first strike may lie
before the cut: it is looked for in the whole clip.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise

import numpy as np

from ..errors import AdverbsError
from .clip import Clip
from .contacts import Contacts, find_contacts
from .heading import character_heading, lateral_axis

ORDERS = {  # the two orders of a cut's toe-offs; see the module docstring
    "walk": "each foot lifts after the other lands: double support",
    "run": "each foot lifts before the other lands: a flight phase",
}
AMBIGUOUS = 1  # frames: a toe-off this close to the other foot's strike is taken as on either side of it
NUDGE = 0.5  # frames: where such a toe-off is placed, on the side its order wants


def toe_off_lags(contacts: Contacts, strikes: np.ndarray) -> np.ndarray:
    """Frames from each heel strike of a cut to the other foot's toe-off ``(n + 1,)``.

    ``strikes (n + 1,)`` are the cut's heel-strike frames, alternating feet (:func:`step_range`). The
    other foot's toe-off is the end of its last contact that begins before the strike, looked for in the
    whole clip, so frames before the cut count. Positive: the other foot is still down when this one
    lands (double support: a walk); zero: it lifts on the frame this one lands; negative: it lifted
    before (a flight phase: a run); ``-inf``: it is in the air from the clip's first frame to the strike.
    """
    if len(contacts.feet) != 2:
        raise AdverbsError(f"toe-off keytimes need two feet; the contacts have {len(contacts.feet)}")
    out = np.empty(len(strikes))
    for j, (s, foot) in enumerate(zip(strikes, _landing(contacts, strikes))):
        toe_off = contacts.toe_off_before(1 - foot, int(s))
        out[j] = -np.inf if toe_off is None else toe_off - s
    return out


def gait_order(lags: Sequence[np.ndarray]) -> str:
    """The one order (``"walk"`` or ``"run"``) for the toe-offs of several cuts, the examples of a verb.

    ``lags`` are each cut's :func:`toe_off_lags`. The order is the one most cuts fit (every cut, when
    they can share one); where both fit as many, the one the toe-offs lean to: the median lag, at or
    after the strike for a walk.
    """
    finite = np.concatenate([np.asarray(a, dtype=float) for a in lags])
    finite = finite[np.isfinite(finite)]
    lean = "walk" if finite.size == 0 or np.median(finite) >= 0 else "run"
    fits = {order: sum(_misfit(a, order) is None for a in lags) for order in ORDERS}
    return max(ORDERS, key=lambda order: (fits[order], order == lean))


def step_events(contacts: Contacts, strikes: np.ndarray, order: str | None = None) -> tuple[np.ndarray, list[str]]:
    """Keytime events of a cut, frames ``(N,)`` (half frames where nudged) and names, in time order.

    ``strikes (n + 1,)`` are the cut's heel strikes, alternating feet (:func:`step_range`); each is a
    ``"<side> strike"``. With ``order`` each step also gets one toe-off (see the module docstring):
    ``"walk"``: the other foot's, after the strike; ``"run"``: the landing foot's, before the next strike.
    A toe-off within :data:`AMBIGUOUS` frame on the wrong side of the strike is placed :data:`NUDGE`
    frame on the right side; one farther away raises an :class:`AdverbsError` naming the foot, the
    event, the strike's frame and what the foot does instead. The toe-offs open and close the feet's
    constraints (:mod:`adverbs.verb.constraints`).
    """
    strikes = np.asarray(strikes, dtype=int)
    if strikes.ndim != 1 or strikes.size < 2 or np.any(np.diff(strikes) <= 0):
        raise AdverbsError(f"strikes must be two or more increasing heel-strike frames, got {strikes.tolist()}")
    sides = [contacts.feet[i].side for i in _landing(contacts, strikes)]
    if order is None:
        return strikes.astype(float), [f"{side} strike" for side in sides]
    if order not in ORDERS:
        raise AdverbsError(f"order must be one of {', '.join(ORDERS)}, got {order!r}")
    lags = toe_off_lags(contacts, strikes)
    bad = _misfit(lags, order)
    if bad is not None:
        lifting = sides[bad + 1] if order == "walk" else sides[bad - 1]  # the other foot: feet alternate
        raise AdverbsError(_missing_toe_off(order, int(strikes[bad]), lifting, sides[bad], lags[bad]))
    frames, names = [float(strikes[0])], [f"{sides[0]} strike"]
    for j in range(len(strikes) - 1):
        if order == "walk":  # the other foot lifts after this one lands
            s, lag = strikes[j], lags[j]
            frames.append(float(s + lag) if lag >= 1 else s + NUDGE)
            names.append(f"{sides[j + 1]} toe-off")
        else:  # this foot lifts before the other lands
            s, lag = strikes[j + 1], lags[j + 1]
            frames.append(float(s + lag) if lag <= -1 else s - NUDGE)
            names.append(f"{sides[j]} toe-off")
        frames.append(float(strikes[j + 1]))
        names.append(f"{sides[j + 1]} strike")
    return np.array(frames), names


def _landing(contacts: Contacts, strikes: np.ndarray) -> list[int]:
    """The index of the foot that lands at each of ``strikes``; an error names frames that are no heel strike."""
    landing = dict(contacts.steps())
    missing = [int(s) for s in strikes if int(s) not in landing]
    if missing:
        raise AdverbsError(f"no heel strike at frame(s) {missing}")
    return [landing[int(s)] for s in strikes]


def _misfit(lags: np.ndarray, order: str) -> int | None:
    """Index of the first strike whose toe-off cannot be placed in ``order``, or None when all can.

    A walk reads the lags of every strike but the last (the other foot lifts after it), a run those of
    every strike but the first (the landing foot lifted before it).
    """
    if order == "walk":
        bad = np.flatnonzero(lags[:-1] < -AMBIGUOUS)
    else:
        bad = np.flatnonzero(lags[1:] > AMBIGUOUS) + 1
    return int(bad[0]) if bad.size else None


def _missing_toe_off(order: str, strike: int, lifting: str, landing: str, lag: float) -> str:
    """Why the toe-off of foot ``lifting`` around ``landing``'s strike at frame ``strike`` does not fit ``order``."""
    if order == "walk":
        what = f"the {lifting} toe-off after the {landing} strike at frame {strike} is missing: "
        if not np.isfinite(lag):
            return (
                what + f"the {lifting} foot is in the air from the clip's first frame to that strike (a flight phase)"
            )
        return what + (
            f"the {lifting} foot lifted at frame {strike + int(lag)}, {-int(lag)} frames before that strike "
            "(a flight phase, as in a run)"
        )
    return (
        f"the {lifting} toe-off before the {landing} strike at frame {strike} is missing: the {lifting} foot "
        f"stays down until frame {strike + int(lag)}, {int(lag)} frames after that strike (double support, no "
        "flight phase, as in a walk or a jog)"
    )


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
    end minus start), as :mod:`adverbs.verb.measures` reads ``heading_change``. Candidates whose steps
    do not alternate (a contact missed in a sharp turn) are skipped.
    """
    contacts = find_contacts(clip) if contacts is None else contacts
    skel = clip.skeleton
    root = skel.body_root()
    lateral = lateral_axis(skel, root)
    _, grot = clip.forward_kinematics()
    best = None
    for k in range(len(contacts.strikes(foot))):
        try:
            strikes = step_range(contacts, foot, k, steps, clip.name)
        except AdverbsError:  # past the last strike, or steps that do not alternate (a missed contact): skip
            continue
        h = character_heading(grot[int(strikes[0]) : int(strikes[-1]) + 1, root], lateral, clip.fps)
        turn = abs(h[-1] - h[0])
        if best is None or turn > best[0]:
            best = (turn, strikes)
    if best is None:
        step_range(contacts, foot, 0, steps, clip.name)  # raises the informative error
    return best[1]
