"""The compiled loop behind :class:`adverbs.feet.planter.FootPlanter`: its state machine, creature by creature, leg by leg.

Every function mirrors a piece of the NumPy reference in :mod:`adverbs.feet.planter` (same rules, same
order of operations, named in each docstring), so the two agree to rounding; ``tests/test_planting_kernel.py``
holds them to it. The reference is vectorized over creatures and legs; here one effector at a time goes
through the frame, which comes to the same: no effector's rules read another's, but for a creature's
contact level when planting starts (the lowest of its feet that are down).

The arguments come in tuples (what ``FootPlanter`` keeps):

* ``floor = (kind, params, tilt, gx, gz, grid)``: a plane (:data:`PLANE`: ``FlatFloor``, ``SlopeFloor``;
  ``params`` ``(level, gradient, direction x, direction z, step)``, and its ``tilt (3, 3)``, the same
  everywhere: the identity on a flat floor) or a bilinear height map (:data:`GRID`: ``HeightMapFloor``, its grid
  lines ``gx``, ``gz`` and ``grid (len(gz), len(gx))``; ``params`` ``(0, 0, 0, 0, step)``; its tilt is taken
  from normals by central differences ``step`` apart, as ``Floor.normal`` takes them).
* ``legs = (heights, opens, heel_heights, tip_offset, heel_axis)``, per effector ``(L,)`` (``(L, 3)``).
* ``state = (mode, turn, target, held_rot, offset, offset_vel, since, spent, rising, rel_vec, rot_since,
  settle, hover, ground, prev_free, drop, heel, kept)``: ``FootPlanter``'s state arrays, updated in place.
* ``k_``: the planter's constants, :func:`constants`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._scratch_kernel import carve
from ..kinematics._fk_kernel import forward_to
from ..kinematics._ik_kernel import _copy33, _mat_to_quat, _mm, _mv, _quat_to_mat, _rotation, solve_batch
from ..motion import _pose_kernel
from ._planting_scalars import hold_mode as _hold_mode
from ._planting_scalars import smoothstep as _smoothstep
from ._planting_scalars import spring as _spring

PLANE, GRID = 0, 1
FREE, HEEL, BALL = 0, 1, 2  # planting.FREE, HEEL, BALL
# Where each constant sits in ``k_`` (see constants()).
_SWING, _LN2, _OFFSET, _SETTLE, _CLEARANCE, _STILL_DOWN, _LIFTS_OFF, _TOE_LANDS, _FADE = 0, 1, 2, 5, 6, 7, 8, 9, 10
_SWING_LIFT, _LIFT_BLEND, _HEEL_LIFT, _HEEL_STEEPEST, _INSIDE, _TRAILING, _SLACK, _RISE = 11, 12, 13, 14, 15, 16, 17, 18
_LANDING = 19


def constants(swing, ln2, halflives, settle, clearance, still_down, lifts_off, toe_lands, drop_halflife, swing_lift,
              lift_blend, heel_lift, heel_steepest, inside, trailing, slack, rise, landing):  # fmt: skip
    """``k_``: ``SWING_HALFLIFE``, ln 2, the free offset's half-lives ``(3,)``, ``SETTLE_HALFLIFE``,
    ``SWING_CLEARANCE``, ``STILL_DOWN``, ``LIFTS_OFF``, ``TOE_LANDS``, ln 2 / ``DROP_HALFLIFE``, ``SWING_LIFT``,
    ``LIFT_BLEND``, ``HEEL_LIFT``, ``HEEL_STEEPEST``, ``INSIDE``, ``TRAILING``, ``EXAMPLE_SLACK``, ``RISE`` and
    ``LANDING``."""
    return np.array([
        swing, ln2, *halflives, settle, clearance, still_down, lifts_off, toe_lands, ln2 / drop_halflife, swing_lift,
        lift_blend, heel_lift, heel_steepest, inside, trailing, slack, rise, landing,
    ])  # fmt: skip


# ----- floors: kinematics.floor ---------------------------------------------------------------------------


@njit(cache=True, _nrt=False)
def _grid_index(axis, v):
    """The cell ``i`` of regular grid lines ``axis`` holding ``v`` (the edge cells beyond) and ``v``'s fraction across it."""
    i = int(math.floor((v - axis[0]) / (axis[1] - axis[0])))
    i = min(max(i, 0), len(axis) - 2)
    return i, (v - axis[i]) / (axis[i + 1] - axis[i])


