"""How good is a verb: leave-one-out against other interpolators, and whether adverbs are obeyed.

Leave-one-out: each example in turn is left out, the rest predict its B-spline control points and
keytimes at its adverb point, and the prediction is compared with it:

* pose error — mean distance of the joints (body root down, in the character's heading frame so the
  trajectory does not count twice) over 60 samples of generic time, millimetres;
* adverb error — the predicted motion synthesized and measured like the examples, the error as a
  percentage of the examples' range, averaged over the measured adverbs;
* goal error — for verbs whose adverbs are a joint's position (reach), the distance from that joint
  at its keytime to the goal, millimetres.

Methods: ``nearest`` example; ``linear`` (the least-squares hyperplane alone); ``idw`` (inverse
distance weighting, power 2); ``scipy-rbf`` (``scipy.interpolate.RBFInterpolator``, thin-plate spline,
degree 1); ``ours`` (linear + cubic B-spline radial bases, eqs. 3–4, with the verb's own smoothing
rule: exact by default); ``ours-auto`` (the same, its smoothing and slope shrinkage chosen by
leave-one-out among the examples it is given, see :mod:`adverbs.interp.rbf`). All work in the same
scaled adverb coordinates and interpolate log keytime intervals.

Held-out takes (:func:`held_out`): for each class of Bandai Namco dataset-2 takes (straight walk, walk
turning left, turning right, run, reach), the odd takes build the verb and the even takes are
predicted at their measured adverb points; the same pose and adverb errors, medians over the test takes.
The other way round (even takes build) and leave-one-take-out are there to show how much the split matters.

Planted feet: at the same points, two cycles synthesized with and without the constraints enforced;
the drift of each contact phase (see :func:`adverbs.feet.measures.planted_drift`).

Obedience: our verb synthesized at every example, halfway between each example and its nearest
neighbour, and 25% past each example (``c + 1.25 (p_i − c)``, ``c`` the examples' centre), each
measured; the largest error per adverb as a percentage of the examples' range.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import RBFInterpolator

from ..errors import AdverbsError
from ..interp import bspline
from ..interp.rbf import AdverbInterpolator
from ..kinematics.fk import forward_kinematics
from ..verb.fit import build_from_spec
from ..verb.measures import measure_all
from ..feet.measures import foot_drift, measure_feet
from ..feet.offline import plant_feet
from ..verb.tables import Verb

METHODS = ("nearest", "linear", "idw", "scipy-rbf", "ours", "ours-auto")
SAMPLES = 60


@dataclass
class Evaluation:
    """Results: per method, per example arrays; obedience per adverb and kind of point."""

    verb: str
    examples: list[str]
    pose_mm: dict[str, np.ndarray]
    adverb_pct: dict[str, np.ndarray]
    goal_mm: dict[str, np.ndarray] | None
    measured: list[str]
    obedience: dict[str, np.ndarray]  # "at examples" / "between" / "25% past" → (M,) max % of range
    drift: dict[str, dict[str, np.ndarray]] | None = None  # kind of point → {"ik", "no ik"} → drifts (m)

    def table(self) -> str:
        """Markdown tables of the leave-one-out means and of obedience."""
        head = "| method | pose error (mm) | adverb error (% of range) |" + (
            " goal error (mm) |" if self.goal_mm else ""
        )
        sep = "| --- | --- | --- |" + (" --- |" if self.goal_mm else "")
        rows = [f"Leave-one-out over {len(self.examples)} examples of {self.verb} (means):", "", head, sep]
        for m in METHODS:
            row = f"| {m} | {_mean(self.pose_mm[m], 1)} | {_mean(self.adverb_pct[m], 2)} |"
            if self.goal_mm:
                row += f" {_mean(self.goal_mm[m], 1)} |"
            rows.append(row)
        rows += ["", f"Adverbs obeyed by {self.verb} (largest error, % of the examples' range):", ""]
        rows.append("| adverb | " + " | ".join(self.obedience) + " |")
        rows.append("| --- |" + " --- |" * len(self.obedience))
        for i, name in enumerate(self.measured):
            rows.append(f"| {name} | " + " | ".join(f"{v[i]:.2f}" for v in self.obedience.values()) + " |")
        if self.drift:
            rows += ["", f"Planted feet of {self.verb}: drift per contact phase (mm), median / max:", ""]
            rows += ["| points | with IK | without IK |", "| --- | --- | --- |"]
            for kind, d in self.drift.items():
                ik, raw = 1000 * d["ik"], 1000 * d["no ik"]
                rows.append(
                    f"| {kind} | {np.median(ik):.2f} / {ik.max():.2f} | {np.median(raw):.1f} / {raw.max():.1f} |"
                )
        return "\n".join(rows)

    def to_dict(self) -> dict:
        out = {
            "verb": self.verb,
            "examples": self.examples,
            "pose_mm": {m: v.tolist() for m, v in self.pose_mm.items()},
            "adverb_pct": {m: v.tolist() for m, v in self.adverb_pct.items()},
            "measured": self.measured,
            "obedience_pct": {k: v.tolist() for k, v in self.obedience.items()},
        }
        if self.drift:
            out["drift_mm"] = {k: {m: (1000 * v).tolist() for m, v in d.items()} for k, d in self.drift.items()}
        if self.goal_mm:
            out["goal_mm"] = {m: v.tolist() for m, v in self.goal_mm.items()}
        return out

    def plot(self, path: str) -> None:
        """A PNG: per-example pose error of each method (bars), and the mean adverb error."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from .figures import save_figure

        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 4.5), gridspec_kw={"width_ratios": [3, 1]})
        x = np.arange(len(self.examples))
        width = 0.8 / len(METHODS)
        for k, m in enumerate(METHODS):
            ax1.bar(x + (k - len(METHODS) / 2 + 0.5) * width, self.pose_mm[m], width, label=m)
        ax1.set_xticks(x, self.examples, rotation=60, ha="right", fontsize=7)
        ax1.set_ylabel("mean joint-position error (mm)")
        ax1.set_title(f"{self.verb}: leave-one-out")
        ax1.legend(fontsize=8)
        ax2.bar(METHODS, [np.nan_to_num(np.nanmean(self.adverb_pct[m])) for m in METHODS], color="C1")
        ax2.set_ylabel("adverb error (% of range)")
        ax2.tick_params(axis="x", rotation=45)
        save_figure(fig, Path(path), plt)


