"""Limits on the work one argument or one file can ask for, checked before the work starts.

A frame rate of 1e9, a duration of a year, a BVH file that claims a billion frames or a skeleton a million joints
deep would each run for hours or exhaust memory; these limits refuse them at once, with a message that says what
was asked and what the limit is. Every limit can be raised (or lowered) for one process, by environment variable
or from Python::

    ADVERBS_MAX_FRAMES=2000000 adverbs synth ...        # or: adverbs.limits.LIMITS.frames = 2_000_000
    ADVERBS_MAX_MEMORY=8G adverbs convert ...           # bytes; K, M, G and T suffixes (powers of 1024)
    ADVERBS_MAX_JOINTS=20000 adverbs info big.bvh

``frames``: frames in one clip (read, synthesized, resampled, recorded); ``memory``: the estimated peak memory of
one such piece of work (frames × joints × :data:`BYTES_PER_JOINT_FRAME`); ``joints``: joints in one skeleton.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from fractions import Fraction

from .errors import AdverbsError

# Measured peak of the heaviest path per joint and frame (synthesis with feet planted, then a BVH written): the
# poses in several forms (rotations, positions, DOFs, Euler channels, text) at 8 bytes a number.
BYTES_PER_JOINT_FRAME = 400
_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
LARGEST = 1 << 62  # the largest value a limit may be given: any count or byte size a machine holds is far less


class LimitError(AdverbsError):
    """Work refused before it started because it would pass a limit (see :mod:`adverbs.limits`)."""


def _size(text: str, name: str) -> int:
    m = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]*)?)\s*([KMGT]?)i?B?\s*", text, re.IGNORECASE)
    if m is None:
        raise AdverbsError(f"{name}={_shown(text)}: give a whole number, optionally with K, M, G or T (e.g. 4G)")
    whole, _, fraction = m.group(1).partition(".")
    whole = whole.lstrip("0") or "0"
    # exact, and never a float's infinity (400 nines) or a string of more digits than int() converts
    value = Fraction(f"{whole[:20]}.{fraction[:20] or '0'}") * _UNITS[m.group(2).upper()]
    if len(whole) > 20 or value > LARGEST:
        raise AdverbsError(f"{name}={_shown(text)}: more than {LARGEST:,}; give a whole number up to that")
    return int(value)


def _shown(text: str) -> str:
    """``repr(text)``, cut short for a message."""
    return repr(text) if len(text) <= 40 else f"{text[:20]!r}… ({len(text)} characters)"


@dataclass
class Limits:
    """The limits in force (see the module); change the attributes to change them."""

    frames: int = 200_000
    memory: int = 4 << 30
    joints: int = 10_000

    @classmethod
    def from_environment(cls) -> Limits:
        out = cls()
        for field, var in (("frames", "ADVERBS_MAX_FRAMES"), ("memory", "ADVERBS_MAX_MEMORY"), ("joints", "ADVERBS_MAX_JOINTS")):
            if os.environ.get(var):
                setattr(out, field, _size(os.environ[var], var))
        return out


def _from_environment() -> tuple[Limits, AdverbsError | None]:
    """The limits the environment asks for; a bad variable leaves the defaults and is reported when work is checked
    (:func:`check_environment`), so ``import adverbs`` never fails on it."""
    try:
        return Limits.from_environment(), None
    except AdverbsError as e:
        return Limits(), e


LIMITS, _ENVIRONMENT_ERROR = _from_environment()


def check_environment() -> None:
    """Raise the error of a malformed ``ADVERBS_MAX_*`` variable, if one was set."""
    if _ENVIRONMENT_ERROR is not None:
        raise AdverbsError(str(_ENVIRONMENT_ERROR))


def _gib(n: float) -> str:
    return f"{n / (1 << 30):.3g} GiB" if n >= 1 << 28 else f"{n / (1 << 20):.3g} MiB"


def check_frames(frames: float, joints: int, what: str) -> int:
    """Refuse ``frames`` frames of a ``joints``-joint skeleton for ``what`` (e.g. "10 s at 1e9 fps") when they pass
    the frame or memory limit; return the number of frames as an int."""
    check_environment()
    if not frames >= 0:  # NaN as well
        raise LimitError(f"{what}: {frames} frames is not a number of frames")
    if frames > LIMITS.frames:
        raise LimitError(
            f"{what} is {frames:,.0f} frames; the limit is {LIMITS.frames:,} per clip "
            "(ADVERBS_MAX_FRAMES raises it: see adverbs.limits)"
        )
    need = frames * max(int(joints), 1) * BYTES_PER_JOINT_FRAME
    if need > LIMITS.memory:
        raise LimitError(
            f"{what} is {frames:,.0f} frames of {joints} joints, about {_gib(need)} of memory; the limit is "
            f"{_gib(LIMITS.memory)} (ADVERBS_MAX_MEMORY raises it: see adverbs.limits)"
        )
    return int(frames)


def check_joints(joints: int, what: str) -> None:
    """Refuse a skeleton of more than the joint limit."""
    check_environment()
    if joints > LIMITS.joints:
        raise LimitError(
            f"{what} has {joints:,} joints; the limit is {LIMITS.joints:,} (ADVERBS_MAX_JOINTS raises it: see adverbs.limits)"
        )