@njit(cache=True, inline="always")
def _height(floor, x, z):
    """``Floor.height`` at ``(x, z)``: a plane's ``level + gradient · (xz · direction)`` (``SlopeFloor``; a
    ``FlatFloor`` has no gradient), or a height map's bilinear sample clipped to its edges (``HeightMapFloor``)."""
    kind, params, _, gx, gz, grid = floor
    if kind == PLANE:
        return params[0] + params[1] * (x * params[2] + z * params[3])
    i, u = _grid_index(gz, min(max(z, gz[0]), gz[len(gz) - 1]))
    j, v = _grid_index(gx, min(max(x, gx[0]), gx[len(gx) - 1]))
    return (grid[i, j] * (1.0 - u) * (1.0 - v) + grid[i, j + 1] * (1.0 - u) * v
            + grid[i + 1, j] * u * (1.0 - v) + grid[i + 1, j + 1] * u * v)  # fmt: skip


@njit(cache=True, _nrt=False)
def _tilt(floor, x, z, out):
    """``FootPlanter._tilt`` at ``(x, z)`` into ``out (3, 3)``: ``floor.tilt(floor.normal(xz))``, the shortest turn
    of the vertical onto the normal taken by central differences (a plane's is given: its difference quotients
    are its gradient, whatever the point, to rounding)."""
    if floor[0] == PLANE:
        _copy33(floor[2], out)
        return
    h = floor[1][4]
    sx = (_height(floor, x + h, z) - _height(floor, x - h, z)) / (2 * h)
    sz = (_height(floor, x, z + h) - _height(floor, x, z - h)) / (2 * h)
    norm = math.sqrt(sx * sx + 1.0 + sz * sz)
    nx, ny, nz = -sx / norm, 1.0 / norm, -sz / norm
    s = math.sqrt(nz * nz + nx * nx)  # |ŷ × n|, the axis being (nz, 0, −nx)
    k = math.atan2(s, ny) / (s if s > 1e-12 else 1.0)
    _rotvec_matrix(nz * k, 0.0, -nx * k, out)


# ----- rotations: kinematics.quat ------------------------------------------------------------------------


@njit(cache=True, _nrt=False)
def _rotvec_matrix(vx, vy, vz, out):
    """``quat.rotvec_matrix`` of one rotation vector."""
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    a = 1.0 if angle < 1e-12 else angle
    _rotation(vx / a, vy / a, vz / a, angle, out)


@njit(cache=True, inline="always")
def _mmt(a, b, out):
    """a bᵀ"""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]


@njit(cache=True, _nrt=False)
def _log(q, out):
    """``quat.log``: the rotation vector of ``q``, keeping its sign."""
    out[0], out[1], out[2] = _pose_kernel._log(q[0], q[1], q[2], q[3])


@njit(cache=True, _nrt=False)
def _turn(held, free, w, out, q):
    """``planting._turn`` of one foot: ``held`` slerped towards ``free`` by ``w`` (``quat.slerp``; one or the
    other outside ``(0, 1)``); ``q (2, 4)``: scratch."""
    if w >= 1.0:
        _copy33(free, out)
        return
    if not w > 0.0:
        _copy33(held, out)
        return
    a, b = q[0], q[1]
    _mat_to_quat(held, a)
    _mat_to_quat(free, b)
    if a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0:  # the short way
        for e in range(4):
            b[e] = -b[e]
    x, y, z, s = _pose_kernel._mul(-a[0], -a[1], -a[2], a[3], b[0], b[1], b[2], b[3])
    rx, ry, rz = _pose_kernel._log(x, y, z, s)
    x, y, z, s = _pose_kernel._exp(rx * w, ry * w, rz * w)
    b[0], b[1], b[2], b[3] = _pose_kernel._mul(a[0], a[1], a[2], a[3], x, y, z, s)
    b /= math.sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + b[3] * b[3])
    _quat_to_mat(b, out)


# ----- the state machine: FootPlanter.targets_reference --------------------------------------------------


@njit(cache=True, inline="always")
def _lowered(lift, hover, clearance):
    """``planting._lowered``."""
    return lift - hover * (1.0 - _smoothstep((lift - hover) / clearance))


@njit(cache=True, inline="always")
def _ramp(x, k):
    """``planting._ramp``."""
    x = max(x, 0.0)
    return x * x / (2.0 * k) if x < k else x - 0.5 * k


@njit(cache=True, inline="always")
def _smooth_max(a, b, k):
    """``planting._smooth_max``."""
    h = max(k - abs(a - b), 0.0) / k
    return max(a, b) + 0.25 * k * h * h