def _mean(values: np.ndarray, digits: int) -> str:
    """The mean as text, or "n/a" where a method could not predict (too few examples left)."""
    values = np.asarray(values, dtype=float)
    return "n/a" if np.all(np.isnan(values)) else f"{np.nanmean(values):.{digits}f}"


def _measured(verb: Verb) -> list[int]:
    return [i for i, a in enumerate(verb.adverbs) if a.measure is not None]


def measure_motion(verb: Verb, control_points: np.ndarray, keytimes: np.ndarray) -> np.ndarray:
    """Measured adverb values ``(M,)`` of one cycle rendered from control points and keytimes."""
    one = verb.playing(control_points, keytimes)
    return measure_point(one, one.points[0])


def measure_point(verb: Verb, p: np.ndarray) -> np.ndarray:
    """Measured adverb values ``(M,)`` of one cycle of the verb itself at ``p`` (its goal correction included)."""
    clip, k = verb.synthesize(p, fps=max(verb.fps, 60.0))
    return measure_all(clip, k, [verb.adverbs[i].measure for i in _measured(verb)])


def _pose_positions(verb: Verb, control_points: np.ndarray) -> np.ndarray:
    """Joint positions ``(S, J', 3)`` in the heading frame at evenly spaced generic times."""
    enc = verb.encoding
    dofs = bspline.evaluate(control_points, np.linspace(0.0, 1.0, SAMPLES))
    dofs[:, :3] = 0.0  # no travel, no turning: every frame in the character's own frame
    gpos = forward_kinematics(enc.skeleton.parents, *enc.decode(dofs, verb.fps))[0]
    body = np.flatnonzero(enc.skeleton.below(enc.body_root)).tolist()
    return gpos[:, body]


