"""A verb graph: verbs, the adverbs they share by name, and transitions between them (§5).

:class:`Graph` is immutable data that any number of creatures read at once (their progress through it
lives in :class:`~adverbs.graph.state.GraphState`). A :class:`Transition` from verb A to verb B is a
correspondence region in each verb's generic time, ``[t_s^A, t_e^A]`` and ``[t_s^B, t_e^B]``, and a
likelihood, used to draw among the ways out of a verb when nothing was asked for. Every cyclic verb
has a transition into itself (the graph's own, or one the graph adds, :func:`loop_region` in both: the last
``LOOP`` of one cycle's clock time blended with the same part of the next, so a cycle follows itself through
the same machinery as any other transition).

The planner (:meth:`Graph.path`) finds the path with the fewest transitions (breadth first; among
equally short paths, the one whose transitions come first in the graph) and draws default transitions
by likelihood (:meth:`Graph.draw`).
"""

from __future__ import annotations

import bisect
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import AdverbsError
from ..feet.planter import effector_joints
from ..interp.timewarp import generic_time
from ..kinematics.fk import path_to
from ..verb.tables import Verb

BLENDS = ("cosine", "inertial")
REACH = 0.5  # how far past its examples a graph plays an adverb, in spans of the examples (each side)
LOOP = 0.25  # the fraction of a cycle over which a cyclic verb's own loop blends one cycle into the next


def loop_region(verb: Verb) -> tuple[float, float]:
    """The generic-time region ``(start, 1)`` of a cyclic verb's loop into itself: its last :data:`LOOP` of clock time
    at the examples' mean.

    In clock time, not generic: a run's last keytime interval (toe-off to strike) can be two frames, and a loop
    over the last quarter of generic time would be that short.
    """
    k = verb.keytimes(verb.points.mean(axis=0))
    return float(generic_time((1.0 - LOOP) * k[-1], k, verb.generic_keytimes)), 1.0


@dataclass(frozen=True)
class Transition:
    """A way from verb ``source`` to verb ``target`` (indices into the graph's verbs).

    ``source_region`` and ``target_region`` are ``(start, end)`` in generic time; ``blend`` is "cosine"
    (the paper's: both verbs play through the regions, ``α = 0.5 cos(βπ) + 0.5``) or "inertial" (the
    target starts at once and the pose difference decays); ``interruptible``: a new command during it
    starts from the current pose at once, instead of after it ends (but a stop, a cycle blending into a one-shot,
    always ends first: its feet land); ``added``: the graph made it (a
    cyclic verb's own loop), the spec did not list it.
    """

    source: int
    target: int
    source_region: tuple[float, float]
    target_region: tuple[float, float]
    likelihood: float = 1.0
    blend: str = "cosine"
    interruptible: bool = True
    added: bool = False


class GraphError(AdverbsError):
    """A graph that cannot be made; ``field`` names what is wrong: a transition's (``from_region``,
    ``to_region``, ``likelihood``, ``blend``, ``from``, ``to``) or the graph's (``verbs``, ``adverbs``,
    ``transitions``, ``start``)."""

    def __init__(self, reason: str, field: str | None = None):
        self.field = field
        super().__init__(reason)


class CommandRefused(AdverbsError):
    """A command the graph cannot carry out (an unknown or unreachable verb); nothing was changed."""