@njit(cache=True, inline="always")
def _released_rot(free_rot, rel_vec, rot_since, k_, out, scratch):
    """``FootPlanter._released_rot`` of one foot: its orientation turned by what is left of its release's turn."""
    k = _spring(1.0, 0.0, rot_since, k_[_SWING], k_[_LN2])
    if k < 1e-9:  # long let go: nothing left to turn
        _copy33(free_rot, out)
        return
    _rotvec_matrix(rel_vec[0] * k, rel_vec[1] * k, rel_vec[2] * k, scratch)
    _mm(scratch, free_rot, out)


# Inlined: numba passes a call's tuples of arrays flattened, word by word, and ``state`` alone is some 170 words. As a
# call, _shown's arguments were copied over the stack once or twice a foot a frame: 80% of advance's time, a sixth of
# a crowd's frame (perf, 1,000 creatures). Inlined at its three calls, the frame is 15-25% quicker; the kernels take
# about 6% longer to compile.
@njit(cache=True, inline="always")
def _shown(c, i, base, free_rot, turn, follows, height, tip, axis, k_, floor, state, shown, wanted, s, q):
    """``FootPlanter._shown`` (with ``_offset``, ``_held_offset``, ``_shown_held``, ``_ground_shift``) of effector
    ``i`` of creature ``c`` in its mode now: where it is shown, into ``shown (3,)``, and its foot's wanted
    orientation, into ``wanted (3, 3)``; ``axis (3,)``: its heel axis. ``s (4, 3, 3)``, ``q (2, 4)``: scratch."""
    mode, _, target, held_rot, offset, offset_vel, since, _, rising, rel_vec, rot_since, settle = state[:12]
    rr, tl, turned = s[0], s[1], s[2]
    _released_rot(free_rot, rel_vec[c, i], rot_since[c, i], k_, rr, s[3])
    m = mode[c, i]
    if m == FREE:  # the free rule: the verb's, plus the offset decaying from a release, kept over the floor
        _tilt(floor, base[0], base[2], tl)
        _mm(tl, rr, wanted)
        for a in range(3):
            shown[a] = base[a]
            if not settle[c, i]:  # (a landing's offset decays in the held rule)
                shown[a] += _spring(offset[c, i, a], offset_vel[c, i, a], since[c, i, a], k_[_OFFSET + a], k_[_LN2])
        if not follows:
            under = _height(floor, shown[0], shown[2])
            shown[1] += under - _height(floor, base[0], base[2])
            shown[1] = max(shown[1], under + height)
        return
    _tilt(floor, target[c, i, 0], target[c, i, 2], tl)
    if m == HEEL:
        _mm(tl, rr, wanted)
    else:
        _turn(held_rot[c, i], rr, turn, turned, q)
        _mm(tl, turned, wanted)
        _heel_turn(wanted, axis, state[16][c, i], s[3], turned)
    for a in range(3):
        shown[a] = target[c, i, a]
        if settle[c, i]:
            shown[a] += _spring(offset[c, i, a], offset_vel[c, i, a], since[c, i, a], k_[_SETTLE], k_[_LN2])
    if m == BALL:
        shown[1] += rising[c, i]
    else:  # the heel held: the effector hangs off the ankle as the foot rolls down
        for a in range(3):
            shown[a] += wanted[a, 0] * tip[0] + wanted[a, 1] * tip[1] + wanted[a, 2] * tip[2]


@njit(cache=True, inline="always")
def _land(c, i, point, height, floor, state):
    """``FootPlanter._land`` of one effector: hold ``point`` ``height`` above the floor (NaN: where it is)."""
    target, offset, offset_vel, since, settle = state[2], state[4], state[5], state[6], state[11]
    for a in range(3):
        target[c, i, a] = point[a]
    if not math.isnan(height):
        target[c, i, 1] = _height(floor, point[0], point[2]) + height
    offset[c, i, :] = 0.0
    offset[c, i, 1] = max(point[1] - target[c, i, 1], 0.0)  # settles down, never up from below
    offset_vel[c, i, :] = 0.0
    since[c, i, :] = 0.0
    settle[c, i] = True