def predict(
    method: str, verb: Verb, target: np.ndarray, keep: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray] | None:
    """Control points ``(NumCP, D)`` and keytimes ``(N,)`` at ``target`` by ``method`` from the examples ``keep``.

    ``keep`` defaults to every example; None is returned where the method cannot predict from so few.
    """
    if method not in METHODS:
        raise AdverbsError(f"unknown method {method!r}; methods are {', '.join(METHODS)}")
    keep = np.arange(len(verb.examples)) if keep is None else np.asarray(keep)
    pts = verb.points[keep]
    logk = np.log(np.diff(verb.keytimes_table[keep], axis=1))
    coef = verb.coefficients[keep]
    values = np.concatenate([coef.reshape(len(keep), -1), logk], axis=1)
    scale = np.where(np.ptp(pts, axis=0) > 0, np.ptp(pts, axis=0), 1.0)
    q, qt = pts / scale, target / scale
    if method == "nearest":
        pred = values[np.argmin(np.linalg.norm(q - qt, axis=1))]
    elif method == "idw":
        w = 1.0 / np.maximum(np.linalg.norm(q - qt, axis=1), 1e-12) ** 2
        pred = w @ values / w.sum()
    elif method == "scipy-rbf":
        if len(q) < q.shape[1] + 1:  # a degree-1 polynomial needs A + 1 points
            return None
        pred = RBFInterpolator(q, values, kernel="thin_plate_spline", degree=1)(qt[None])[0]
    else:
        linear = np.array([not verb.examples[j].refine for j in keep])
        if len(keep) < 2 or not linear.any():  # nothing left to interpolate between
            return None
        if method == "linear":
            pred = AdverbInterpolator(pts, linear=linear).linear_weights(target) @ values
        else:
            own = verb.interpolator
            rules = ("auto", "auto") if method == "ours-auto" else (own.smoothing_rule, own.shrinkage_rule)
            interp = AdverbInterpolator(pts, linear=linear, smoothing=rules[0], shrinkage=rules[1], values=values)
            pred = interp.weights(target) @ values
    n = coef.shape[1] * coef.shape[2]
    cp = pred[:n].reshape(coef.shape[1:])
    k = np.concatenate([[0.0], np.cumsum(np.exp(pred[n:]))])
    return cp, k


def evaluate(verb: Verb, progress: Callable[[float, float], None] | None = None) -> Evaluation:
    """Leave-one-out comparison and obedience for ``verb`` (see the module docstring); ``progress(done, total)`` is
    called as each example is predicted."""
    e = len(verb.examples)
    if e < 2 or not verb.adverbs:
        raise AdverbsError(
            f"verb {verb.name!r} has {e} example(s) and {len(verb.adverbs)} adverb(s): leaving one example out "
            "to predict it from the others needs at least two examples over at least one adverb"
        )
    measured = _measured(verb)
    goal_axes = [i for i in measured if verb.adverbs[i].measure["kind"] == "joint_position"]
    pose = {m: np.zeros(e) for m in METHODS}
    adverb = {m: np.zeros(e) for m in METHODS}
    goal = {m: np.zeros(e) for m in METHODS} if goal_axes else None
    for i in range(e):
        errors = predicted_errors(verb, METHODS, i, np.array([j for j in range(e) if j != i]), _ranges(verb.points))
        for m, (pose[m][i], adverb[m][i], g) in errors.items():
            if goal is not None:
                goal[m][i] = g
        if progress is not None:
            progress(i + 1, e + 1)
    result = Evaluation(
        verb.name,
        [x.name for x in verb.examples],
        pose,
        adverb,
        goal,
        [verb.adverbs[i].name for i in measured],
        obedience(verb) if measured else {},
        drift(verb) if verb.constraints else None,
    )
    if progress is not None:
        progress(e + 1, e + 1)
    return result


def _ranges(points: np.ndarray) -> np.ndarray:
    """Each adverb's range over ``points (E, A)``, 1 where it is 0."""
    ranges = np.ptp(points, axis=0)
    return np.where(ranges > 0, ranges, 1.0)