@dataclass(frozen=True, eq=False)
class Graph:
    """Verbs on one skeleton, the adverbs they share, and the transitions between them.

    Attributes
    ----------
    name : str
    verbs : tuple of Verb
    adverb_names : tuple of str
        Every adverb of any verb, by name (shared: two verbs with an adverb of one name read one value).
    defaults : (A,)
        Where each adverb starts (the graph's ``adverbs`` table, else the mean of the examples of the
        verbs that take it).
    columns : tuple of (A_v,) int arrays
        For each verb, the graph adverb each of its adverbs reads.
    transitions : tuple of Transition
    start : int
        The verb creatures start in.
    clamped : tuple of bool
        For each verb, whether it plays at its adverbs kept inside its examples' ranges.
    source : str
        Where the graph came from (a spec file), for messages.
    """

    name: str
    verbs: tuple[Verb, ...]
    adverb_names: tuple[str, ...]
    defaults: np.ndarray
    columns: tuple[np.ndarray, ...]
    transitions: tuple[Transition, ...]
    start: int = 0
    source: str = ""
    clamped: tuple[bool, ...] = ()

    @classmethod
    def make(
        cls,
        name: str,
        verbs: Sequence[Verb],
        transitions: Sequence[Transition],
        defaults: dict[str, float] | None = None,
        start: int = 0,
        loop_likelihoods: Sequence[float] | None = None,
        source: str = "",
        clamped: Sequence[bool] | None = None,
    ) -> Graph:
        """Check and assemble a graph; a cyclic verb without a transition into itself gets one (``loop_likelihoods``)."""
        verbs = tuple(verbs)
        if not verbs:
            raise GraphError(f"graph {name!r} has no verbs", "verbs")
        names = [v.name for v in verbs]
        for i, v in enumerate(verbs):
            if names.index(v.name) != i:
                raise GraphError(f"graph {name!r}: two verbs are named {v.name!r}", "verbs")
            why = verbs[0].skeleton.structure_difference(v.skeleton)
            if why is not None:
                raise GraphError(f"graph {name!r}: verb {v.name!r} is on a different skeleton from {verbs[0].name!r}: {why}", "verbs")
        adverb_names: list[str] = []
        for v in verbs:
            adverb_names += [a for a in v.adverb_names if a not in adverb_names]
        columns = tuple(np.array([adverb_names.index(a) for a in v.adverb_names], dtype=np.int64) for v in verbs)
        values = np.zeros(len(adverb_names))
        for k, a in enumerate(adverb_names):
            takers = [v.points[:, list(v.adverb_names).index(a)] for v in verbs if a in v.adverb_names]
            values[k] = float(np.mean(np.concatenate(takers)))
        for a, x in (defaults or {}).items():
            if a not in adverb_names:
                raise GraphError(f"graph {name!r}: default for adverb {a!r}, which no verb takes ({', '.join(adverb_names) or 'none'})", "adverbs")
            values[adverb_names.index(a)] = float(x)
        edges = list(transitions)
        for t in edges:
            check_transition(t, verbs)
        loops = [1.0] * len(verbs) if loop_likelihoods is None else list(loop_likelihoods)
        for i, v in enumerate(verbs):
            if v.cyclic and not any(t.source == i and t.target == i for t in edges):
                region = loop_region(v)
                edges.append(Transition(i, i, region, region, float(loops[i]), "cosine", True, True))
        for i, v in enumerate(verbs):
            if not any(t.source == i for t in edges):
                raise GraphError(f"graph {name!r}: verb {v.name!r} has no way out (no transition leaves it)", "transitions")
        if not 0 <= start < len(verbs):
            raise GraphError(f"graph {name!r}: start verb {start} is not one of its {len(verbs)} verbs", "start")
        values.setflags(write=False)
        clamped = tuple(bool(x) for x in (clamped if clamped is not None else [False] * len(verbs)))
        return cls(name, verbs, tuple(adverb_names), values, columns, tuple(edges), int(start), source, clamped)

    @classmethod
    def of_verb(cls, verb: Verb, source: str = "") -> Graph:
        """A graph of one verb playing over and over: a cyclic verb loops into itself, a one-shot verb (a reach, a bow)
        blends its last ``LOOP`` of generic time into its first, starting again where it ended."""
        again = [] if verb.cyclic else [Transition(0, 0, (1.0 - LOOP, 1.0), (0.0, LOOP), 1.0, "cosine", True, True)]
        return cls.make(verb.name, [verb], again, source=source)

    def verb_points(self, v: int, points: np.ndarray) -> np.ndarray:
        """Verb ``v``'s adverb points ``(C, A_v)`` from graph points ``(C, A)`` (kept inside its examples if clamped)."""
        p = np.ascontiguousarray(points[:, self.columns[v]])
        if self.clamped and self.clamped[v]:
            p = np.clip(p, self.verbs[v].points.min(axis=0), self.verbs[v].points.max(axis=0))
        return p

    # ----- lookups ----------------------------------------------------------------------------------
    @property
    def verb_names(self) -> tuple[str, ...]:
        return tuple(v.name for v in self.verbs)

    @property
    def skeleton(self):
        return self.verbs[0].skeleton

    @cached_property
    def cyclic(self) -> np.ndarray:
        """Whether each verb is a cycle ``(V,)``."""
        return np.array([v.cyclic for v in self.verbs], dtype=bool)

    @cached_property
    def feet(self) -> tuple[int, ...]:
        """The effector joints any verb holds, in the order the first such verb lists them."""
        out: list[int] = []
        for v in self.verbs:
            out += [j for j in effector_joints(v) if j not in out]
        return tuple(out)

    @cached_property
    def feet_array(self) -> np.ndarray:
        """:attr:`feet` as an array ``(L,)``."""
        return np.array(self.feet, dtype=np.int64)

    @cached_property
    def feet_path(self) -> np.ndarray:
        """The feet and their ancestors but the root, ascending ``(K,)``: what forward kinematics runs through where
        only the feet are read (``fk.path_to``; the feet's slip in a blend)."""
        return path_to(self.skeleton.parents, self.feet_array)

    @cached_property
    def between_verbs(self) -> np.ndarray:
        """Whether each transition goes from one verb to another ``(T,)`` (not a loop into itself)."""
        return np.array([t.source != t.target for t in self.transitions], dtype=bool)

    @cached_property
    def carries_arms(self) -> np.ndarray:
        """How each transition ``(T,)`` carries on past its blend (``player._arms``) what it plays of the verb entered
        at once: 1, a cosine blend from one cycle into another (a walk into a run), the arms (:attr:`arms`), past the
        blend when it is short (:data:`adverbs.graph.state.ARMS_BLEND`); 2, a cosine blend from a cycle into a one-shot
        (a stop), the arms, over the blend; 3, a cosine blend from a one-shot into a cycle (a start), the whole upper
        body (:attr:`carried`), past the blend when it is short; 0, nothing (all blends as the rest)."""
        cyclic = self.cyclic

        def kind(t) -> int:
            if t.source == t.target or t.blend != "cosine" or not (cyclic[t.source] or cyclic[t.target]):
                return 0
            return (1 if cyclic[t.target] else 2) if cyclic[t.source] else 3

        return np.array([kind(t) for t in self.transitions], dtype=np.int64)

    @cached_property
    def leg_chains(self):
        """The leg chains (``ik.LegChains``) of the first verb that holds feet; None when no verb does."""
        return next((v.leg_chains for v in self.verbs if v.constraints), None)

    @cached_property
    def upper_body(self) -> np.ndarray:
        """The joints of the upper body ``(n,)``: every joint neither on a leg (a held foot's hip and what hangs from
        it) nor on the way from the root to the hips; the trunk above the hips, the neck and head, the arms. None in a
        graph whose verbs hold no feet."""
        chains = self.leg_chains
        if chains is None:
            return np.zeros(0, dtype=np.int64)
        skeleton = self.skeleton
        parents = skeleton.parents
        hips, above = {int(j) for j in chains.upper}, {int(j) for j in chains.above}
        upper = np.zeros(skeleton.num_joints, dtype=bool)
        for j in range(skeleton.num_joints):
            if j not in above and int(parents[j]) in above and j not in hips:
                upper |= skeleton.below(j)
        return np.flatnonzero(upper).astype(np.int64)

    @cached_property
    def arms(self) -> np.ndarray:
        """The joints of the arms ``(U,)``: of the upper body (:attr:`upper_body`), what hangs from its first joint
        with more than one child (the chest), but for the smallest of those branches (the neck and head). None in a
        graph whose verbs hold no feet or whose upper body does not branch."""
        skeleton = self.skeleton
        for j in self.upper_body:
            branches = sorted((skeleton.below(i) for i in skeleton.children(int(j))), key=np.count_nonzero)
            if len(branches) > 1:
                return np.flatnonzero(np.any(branches[1:], axis=0)).astype(np.int64)
        return np.zeros(0, dtype=np.int64)

    @cached_property
    def carried(self) -> np.ndarray:
        """What a transition may carry on past its blend (:attr:`carries_arms`, ``player._arms``) ``(U,)``: the arms
        (:attr:`arms`, the first ``len(arms)``), then the rest of the upper body (the trunk above the hips, the neck
        and head)."""
        return np.concatenate([self.arms, np.setdiff1d(self.upper_body, self.arms)]).astype(np.int64)

    @cached_property
    def parts(self) -> tuple[np.ndarray, ...]:
        """The body's parts, each its joints ``(n,)``: the legs (a held foot's hip and what hangs from it), the arms
        (:attr:`arms`) and the rest (the trunk, neck and head); the whole body, one part, in a graph whose verbs hold
        no feet. What an adverb change's ease is measured by (:func:`~adverbs.graph.easing.ease_length`)."""
        chains = self.leg_chains
        n = self.skeleton.num_joints
        if chains is None:
            return (np.arange(n),)
        legs = np.any([self.skeleton.below(int(h)) for h in chains.upper], axis=0)
        arms = np.zeros(n, dtype=bool)
        arms[self.arms] = True
        parts = [np.flatnonzero(legs), np.flatnonzero(arms & ~legs), np.flatnonzero(~legs & ~arms)]
        return tuple(p for p in parts if len(p))

    @cached_property
    def paced(self) -> tuple[np.ndarray, ...]:
        """The parts (:attr:`parts`) a blend between standing verbs is paced by (:attr:`paced_transitions`): all but
        the legs of verbs that hold their feet, which the planter's IK places (what a free leg would show in the blend
        is not what is shown: a stand's and a reach's legs 30° apart, the planted legs turning a third as far)."""
        return self.parts[1:] if self.leg_chains is not None else self.parts

    @cached_property
    def paced_joints(self) -> np.ndarray:
        """Which of :attr:`paced` each joint is in ``(J + 1,)``, −1 for none; the last entry is the body's place (where
        the body root stands over the feet, :func:`~adverbs.verb.tables.body_place`), a part of its own after them
        (``P``; see :attr:`speed_profiles`)."""
        out = np.full(self.skeleton.num_joints + 1, -1, dtype=np.int64)
        for i, p in enumerate(self.paced):
            out[p] = i
        out[-1] = len(self.paced)
        return out

    @cached_property
    def speed_profiles(self) -> tuple[np.ndarray, ...]:
        """Per verb: its examples' joint speeds (rad/s, :attr:`Verb.joint_speed_profile`) and, last, its body's speed
        over its feet (m/s, :attr:`Verb.body_speed_profile`) ``(E_v, S, J + 1)``, as :attr:`paced_joints` reads them."""
        return tuple(
            np.ascontiguousarray(np.concatenate([v.joint_speed_profile, v.body_speed_profile[..., None]], axis=2))
            for v in self.verbs
        )  # fmt: skip

    @cached_property
    def part_speeds(self) -> tuple[np.ndarray, ...]:
        """Per verb: each example's fastest joint of each of :attr:`paced` and its body's fastest over its feet
        ``(E_v, P + 1)``, rad/s and m/s (:attr:`speed_profiles`)."""
        return tuple(np.stack([m.max(axis=1) for m in profiles], axis=1) for profiles in self._paced_profiles)

    @cached_property
    def _paced_profiles(self) -> tuple[tuple[np.ndarray, ...], ...]:
        """Per verb, per part of :attr:`paced` and the body's place: its examples' speeds there ``(E_v, S · J_p)``
        (one product with a creature's weights blends them all)."""
        parts = [*self.paced, np.array([self.skeleton.num_joints])]
        return tuple(
            tuple(np.ascontiguousarray(m[..., p].reshape(len(m), -1)) for p in parts) for m in self.speed_profiles
        )  # fmt: skip

    def own_speeds(self, v: int, weights: np.ndarray) -> np.ndarray:
        """Verb ``v``'s fastest joint of each of :attr:`paced` and its body's fastest over its feet ``(P + 1,)`` at
        cardinal ``weights (E_v,)``, rad/s and m/s: its examples' :attr:`speed_profiles` blended with the weights at
        each generic time, at its fastest, kept within the examples' own (:attr:`part_speeds`)."""
        profiles, speeds = self._paced_profiles[v], self.part_speeds[v]
        w = np.asarray(weights, dtype=float)[: len(speeds)]
        own = np.array([(w @ m).max() for m in profiles])
        return np.minimum(np.maximum(own, speeds.min(axis=0)), speeds.max(axis=0))

    @cached_property
    def paced_transitions(self) -> np.ndarray:
        """Whether each transition's blend is paced by the parts' speeds ``(T,)`` (``clocks.paced_length``): a cosine
        blend from one one-shot verb into another, a stand into a gesture and back. A cycle's blends are timed by its
        feet (a stop lands the swinging foot as the stand takes it)."""
        cyclic = self.cyclic
        return np.array(
            [t.source != t.target and t.blend == "cosine" and not cyclic[t.source] and not cyclic[t.target]
             for t in self.transitions],
            dtype=np.bool_,
        )  # fmt: skip

    @cached_property
    def hold_layout(self) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
        """Per verb: its holds' opening generic times ``(L_v,)`` and which of :attr:`feet` each hold is ``(L_v,)``."""
        return tuple(
            (np.array([h.open for h in v.holds]), np.array([self.feet.index(j) for j in effector_joints(v)], dtype=np.int64))
            for v in self.verbs
        )

    @cached_property
    def inverse_above_body(self) -> np.ndarray:
        """The inverse of the rest rotation of the joint above the body root ``(4,)`` (identity when it has none)."""
        return self.verbs[0].encoding.above_body[1]

    def verb_index(self, name: str | int) -> int:
        """The index of verb ``name``; an unknown one raises :class:`CommandRefused` naming the verbs there are."""
        if isinstance(name, int | np.integer) and not isinstance(name, bool):
            if 0 <= int(name) < len(self.verbs):
                return int(name)
            raise CommandRefused(f"graph {self.name!r} has no verb {int(name)} (it has {len(self.verbs)})")
        if name not in self.verb_names:
            raise CommandRefused(f"graph {self.name!r} has no verb {name!r}; its verbs are {', '.join(self.verb_names)}")
        return self.verb_names.index(name)

    def leaving(self, verb: int) -> list[int]:
        """Indices of the transitions out of ``verb``, in the graph's order."""
        return list(self._leaving[verb])

    def loop(self, verb: int) -> int | None:
        """The transition of ``verb`` into itself (the first, if several), or None."""
        return self._loops[verb]

    @cached_property
    def _leaving(self) -> tuple[tuple[int, ...], ...]:
        """:meth:`leaving` of every verb (a crowd's queues ask hundreds of times a frame)."""
        return tuple(tuple(k for k, t in enumerate(self.transitions) if t.source == v) for v in range(len(self.verbs)))

    @cached_property
    def _loops(self) -> tuple[int | None, ...]:
        """:meth:`loop` of every verb."""
        return tuple(next((k for k in ways if self.transitions[k].target == v), None) for v, ways in enumerate(self._leaving))

    @cached_property
    def _odds(self) -> tuple[list[float], ...]:
        """Per verb, the likelihoods of :meth:`leaving`'s transitions as a cumulative distribution, ending at 1 (what
        :meth:`draw` draws by): ``numpy.random.Generator.choice``'s, as it makes it from ``p``."""
        out = []
        for ways in self._leaving:
            if not ways:
                out.append([])
                continue
            p = np.array([self.transitions[k].likelihood for k in ways])
            cdf = (p / p.sum()).cumsum()
            out.append((cdf / cdf[-1]).tolist())
        return tuple(out)

    def point(self, values: dict[str, float] | Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """A graph adverb point ``(A,)``: the defaults, with ``values`` (by name, or all in order) put in."""
        p = np.array(self.defaults, dtype=float)
        if values is None:
            return p
        if isinstance(values, dict):
            for a, x in values.items():
                if a not in self.adverb_names:
                    raise AdverbsError(f"graph {self.name!r} has no adverb {a!r}; its adverbs are {', '.join(self.adverb_names)}")
                p[self.adverb_names.index(a)] = float(x)
        else:
            v = np.asarray(values, dtype=float)
            if v.shape != p.shape:
                raise AdverbsError(f"graph {self.name!r} takes {len(p)} adverbs ({', '.join(self.adverb_names)}), got shape {v.shape}")
            p = v.copy()
        if not np.all(np.isfinite(p)):
            bad = self.adverb_names[int(np.flatnonzero(~np.isfinite(p))[0])]
            raise AdverbsError(f"adverb {bad!r} must be a finite number (got NaN or infinity)")
        return p

    def adverb_range(self, margin: float = REACH) -> tuple[np.ndarray, np.ndarray]:
        """The lowest and highest value ``(A,)`` each adverb may take: over the verbs that read it, the span of
        their examples widened by ``margin`` of that span on each side (how far the graph extrapolates).
        An adverb only clamped verbs read spans their examples alone."""
        lo, hi = np.full(len(self.adverb_names), np.inf), np.full(len(self.adverb_names), -np.inf)
        for v, verb in enumerate(self.verbs):
            if not len(self.columns[v]):
                continue
            a, b = verb.points.min(axis=0), verb.points.max(axis=0)
            m = 0.0 if (self.clamped and self.clamped[v]) else margin
            cols = self.columns[v]
            lo[cols] = np.minimum(lo[cols], a - m * (b - a))
            hi[cols] = np.maximum(hi[cols], b + m * (b - a))
        return lo, hi

    def check_point(self, p: np.ndarray, margin: float = REACH) -> np.ndarray:
        """``p (A,)`` if every adverb lies within :meth:`adverb_range`, else :class:`CommandRefused` naming it."""
        p = np.asarray(p, dtype=float)
        lo, hi = self.adverb_range(margin)
        for i, name in enumerate(self.adverb_names):
            if not np.isfinite(p[i]):
                raise CommandRefused(f"adverb {name!r} must be a finite number, got {p[i]}")
            if not lo[i] - 1e-9 <= p[i] <= hi[i] + 1e-9:
                raise CommandRefused(
                    f"{name}={p[i]:g} is out of range: graph {self.name!r} plays {name} from {lo[i]:g} to {hi[i]:g} "
                    f"(its examples' span, {margin:g} of it beyond on each side)"
                )
        return p

    # ----- planning ---------------------------------------------------------------------------------
    def path(self, source: str | int, target: str | int) -> list[int]:
        """The transitions (indices) of a path from verb ``source`` to verb ``target`` with the fewest of them.

        Empty when ``source`` is ``target``. An unknown or unreachable verb raises :class:`CommandRefused`.
        """
        a, b = self.verb_index(source), self.verb_index(target)
        if a == b:
            return []
        came: dict[int, int] = {}
        seen = {a}
        todo = deque([a])
        while todo:
            v = todo.popleft()
            for k in self.leaving(v):
                w = self.transitions[k].target
                if w in seen:
                    continue
                seen.add(w)
                came[w] = k
                if w == b:
                    out = [k]
                    while self.transitions[out[-1]].source != a:
                        out.append(came[self.transitions[out[-1]].source])
                    return out[::-1]
                todo.append(w)
        raise CommandRefused(
            f"graph {self.name!r}: verb {self.verbs[b].name!r} cannot be reached from {self.verbs[a].name!r} "
            f"(from there: {', '.join(sorted(self.verbs[i].name for i in seen))})"
        )

    def reachable(self, source: str | int) -> list[int]:
        """The verbs reachable from ``source`` (itself included), in the graph's order."""
        a = self.verb_index(source)
        seen = {a}
        todo = [a]
        while todo:
            v = todo.pop()
            for k in self.leaving(v):
                w = self.transitions[k].target
                if w not in seen:
                    seen.add(w)
                    todo.append(w)
        return sorted(seen)

    def draw(self, verb: int, rng: np.random.Generator) -> int:
        """A transition out of ``verb`` drawn by likelihood (what plays next when nothing was asked for)."""
        ways = self._leaving[verb]
        # rng.choice(len(ways), p=...) draws one uniform number and finds it in this same distribution, the same way,
        # but checks p every call (23 µs; a crowd of 10,000 draws about 140 times a frame): the same draws, 1 µs.
        return ways[bisect.bisect_right(self._odds[verb], rng.random())] if len(ways) > 1 else ways[0]

    def describe(self) -> dict:
        """What the graph holds, as plain data (for ``adverbs graph --describe``)."""
        verbs = []
        for i, v in enumerate(self.verbs):
            verbs.append(
                {
                    "name": v.name,
                    "cyclic": v.cyclic,
                    "examples": len(v.examples),
                    "adverbs": list(v.adverb_names),
                    "ignores": [a for a in self.adverb_names if a not in v.adverb_names],
                    "reaches": [self.verbs[j].name for j in self.reachable(i)],
                    "clamped": bool(self.clamped and self.clamped[i]),
                }
            )
        return {
            "name": self.name,
            "source": self.source,
            "start": self.verbs[self.start].name,
            "adverbs": {a: float(x) for a, x in zip(self.adverb_names, self.defaults)},
            "verbs": verbs,
            "transitions": [
                {
                    "from": self.verbs[t.source].name,
                    "to": self.verbs[t.target].name,
                    "from_region": list(t.source_region),
                    "to_region": list(t.target_region),
                    "likelihood": t.likelihood,
                    "blend": t.blend,
                    "interruptible": t.interruptible,
                    "arms": ("", "carried past the blend when it is short", "carried over the blend",
                             "and the rest of the upper body carried past the blend when it is short")[int(carry)],
                    "added": t.added,
                }
                for t, carry in zip(self.transitions, self.carries_arms)
            ],
        }


def check_transition(t: Transition, verbs: Sequence[Verb]) -> None:
    """Raise an error naming what is wrong with ``t``: verbs, regions, likelihood, blend."""
    for field, k in (("from", t.source), ("to", t.target)):
        if not 0 <= k < len(verbs):
            raise GraphError(f"transition {t.source} → {t.target}: no verb {k}", field)
    what = f"transition {verbs[t.source].name!r} → {verbs[t.target].name!r}"
    for field, region in (("from_region", t.source_region), ("to_region", t.target_region)):
        a, b = region
        if not (np.isfinite(a) and np.isfinite(b) and 0.0 <= a <= 1.0 and 0.0 <= b <= 1.0):
            raise GraphError(f"{what}: {field} {[a, b]} must lie in generic time [0, 1]", field)
        if not a < b:
            raise GraphError(f"{what}: {field} {[a, b]} is empty: its start must come before its end", field)
    if not (np.isfinite(t.likelihood) and t.likelihood > 0):
        raise GraphError(f"{what}: likelihood must be a positive number, got {t.likelihood}", "likelihood")
    if t.blend not in BLENDS:
        raise GraphError(f"{what}: blend must be one of {', '.join(BLENDS)}, got {t.blend!r}", "blend")