@njit(cache=True, _nrt=True)  # allocates: counts even when its caller is compiled without counting
def advance(free_pos, free_rot, generic, inside_in, turn_in, swing_in, examples_in, eased_in, hold_in, use_phases, dt,
            start, times, cyclic, verb_floor, legs, k_, floor, state, shown_out, wanted_out):  # fmt: skip
    """``FootPlanter.targets_reference``: every creature's effectors advanced by one frame (``state`` in place);
    their targets into ``shown_out (C, L, 3)`` and wanted orientations into ``wanted_out (C, L, 3, 3)``.

    ``generic (C,)`` or, with ``use_phases``, ``inside_in``, ``turn_in``, ``swing_in``, ``examples_in (C, L)`` (the
    examples' lifts, ``-inf`` for none; without phases, none), ``eased_in (C,)`` (their share under a decaying
    offset, 1 for none) and ``hold_in (C, L)`` (whether the verbs hold each foot, where ``inside_in`` may keep one
    free: a re-placed foot, which does not land early); ``dt (C,)``; ``start``: the first frame (the contact levels
    from the feet that are down); ``times (C, L, 3)``: the holds' times.
    """
    n_l = free_pos.shape[1]
    inside = np.empty(n_l, dtype=np.bool_)
    buf = np.empty(3 * n_l + 4 * 3 + 4 + 3 * 9 + 4 * 9 + 2 * 4)
    _advance(free_pos, free_rot, generic, inside_in, turn_in, swing_in, examples_in, eased_in, hold_in, use_phases, dt,
             start, times, cyclic, verb_floor, legs, k_, floor, state, shown_out, wanted_out, inside, buf)  # fmt: skip


