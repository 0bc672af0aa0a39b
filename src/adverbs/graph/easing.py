"""Adverb changes eased: each creature's adverb point goes from the one shown to the one asked for over a time, by
smoothstep, so a change never snaps a pose in one frame (one-shot verbs and gestures included). Both a scripted
performance (:func:`~adverbs.graph.performance.perform`) and the run time (:class:`~adverbs.runtime.Simulation`)
ease through this.

How long: what the caller asks, or by default (:func:`ease_length`) as long as the change needs for no part of
the body (:attr:`Graph.parts`: legs, arms, the rest) to turn faster through it than half that part's own fastest in
the verbs playing (so the part moves within 1.5x its own), at least ``EASE`` and at most ``MOST_EASE``. Eased over a
fixed half second, a valence cue in a bow turned the legs at 1.95x the bow's own and a stand's trunk at up to 7.6x;
a walk's arms went to 1.8x (random cues, seeds 0-19: 9 of 20 over 1.5x).
"""

from __future__ import annotations

import numpy as np

from ..kinematics import quat

EASE = 0.5  # seconds: the least an adverb change takes by default
MOST_EASE = 3.0  # seconds: ... and the most (a stand's mood: its body hardly moves, and any change is faster)
HEADROOM = 0.5  # an eased change turns a part at most this share of the part's own fastest in its verb
_SAMPLES = 48  # generic times a verb is sampled at, over its whole length
_PATH = 5  # points along an adverb change's line its poses are sampled at
_PEAK = 1.5  # smoothstep's steepest slope: 1.5x its mean


def smoothstep(s: np.ndarray) -> np.ndarray:
    """``3s² − 2s³`` of ``s`` clipped to ``[0, 1]``."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


class Easing:
    """For C creatures whose adverb points start at ``points (C, A)``: the ease each is in (from, to, its start and
    length), applied to a :class:`~adverbs.graph.state.GraphState`'s points by :meth:`apply` before each frame."""

    def __init__(self, points: np.ndarray):
        points = np.asarray(points, dtype=float)
        self.start_from = points.copy()
        self.to = points.copy()
        self.start = np.zeros(len(points))
        self.over = np.zeros(len(points))

    def set(self, i: int, shown: np.ndarray, target: np.ndarray, t: float, over: float, points: np.ndarray) -> None:
        """Creature ``i`` eases from ``shown`` (the point it plays at now) to ``target`` over ``over`` seconds from
        time ``t``; ``over = 0``: at once, into ``points`` (the state's)."""
        self.start_from[i] = shown
        self.to[i] = target
        self.start[i] = t
        self.over[i] = over
        if over == 0.0:
            points[i] = target

    def ease_to(self, graph, state, i: int, target: np.ndarray, t: float, over: float | None) -> float:
        """Creature ``i`` of graph state ``state`` eases from the point it plays at now to ``target (A,)`` from time
        ``t``, over ``over`` seconds, or by default (None) over :func:`ease_length` for the verbs it plays (the verb,
        and the one it is entering); the seconds it eases over."""
        if over is None:
            verbs = [state.verb[i]] + ([state.into[i]] if state.active[i] >= 0 else [])
            over = ease_length(graph, verbs, state.points[i], target)
        self.set(i, state.points[i], target, t, float(over), state.points)
        return float(over)

    def cued(self, graph, i: int, adverbs: dict[str, float]) -> np.ndarray:
        """The graph point a cue's ``adverbs`` ask creature ``i`` for: the ones it names, the rest where its ease is
        going, held to the graph's range (:meth:`Graph.check_point`)."""
        return graph.check_point(graph.point({**dict(zip(graph.adverb_names, self.to[i])), **adverbs}))

    def apply(self, points: np.ndarray, t: float) -> None:
        """Write into ``points (C, A)`` each easing creature's point at time ``t``; an ease that is over ends."""
        easing = np.flatnonzero(self.over > 0)
        if len(easing):
            u = smoothstep((t - self.start[easing]) / self.over[easing])
            points[easing] = self.start_from[easing] + u[:, None] * (self.to[easing] - self.start_from[easing])
            done = easing[u >= 1.0]
            self.over[done] = 0.0
            points[done] = self.to[done]


def _sampled(graph, v: int, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Verb ``v`` over its whole generic time at verb points ``points (Q, A_v)``: its rotations ``(Q, G, J, 4)`` and
    each part's fastest joint at the first and the last point ``(2, P)`` (rad/s, between samples, by the verb's clock
    at each)."""
    from ..interp.timewarp import clock_time
    from ..verb.sampling import dofs

    verb = graph.verbs[v]
    g = np.linspace(0.0, 1.0, _SAMPLES)
    d = dofs(verb, np.repeat(points, len(g), axis=0), np.tile(g, len(points)))
    rot, _ = verb.encoding.decode_pose(d, np.zeros((len(d), 3)))
    rot = rot.reshape(len(points), len(g), -1, 4)
    ends = rot[[0, -1]]
    seconds = np.stack([clock_time(g, verb.keytimes(p), verb.generic_keytimes) for p in points[[0, -1]]])
    speed = quat.angle(ends[:, 1:], ends[:, :-1]) / np.maximum(np.diff(seconds, axis=1), 1e-9)[..., None]
    return rot, np.stack([speed[..., j].max(axis=(1, 2)) for j in graph.parts], axis=1)


def ease_length(graph, verbs, shown: np.ndarray, target: np.ndarray) -> float:
    """The default length (seconds) of an adverb change from graph point ``shown (A,)`` to ``target (A,)`` of a
    creature playing ``verbs`` (the verb, and the one it is entering, if any), from ``EASE`` to ``MOST_EASE``.

    For each verb and each part of the body (:attr:`Graph.parts`): how fast the change turns the part's joints,
    against the part's fastest joint in the verb at either end, ``ω``. The point goes from one end to the other
    along a straight line, which the verb's poses need not follow (a bye from happy to sad goes by the normal
    one's legs), so the line is sampled (``_PATH`` points, each clamped as the verb plays it) and ``Δθ`` is the
    whole way at its steepest: the most a joint of the part turns over one of its pieces, at any generic time,
    times their number. Smoothstep's steepest is 1.5 times its mean, so over ``T`` the change turns the part at
    most ``1.5 Δθ / T``; held to ``HEADROOM · ω``, ``T = 1.5 Δθ / (HEADROOM ω)``, the longest any verb and part
    needs. It samples the verbs (about 2 ms a change, at the change: an event, not a frame)."""
    shown, target = np.asarray(shown, dtype=float), np.asarray(target, dtype=float)
    line = shown + np.linspace(0.0, 1.0, _PATH)[:, None] * (target - shown)
    need = 0.0
    for v in sorted({int(x) for x in verbs}):
        path = graph.verb_points(v, line)
        if path.shape[1] == 0 or np.array_equal(path[0], path[-1]):
            continue
        rot, own = _sampled(graph, v, path)
        steepest = quat.angle(rot[1:], rot[:-1]).max(axis=1) * (_PATH - 1)  # (pieces, J)
        turn = np.array([steepest[:, j].max() for j in graph.parts])
        need = max(need, float((_PEAK * turn / (HEADROOM * np.maximum(own.max(axis=0), 1e-6))).max()))
    return float(np.clip(need, EASE, MOST_EASE))