def predicted_errors(
    verb: Verb, methods: tuple[str, ...], i: int, keep: np.ndarray, ranges: np.ndarray
) -> dict[str, tuple[float, float, float]]:
    """Example ``i`` predicted by each method from the examples ``keep``: pose, adverb and goal errors.

    Pose error in mm, adverb error in % of ``ranges (A,)`` (mean over the measured adverbs), goal error
    in mm (NaN without joint-position adverbs); all NaN where a method cannot predict from so few.
    """
    measured = _measured(verb)
    goal_axes = [measured.index(a) for a in measured if verb.adverbs[a].measure["kind"] == "joint_position"]
    truth = _pose_positions(verb, verb.coefficients[i])
    out = {}
    for m in methods:
        predicted = predict(m, verb, verb.points[i], keep)
        if predicted is None:
            out[m] = (np.nan, np.nan, np.nan)
            continue
        cp, k = predicted
        pose = 1000.0 * np.mean(np.linalg.norm(_pose_positions(verb, cp) - truth, axis=-1))
        adverb = goal = np.nan
        if measured:
            got = measure_motion(verb, cp, k)
            adverb = 100.0 * np.mean(np.abs(got - verb.points[i, measured]) / ranges[measured])
            if goal_axes:
                goal = 1000.0 * np.linalg.norm(got[goal_axes] - verb.points[i, measured][goal_axes])
        out[m] = (pose, adverb, goal)
    return out


def drift(verb: Verb, cycles: int = 2) -> dict[str, dict[str, np.ndarray]]:
    """Planted-foot drift with and without IK at the obedience points (all phases of each, metres)."""
    out = {}
    for kind, pts in obedience_points(verb).items():
        ik, raw = [], []
        for p in pts:
            clip, k = verb.synthesize(p, cycles=cycles if verb.cyclic else None)
            raw.append(foot_drift(verb, clip, k, verb.weights(p)))
            planted, report = plant_feet(verb, clip, k, None, p)
            ik.append(measure_feet(verb, planted, report).toe_drift)
        out[kind] = {"ik": np.concatenate(ik), "no ik": np.concatenate(raw)}
    return out