@njit(cache=True, _nrt=False)
def _advance(free_pos, free_rot, generic, inside_in, turn_in, swing_in, examples_in, eased_in, hold_in, use_phases, dt,
             start, times, cyclic, verb_floor, legs, k_, floor, state, shown_out, wanted_out, inside, buf):  # fmt: skip
    """:func:`advance` in its working arrays ``inside (L,)`` and ``buf`` (not counted: see ``_frame_kernel``)."""
    mode, turn, _, held_rot, offset, offset_vel, since, spent, rising, rel_vec, rot_since, settle = state[:12]
    hover, ground, prev_free, kept = state[12], state[13], state[14], state[17]
    heights, opens, heel_heights, tip, heel_axis = legs
    n_c, n_l = free_pos.shape[0], free_pos.shape[1]
    clearance, still_down, lifts_off, toe_lands = k_[_CLEARANCE], k_[_STILL_DOWN], k_[_LIFTS_OFF], k_[_TOE_LANDS]
    turns, at = carve(buf, 0, (n_l,))
    lifts, at = carve(buf, at, (n_l,))
    swings, at = carve(buf, at, (n_l,))
    base, at = carve(buf, at, (3,))
    vel, at = carve(buf, at, (3,))
    arm, at = carve(buf, at, (3,))
    shown, at = carve(buf, at, (3,))
    q, at = carve(buf, at, (4,))
    wanted, at = carve(buf, at, (3, 3))
    free_wanted, at = carve(buf, at, (3, 3))
    rel, at = carve(buf, at, (3, 3))
    s, at = carve(buf, at, (4, 3, 3))
    qs, at = carve(buf, at, (2, 4))
    for c in range(n_c):
        for i in range(n_l):
            if use_phases:
                inside[i], turns[i], swings[i] = inside_in[c, i], turn_in[c, i], swing_in[c, i]
            else:
                inside[i], turns[i], swings[i] = _hold_mode(cyclic, generic[c], opens[i], times[c, i])
            # How far the verb's effector is above its contact height (its own floor at these adverbs).
            lifts[i] = 0.0 if math.isnan(heights[i]) else free_pos[c, i, 1] - verb_floor - heights[i]
        if start:  # the verb's level from the feet that are down now, else none
            down = np.inf
            for i in range(n_l):
                if inside[i]:
                    down = min(down, lifts[i])
            for i in range(n_l):
                hover[c, i] = down if math.isfinite(down) else 0.0
                ground[c, i] = np.inf
                for a in range(3):
                    prev_free[c, i, a] = free_pos[c, i, a]
        d = dt[c]
        for i in range(n_l):
            follows = math.isnan(heights[i])  # an effector that keeps the verb's height
            height = 0.0 if follows else heights[i]
            lift, tn, fp, fr = lifts[i], turns[i], free_pos[c, i], free_rot[c, i]
            for a in range(3):
                if since[c, i, a] < 0.0:  # an offset not yet begun holds the foot where it is (FootPlanter.targets)
                    offset[c, i, a] -= fp[a] - prev_free[c, i, a]
                since[c, i, a] += d
                vel[a] = (fp[a] - prev_free[c, i, a]) / (d if d > 0 else np.inf)
            # Landing early under a decaying offset, coming down (FootPlanter.targets).
            early = use_phases and eased_in[c] < 1.0 and not hold_in[c, i] and 0.0 < swings[i] < 1.0 and lift < 0.0
            early = early and not follows and (mode[c, i] != FREE or vel[1] < -k_[_LANDING])
            if early:
                inside[i], tn = True, 0.0
            m, gr = mode[c, i], ground[c, i]
            # Held, over the level this hold has found so far; a ball the verb lifts off it rolls the foot off.
            level = min(gr, lift) if m != FREE and math.isfinite(gr) else hover[c, i]
            raised = _lowered(lift, level, clearance)
            if m == BALL:
                tn = max(tn, _smoothstep((raised - still_down) / (lifts_off - still_down)))
            # A rolling foot the verb already lifts off is let go, and not held again until the next hold.
            spent[c, i] = (spent[c, i] and inside[i]) or (m == BALL and tn > 0.0 and raised >= lifts_off)
            held = inside[i] and not spent[c, i]
            opening, closing = held and m == FREE, not held and m != FREE
            if closing:
                if math.isfinite(gr):
                    hover[c, i] = gr
                level = hover[c, i]
                raised = _lowered(lift, level, clearance)  # the let-go foot's new level
            # Where the free rule puts the foot: the verb's, lowered by its hover, no lower than its examples lift
            # it there, on the floor, lifted at least the swing's least lift.
            swung = raised
            ex = examples_in[c, i] if use_phases else -np.inf
            easing = use_phases and eased_in[c] < 1.0 and math.isfinite(ex)
            if easing:  # eased in, no lower than a floor rising from where a free foot was (FootPlanter.targets)
                cap = lift if math.isnan(kept[c, i]) else kept[c, i] + k_[_RISE] * d
                ex = min(ex, max(ex * eased_in[c], cap))
            if use_phases:
                below = _lowered(ex, level, clearance) - raised - k_[_SLACK]
                swung += _ramp(below, k_[_LIFT_BLEND])
            # (Not for a foot about to land; one its verbs hold past heel-off while still in the air is lifting.)
            lifting = held and m == FREE and tn > 0.0 and swings[i] > 0.0
            least = -np.inf if follows or (held and not lifting and not early) else k_[_SWING_LIFT] * swings[i]
            up = _smooth_max(swung, least, k_[_LIFT_BLEND])
            base[0], base[1], base[2] = fp[0], _height(floor, fp[0], fp[2]) + height + up, fp[2]
            _tilt(floor, base[0], base[2], s[0])
            _mm(s[0], fr, free_wanted)
            rot_since[c, i] += d
            rising[c, i] = 0.0 if follows else max(raised, 0.0) * tn
            _shown(c, i, base, fr, turn[c, i], follows, height, tip[i], heel_axis[i], k_, floor, state, shown, wanted, s, qs)
            # Whether shown and wanted are still what _shown gives at the end (only a rolling ball reads the turn).
            fresh = m != BALL or turn[c, i] == tn
            if closing:  # let go: what the foot's orientation had still to turn decays from here
                _mmt(wanted, free_wanted, rel)
                _mat_to_quat(rel, q)
                if q[3] < 0.0:  # the short way round
                    for e in range(4):
                        q[e] = -q[e]
                _log(q, rel_vec[c, i])
                rot_since[c, i] = 0.0
                for a in range(3):
                    offset[c, i, a] = shown[a] - base[a]  # let go from where it was shown
                # Its height as a height over the floor under it (_ground_shift).
                offset[c, i, 1] -= _height(floor, shown[0], shown[2]) - _height(floor, base[0], base[2])
                # Leaves from rest horizontally (_AT_REST), rises as the verb lifts it.
                offset_vel[c, i, 0], offset_vel[c, i, 1], offset_vel[c, i, 2] = -vel[0], -vel[1] * 0.0, -vel[2]
                since[c, i, :] = 0.0
                settle[c, i] = False
                mode[c, i] = FREE
                fresh = False
            # A landing foot rolls down from its heel unless its ball is down already or the heel is lifting.
            has_heel = not follows and not math.isnan(heel_heights[i])
            low = shown[1] - _height(floor, shown[0], shown[2]) - height <= toe_lands
            rocking = opening and has_heel and not low and tn == 0.0
            opening = opening and (low or tn == 0.0)
            if rocking:  # heel strike: the ankle is held where it is shown, at its height over the floor
                _mv(free_wanted, tip[i], arm)
                for a in range(3):
                    shown[a] -= arm[a]
                _land(c, i, shown, heel_heights[i], floor, state)
                mode[c, i] = HEEL
                _shown(c, i, base, fr, tn, follows, height, tip[i], heel_axis[i], k_, floor, state, shown, wanted, s, qs)
                fresh = True
                low = shown[1] - _height(floor, shown[0], shown[2]) - height <= toe_lands
            # The ball is down once the rolling foot brings it to the floor (or, at the latest, at heel-off).
            if (opening and not rocking) or (mode[c, i] == HEEL and (low or tn > 0.0)):
                _land(c, i, shown, np.nan if follows else height, floor, state)
                _released_rot(fr, rel_vec[c, i], rot_since[c, i], k_, held_rot[c, i], s[3])
                mode[c, i] = BALL
                fresh = False
            if opening:
                ground[c, i] = np.inf
            if mode[c, i] != FREE:  # the verb's own level: the lowest its foot gets while held
                ground[c, i] = min(ground[c, i], lift)
            turn[c, i] = tn
            for a in range(3):
                prev_free[c, i, a] = fp[a]
            kept[c, i] = ex if easing and mode[c, i] == FREE else np.nan
            if fresh:  # nothing _shown reads has changed since it ran
                for a in range(3):
                    shown_out[c, i, a] = shown[a]
                _copy33(wanted, wanted_out[c, i])
            else:
                _shown(c, i, base, fr, tn, follows, height, tip[i], heel_axis[i], k_, floor, state, shown_out[c, i],
                       wanted_out[c, i], s, qs)  # fmt: skip


