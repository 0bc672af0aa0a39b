"""The examples a spec names: read, resampled, mirrored, cut at contact events, annotated and measured."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import AdverbsError
from ..io.bvh import read_bvh
from ..motion.clip import Clip
from ..motion.contacts import find_contacts
from ..motion.cutting import most_turning, step_events, step_range
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
    pending = []
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
        elif pending and clip.fps != pending[0][1].fps:
            raise SpecError(
                path,
                f"{file.name} runs at {clip.fps:g} fps and example {pending[0][0]['name']!r} at "
                f"{pending[0][1].fps:g}: set fps = ... at the top of the spec to resample every example",
                name,
                "file",
            )
        if reference is not None and not clip.skeleton.same_structure(reference):
            raise SpecError(path, f"{file.name} is on a different skeleton from {spec['skeleton']}", name, "file")
        if pending:
            first = pending[0][1]
            if not clip.skeleton.same_structure(first.skeleton):
                raise SpecError(
                    path, f"{file.name} is on a different skeleton from example {pending[0][0]['name']!r}", name, "file"
                )
        mirror = ex.get("mirror", False)
        for flag in ("mirror", "refine"):
            if not isinstance(ex.get(flag, False), bool):
                raise SpecError(path, "must be true or false", name, flag)
        if mirror:
            try:
                clip = clip.mirror()
            except AdverbsError as e:
                raise SpecError(path, str(e), name, "mirror") from None
        part, keytimes, names, desc = _cut(path, ex, clip, spec)
        pending.append((ex, clip, part, keytimes, desc, names))

    num_keytimes = len(pending[0][3])
    first_names = pending[0][5]
    if spec["cyclic"] and first_names[0] != first_names[-1] and not first_names[0].startswith("keytime"):
        raise SpecError(
            path,
            f"a cycle must end on the event it starts with, but its keytimes run from '{first_names[0]}' to "
            f"'{first_names[-1]}': use an even number of steps",
            pending[0][0]["name"],
            "cut.steps",
        )
    for ex, _, _, keytimes, _, names in pending:
        if len(keytimes) != num_keytimes:
            raise SpecError(
                path,
                f"has {len(keytimes)} keytimes, example {pending[0][0]['name']!r} has {num_keytimes}: "
                "every example needs the same structure (same number of steps)",
                ex["name"],
                "keytimes",
            )
        if names != pending[0][5]:
            raise SpecError(
                path,
                f"its keytimes are {', '.join(names)}; example {pending[0][0]['name']!r} has "
                f"{', '.join(pending[0][5])}: every example needs the same events in the same order",
                ex["name"],
                "keytimes",
            )

    adverbs = []
    for a in spec["adverbs"]:
        m = a.get("measure")
        if m is not None:
            try:
                m = check_measure(m, pending[0][1].skeleton.names, num_keytimes, f"{path}: adverb {a['name']!r}")
            except AdverbsError as e:
                raise SpecError(path, str(e).split(": ", 2)[-1], field=f"adverbs.{a['name']}.measure") from None
        unit = a.get("unit", default_unit(m["kind"]) if m else "")
        adverbs.append(Adverb(a["name"], str(unit), m))

    for ex, _, part, keytimes, desc, names in pending:
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
                ex["name"], part, keytimes, np.array(point), ex["file"], desc, ex.get("refine", False), tuple(names)
            )
        )
    return examples, adverbs


def _cut(path: Path, ex: dict, clip: Clip, spec: dict) -> tuple[Clip, np.ndarray, list[str], str]:
    """The example's part of the clip, its keytimes (seconds), their names, and a description."""
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
        return (part, *_given_keytimes(path, ex, part), f"frames {frames[0]}:{frames[1]}")
    cut = dict(spec["cut"] or {})
    cut.update(ex.get("cut", {}))
    if not cut:
        return (clip, *_given_keytimes(path, ex, clip), "whole file")
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
    frames, names = step_events(contacts, start, stop, toe_offs=events == "contacts")
    k = int(np.flatnonzero(np.array(contacts.strikes(foot)) == start)[0])
    return (
        clip.frames(start, stop + 1),
        (frames - start) / clip.fps,
        names,
        f"{steps} steps from {foot} heel strike {k}",
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
