"""Whole motions from a verb: the sampling kernel run over the frames of a clip, then decoded.

:func:`synthesize` is offline synthesis as the run-time loop does it, all frames at once: one
creature (``C = 1``) of :class:`~adverbs.verb.sampling.SamplingState`, sampled at the clock time of
every frame (so cycles and their seams are handled by the kernel, exactly as for a live creature),
the root integrated from its velocities and the poses decoded.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..errors import AdverbsError, AdverbsWarning
from ..limits import check_frames
from ..motion.clip import Clip
from . import sampling

if TYPE_CHECKING:
    from .tables import Verb

MAX_FPS = 1e4  # frames per second: far past any capture; a BVH frame time down to 1e-4 s
WARN_BEYOND = 0.25  # ranges of the examples: farther out than this, synthesize warns


def frame_clocks(
    verb: Verb,
    length: float,
    duration: float | None = None,
    cycles: float | None = None,
    fps: float | None = None,
) -> tuple[np.ndarray, float]:
    """Clock times ``(F,)`` of the frames of a motion whose cycle (or whole motion) lasts ``length`` seconds, and the fps.

    ``cycles`` (default 1) repeats a cyclic verb; ``duration`` in seconds overrides it. Refused before any heavy
    work: a frame rate too low to show the cycle in two frames, a duration past the frame limit. (A degenerate
    ``length`` has been refused already, with its adverb point, by the sampling state :func:`plan` made.)
    """
    fps = verb.fps if fps is None else float(fps)
    if not (np.isfinite(fps) and 0 < fps <= MAX_FPS):
        raise AdverbsError(f"fps must be a positive number up to {MAX_FPS:g}, got {fps}")
    if length * fps < 2.0:
        what = "cycle" if verb.cyclic else "motion"
        raise AdverbsError(f"fps {fps:g} is too low: one {what} ({length:.3g} s) would be less than two frames")
    if cycles is not None and not verb.cyclic and float(cycles) != 1.0:
        raise AdverbsError(f"verb {verb.name!r} is a one-shot motion: it plays once (give a duration instead of cycles)")
    if duration is None:
        duration = length * (1.0 if cycles is None else float(cycles))
    if not (np.isfinite(duration) and duration > 0):
        raise AdverbsError(f"duration must be a positive number of seconds, got {duration}")
    frames = check_frames(round(duration * fps) + 1, verb.skeleton.num_joints, f"{duration:g} s at {fps:g} fps")
    if frames < 2:
        raise AdverbsError(f"{duration:g} s at {fps:g} fps is {frames} frame; synthesize two or more")
    return np.arange(frames) / fps, fps


def plan(
    verb: Verb,
    p: np.ndarray,
    duration: float | None = None,
    cycles: float | None = None,
    fps: float | None = None,
) -> tuple[np.ndarray, sampling.SamplingState, np.ndarray, float]:
    """What a synthesis at ``p`` will sample, checked before any heavy work: the point ``(A,)``, its sampling state
    (one creature), the clock times ``(F,)`` of the frames and the frame rate. Warns when ``p`` lies more than
    :data:`WARN_BEYOND` of the examples' ranges outside them; refuses a point whose blend weights' magnitudes sum past
    :data:`~adverbs.verb.sampling.MAX_GAIN`, or whose motion would last too long or too short
    (:meth:`~adverbs.verb.sampling.SamplingState.update`), and frames it cannot show (:func:`frame_clocks`)."""
    p = verb.point(p)
    beyond = verb.outside(p)
    if beyond.size and beyond.max() > WARN_BEYOND:
        i = int(np.argmax(beyond))
        lo, hi = verb.points[:, i].min(), verb.points[:, i].max()
        warnings.warn(
            f"{verb.adverbs[i].name}={p[i]:g} is {beyond[i]:.2g} ranges outside the examples ({lo:g} .. {hi:g}): "
            "the motion is extrapolated that far",
            AdverbsWarning,
            stacklevel=4,
        )
    state = sampling.SamplingState.new(verb, 1)
    state.update(verb, p[None])  # refuses a point whose blend or keytimes degenerate
    clocks, fps = frame_clocks(verb, state.keytimes[0, -1], duration, cycles, fps)
    return p, state, clocks, fps


def synthesize_dofs(
    verb: Verb,
    p: np.ndarray,
    duration: float | None = None,
    cycles: float | None = None,
    fps: float | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """DOFs ``(F, D)`` of one creature at ``p`` at every frame, its keytimes ``(N,)`` and the frame rate."""
    _, state, clocks, fps = plan(verb, p, duration, cycles, fps)
    return sampling.clocks_dofs(verb, state, np.zeros(len(clocks), dtype=np.int64), clocks), state.keytimes[0].copy(), fps


def synthesize(
    verb: Verb,
    p: np.ndarray,
    duration: float | None = None,
    cycles: float | None = None,
    fps: float | None = None,
    start: Sequence[float] = (0.0, 0.0, 0.0),
) -> tuple[Clip, np.ndarray]:
    """Motion at adverb point ``p``: a clip and its keytimes ``(N,)`` (those of the first cycle).

    ``cycles`` (default 1) repeats a cyclic verb, the root carrying on from where each cycle ends;
    ``duration`` in seconds overrides it. The root starts at ``start = (x, z, heading)``.
    """
    dofs, k, fps = synthesize_dofs(verb, p, duration, cycles, fps)
    return verb.encoding.decode_clip(dofs, fps, start, name=verb.name), k
