"""Building a verb: examples → DOF curves → keytime-warped least-squares B-splines → the verb's tables (§3.1, §3.2).

Each example is encoded to DOF curves (:class:`~adverbs.motion.encoding.DofEncoding`), warped to
generic time by its keytimes and fitted with uniform cubic B-splines (NumCP control points per DOF,
least squares); the fit error is reported per example. :func:`build_from_spec` does the whole path
from a TOML spec.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import AdverbsError
from ..interp import bspline, timewarp
from ..kinematics.fk import forward_kinematics
from ..motion.clip import Clip
from ..motion.encoding import DofEncoding
from .constraints import Constraint, auto_constraints
from .examples import examples_from_spec
from .spec import SpecError, load_spec
from .tables import Adverb, Example, ExampleRecord, Verb


def build_verb(
    name: str,
    examples: Sequence[Example],
    adverbs: Sequence[Adverb],
    num_cp: int = 12,
    encoding: str = "logquat",
    cyclic: bool = True,
    constraints: Sequence[Constraint] | str = "auto",
    floor: float = 0.0,
) -> Verb:
    """Fit B-splines to every example in generic time and set up the interpolation (§3.1, §4).

    ``constraints`` are the verb's kinematic constraints, or ``"auto"`` to find them from the
    examples' contact keytimes (see :mod:`adverbs.verb.constraints`); ``floor`` is the height of the
    ground the examples walk on.
    """
    if len(examples) < 2:
        raise AdverbsError(f"verb {name!r}: needs at least two examples, got {len(examples)}")
    bspline.check_num_cp(num_cp)
    first = examples[0]
    for ex in examples[1:]:
        if not ex.clip.skeleton.same_structure(first.clip.skeleton):
            raise AdverbsError(f"example {ex.name!r} is on a different skeleton from example {first.name!r}")
        if len(ex.keytimes) != len(first.keytimes):
            raise AdverbsError(
                f"example {ex.name!r} has {len(ex.keytimes)} keytimes, example {first.name!r} has "
                f"{len(first.keytimes)}: every example of a verb needs the same structure"
            )
    enc = DofEncoding.fit([ex.clip for ex in examples], encoding)
    coefficients = np.empty((len(examples), num_cp, enc.num_dofs))
    records = []
    for i, ex in enumerate(examples):
        k = timewarp.check_keytimes(ex.keytimes, f"example {ex.name!r}")
        if k[0] != 0.0 or abs(k[-1] - ex.clip.duration) > 0.5 / ex.clip.fps:
            raise AdverbsError(
                f"example {ex.name!r}: keytimes must run from 0 to the clip's duration {ex.clip.duration:.4f} s, "
                f"got {k[0]:.4f} to {k[-1]:.4f}"
            )
        dofs = enc.encode(ex.clip)
        t = timewarp.generic_time(np.arange(ex.clip.num_frames) / ex.clip.fps, k)
        coefficients[i], _ = bspline.fit(t, dofs, num_cp)
        fitted = enc.decode(bspline.evaluate(coefficients[i], t), ex.clip.fps, enc.start(ex.clip))
        err = _body_error(enc, ex.clip, fitted)
        records.append(ExampleRecord(ex.name, ex.source, ex.part, err, ex.refine))
    keytimes = np.stack([np.asarray(ex.keytimes, dtype=float) for ex in examples])
    keytimes[:, -1] = [ex.clip.duration for ex in examples]
    points = np.stack([np.asarray(ex.point, dtype=float) for ex in examples])
    names = first.keytime_names
    if isinstance(constraints, str):
        if constraints != "auto":
            raise AdverbsError(f"constraints must be a list or 'auto', got {constraints!r}")
        constraints = auto_constraints(
            names or [f"keytime {i}" for i in range(len(first.keytimes))], [ex.clip for ex in examples], cyclic
        )
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
    )


def _body_error(enc: DofEncoding, clip: Clip, decoded: tuple[np.ndarray, np.ndarray]) -> float:
    """Largest distance between the clip's joints (from the body root down) and the decoded ones."""
    skel = clip.skeleton
    body = [j for j in range(skel.num_joints) if enc.body_root in skel.ancestors(j)]
    a = clip.global_positions()[:, body]
    b = forward_kinematics(skel.parents, *decoded)[0][:, body]
    return float(np.linalg.norm(a - b, axis=-1).max())


def build_from_spec(path: str | Path) -> Verb:
    """Parse a spec, read and cut its examples, and build the verb."""
    spec = load_spec(path)
    examples, adverbs = examples_from_spec(spec)
    constraints = spec["constraints"]
    if constraints != "auto":
        constraints = [Constraint(str(c["effector"]), c["open"], c["close"]) for c in constraints]
    try:
        return build_verb(
            spec["name"],
            examples,
            adverbs,
            spec["num_cp"],
            spec["encoding"],
            spec["cyclic"],
            constraints,
            spec["floor"],
        )
    except SpecError:
        raise
    except AdverbsError as e:
        text = str(e)
        example = next((ex.name for ex in examples if f"{ex.name!r}" in text), None)
        field = "adverbs" if "adverb point" in text or "non-finite" in text else None
        if text.startswith("constraint on") or "no joint named" in text:
            field = "constraints"
        raise SpecError(spec["path"], text, example, field) from None