# ----- the rest of a frame: _rise, reach, _ride_floor, _tilts, then IK ----------------------------------


@njit(cache=True, _nrt=False)
def rise(roots, targets, verb_floor, floor, out):
    """``planting._rise``: how far each creature's pelvis rides up (``roots (C, 3)``, ``targets (C, L, 3)``), into ``out (C,)``."""
    for c in range(len(out)):
        low = _height(floor, roots[c, 0], roots[c, 2])
        for i in range(targets.shape[1]):
            low = min(low, _height(floor, targets[c, i, 0], targets[c, i, 2]))
        out[c] = low - verb_floor


@njit(cache=True, _nrt=False)
def _heel_turn(wanted, axis, angle, rot, out):
    """``planting._heel_turn`` of one foot: ``wanted (3, 3)`` turned heel-up by ``angle`` about ``axis (3,)`` in the
    foot's frame, in place; ``rot``, ``out (3, 3)``: scratch."""
    if angle == 0.0:
        return
    _mv(wanted, axis, out[0])  # the axis in the world
    _rotvec_matrix(out[0, 0] * angle, out[0, 1] * angle, out[0, 2] * angle, rot)
    _mm(rot, wanted, out)
    _copy33(out, wanted)


@njit(cache=True, _nrt=False)
def _heel_needed(bx, by, bz, ax, ay, az, ux, uy, uz, r):
    """``planting._heel_needed`` of one foot: the ball ``b`` from the hip, the ankle ``a`` from the ball, the heel
    axis ``u`` (world), the leg's reach ``r``."""
    k = ax * ux + ay * uy + az * uz
    lx, ly, lz = k * ux, k * uy, k * uz  # along the axis
    a = bx * (ax - lx) + by * (ay - ly) + bz * (az - lz)
    b = bx * (uy * az - uz * ay) + by * (uz * ax - ux * az) + bz * (ux * ay - uy * ax)
    c = bx * lx + by * ly + bz * lz
    room = 0.5 * (r * r - (bx * bx + by * by + bz * bz) - (ax * ax + ay * ay + az * az)) - c
    if not (a > room and b < 0.0):
        return 0.0
    rr = math.hypot(a, b)
    start = math.atan2(-b, a)
    cross = math.acos(min(max(room / (rr if rr > 0.0 else 1.0), -1.0), 1.0))
    return max(cross - start, 0.0)


@njit(cache=True, _nrt=True)  # allocates: counts even when its caller is compiled without counting
def reach(hips, rises, targets, wanted, dt, tip, axis, reach_, max_drop, k_, state):
    """``FootPlanter.reach_reference``: heels lifted, each creature's root drop (``state[15]``) and free feet
    brought within reach, ``targets (C, L, 3)`` and ``wanted (C, L, 3, 3)`` in place; ``max_drop``: ``ik.MAX_DROP``
    times the shortest ``reach_``."""
    buf = np.empty(3 * 3 + 2 * 9)
    loose = np.empty(hips.shape[1], dtype=np.bool_)
    _reach(hips, rises, targets, wanted, dt, tip, axis, reach_, max_drop, k_, state, buf, loose)


