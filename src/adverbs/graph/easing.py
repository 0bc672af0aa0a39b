"""Adverb changes eased: each creature's adverb point goes from the one shown to the one asked for over a time, by
smoothstep, so a change never snaps a pose in one frame (one-shot verbs and gestures included). Both a scripted
performance (:func:`~adverbs.graph.performance.perform`) and the run time (:class:`~adverbs.runtime.Simulation`)
ease through this."""

from __future__ import annotations

import numpy as np

EASE = 0.5  # seconds: how long an adverb change takes by default


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

    def apply(self, points: np.ndarray, t: float) -> None:
        """Write into ``points (C, A)`` each easing creature's point at time ``t``; an ease that is over ends."""
        easing = np.flatnonzero(self.over > 0)
        if len(easing):
            u = smoothstep((t - self.start[easing]) / self.over[easing])
            points[easing] = self.start_from[easing] + u[:, None] * (self.to[easing] - self.start_from[easing])
            done = easing[u >= 1.0]
            self.over[done] = 0.0
            points[done] = self.to[done]
