"""The examples a spec names: read, resampled, mirrored, cut at contact events, annotated and measured."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import AdverbsError
from ..io.bvh import read_bvh
from ..motion.clip import Clip
from ..motion.contacts import Contacts, find_contacts
from ..motion.cutting import ORDERS, gait_order, most_turning, step_events, step_range, toe_off_lags
from .measures import check_measure, default_unit, measure_all
from .spec import CUT_FIELDS, SpecError
from .tables import Adverb, Example


def examples_from_spec(spec: dict[str, Any]) -> tuple[list[Example], list[Adverb]]:
    """Read, cut, annotate and measure every example of a parsed spec."""
    path: Path = spec["path"]
    base = path.parent
    reference = None
    if spec["skeleton"] is not None:
        try:
            reference = read_bvh(base / spec["skeleton"]).skeleton
        except AdverbsError as e:
            raise SpecError(path, str(e), field="skeleton") from None
    examples: list[Example] = []
    pending: list[_Part] = []
    for ex in spec["examples"]:
        name = ex["name"]
        file = base / ex["file"]
        if not file.exists():
            raise SpecError(path, f"no such file: {file}", name, "file")
        try:
            clip = read_bvh(file)
        except AdverbsError as e:
            raise SpecError(path, str(e), name, "file") from None
        if spec["fps"] is not None and clip.fps != spec["fps"]:
            clip = clip.resample(spec["fps"])
        elif pending and clip.fps != pending[0].part.fps:
            raise SpecError(
                path,
                f"{file.name} runs at {clip.fps:g} fps and example {pending[0].ex['name']!r} at "
                f"{pending[0].part.fps:g}: set fps = ... at the top of the spec to resample every example",
                name,
                "file",
            )
        for other, what in (
            (reference, str(spec["skeleton"])),
            (pending[0].part.skeleton if pending else None, f"example {pending[0].ex['name']!r}" if pending else ""),
        ):
            why = None if other is None else other.structure_difference(clip.skeleton)
            if why is not None:
                raise SpecError(path, f"{file.name} is on a different skeleton from {what}: {why}", name, "file")
        mirror = ex.get("mirror", False)
        for flag in ("mirror", "refine"):
            if not isinstance(ex.get(flag, False), bool):
                raise SpecError(path, "must be true or false", name, flag)
        if mirror:
            try:
                clip = clip.mirror()
            except AdverbsError as e:
                raise SpecError(path, str(e), name, "mirror") from None
        pending.append(_cut(path, ex, clip, spec))
        if spec.get("in_place") is True:
            pending[-1].part = in_place(pending[-1].part)
    _place_toe_offs(path, pending)

    first = pending[0]
    num_keytimes = len(first.keytimes)
    if spec["cyclic"] and first.names[0] != first.names[-1] and not first.names[0].startswith("keytime"):
        raise SpecError(
            path,
            f"a cycle must end on the event it starts with, but its keytimes run from '{first.names[0]}' to "
            f"'{first.names[-1]}': use an even number of steps",
            first.ex["name"],
            "cut.steps",
        )
    for p in pending:
        if p.names != first.names:
            raise SpecError(
                path,
                f"has {len(p.names)} keytimes ({', '.join(p.names)}), example {first.ex['name']!r} has "
                f"{num_keytimes} ({', '.join(first.names)}): every example needs the same events in the same "
                "order (the same cut.steps and cut.events)",
                p.ex["name"],
                "keytimes",
            )

    adverbs = []
    for a in spec["adverbs"]:
        m = a.get("measure")
        if m is not None:
            try:
                m = check_measure(m, first.part.skeleton.names, num_keytimes, f"{path}: adverb {a['name']!r}")
            except AdverbsError as e:
                raise SpecError(path, str(e).split(": ", 2)[-1], field=f"adverbs.{a['name']}.measure") from None
        unit = a.get("unit", default_unit(m["kind"]) if m else "")
        adverbs.append(Adverb(a["name"], str(unit), m))

    for p in pending:
        ex, part, keytimes = p.ex, p.part, p.keytimes
        given = ex.get("adverbs", {})
        if not isinstance(given, dict):
            raise SpecError(path, "must be a table of adverb values", ex["name"], "adverbs")
        unknown = sorted(set(given) - {a.name for a in adverbs})
        if unknown:
            raise SpecError(path, "the verb has no such adverb", ex["name"], f"adverbs.{unknown[0]}")
        point = []
        measured = iter(measure_all(part, keytimes, [a.measure for a in adverbs if a.measure is not None]))
        for a in adverbs:
            field = f"adverbs.{a.name}"
            if a.measure is not None:
                if a.name in given:
                    raise SpecError(
                        path, "this adverb is measured from the motion; do not also give it", ex["name"], field
                    )
                point.append(float(next(measured)))
                continue
            if a.name not in given:
                raise SpecError(
                    path, "missing: this adverb has no measure, so every example must give it", ex["name"], field
                )
            value = given[a.name]
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise SpecError(path, f"must be a finite number, got {value!r}", ex["name"], field)
            point.append(float(value))
        for other in examples:
            if np.allclose(other.point, point, rtol=1e-12, atol=1e-12):
                raise SpecError(
                    path,
                    f"examples {other.name!r} and {ex['name']!r} are at the same adverb point {point}; "
                    "examples must be at distinct points",
                    ex["name"],
                    "adverbs",
                )
        examples.append(
            Example(
                ex["name"], part, keytimes, np.array(point), ex["file"], p.desc, ex.get("refine", False), tuple(p.names)
            )
        )
    return examples, adverbs


def in_place(clip: Clip) -> Clip:
    """``clip`` with its body root's travel across the floor and its turn taken off, frame by frame (the root joint
    turned about the vertical through the body root, then moved back): the body stays where it stands, facing one
    way; its height, its lean and every joint's turn are kept.

    For a one-shot verb that stays where it stands (``in_place = true``): the Bandai stand's takes lean 0.2-0.9 cm
    and turn 0.2-1.0° over their 0.4-1.2 s with the feet still, and a stand looping into itself took that on at each
    loop. Held by its feet, a standing figure's body crept off them 0.3-0.6 cm a second and turned about 1° a second
    (the hips 57° from the feet after a minute), and from about half a minute on a foot stepped after it every 10-20
    s. With the travel taken off evenly over each take (its sway kept), the loop's blend of two parts of the take
    still crept 5-15 cm and turned 4° a minute; taken off every frame it does not move at all (the takes' sway is
    within 1.1 cm and 1.1°)."""
    from ..kinematics import quat
    from ..motion.heading import heading, lateral_axis

    body = clip.skeleton.body_root()
    pos, rot = clip.forward_kinematics()
    face = np.unwrap(heading(rot[:, body], lateral_axis(clip.skeleton, body)))
    turn = quat.about_y(-(face - face[0]))  # (F, 4)
    rotations, translations = clip.rotations.copy(), clip.translations.copy()
    centre = pos[:, body] * np.array([1.0, 0.0, 1.0])
    rotations[:, 0] = quat.mul(turn, rotations[:, 0])
    translations[:, 0] = centre + quat.rotate(turn, translations[:, 0] - centre)  # the body root stays where it was
    translations[:, 0, [0, 2]] -= (pos[:, body] - pos[0, body])[:, [0, 2]]
    return clip.replace(rotations=rotations, translations=translations)


@dataclass
class _Part:
    """One example's part of its file, before it is measured.

    ``gait`` holds the file's contacts and the cut's heel-strike frames when toe-offs are to be keytimes
    (``cut.events = "contacts"``); :func:`_place_toe_offs` then adds them to ``keytimes`` and ``names``.
    """

    ex: dict
    part: Clip
    keytimes: np.ndarray  # (N,) seconds from the part's start
    names: list[str]
    desc: str
    gait: tuple[Contacts, np.ndarray] | None = None


def _place_toe_offs(path: Path, parts: list[_Part]) -> None:
    """Toe-off keytimes for the examples cut with ``events = "contacts"``, all in one order.

    The order (:func:`adverbs.motion.cutting.gait_order`: a walk's or a run's) is the one most of those
    examples fit; an example that does not fit it is a :class:`SpecError` naming the example, the foot
    and the event, and the examples that have it.
    """
    gaits = [p for p in parts if p.gait is not None]
    if not gaits:
        return
    try:
        order = gait_order([toe_off_lags(*p.gait) for p in gaits])
    except AdverbsError as e:
        raise SpecError(path, str(e), gaits[0].ex["name"], "cut.events") from None
    misfits = []
    for p in gaits:
        contacts, strikes = p.gait
        try:
            frames, p.names = step_events(contacts, strikes, order)
        except AdverbsError as e:
            misfits.append((p, str(e)))
            continue
        p.keytimes = (frames - strikes[0]) / contacts.fps
    if misfits:
        p, reason = misfits[0]
        have = [q.ex["name"] for q in gaits if all(q is not m for m, _ in misfits)]
        listed = ", ".join(repr(n) for n in have[:3]) + (f" and {len(have) - 3} more" if len(have) > 3 else "")
        raise SpecError(
            path,
            f"{reason}. The other examples ({listed}) have it: their toe-offs come in a {order}'s order "
            f"({ORDERS[order]}). A run with a flight phase and a walk or jog without one cannot share toe-off "
            "keytimes, their events come in a different order; use heel-strike keytimes only (cut.events = "
            '"strikes") to keep them in one verb, or leave this example out',
            p.ex["name"],
            "cut.events",
        )


def _cut(path: Path, ex: dict, clip: Clip, spec: dict) -> _Part:
    """The example's part of the clip, its keytimes (seconds) and their names, and a description."""
    name = ex["name"]
    if "frames" in ex:
        frames = ex["frames"]
        if not (isinstance(frames, list) and len(frames) == 2 and all(isinstance(f, int) for f in frames)):
            raise SpecError(path, f"must be [A, B] whole frame numbers, got {frames!r}", name, "frames")
        try:
            part = clip.frames(*frames)
        except AdverbsError as e:
            raise SpecError(path, str(e), name, "frames") from None
        if part.num_frames < 2:
            raise SpecError(path, f"{frames} is a single frame; an example needs at least two", name, "frames")
        return _Part(ex, part, *_given_keytimes(path, ex, part), f"frames {frames[0]}:{frames[1]}")
    cut = dict(spec["cut"] or {})
    cut.update(ex.get("cut", {}))
    if not cut:
        return _Part(ex, clip, *_given_keytimes(path, ex, clip), "whole file")
    extra = sorted(set(cut) - CUT_FIELDS)
    if extra:
        raise SpecError(path, f"unknown field; cut takes {', '.join(sorted(CUT_FIELDS))}", name, f"cut.{extra[0]}")
    foot, steps, strike = cut.get("foot", "left"), cut.get("steps", 2), cut.get("strike", 0)
    events = cut.get("events", "strikes")
    if not isinstance(steps, int) or steps < 1:
        raise SpecError(path, f"must be a whole number of steps ≥ 1, got {steps!r}", name, "cut.steps")
    if events not in ("strikes", "contacts"):
        raise SpecError(path, f'must be "strikes" or "contacts", got {events!r}', name, "cut.events")
    if "keytimes" in ex:
        raise SpecError(path, "a cut at heel strikes takes its keytimes from them; remove 'keytimes'", name, "keytimes")
    try:
        contacts = find_contacts(clip)
        if strike == "most_turning":
            strikes = most_turning(clip, foot, steps, contacts)
        elif isinstance(strike, int) and strike >= 0:
            strikes = step_range(contacts, foot, strike, steps, clip.name)
        else:
            raise SpecError(
                path, f'must be a heel-strike index ≥ 0 or "most_turning", got {strike!r}', name, "cut.strike"
            )
    except SpecError:
        raise
    except AdverbsError as e:
        raise SpecError(path, str(e), name, "cut") from None
    start, stop = int(strikes[0]), int(strikes[-1])
    frames, names = step_events(contacts, strikes)
    k = int(np.flatnonzero(np.array(contacts.strikes(foot)) == start)[0])
    return _Part(
        ex,
        clip.frames(start, stop + 1),
        (frames - start) / clip.fps,
        names,
        f"{steps} steps from {foot} heel strike {k}",
        (contacts, strikes) if events == "contacts" else None,
    )


