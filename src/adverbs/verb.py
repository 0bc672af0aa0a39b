"""A verb: example motions → interpolation tables → pose at any adverb point ``p`` and time (§3, §4).

Build: each example is encoded to DOF curves, warped to generic time by its keytimes, and fitted with
uniform cubic B-splines (NumCP control points per DOF, least squares). Every control point and every
keytime is then interpolated over adverb space by :class:`~adverbs.rbf.AdverbInterpolator` (eqs. 3, 4),
used through its cardinal weights ``w(p)``: ``b(p) = Σ_i w_i(p) b_i``.

Keytime policy: the paper interpolates keytimes directly (eq. 4), which can make them cross when
extrapolating. Here the *intervals* between keytimes are interpolated as logarithms,
``K_{m+1}(p) − K_m(p) = exp(Σ_i w_i(p) log(K_{i,m+1} − K_{i,m}))``, so keytimes are strictly increasing at
every ``p``, examples are still reproduced exactly, and durations extrapolate multiplicatively (a walk
25% faster than the fastest example gets shorter, never negative, steps).

Evaluate: ``K(p)``; ``t = GenericTime(T, K(p))``; only the four control points live at ``t`` are
interpolated. What depends on ``p`` alone (weights, keytimes) is cached for the last ``p`` seen.
"""

from __future__ import annotations

import io
import json
import os
import tempfile
import math
import zipfile
from bisect import bisect_right
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import bspline, timewarp
from .clip import Clip
from .constraints import Constraint, auto_constraints, check_constraint
from .encoding import DofEncoding
from .errors import AdverbsError
from .fk import forward_kinematics
from .ik import LegChains
from .rbf import AdverbInterpolator
from .skeleton import Skeleton

FORMAT = "adverbs-verb"  # version 2 added keytime names, constraints and the floor
MAX_FRAMES = 1_000_000  # per synthesize call: about an hour at 240 fps
_CHUNK = 2048  # queries per block in batched evaluation
SEAM_BLEND = 0.25  # fraction of a cycle over which the seam between cycles is blended
VERSION = 2


@dataclass(frozen=True)
class Adverb:
    """One axis of a verb's parameter space; ``measure`` says how it is read off a motion (or ``None``)."""

    name: str
    unit: str = ""
    measure: dict | None = None


@dataclass(eq=False)
class Example:
    """One example motion, cut and annotated: the input of :meth:`Verb.build`.

    ``keytimes (N,)`` are clock seconds from 0 to the clip's duration; ``point (A,)`` its adverb values.
    """

    name: str
    clip: Clip
    keytimes: np.ndarray
    point: np.ndarray
    source: str = ""
    part: str = ""
    refine: bool = False  # a local refinement: radial part only, not in the linear fit
    keytime_names: tuple[str, ...] = ()  # e.g. ("left strike", "right toe-off", ...)


@dataclass(frozen=True)
class ExampleRecord:
    """What a built verb keeps about each example (its motion lives in the coefficient table)."""

    name: str
    source: str
    part: str
    fit_error: float = field(default=0.0)  # largest joint-position error of the B-spline fit, metres
    refine: bool = False