@njit(cache=True, _nrt=False)
def _reach(hips, rises, targets, wanted, dt, tip, axis, reach_, max_drop, k_, state, buf, loose):
    """:func:`reach` in its working arrays ``buf`` and ``loose (L,)`` (not counted: see ``_frame_kernel``)."""
    mode, turn, spent, drop, heel = state[0], state[1], state[7], state[15], state[16]
    n_l = hips.shape[1]
    arm, at = carve(buf, 0, (3,))
    hip, at = carve(buf, at, (3,))
    u, at = carve(buf, at, (3,))
    rot, at = carve(buf, at, (3, 3))
    tmp, at = carve(buf, at, (3, 3))
    for c in range(len(drop)):
        fade = math.exp(-k_[_FADE] * dt[c])
        need_drop = -np.inf
        for i in range(n_l):
            w = wanted[c, i]
            held = mode[c, i] == BALL
            if held:
                _heel_turn(w, axis[i], -heel[c, i], rot, tmp)
            _mv(w, tip[i], arm)  # ankle → effector
            _mv(w, axis[i], u)  # the heel axis in the world
            for a in range(3):
                hip[a] = hips[c, i, a]
            hip[1] += rises[c]
            need = _heel_needed(targets[c, i, 0] - hip[0], targets[c, i, 1] - hip[1], targets[c, i, 2] - hip[2],
                                -arm[0], -arm[1], -arm[2], u[0], u[1], u[2], reach_[i])  # fmt: skip
            flat = math.hypot(arm[0], arm[2])
            most = min(max(k_[_HEEL_STEEPEST] - math.atan2(-arm[1], flat), 0.0), k_[_HEEL_LIFT])
            # Only a foot the hips have passed.
            behind = ((hip[0] - targets[c, i, 0]) * arm[0] + (hip[2] - targets[c, i, 2]) * arm[2]) / max(flat, 1e-9)
            most = most * _smoothstep(behind / k_[_TRAILING])
            going = held and turn[c, i] > 0.0 and behind >= k_[_TRAILING] and max(need, 2.0 * need - heel[c, i]) > most
            heel[c, i] = min(max(need, heel[c, i] * fade), most) if held else 0.0
            if going:
                spent[c, i] = True
            _heel_turn(w, axis[i], heel[c, i], rot, tmp)
            loose[i] = mode[c, i] == FREE or going
            if not loose[i]:
                _mv(w, tip[i], arm)
                dx = targets[c, i, 0] - arm[0] - hip[0]
                dy = targets[c, i, 1] - arm[1] - hip[1]
                dz = targets[c, i, 2] - arm[2] - hip[2]
                across = math.hypot(dx, dz)
                need_drop = max(need_drop, -dy - math.sqrt(max(reach_[i] ** 2 - across**2, 0.0)) if across < reach_[i] else 0.0)
        need_drop = min(max(need_drop, 0.0), max_drop)
        drop[c] = max(need_drop, drop[c] * fade)
        for i in range(n_l):
            if not loose[i]:
                continue
            _mv(wanted[c, i], tip[i], arm)
            hy = hips[c, i, 1] + rises[c] - drop[c]
            dx = targets[c, i, 0] - arm[0] - hips[c, i, 0]
            dy = targets[c, i, 1] - arm[1] - hy
            dz = targets[c, i, 2] - arm[2] - hips[c, i, 2]
            far = math.sqrt(dx * dx + dy * dy + dz * dz)
            inside = reach_[i] * k_[_INSIDE]
            if far > inside:
                across = math.hypot(dx, dz)
                if across < inside and dy < 0.0:  # raised to the reach: it lifts off rather than slides
                    dy = -math.sqrt(max(inside * inside - across * across, 0.0))
                else:  # along the line to the hip
                    scale = inside / far
                    dx, dy, dz = dx * scale, dy * scale, dz * scale
                targets[c, i, 0] = hips[c, i, 0] + dx + arm[0]
                targets[c, i, 1] = hy + dy + arm[1]
                targets[c, i, 2] = hips[c, i, 2] + dz + arm[2]