def _given_keytimes(path: Path, ex: dict, part: Clip) -> tuple[np.ndarray, list[str]]:
    name = ex["name"]
    given = ex.get("keytimes")
    if given is None:
        raise SpecError(path, "missing: a frame range needs keytimes (seconds, or { peak = JOINT })", name, "keytimes")
    if isinstance(given, dict):
        extra = sorted(set(given) - {"peak"})
        if extra or "peak" not in given:
            raise SpecError(path, 'takes { peak = "JOINT" }', name, "keytimes")
        try:
            j = part.skeleton.index(given["peak"])
        except AdverbsError as e:
            raise SpecError(path, str(e), name, "keytimes.peak") from None
        height = part.global_positions()[:, j, 1]
        peak = int(np.argmax(height))
        if peak == 0 or peak == part.num_frames - 1:
            raise SpecError(
                path, f"{given['peak']} is highest at the first or last frame: no peak inside", name, "keytimes.peak"
            )
        return np.array([0.0, peak / part.fps, part.duration]), ["start", f"{given['peak']} peak", "end"]
    if not isinstance(given, list) or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in given):
        raise SpecError(path, f"must be a list of seconds, got {given!r}", name, "keytimes")
    k = np.array(given, dtype=float)
    if len(k) < 2 or not np.all(np.isfinite(k)):
        raise SpecError(path, "needs at least two finite keytimes", name, "keytimes")
    if k[0] != 0 or abs(k[-1] - part.duration) > 0.5 / part.fps:
        raise SpecError(
            path,
            f"must start at 0 and end at the part's duration {part.duration:.4f} s, got {k[0]} .. {k[-1]}",
            name,
            "keytimes",
        )
    k[-1] = part.duration  # within half a frame: the part's end, exactly
    if np.any(np.diff(k) <= 0):
        i = int(np.argmax(np.diff(k) <= 0))
        raise SpecError(
            path,
            f"out of order: keytime {i + 2} ({k[i + 1]} s) is not after keytime {i + 1} ({k[i]} s)",
            name,
            "keytimes",
        )
    return k, [f"keytime {i}" for i in range(len(k))]