class Verb:
    """A parameterized motion. Use :meth:`build` or :meth:`load`.

    Attributes
    ----------
    points : (E, A) adverb points of the examples
    keytimes_table : (E, N) keytimes of the examples, seconds
    coefficients : (E, NumCP, D) B-spline control points of every DOF of every example
    encoding : DofEncoding (the skeleton is ``encoding.skeleton``)
    """

    def __init__(
        self,
        name: str,
        encoding: DofEncoding,
        adverbs: Sequence[Adverb],
        examples: Sequence[ExampleRecord],
        points: np.ndarray,
        keytimes: np.ndarray,
        coefficients: np.ndarray,
        cyclic: bool,
        fps: float,
        keytime_names: Sequence[str] = (),
        constraints: Sequence[Constraint] = (),
        floor: float = 0.0,
    ):
        self.name = name
        self.encoding = encoding
        self.adverbs = tuple(adverbs)
        self.examples = tuple(examples)
        self.points = np.asarray(points, dtype=float)
        self.keytimes_table = timewarp.check_keytimes(keytimes, f"verb {name!r}")
        self.coefficients = np.asarray(coefficients, dtype=float)
        self.cyclic = bool(cyclic)
        self.fps = float(fps)
        n = self.keytimes_table.shape[1]
        self.keytime_names = tuple(keytime_names) or tuple(f"keytime {i}" for i in range(n))
        if len(self.keytime_names) != n:
            raise AdverbsError(f"verb {name!r}: {len(self.keytime_names)} keytime names for {n} keytimes")
        self.constraints = tuple(constraints)
        for c in self.constraints:
            check_constraint(c, encoding.skeleton, n, self.cyclic)
        self.floor = float(floor)
        e = len(self.examples)
        if self.points.shape != (e, len(self.adverbs)) or self.keytimes_table.shape[0] != e:
            raise AdverbsError(f"verb {name!r}: tables disagree on the number of examples or adverbs")
        if self.coefficients.shape[0] != e or self.coefficients.shape[2] != encoding.num_dofs:
            raise AdverbsError(f"verb {name!r}: coefficient table {self.coefficients.shape} does not fit")
        self.interpolator = AdverbInterpolator(
            self.points, [x.name for x in self.examples], linear=np.array([not x.refine for x in self.examples])
        )
        self._log_intervals = np.log(np.diff(self.keytimes_table, axis=1))  # (E, N-1)
        self._by_cp = np.ascontiguousarray(self.coefficients.transpose(1, 0, 2))  # (NumCP, E, D)
        self._by_cp_sixth = self._by_cp / 6.0  # the B-spline weights' common factor, folded in once
        self._cache_key = b""
        self._chains: LegChains | None = None
        self._cache_w = np.empty(0)
        self._cache_k: list[float] = []

    # ----- shape -------------------------------------------------------------------------------
    @property
    def skeleton(self) -> Skeleton:
        return self.encoding.skeleton

    @property
    def num_cp(self) -> int:
        return self.coefficients.shape[1]

    @property
    def num_keytimes(self) -> int:
        return self.keytimes_table.shape[1]

    def leg_chains(self) -> LegChains:
        """The two-bone chains of the constrained effectors, knee axes fitted to the examples (cached)."""
        if self._chains is None:
            if not self.constraints:
                raise AdverbsError(f"verb {self.name!r} has no constraints")
            e, n, d = self.coefficients.shape
            flat = self.coefficients.transpose(1, 0, 2).reshape(n, e * d)
            samples = bspline.evaluate(flat, np.linspace(0, 1, 24)).reshape(24, e, d)
            rotations, _ = self.encoding.decode(samples.transpose(1, 0, 2), self.fps)
            effectors = [c.effector for c in self.constraints]
            self._chains = LegChains.build(self.skeleton, effectors, rotations.reshape(-1, *rotations.shape[-2:]))
        return self._chains

    @property
    def adverb_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.adverbs)

    def point(self, values: dict[str, float] | Sequence[float] | np.ndarray) -> np.ndarray:
        """An adverb point ``(A,)`` from a mapping of adverb names (missing ones: the examples' mean) or a sequence."""
        if isinstance(values, dict):
            unknown = set(values) - set(self.adverb_names)
            if unknown:
                raise AdverbsError(
                    f"verb {self.name!r} has no adverb {sorted(unknown)[0]!r}; adverbs are {', '.join(self.adverb_names)}"
                )
            p = self.points.mean(axis=0)
            for k, v in values.items():
                p[self.adverb_names.index(k)] = v
        else:
            p = np.asarray(values, dtype=float)
        if p.shape[-1:] != (len(self.adverbs),):
            raise AdverbsError(f"verb {self.name!r} takes {len(self.adverbs)} adverbs, got {p.shape[-1:]}")
        if not np.all(np.isfinite(p)):
            bad = [self.adverb_names[i] for i in np.flatnonzero(~np.isfinite(p.reshape(-1, p.shape[-1])).any(0))]
            raise AdverbsError(f"adverb {bad[0]!r} must be a finite number")
        return p

    # ----- build -------------------------------------------------------------------------------
    @classmethod
    def build(
        cls,
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
        examples' contact keytimes (see :mod:`adverbs.constraints`); ``floor`` is the height of the
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
        return cls(
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

    # ----- evaluate ----------------------------------------------------------------------------
    def weights(self, p: np.ndarray) -> np.ndarray:
        """Cardinal weights ``(..., E)`` at adverb points ``(..., A)``."""
        return self.interpolator.weights(p)

    def keytimes(self, p: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
        """Keytimes ``(..., N)`` at ``p``: strictly increasing from 0 (see the module's keytime policy)."""
        w = self.weights(p) if weights is None else weights
        steps = np.exp(w @ self._log_intervals)
        return np.concatenate([np.zeros(steps.shape[:-1] + (1,)), np.cumsum(steps, axis=-1)], axis=-1)

    def control_points(self, p: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
        """All control points ``(..., NumCP, D)`` at ``p`` (eq. 3); ``weights`` if already known."""
        w = self.weights(p) if weights is None else weights
        return np.tensordot(w, self.coefficients, axes=(-1, 0))

    def dofs(self, p: np.ndarray, t: np.ndarray) -> np.ndarray:
        """DOFs ``(Q, D)`` at adverb points ``p (Q, A)`` and generic times ``t (Q,)``, batched.

        Only the four live control points of each query are interpolated; queries are grouped by
        B-spline segment so each group is one matrix product.
        """
        p = np.asarray(p, dtype=float)
        if p.shape[-1:] != (len(self.adverbs),):
            raise AdverbsError(f"verb {self.name!r} takes {len(self.adverbs)} adverbs, got points of shape {p.shape}")
        p = p.reshape(-1, len(self.adverbs))
        t = np.asarray(t, dtype=float).reshape(-1)
        if not np.all(np.isfinite(t)):
            raise AdverbsError("generic times must be finite numbers")
        if len(p) != len(t):
            raise AdverbsError(f"dofs: {len(p)} adverb points but {len(t)} times")
        out = np.empty((len(t), self.encoding.num_dofs))
        for a in range(0, len(t), _CHUNK):  # chunks that stay in cache
            out[a : a + _CHUNK] = self._dofs_chunk(p[a : a + _CHUNK], t[a : a + _CHUNK])
        return out

    def _dofs_chunk(self, p: np.ndarray, t: np.ndarray) -> np.ndarray:
        w = self.weights(p)
        idx, bw = bspline.basis(t, self.num_cp)
        first = idx[:, 0]
        order = np.argsort(first, kind="stable")
        first = first[order]
        e = len(self.examples)
        # Every query's 4 × E blend weights, in segment order so each segment is one contiguous block.
        mixed = (bw[order][:, :, None] * w[order][:, None, :]).reshape(len(order), 4 * e)
        out_sorted = np.empty((len(order), self.encoding.num_dofs))
        starts = np.flatnonzero(np.diff(first, prepend=-1))
        for a, b in zip(starts, [*starts[1:], len(order)]):
            s = first[a]
            np.matmul(mixed[a:b], self._by_cp[s : s + 4].reshape(4 * e, -1), out=out_sorted[a:b])
        out = np.empty_like(out_sorted)
        out[order] = out_sorted
        return out

    def dofs_reference(self, p: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The same as :meth:`dofs` the slow way: every control point by eq. 3, then the spline."""
        ip = self.interpolator
        coef = ip.fit(self.coefficients)
        out = []
        for pi, ti in zip(np.asarray(p, dtype=float).reshape(-1, len(self.adverbs)), np.asarray(t).reshape(-1)):
            out.append(bspline.evaluate(ip.evaluate(pi, coef), np.array(ti)))
        return np.stack(out)

    def _at(self, p: np.ndarray) -> tuple[np.ndarray, list[float]]:
        """Weights and keytimes (a list, for ``bisect``) at ``p``, cached for the last ``p`` seen."""
        p = np.asarray(p, dtype=float)
        key = p.tobytes()
        if key != self._cache_key:
            if p.shape != (len(self.adverbs),):
                raise AdverbsError(f"verb {self.name!r} takes {len(self.adverbs)} adverbs, got shape {p.shape}")
            w = self.interpolator.weights_one(p)
            steps = np.exp(w @ self._log_intervals)
            self._cache_w, self._cache_k = w, [0.0, *np.cumsum(steps).tolist()]
            self._cache_key = key
        return self._cache_w, self._cache_k

    def pose(self, p: np.ndarray, clock: float) -> np.ndarray:
        """DOFs ``(D,)`` at one adverb point and clock time ``T`` seconds into the verb.

        Cyclic verbs wrap ``T`` by the cycle's duration ``K_N(p)``; one-shot verbs hold their ends.
        The fast path: weights and keytimes cached for the last ``p``, the time warp and the four
        B-spline weights in plain floats, the four live control points sliced (not copied), two
        small matrix products.
        """
        w, k = self._at(p)
        n = len(k)
        end = k[-1]
        clock = float(clock)
        if not math.isfinite(clock):
            raise AdverbsError(f"clock time must be a finite number of seconds, got {clock}")
        clock = clock % end if self.cyclic else min(max(clock, 0.0), end)
        m = min(bisect_right(k, clock) - 1, n - 2)
        t = (m + (clock - k[m]) / (k[m + 1] - k[m])) / (n - 1)
        u = min(max(t, 0.0), 1.0) * (self.num_cp - 3)
        seg = min(int(u), self.num_cp - 4)
        x = u - seg
        x2, x3 = x * x, x * x * x
        y = 1.0 - x
        bw = np.array([y * y * y, 3.0 * x3 - 6.0 * x2 + 4.0, -3.0 * x3 + 3.0 * x2 + 3.0 * x + 1.0, x3])
        return bw @ np.matmul(w, self._by_cp_sixth[seg : seg + 4])

    def duration(self, p: np.ndarray) -> float:
        """Clock duration ``K_N(p)`` of one cycle (or of the whole motion) at ``p``."""
        return self._at(p)[1][-1]

    def synthesize(
        self,
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
        p = self.point(p)
        w = self.weights(p)
        return self.render(self.control_points(p, w), self.keytimes(p, w), duration, cycles, fps, start)

    def render(
        self,
        control_points: np.ndarray,
        keytimes: np.ndarray,
        duration: float | None = None,
        cycles: float | None = None,
        fps: float | None = None,
        start: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> tuple[Clip, np.ndarray]:
        """Motion from control points ``(NumCP, D)`` and keytimes ``(N,)`` (what :meth:`synthesize` does at ``p``)."""
        k = np.asarray(keytimes, dtype=float)
        fps = self.fps if fps is None else float(fps)
        if not (np.isfinite(fps) and fps > 0):
            raise AdverbsError(f"fps must be a positive number, got {fps}")
        if cycles is not None and not self.cyclic and float(cycles) != 1.0:
            raise AdverbsError(
                f"verb {self.name!r} is a one-shot motion: it plays once (give a duration instead of cycles)"
            )
        if duration is None:
            duration = k[-1] * (1.0 if cycles is None else float(cycles))
        if not (np.isfinite(duration) and duration > 0):
            raise AdverbsError(f"duration must be a positive number of seconds, got {duration}")
        frames = int(round(duration * fps)) + 1
        if not 2 <= frames <= MAX_FRAMES:
            raise AdverbsError(
                f"{duration:g} s at {fps:g} fps is {frames} frames; synthesize between 2 and {MAX_FRAMES:,} at a time"
            )
        clock = np.arange(frames) / fps
        if not self.cyclic:
            dofs = bspline.evaluate(control_points, timewarp.generic_time(np.minimum(clock, k[-1]), k))
        else:
            # Cycle index and time within it; a frame exactly at a cycle's end belongs to that cycle.
            cycle = np.maximum(np.ceil(clock / k[-1] - 1e-9) - 1, 0)
            local = clock - cycle * k[-1]
            dofs = bspline.evaluate(control_points, timewarp.generic_time(local, k))
            dofs += _seam_offsets(control_points, cycle, local, SEAM_BLEND * k[-1])
        return self.encoding.decode_clip(dofs, fps, start, name=self.name), k

    # ----- files -------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write the verb as one zip file: ``verb.json`` (metadata) and ``.npy`` arrays; no pickles.

        The file is written next to its destination and renamed into place, so a crash never
        leaves half a verb.
        """
        path = Path(path)
        enc, skel = self.encoding, self.skeleton
        meta = {
            "format": FORMAT,
            "version": VERSION,
            "name": self.name,
            "cyclic": self.cyclic,
            "fps": self.fps,
            "num_cp": self.num_cp,
            "keytime_names": list(self.keytime_names),
            "constraints": [c.to_dict() for c in self.constraints],
            "floor": self.floor,
            "adverbs": [{"name": a.name, "unit": a.unit, "measure": a.measure} for a in self.adverbs],
            "examples": [
                {"name": x.name, "source": x.source, "part": x.part, "fit_error": x.fit_error, "refine": x.refine}
                for x in self.examples
            ],
            "encoding": {
                "kind": enc.kind,
                "body_root": enc.body_root,
                "names": list(enc.names),
                "heading_smoothing": enc.smoothing,
            },
            "skeleton": {
                "names": list(skel.names),
                "channels": [list(c) for c in skel.channels],
                "unit_scale": skel.unit_scale,
                "units": skel.units,
            },
        }
        arrays = {
            "points": self.points,
            "keytimes": self.keytimes_table,
            "coefficients": self.coefficients,
            "parents": skel.parents,
            "offsets": skel.offsets,
            "end_site_parents": skel.end_site_parents,
            "end_site_offsets": skel.end_site_offsets,
            "lateral": enc.lateral,
            "reference": enc.reference,
            "base_translations": enc.base_translations,
            "translated": enc.translated,
        }
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f, zipfile.ZipFile(f, "w", zipfile.ZIP_DEFLATED) as z:
                z.writestr("verb.json", json.dumps(meta, indent=1))
                for key, value in arrays.items():
                    buf = io.BytesIO()
                    np.lib.format.write_array(buf, np.ascontiguousarray(value), allow_pickle=False)
                    z.writestr(f"{key}.npy", buf.getvalue())
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)

    @classmethod
    def load(cls, path: str | Path) -> Verb:
        """Read a verb written by :meth:`save`; other versions and damaged files raise AdverbsError."""
        path = Path(path)
        try:
            with zipfile.ZipFile(path) as z:
                meta = json.loads(z.read("verb.json"))
                if not isinstance(meta, dict) or meta.get("format") != FORMAT:
                    raise AdverbsError(f"{path}: not an adverbs verb file")
                if meta.get("version") != VERSION:
                    raise AdverbsError(
                        f"{path}: verb file version {meta.get('version')!r}; this adverbs reads version {VERSION}. "
                        "Rebuild it from its spec with `adverbs build`."
                    )
                arrays = {
                    n[:-4]: np.lib.format.read_array(io.BytesIO(z.read(n)), allow_pickle=False)
                    for n in z.namelist()
                    if n.endswith(".npy")
                }
        except FileNotFoundError:
            raise AdverbsError(f"{path}: no such verb file") from None
        except (zipfile.BadZipFile, KeyError, ValueError, EOFError, OSError) as e:
            if isinstance(e, AdverbsError):
                raise
            raise AdverbsError(f"{path}: damaged verb file ({e})") from None
        try:
            sk = meta["skeleton"]
            skel = Skeleton(
                tuple(sk["names"]),
                arrays["parents"],
                arrays["offsets"],
                tuple(tuple(c) for c in sk["channels"]),
                arrays["end_site_parents"],
                arrays["end_site_offsets"],
                float(sk["unit_scale"]),
                sk["units"],
            )
            e = meta["encoding"]
            enc = DofEncoding(
                e["kind"],
                skel,
                int(e["body_root"]),
                arrays["lateral"],
                arrays["reference"],
                arrays["base_translations"],
                arrays["translated"],
                tuple(e["names"]),
                float(e["heading_smoothing"]),
            )
            adverbs = [Adverb(a["name"], a.get("unit", ""), a.get("measure")) for a in meta["adverbs"]]
            examples = [
                ExampleRecord(x["name"], x["source"], x["part"], float(x["fit_error"]), bool(x.get("refine", False)))
                for x in meta["examples"]
            ]
            return cls(
                meta["name"],
                enc,
                adverbs,
                examples,
                arrays["points"],
                arrays["keytimes"],
                arrays["coefficients"],
                bool(meta["cyclic"]),
                float(meta["fps"]),
                tuple(meta["keytime_names"]),
                [Constraint(c["effector"], int(c["open"]), int(c["close"])) for c in meta["constraints"]],
                float(meta["floor"]),
            )
        except AdverbsError as e:
            raise AdverbsError(f"{path}: {e}") from None
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
            raise AdverbsError(f"{path}: damaged verb file (missing or malformed {e})") from None


def _seam_offsets(coef: np.ndarray, cycle: np.ndarray, local: np.ndarray, window: float) -> np.ndarray:
    """Offsets ``(F, D)`` that hide the seam where a cycle follows itself.

    A captured cycle ends a little away from where it began: the jump ``δ = d(1) − d(0)`` is added to
    each new cycle at its start and faded out over ``window`` seconds with a smoothstep, so values are
    continuous (offset blending, as game engines' inertial blends do). The first cycle is untouched.
    """
    v0, _, v1, _ = bspline.ends(coef)
    x = np.clip(local / window, 0.0, 1.0)
    fade = np.where(cycle > 0, 1.0 - x * x * (3.0 - 2.0 * x), 0.0)
    return fade[:, None] * (v1 - v0)[None, :]


def _body_error(enc: DofEncoding, clip: Clip, decoded: tuple[np.ndarray, np.ndarray]) -> float:
    """Largest distance between the clip's joints (from the body root down) and the decoded ones."""
    skel = clip.skeleton
    body = [j for j in range(skel.num_joints) if enc.body_root in skel.ancestors(j)]
    a = clip.global_positions()[:, body]
    b = forward_kinematics(skel.parents, *decoded)[0][:, body]
    return float(np.linalg.norm(a - b, axis=-1).max())
