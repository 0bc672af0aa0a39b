"""Building a verb: examples → DOF curves → keytime-warped least-squares B-splines → the verb's tables (§3.1, §3.2).

Each example is encoded to DOF curves (:class:`~adverbs.motion.encoding.DofEncoding`), warped to
generic time by its keytimes and fitted with uniform cubic B-splines (NumCP control points per DOF,
regularized least squares); the fit error is reported per example. :func:`build_from_spec` does the
whole path from a TOML spec.

Well-posed fits whatever the keytime spacing. With toe-offs as keytimes, an interval can be a frame
long or less (a toe-off on the frame of the other foot's strike). The paper spaces keytimes evenly in
generic time, which gives that half frame as many control points as a whole step: they are fitted to
one or two samples, the system's condition number reaches 1e17, and between frames the curves swing
(joint speeds of 60–280 m/s, measured). Two things keep the fit well posed:

* generic keytimes spaced as the examples' keytimes are on average (``keytime_spacing = "examples"``,
  the default; ``"even"`` is the paper's; see :func:`~adverbs.interp.timewarp.examples_spacing`), so
  each stretch of generic time holds about as many samples as any other, and control points are
  spent evenly over the motion;
* a small penalty on the control points' second differences (:func:`~adverbs.interp.bspline.fit`),
  which leaves straight lines alone and pins control points that no sample reaches;
* the curves follow the example between its frames too: they are fitted to its frames joined by slerp,
  ``FINE`` samples per frame. An example whose keytime interval is one frame long, where the others'
  are several, has that frame stretched over a long stretch of generic time; fitted to the two frames
  alone, a curve that must slow down there overshoots between them (a toe 19 cm off the example's
  path for 1/30 s on CMU's jogs, measured); fitted to the path between them it follows it.

The fit error is measured at the frames and, for the pose, on a grid four times finer (against the
example's frames joined by slerp); a fit whose curves move a joint much faster between frames than
the example ever does raises an :class:`~adverbs.errors.AdverbsWarning` naming the example.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import AdverbsError, AdverbsWarning
from ..interp import bspline, timewarp
from ..kinematics.fk import forward_kinematics
from ..motion.clip import Clip
from ..motion.encoding import DofEncoding
from ._sampling_kernel import VELOCITIES
from .constraints import Constraint, auto_constraints, check_constraint, derive_holds
from .examples import examples_from_spec
from .spec import SpecError, load_spec
from .tables import Adverb, Example, ExampleRecord, Verb

FIT_SMOOTHING = 1e-4  # second-difference penalty of the B-spline fit (see bspline.fit)
FINE = 4  # the fit error is measured at this many times the examples' frame rate
SPEED_WARNING = 2.0  # warn when a fit moves a joint this many times faster than its example ever does (see build_verb)
KEYTIME_SPACINGS = ("examples", "even")


def build_verb(
    name: str,
    examples: Sequence[Example],
    adverbs: Sequence[Adverb],
    num_cp: int = 12,
    encoding: str = "logquat",
    cyclic: bool = True,
    constraints: Sequence[Constraint] | str = "auto",
    floor: float = 0.0,
    keytime_spacing: str = "examples",
    smoothing: float | str = 0.0,
    shrinkage: float | str = 0.0,
    goal_chain: Sequence[str] = (),
    timing: str = "extrapolate",
    anchored: bool = False,
) -> Verb:
    """Fit B-splines to every example in generic time and set up the interpolation (§3.1, §4).

    ``constraints`` are the verb's kinematic constraints, or ``"auto"`` to find them from the
    examples' contact keytimes (see :mod:`adverbs.verb.constraints`); ``floor`` is the height of the
    ground the examples walk on; ``keytime_spacing`` places the keytimes in generic time (``"examples"``:
    spaced as the examples' keytimes are on average; ``"even"``: evenly, as in the paper);
    ``smoothing`` and ``shrinkage`` make the interpolation approximate (a number ≥ 0 or ``"auto"``;
    see :class:`~adverbs.interp.rbf.AdverbInterpolator`; 0, exact, is the default); ``goal_chain`` names
    the joints that put the joint of ``joint_position`` adverbs on its goal (see :mod:`adverbs.verb.goal`);
    ``timing`` says whether keytime intervals extrapolate past the examples or stay within theirs
    (``"extrapolate"``, the paper's, or ``"clamp"``; see :class:`~adverbs.verb.tables.Verb`); ``anchored``: the
    verb stands on its feet throughout, its root where they stand (``in_place = "feet"``; see
    :mod:`adverbs.motion.encoding`).
    """
    if len(examples) < 1:
        raise AdverbsError(f"verb {name!r}: needs at least one example")
    if len(examples) > 1 and not adverbs:
        raise AdverbsError(f"verb {name!r}: {len(examples)} examples need at least one adverb to tell them apart")
    bspline.check_num_cp(num_cp)
    first = examples[0]
    for ex in examples[1:]:
        why = first.clip.skeleton.structure_difference(ex.clip.skeleton)
        if why is not None:
            raise AdverbsError(f"example {ex.name!r} is on a different skeleton from example {first.name!r}: {why}")
        if len(ex.keytimes) != len(first.keytimes):
            raise AdverbsError(
                f"example {ex.name!r} has {len(ex.keytimes)} keytimes, example {first.name!r} has "
                f"{len(first.keytimes)}: every example of a verb needs the same structure"
            )
    if keytime_spacing not in KEYTIME_SPACINGS:
        raise AdverbsError(f"keytime_spacing must be one of {', '.join(KEYTIME_SPACINGS)}, got {keytime_spacing!r}")
    for ex in examples:
        k = timewarp.check_keytimes(ex.keytimes, f"example {ex.name!r}")
        if k[0] != 0.0 or abs(k[-1] - ex.clip.duration) > 0.5 / ex.clip.fps:
            raise AdverbsError(
                f"example {ex.name!r}: keytimes must run from 0 to the clip's duration {ex.clip.duration:.4f} s, "
                f"got {k[0]:.4f} to {k[-1]:.4f}"
            )
        if ex.clip.num_frames < num_cp:
            shortest = min(examples, key=lambda x: x.clip.num_frames)
            raise AdverbsError(
                f"example {ex.name!r} has {ex.clip.num_frames} frames ({ex.clip.duration:.3f} s), too few to fit "
                f"num_cp = {num_cp} control points: lower num_cp to at most {shortest.clip.num_frames} "
                f"(the shortest example, {shortest.name!r}, has {shortest.clip.num_frames} frames)"
            )
    keytimes = np.stack([np.asarray(ex.keytimes, dtype=float) for ex in examples])
    keytimes[:, -1] = [ex.clip.duration for ex in examples]
    if keytime_spacing == "examples":
        spacing = timewarp.examples_spacing(keytimes)
    else:
        spacing = timewarp.even_spacing(keytimes.shape[1])
    enc = DofEncoding.fit([ex.clip for ex in examples], encoding, anchored=anchored)
    coefficients = np.empty((len(examples), num_cp, enc.num_dofs))
    records = []
    for i, ex in enumerate(examples):
        coefficients[i], err, fine_err, speed = _fit_example(enc, ex.clip, keytimes[i], spacing, num_cp)
        if speed > SPEED_WARNING:
            warnings.warn(
                f"example {ex.name!r}: its fitted curves move a joint {speed:.1f}x faster between frames than the "
                f"example ever does (pose error {fine_err * 1000:.0f} mm on a {FINE}x finer grid): the fit cannot "
                "be trusted; lower num_cp or check the example's keytimes",
                AdverbsWarning,
                stacklevel=2,
            )
        records.append(ExampleRecord(ex.name, ex.source, ex.part, err, ex.refine, fine_err))
    points = np.stack([np.asarray(ex.point, dtype=float) for ex in examples])
    names = first.keytime_names
    event_names = names or [f"keytime {i}" for i in range(len(first.keytimes))]
    if isinstance(constraints, str):
        if constraints != "auto":
            raise AdverbsError(f"constraints must be a list or 'auto', got {constraints!r}")
        constraints = auto_constraints(event_names, [ex.clip for ex in examples], cyclic)
        auto = True
    else:
        auto = False
        for c in constraints:
            check_constraint(c, first.clip.skeleton, keytimes.shape[1], cyclic)
    holds, hold_table, hold_warnings = derive_holds(
        constraints, [ex.clip for ex in examples], keytimes, spacing, event_names, cyclic, floor, auto,
        [ex.name for ex in examples],
    )  # fmt: skip
    for w in hold_warnings:
        warnings.warn(f"verb {name!r}: {w}", AdverbsWarning, stacklevel=2)
    return Verb(
        name,
        enc,
        adverbs,
        records,
        points,
        keytimes,
        coefficients,
        cyclic,
        first.clip.fps,
        names,
        constraints,
        floor,
        spacing,
        smoothing,
        shrinkage,
        holds,
        hold_table,
        tuple(goal_chain),
        timing,
    )


def _joined(clip: Clip) -> Clip:
    """``clip``'s frames joined by slerp, ``FINE`` samples per frame: what the fit follows and is checked against."""
    return clip.at(np.arange((clip.num_frames - 1) * FINE + 1) / FINE, clip.fps * FINE)


def _fit_example(
    enc: DofEncoding, clip: Clip, keytimes: np.ndarray, spacing: np.ndarray, num_cp: int
) -> tuple[np.ndarray, float, float, float]:
    """An example's control points ``(num_cp, D)``, fitted to :func:`_samples`, and how well they fit it
    (:func:`_fine_fit_check`): the clip and its frames joined are encoded once for both."""
    framed, joined = enc.encode(clip), enc.encode(_joined(clip))
    t, samples = _samples(clip, framed, joined, keytimes, spacing)
    coefficients, _ = bspline.fit(t, samples, num_cp, FIT_SMOOTHING)
    return coefficients, *_fine_fit_check(enc, clip, coefficients, t, samples, framed)


def _samples(
    clip: Clip, framed: np.ndarray, joined: np.ndarray, keytimes: np.ndarray, spacing: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """What an example's curves are fitted to: generic times ``(S,)`` and DOFs ``(S, D)`` of its frames joined,
    ``FINE`` samples per frame, from the DOFs of ``clip`` (``framed (F, D)``) and of :func:`_joined` (``joined``).

    The pose columns are the frames joined by slerp. The root's velocities are the frames' own (each
    frame's step to the next, which playing at the example's rate integrates back to its path exactly)
    joined linearly: the joined clip's would be each step's velocity held over its frame, whose fit is
    half a frame late at every frame.
    """
    values = joined.copy()
    at = np.arange(len(joined)) / FINE  # frame positions
    for c in range(VELOCITIES):
        values[:, c] = np.interp(at, np.arange(clip.num_frames), framed[:, c])
    return timewarp.generic_time(at / clip.fps, keytimes, spacing), values


def _fine_fit_check(
    enc: DofEncoding, clip: Clip, coefficients: np.ndarray, t: np.ndarray, samples: np.ndarray, framed: np.ndarray
) -> tuple[float, float, float]:
    """How well the curves fit ``clip``: at its frames, and on a grid ``FINE`` times finer (the generic times ``t``
    and DOFs ``samples`` of :func:`_samples`; ``framed``: the clip's own DOFs).

    Returns the largest distance (metres) of the fitted joints (from the body root down) from the
    clip's at its frames; the largest distance on the fine grid between the fitted pose and the
    clip's frames joined by slerp, both in the character's own frame (a root integrated at another
    rate is shifted by half a frame along its path, which is not an error of the fit); and the ratio
    of the fitted pose's largest joint speed there to the clip's own (frame differences at its rate).
    """
    skel = clip.skeleton
    body = np.flatnonzero(skel.below(enc.body_root)).tolist()
    at = t[::FINE]  # the frames' own generic times
    decoded = enc.decode(bspline.evaluate(coefficients, at), clip.fps, enc.start(clip))
    at_frames = np.linalg.norm(forward_kinematics(skel.parents, *decoded)[0][:, body] - clip.global_positions()[:, body], axis=-1)

    def own_frame(dofs: np.ndarray, fps: float) -> np.ndarray:
        dofs = dofs.copy()
        dofs[:, :VELOCITIES] = 0.0  # no travel, no turning: the pose in the character's own frame
        return forward_kinematics(skel.parents, *enc.decode(dofs, fps))[0][:, body]

    fine_fps = clip.fps * FINE
    fitted = own_frame(bspline.evaluate(coefficients, t), fine_fps)
    error = np.linalg.norm(own_frame(samples, fine_fps) - fitted, axis=-1).max()
    own = own_frame(framed, clip.fps)
    speed = np.linalg.norm(np.diff(fitted, axis=0), axis=-1).max() * fine_fps
    speed_own = np.linalg.norm(np.diff(own, axis=0), axis=-1).max() * clip.fps
    return float(at_frames.max()), float(error), float(speed / speed_own)


def build_from_spec(path: str | Path) -> Verb:
    """Parse a spec, read and cut its examples, and build the verb."""
    return build_with_examples(path)[0]


def verb_from(path: str | Path) -> Verb:
    """A verb from a spec (``.toml``, built now) or a built verb file (anything else)."""
    from .store import load_verb

    return build_from_spec(path) if Path(path).suffix.lower() == ".toml" else load_verb(path)


def build_with_examples(path: str | Path) -> tuple[Verb, list[Example]]:
    """:func:`build_from_spec`, also returning the examples the verb was built from (cut, measured)."""
    spec = load_spec(path)
    examples, adverbs = examples_from_spec(spec)
    return build_from_examples(spec, examples, adverbs), examples


def build_from_examples(spec: dict, examples: Sequence[Example], adverbs: Sequence[Adverb]) -> Verb:
    """The verb of a parsed ``spec`` (:func:`~adverbs.verb.spec.load_spec`) from its examples and adverbs, already
    read and cut (:func:`~adverbs.verb.examples.examples_from_spec`): :func:`build_verb` with every option of the
    spec, its errors raised as :class:`SpecError` naming the spec's field."""
    constraints = spec["constraints"]
    if constraints != "auto":
        constraints = [Constraint(str(c["effector"]), c["open"], c["close"]) for c in constraints]
    try:
        verb = build_verb(
            spec["name"],
            examples,
            adverbs,
            spec["num_cp"],
            spec["encoding"],
            spec["cyclic"],
            constraints,
            spec["floor"],
            spec["keytime_spacing"],
            spec["smoothing"],
            spec["shrinkage"],
            spec["goal_chain"],
            spec["timing"],
            spec.get("in_place") == "feet",
        )
    except SpecError:
        raise
    except AdverbsError as e:
        text = str(e)
        example = next((ex.name for ex in examples if f"{ex.name!r}" in text), None)
        field = "adverbs" if "adverb point" in text or "non-finite" in text else None
        if text.startswith("constraint on") or "no joint named" in text:
            field = "constraints"
        elif "num_cp" in text:
            field = "num_cp"
        elif text.startswith(f"verb {spec['name']!r}: goal:"):
            field = "goal.chain"
        elif "shrinkage" in text:
            field = "shrinkage"
        elif "smoothing" in text:
            field = "smoothing"
        raise SpecError(spec["path"], text, example, field) from None
    return verb
