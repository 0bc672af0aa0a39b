"""Inverse kinematics for planted feet (§3.3, eq. 2): two-bone chains solved in closed form.

Each constrained effector (an ankle) hangs from a two-bone chain: the upper joint (hip) with three
rotational DOFs and the middle joint (knee) bending about a hinge. Eq. 2 asks for the change of the chain's
DOFs that takes the effector from where the verb put it to its target, ``J Δθ = Δx``; for a two-bone chain
that change has a closed form (what iterating damped least squares on ``J`` converges to, without its
iterations), two steps per leg:

1. the knee turns about its hinge by the ``θ`` that makes the hip-to-ankle distance the target's: with the
   shin ``s`` split along the hinge ``h`` and across it, ``|o_u + R(h, θ) s|² = |o_u|² + |s|² + 2 (a + b cos θ
   + c sin θ)``, one ``cos(θ − φ)``; of its two roots the one that bends the knee forward (flexion at least
   ``min_flex``) and turns it least;
2. the hip turns by the least rotation that takes the hip-to-ankle direction onto the target's (no turn about
   the leg's own axis, which the target does not ask for; the least-squares steps left some, wherever their path
   led).

A target past the leg's reach leaves the knee at ``min_flex`` and the leg aimed at it (its miss reported); the
knee is never hyper-extended. The root is lowered when a target is beyond the leg's reach (by at most half a
leg: a pit is not reached by squatting into it; what stays out of reach is reported), and only the chain's
joints change: the effector's own rotation is set so the foot keeps its global orientation (tilted to the
ground's slope when a tilt is given). Against eight damped least-squares iterations (what this replaced), on the
feet of a planted Bandai crowd: the same knees (1e-4 degrees), hips and ankles within 1.2 degrees (median 0.02:
the turn about the leg's axis the iterations' path left), the feet on their targets to 1e-15 m where the
iterations left 2e-7.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import AdverbsError
from . import quat
from .skeleton import Skeleton

REACH = 0.995  # fraction of the straight leg's length a target may ask for
MAX_DROP = 0.5  # the root is lowered by at most this fraction of the shortest leg's reach
MISS = 1e-3  # metres: an effector farther than this from its target counts as out of reach
# metres: a chain whose effector is this near its target, its knee bent at least ``min_flex``, is left as the verb
# has it (most chains of a crowd's frame are feet already where the verb puts them)
CONVERGED = 1e-7


@dataclass(frozen=True, eq=False)
class LegChains:
    """Two-bone chains ending at the constrained effectors, ``L`` of them.

    An effector is either the chain's end (an ankle, a wrist) or a point fixed in the end's frame
    (a toe joint below the ankle): the end's global orientation is kept from the motion, so holding the
    toe means holding the ankle at ``toe − R_ankle · tip_offset``.

    Attributes
    ----------
    upper, middle, end : (L,) int
        Hip, knee and ankle joint indices.
    tip_offset : (L, 3)
        The effector's offset in the end's frame (zeros when the effector is the end itself).
    above : tuple of int
        Joints from the root to the hips' common parent, root first (their FK gives the hips' frame).
        The last of them (the pelvis) is what is lowered when a target is out of reach.
    hinge : (L, 3)
        The knee's bending axis in the hip's frame (flexion is positive about it).
    upper_offset, end_offset : (L, 3)
        The knee's offset in the hip's frame and the ankle's in the knee's frame (metres).
    heel_axis : (L, 3)
        Across the foot in the end's frame (zeros where the effector is the end): turning the end about it by
        a positive angle, through the tip, lifts the heel (the ankle rises about the toe's joint).
    """

    upper: np.ndarray
    middle: np.ndarray
    end: np.ndarray
    above: tuple[int, ...]
    hinge: np.ndarray
    upper_offset: np.ndarray
    end_offset: np.ndarray
    tip_offset: np.ndarray
    heel_axis: np.ndarray
    min_flex: float = np.deg2rad(2.0)

    @property
    def reach(self) -> np.ndarray:
        return REACH * (np.linalg.norm(self.upper_offset, axis=1) + np.linalg.norm(self.end_offset, axis=1))

    @classmethod
    def build(cls, skeleton: Skeleton, effectors: Sequence[str | int], sample_rotations: np.ndarray) -> LegChains:
        """Chains for ``effectors``; the hinge axes are fitted to ``sample_rotations (F, J, 4)`` of real motion.

        A toe found by :meth:`Skeleton.feet` hangs from its ankle; any other effector ends its chain.
        """
        toes = {f.toe: f.ankle for f in skeleton.feet() if f.toe is not None}
        tips = [skeleton.index(e) if isinstance(e, str) else int(e) for e in effectors]
        ends = [toes.get(t, t) for t in tips]
        tip_offset = np.array([skeleton.offsets[t] if t in toes else np.zeros(3) for t in tips]).reshape(-1, 3)
        middle, upper = [], []
        for e in ends:
            chain = skeleton.ancestors(e)
            if len(chain) < 3:
                raise AdverbsError(f"effector {skeleton.names[e]!r} needs two joints above it for IK")
            middle.append(chain[1])
            upper.append(chain[2])
        parents = {int(skeleton.parents[u]) for u in upper}
        if len(parents) != 1:
            raise AdverbsError("the constrained chains must hang from one joint (the hips' parent)")
        parent = parents.pop()
        if parent < 0:
            raise AdverbsError("the constrained chains must hang from a joint (a pelvis), not from the root itself")
        above = tuple(skeleton.ancestors(parent)[::-1])
        upper_offset = skeleton.offsets[middle]
        end_offset = skeleton.offsets[ends]
        hinge = np.empty((len(ends), 3))
        for i, (m, o_u, o_e) in enumerate(zip(middle, upper_offset, end_offset)):
            shin = quat.rotate(sample_rotations[:, m], o_e)  # (F, 3) in the hip's frame
            axes = np.cross(o_u, shin)
            total = axes.sum(axis=0)
            if np.linalg.norm(total) < 1e-9:
                raise AdverbsError(f"cannot find the knee axis of {skeleton.names[m]!r}: the leg never bends")
            hinge[i] = total / np.linalg.norm(total)
        return cls(
            np.array(upper), np.array(middle), np.array(ends), above, hinge, upper_offset, end_offset, tip_offset,
            _heel_axes(skeleton, ends, tip_offset, sample_rotations),
        )  # fmt: skip


def _heel_axes(skeleton: Skeleton, ends: Sequence[int], tip_offset: np.ndarray, sample_rotations: np.ndarray) -> np.ndarray:
    """Each foot's heel-lift axis in its end's frame ``(L, 3)``: across the foot, perpendicular to the toe's offset
    and to the world's up as the end's frame sees it on average over ``sample_rotations (F, J, 4)`` (a foot is
    near flat for most of real motion), signed so a positive turn raises the ankle; zeros without a toe."""
    axes = np.zeros((len(ends), 3))
    for i, (e, t) in enumerate(zip(ends, tip_offset)):
        if np.linalg.norm(t) < 1e-9:
            continue
        g = sample_rotations[:, skeleton.ancestors(e)[-1]]
        for j in skeleton.ancestors(e)[-2::-1]:  # root to end: the end's global orientation
            g = quat.mul(g, sample_rotations[:, j])
        up = quat.rotate(quat.inv(g), np.array([0.0, 1.0, 0.0])).mean(axis=0)
        axis = np.cross(t, up)
        n = np.linalg.norm(axis)
        if n < 1e-9:
            continue
        axis /= n
        axes[i] = axis if np.dot(np.cross(axis, -t), up) > 0.0 else -axis  # the ankle (−t from the toe) rises
    return axes


def _checked(rotations, translations, targets) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Copies of the pose and the targets as float arrays; non-finite targets are refused."""
    targets = np.asarray(targets, dtype=float)
    if not np.all(np.isfinite(targets)):
        raise AdverbsError("IK targets must be finite (got NaN or infinity)")
    return np.array(rotations, dtype=float), np.array(translations, dtype=float), targets


@dataclass
class IKResult:
    """The corrected pose and what could not be done."""

    rotations: np.ndarray  # (..., J, 4)
    translations: np.ndarray  # (..., J, 3)
    root_drop: np.ndarray  # (...,) metres the root was lowered to bring targets within reach
    unreachable: np.ndarray  # (..., L) bool: the target stayed out of reach even so
    residual: np.ndarray  # (..., L) metres left between effector and target


def solve_reference(
    chains: LegChains,
    rotations: np.ndarray,
    translations: np.ndarray,
    targets: np.ndarray,
    tilts: np.ndarray | None = None,
    min_drop: np.ndarray | float = 0.0,
) -> IKResult:
    """Move each chain's effector to its target, changing only the chains' joints and the root height.

    Parameters
    ----------
    rotations, translations : (..., J, 4), (..., J, 3)
        Local pose from the verb.
    targets : (..., L, 3)
        Where each effector (the chain's end, or its tip) should be, world space.
    tilts : (..., L, 3, 3), optional
        Extra rotation of each effector's global orientation (the ground's slope); default none.
    min_drop : (...,), optional
        Lower the root at least this much (metres), e.g. to let a root drop fade out smoothly.

    This is the readable NumPy version, vectorized over the leading axes; :func:`solve` computes the
    same with a compiled loop (numba), which is what run time uses.
    """
    rotations, translations, targets = _checked(rotations, translations, targets)
    lead = rotations.shape[:-2]

    # The hips' parent frame, by FK along the few joints above them.
    g = np.broadcast_to(np.eye(3), lead + (3, 3))
    p = np.zeros(lead + (3,))
    for j in chains.above:
        outer = g  # the frame the pelvis's translation is given in, at the last step
        p = p + (g @ translations[..., j, :, None])[..., 0]
        g = g @ quat.to_matrix(rotations[..., j, :])
    g_parent = g[..., None, :, :]  # (..., 1, 3, 3)
    hip = p[..., None, :] + (g_parent @ translations[..., chains.upper, :, None])[..., 0]  # (..., L, 3)

    l_upper = quat.to_matrix(rotations[..., chains.upper, :])  # (..., L, 3, 3)
    l_middle = quat.to_matrix(rotations[..., chains.middle, :])
    g_end = g_parent @ l_upper @ l_middle @ quat.to_matrix(rotations[..., chains.end, :])  # the foot's global frame
    wanted_end = g_end if tilts is None else tilts @ g_end
    targets = targets - (wanted_end @ chains.tip_offset[..., None])[..., 0]  # where the end must go

    # Lower the root where a target is beyond reach: the smallest drop that brings every target in.
    reach = chains.reach
    delta = targets - hip
    horizontal = np.sqrt(delta[..., 0] ** 2 + delta[..., 2] ** 2)
    feasible = horizontal < reach
    below = np.sqrt(np.maximum(reach**2 - horizontal**2, 0.0))
    need = np.where(feasible, -delta[..., 1] - below, 0.0)  # how far the hip must come down
    drop = np.minimum(np.maximum(np.maximum(need.max(axis=-1), 0.0), min_drop), MAX_DROP * reach.min())
    if np.any(drop > 0):
        down = np.swapaxes(outer, -1, -2)[..., :, 1]  # world up in the pelvis's parent frame
        translations[..., chains.above[-1], :] -= drop[..., None] * down
        hip = hip - drop[..., None, None] * np.array([0.0, 1.0, 0.0])

    g_upper = g_parent @ l_upper
    hinge, o_u, o_e = chains.hinge, chains.upper_offset, chains.end_offset
    shin = (l_middle @ o_e[..., None])[..., 0]  # ankle from knee, in the hip's frame
    r = targets - hip - (g_upper @ (o_u + shin)[..., None])[..., 0]
    flex = np.arctan2(np.sum(hinge * np.cross(o_u, shin), axis=-1), np.sum(o_u * shin, axis=-1))
    # A chain at its target with its knee bent enough stays as it is.
    done = (np.sqrt(np.sum(r * r, axis=-1)) <= CONVERGED) & (flex >= chains.min_flex)
    # The knee: turned about its hinge by θ, the shin is s∥ + cos θ s⊥ + sin θ (h × s), and the hip-to-ankle
    # distance² |o_u + shin|² = |o_u|² + |s|² + 2 (a + b cos θ + c sin θ): the θ that gives the target's distance.
    along = np.sum(hinge * shin, axis=-1)[..., None] * hinge
    across, turned = shin - along, np.cross(hinge, shin)
    a, b, c = np.sum(o_u * along, axis=-1), np.sum(o_u * across, axis=-1), np.sum(o_u * turned, axis=-1)
    p_, q_ = np.sum(hinge * np.cross(o_u, across), axis=-1), np.sum(hinge * np.cross(o_u, turned), axis=-1)
    to = targets - hip
    k = 0.5 * (np.sum(to * to, axis=-1) - np.sum(o_u * o_u, axis=-1) - np.sum(shin * shin, axis=-1))
    radius = np.sqrt(b * b + c * c)
    flat = radius < 1e-12  # the shin along the hinge or the thigh: the knee cannot change the distance
    radius = np.where(flat, 1.0, radius)
    x = np.clip((k - a) / radius, -1.0, 1.0)  # cos(θ − φ); beyond reach (or nearer than the knee bends), the nearest
    cos_a, sin_a = x, np.sqrt(1.0 - x * x)
    cos_p, sin_p = b / radius, c / radius
    cos_1, sin_1 = cos_p * cos_a - sin_p * sin_a, sin_p * cos_a + cos_p * sin_a  # θ = φ + α
    cos_2, sin_2 = cos_p * cos_a + sin_p * sin_a, sin_p * cos_a - cos_p * sin_a  # θ = φ − α
    flex_1 = np.arctan2(p_ * cos_1 + q_ * sin_1, a + b * cos_1 + c * sin_1)
    flex_2 = np.arctan2(p_ * cos_2 + q_ * sin_2, a + b * cos_2 + c * sin_2)
    ok_1, ok_2 = flex_1 >= chains.min_flex, flex_2 >= chains.min_flex
    first = ok_1 & (~ok_2 | (cos_1 >= cos_2))  # the knee bent forward, turned the least
    cos_t, sin_t = np.where(first, cos_1, cos_2), np.where(first, sin_1, sin_2)
    # Neither bends it enough (the target at or past the leg's reach): flexion min_flex, the leg aimed at it.
    least = ~(ok_1 | ok_2) | flat
    turn = np.where(least, chains.min_flex - flex, 0.0)
    cos_t = np.where(least, np.cos(turn), cos_t)
    sin_t = np.where(least, np.sin(turn), sin_t)
    cos_t, sin_t = np.where(done, 1.0, cos_t), np.where(done, 0.0, sin_t)
    hinge_skew = quat.cross_matrix(hinge)
    knee = np.eye(3) + sin_t[..., None, None] * hinge_skew + (1.0 - cos_t)[..., None, None] * (hinge_skew @ hinge_skew)
    l_middle = knee @ l_middle
    # The hip: the least rotation that turns the leg (hip to ankle) onto the target's direction.
    leg = (g_upper @ (o_u + (l_middle @ o_e[..., None])[..., 0])[..., None])[..., 0]
    leg = leg / np.sqrt(np.sum(leg * leg, axis=-1))[..., None]
    aim = to / np.maximum(np.sqrt(np.sum(to * to, axis=-1)), 1e-300)[..., None]  # (a target on the hip: no turn)
    cos_s = np.sum(leg * aim, axis=-1)
    still = done | (1.0 + cos_s < 1e-12)  # (a leg turned straight away from its target: left, its miss reported)
    skew = quat.cross_matrix(np.cross(leg, aim))
    swing = np.eye(3) + skew + (skew @ skew) / np.where(still, 1.0, 1.0 + cos_s)[..., None, None]
    g_upper = np.where(still[..., None, None], g_upper, swing @ g_upper)

    end = hip + (g_upper @ (o_u + (l_middle @ o_e[..., None])[..., 0])[..., None])[..., 0]
    residual = np.linalg.norm(targets - end, axis=-1)
    l_upper = np.swapaxes(g_parent, -1, -2) @ g_upper
    l_end = np.swapaxes(g_upper @ l_middle, -1, -2) @ wanted_end
    rotations[..., chains.upper, :] = quat.from_matrix(l_upper)
    rotations[..., chains.middle, :] = quat.from_matrix(l_middle)
    rotations[..., chains.end, :] = quat.from_matrix(l_end)
    return IKResult(rotations, translations, drop, residual > MISS, residual)


# ----- the compiled path -----------------------------------------------------------------------


def solve(
    chains: LegChains,
    rotations: np.ndarray,
    translations: np.ndarray,
    targets: np.ndarray,
    tilts: np.ndarray | None = None,
    min_drop: np.ndarray | float = 0.0,
) -> IKResult:
    """:func:`solve_reference`, compiled: the same algorithm and results, one pose at a time in a loop.

    One creature's two feet take tens of microseconds instead of a couple of milliseconds of NumPy calls.
    """
    rotations, translations, targets = _checked(rotations, translations, targets)
    lead = rotations.shape[:-2]
    j, n_legs = rotations.shape[-2], len(chains.end)
    rot = np.ascontiguousarray(rotations.reshape(-1, j, 4))
    trans = np.ascontiguousarray(translations.reshape(-1, j, 3))
    tgt = np.ascontiguousarray(np.broadcast_to(targets, lead + (n_legs, 3)).reshape(-1, n_legs, 3))
    if tilts is None:
        tl = np.zeros((0, n_legs, 3, 3))
    else:
        tl = np.ascontiguousarray(np.broadcast_to(tilts, lead + (n_legs, 3, 3)).reshape(-1, n_legs, 3, 3))
    drop = np.array(np.broadcast_to(np.asarray(min_drop, dtype=float), lead), dtype=float).reshape(-1)
    residual = np.zeros((len(rot), n_legs))
    _kernel().solve_batch(
        rot, trans, tgt, tl, np.array(chains.above, dtype=np.int64), chains.upper, chains.middle, chains.end,
        chains.hinge, chains.upper_offset, chains.end_offset, chains.tip_offset, chains.reach, chains.min_flex,
        CONVERGED, MAX_DROP * float(chains.reach.min()), drop, residual,
    )  # fmt: skip
    residual = residual.reshape(lead + (n_legs,))
    return IKResult(
        rot.reshape(rotations.shape), trans.reshape(translations.shape), drop.reshape(lead), residual > MISS, residual
    )


_KERNEL = None


def _kernel():
    """Compile the loop on first use (cached on disk by numba), so importing adverbs stays quick."""
    global _KERNEL
    if _KERNEL is None:
        from . import _ik_kernel

        _KERNEL = _ik_kernel
    return _KERNEL