def obedience_points(verb: Verb) -> dict[str, np.ndarray]:
    """The points where obedience is checked: at, between (nearest pairs) and 25% past the examples."""
    pts = verb.points
    q = (pts - pts.mean(axis=0)) / np.where(np.ptp(pts, axis=0) > 0, np.ptp(pts, axis=0), 1.0)
    d = np.linalg.norm(q[:, None] - q[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    pairs = {tuple(sorted((i, int(np.argmin(d[i]))))) for i in range(len(pts))}
    between = np.array([(pts[a] + pts[b]) / 2 for a, b in sorted(pairs)])
    centre = pts.mean(axis=0)
    return {"at examples": pts, "between": between, "25% past": centre + 1.25 * (pts - centre)}


def obedience(verb: Verb) -> dict[str, np.ndarray]:
    """Largest measured-minus-asked error per measured adverb, % of range, at each kind of point."""
    measured = _measured(verb)
    ranges = _ranges(verb.points)[measured]
    out = {}
    for kind, pts in obedience_points(verb).items():
        errs = [np.abs(measure_point(verb, p) - p[measured]) / ranges for p in pts]
        out[kind] = 100.0 * np.max(errs, axis=0)
    return out


# ----- held-out takes -------------------------------------------------------------------------

DATA = Path(__file__).resolve().parents[3] / "data" / "bandai"
HELD_OUT_METHODS = ("ours", "ours-auto", "linear", "nearest", "idw", "scipy-rbf")
SPLITS = ("odd-even", "even-odd", "leave-one-out")  # see TakeClass.folds


@dataclass(frozen=True)
class TakeClass:
    """Several takes of one action in Bandai Namco dataset 2: ``files`` formats the take number (1-based).

    A gait's example is one cycle (two steps) from left heel strike ``strike`` (``"most_turning"``: the
    cycle that turns most), over measured speed and turn rate; ``exceptions`` give some takes another
    strike. A reach is the whole take, keytimes at the right hand's peak, over that peak's position.
    """

    name: str
    files: str
    takes: int
    kind: str  # "gait" or "reach"
    strike: int | str = 1
    exceptions: tuple[tuple[int, int], ...] = ()

    @property
    def train(self) -> list[int]:
        """The split: odd takes (1, 3, 5, …) build the verb."""
        return list(range(1, self.takes + 1, 2))

    @property
    def test(self) -> list[int]:
        """Even takes (2, 4, 6, …) are predicted at their measured adverb points."""
        return list(range(2, self.takes + 1, 2))

    def folds(self, split: str = "odd-even") -> list[tuple[list[int], list[int]]]:
        """``(train, test)`` take numbers of each fold of ``split`` (one of :data:`SPLITS`).

        ``"odd-even"``: odd takes build, even takes are predicted (the README's table); ``"even-odd"``: the
        other way round; ``"leave-one-out"``: each take predicted from all the others, one fold per take.
        """
        if split == "odd-even":
            return [(self.train, self.test)]
        if split == "even-odd":
            return [(self.test, self.train)]
        if split == "leave-one-out":
            every = range(1, self.takes + 1)
            return [([s for s in every if s != t], [t]) for t in every]
        raise AdverbsError(f"unknown split {split!r}; splits are {', '.join(SPLITS)}")

    def spec(self, data: Path) -> str:
        """A verb spec (TOML) of every take, the same settings as the shipped walk and reach specs."""
        if self.kind == "gait":
            lines = ["num_cp = 16", "cyclic = true", 'cut = { foot = "left", steps = 2 }']
            lines += [f'[[adverbs]]\nname = "{m}"\nmeasure = "{m}"' for m in ("speed", "turn_rate")]
        else:
            lines = ["num_cp = 20", "cyclic = false"]
            lines += [
                f'[[adverbs]]\nname = "hand_{a}"\n'
                f'measure = {{ kind = "joint_position", joint = "Hand_R", axis = "{a}", keytime = 1 }}'
                for a in "xyz"
            ]
        strikes = dict(self.exceptions)
        for t in range(1, self.takes + 1):
            part = 'keytimes = { peak = "Hand_R" }'
            if self.kind == "gait":
                strike = strikes.get(t, self.strike)
                part = f"cut = {{ strike = {strike if isinstance(strike, int) else repr(strike)} }}"
            lines.append(f'[[examples]]\nname = "take {t:02d}"\nfile = "{data / self.files.format(t)}"\n{part}')
        return f'name = "{self.name}"\nencoding = "logquat"\n' + "\n".join(lines) + "\n"


HELD_OUT_CLASSES = (
    TakeClass("walk", "dataset-2_walk_normal_{:03d}.bvh", 8, "gait"),
    TakeClass("walk-turn-left", "dataset-2_walk-turn-left_normal_{:03d}.bvh", 10, "gait", "most_turning"),
    # Take 4's most-turning cycle is its last: a stop, turning back left at 131 deg/s. Its third cycle
    # is the right turn (-45 deg/s).
    TakeClass("walk-turn-right", "dataset-2_walk-turn-right_normal_{:03d}.bvh", 10, "gait", "most_turning", ((4, 2),)),
    TakeClass("run", "dataset-2_run_normal_{:03d}.bvh", 5, "gait"),
    TakeClass("reach", "dataset-2_raise-up-right-hand_normal_{:03d}.bvh", 20, "reach"),
)


@dataclass
class HeldOut:
    """Per class: the folds of the split, the smoothing "auto" chose on each fold's training takes, and
    per-method errors of each test take (every fold's test takes, in fold order)."""

    classes: list[TakeClass]
    chosen: list[list[tuple[float, float]]]  # per fold: (λ, μ) of ours-auto fitted to its training takes
    pose_mm: list[dict[str, np.ndarray]]  # method → (T,) pose error of each test take
    adverb_pct: list[dict[str, np.ndarray]]  # method → (T,) adverb error, % of the training takes' range
    split: str = "odd-even"

    def medians(self, errors: str = "pose_mm") -> list[dict[str, float]]:
        """Per class, each method's median error over the test takes."""
        return [{m: float(np.median(v)) for m, v in per.items()} for per in getattr(self, errors)]

    def table(self) -> str:
        """Markdown: median pose error (and adverb error) of the test takes per class and method."""
        head = "| class | train | test | ours-auto λ, μ | " + " | ".join(HELD_OUT_METHODS) + " |"
        rows = [
            f"Held-out takes, split {self.split}: median pose error, mm (median adverb error, % of the training range):",
            "",
        ]
        rows += [head, "| --- " * (4 + len(HELD_OUT_METHODS)) + "|"]
        for c, chosen, pose, adverb in zip(self.classes, self.chosen, self.medians(), self.medians("adverb_pct")):
            cells = []
            best = min(pose[m] for m in ("linear", "nearest", "idw"))
            for m in HELD_OUT_METHODS:
                text = f"{pose[m]:.1f} ({adverb[m]:.0f}%)"
                cells.append(f"**{text}**" if m.startswith("ours") and pose[m] <= best else text)
            folds = c.folds(self.split)
            if len(folds) == 1:
                split = f"{_takes(folds[0][0])} | {_takes(folds[0][1])}"
            else:
                split = f"all but the test take | each take ({len(folds)} folds)"
            rows.append(f"| {c.name} | {split} | {_chosen(chosen)} | " + " | ".join(cells) + " |")
        return "\n".join(rows)


def _chosen(chosen: list[tuple[float, float]]) -> str:
    """The (λ, μ) ours-auto chose: the one fold's, or the most frequent over the folds and how often."""
    values, counts = np.unique(np.array(chosen), axis=0, return_counts=True)
    lam, mu = values[np.argmax(counts)]
    return f"{lam:g}, {mu:g}" if len(chosen) == 1 else f"{lam:g}, {mu:g} ({counts.max()} of {len(chosen)} folds)"


def _takes(numbers: list[int]) -> str:
    return ", ".join(f"{t:03d}" for t in numbers)


def held_out(
    classes: tuple[TakeClass, ...] = HELD_OUT_CLASSES,
    data: Path = DATA,
    progress: Callable[[float, float], None] | None = None,
    split: str = "odd-even",
) -> HeldOut:
    """Build each class's verb from some of its takes and predict the others (see :meth:`TakeClass.folds`).

    One verb is built from every take of a class (so the held-out takes' own control points are the
    truth, compared as in the leave-one-out table), and each method predicts from the fold's training
    takes only: ``ours-auto`` chooses its smoothing by leave-one-out among those. The encoding's
    reference rotations (the centre of its log map) are the mean over all the class's takes: a chart
    shared by truth and prediction, not part of any method.
    """
    if split not in SPLITS:
        raise AdverbsError(f"unknown split {split!r}; splits are {', '.join(SPLITS)}")
    chosen, pose, adverb = [], [], []
    total = sum(len(c.folds(split)) for c in classes)
    done = 0
    if progress is not None:
        progress(done, total)
    with tempfile.TemporaryDirectory() as tmp:
        for c in classes:
            path = Path(tmp) / f"{c.name}.toml"
            path.write_text(c.spec(Path(data).resolve()), encoding="utf-8")
            verb = build_from_spec(path)
            errors, picks = [], []
            for train_takes, test_takes in c.folds(split):
                train, test = np.array(train_takes) - 1, np.array(test_takes) - 1
                ranges = _ranges(verb.points[train])
                errors += [predicted_errors(verb, HELD_OUT_METHODS, i, train, ranges) for i in test]
                values = np.concatenate(
                    [verb.coefficients[train].reshape(len(train), -1), verb.log_intervals[train]], axis=1
                )
                ip = AdverbInterpolator(verb.points[train], smoothing="auto", shrinkage="auto", values=values)
                picks.append((ip.smoothing, ip.shrinkage))
                done += 1
                if progress is not None:
                    progress(done, total)
            pose.append({m: np.array([e[m][0] for e in errors]) for m in HELD_OUT_METHODS})
            adverb.append({m: np.array([e[m][1] for e in errors]) for m in HELD_OUT_METHODS})
            chosen.append(picks)
    return HeldOut(list(classes), chosen, pose, adverb, split)