@njit(cache=True, _nrt=True)  # allocates: counts even when its caller is compiled without counting
def step(parents, rotations, translations, generic, inside_in, turn_in, swing_in, examples_in, eased_in, hold_in,
         use_phases, dt, start, times, cyclic, verb_floor, tips, root, legs, k_, floor, state, chain, ik_params,
         out):  # fmt: skip
    """``FootPlanter.step_reference`` of ``C`` creatures' poses ``rotations (C, J, 4)``, ``translations (C, J, 3)``,
    planted in place: FK, :func:`advance`, :func:`rise`, :func:`reach`, the pelvis raised
    (``planting._ride_floor``), the feet's tilts (``FootPlanter._tilts``), then the IK
    (``_ik_kernel.solve_batch``).

    ``chain = (above, upper, middle, end, hinge, upper_offset, end_offset, path, reach)``: ``ik.LegChains`` and the
    tips' ancestors (``fk.path_to``: the joints FK places; ``gpos``, ``grot`` hold those alone);
    ``ik_params = (min_flex, converged, max drop)``; ``out = (gpos, grot, targets, wanted,
    root_drop, residual)``: FK, the planter's targets and orientations, the IK's root drop and misses.
    Returns whether every target is finite (if not, the IK is not run).
    """
    buf = np.empty(rotations.shape[0] * (24 * len(tips) + 1))
    return _step(parents, rotations, translations, generic, inside_in, turn_in, swing_in, examples_in, eased_in,
                 hold_in, use_phases, dt, start, times, cyclic, verb_floor, tips, root, legs, k_, floor, state, chain,
                 ik_params, out, buf)  # fmt: skip


@njit(cache=True, _nrt=False)
def _step(parents, rotations, translations, generic, inside_in, turn_in, swing_in, examples_in, eased_in, hold_in,
          use_phases, dt, start, times, cyclic, verb_floor, tips, root, legs, k_, floor, state, chain, ik_params, out,
          buf):  # fmt: skip
    """:func:`step` in its working array ``buf`` (not counted: see ``runtime._frame_kernel``)."""
    above, upper, middle, end, hinge, upper_offset, end_offset, path, reach_ = chain
    min_flex, converged, max_drop = ik_params
    gpos, grot, targets, wanted, root_drop, residual = out
    tip, drop = legs[3], state[15]
    n_c, n_l = rotations.shape[0], len(tips)
    forward_to(parents, path, rotations, translations, gpos, grot)  # the toes' ancestors: all it reads
    free_pos, at = carve(buf, 0, (n_c, n_l, 3))
    free_rot, at = carve(buf, at, (n_c, n_l, 3, 3))
    hips, at = carve(buf, at, (n_c, n_l, 3))
    tilts, at = carve(buf, at, (n_c, n_l, 3, 3))
    rises, at = carve(buf, at, (n_c,))
    for c in range(n_c):
        for i in range(n_l):
            for a in range(3):
                free_pos[c, i, a] = gpos[c, tips[i], a]
                hips[c, i, a] = gpos[c, upper[i], a]
            _quat_to_mat(grot[c, end[i]], free_rot[c, i])
    advance(free_pos, free_rot, generic, inside_in, turn_in, swing_in, examples_in, eased_in, hold_in, use_phases, dt,
            start, times, cyclic, verb_floor, legs, k_, floor, state, targets, wanted)  # fmt: skip
    rise(gpos[:, root], targets, verb_floor, floor, rises)
    reach(hips, rises, targets, wanted, dt, tip, legs[4], reach_, max_drop, k_, state)
    pelvis = above[len(above) - 1]
    parent = parents[pelvis]
    for c in range(n_c):
        ux, uy, uz = 0.0, 1.0, 0.0  # world up, in the pelvis's parent frame: quat.rotate(quat.inv(g), up)
        if parent >= 0:
            x, y, z, w = -grot[c, parent, 0], -grot[c, parent, 1], -grot[c, parent, 2], grot[c, parent, 3]
            tx, tz = 2.0 * -z, 2.0 * x
            ux, uy, uz = w * tx + y * tz, 1.0 + z * tx - x * tz, w * tz - y * tx
        translations[c, pelvis, 0] += rises[c] * ux
        translations[c, pelvis, 1] += rises[c] * uy
        translations[c, pelvis, 2] += rises[c] * uz
        root_drop[c] = drop[c]
        for i in range(n_l):
            _mmt(wanted[c, i], free_rot[c, i], tilts[c, i])
    for c in range(n_c):
        for i in range(n_l):
            for a in range(3):
                if not math.isfinite(targets[c, i, a]):
                    return False  # ik.solve refuses these
    solve_batch(rotations, translations, targets, tilts, above, upper, middle, end, hinge, upper_offset,
                end_offset, tip, reach_, min_flex, converged, max_drop, root_drop, residual)  # fmt: skip
    return True
