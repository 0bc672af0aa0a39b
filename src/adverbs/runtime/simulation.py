"""Creatures in one simulation, moved by the event loop of §6: the run-time half of the system.

A :class:`Simulation` holds creatures on one or more verb graphs (one group of arrays per graph, so a
Bandai creature and a CMU creature can share a scene) and runs them on a clock::

    sim = Simulation(graph)
    hero = sim.add_creature(at=(0, 0), heading=0)
    hero.perform("run")
    hero.set_adverbs(valence=0.7, over=1.0)
    sim.run(10.0, on_frame=lambda sim: print(sim.time, hero.playing))

Each frame is a *render* event (normal: it steps every group's creatures together — graph, then planted
feet — and measures what that cost) and a *display* event (sync: it waits for the clock, then hands the
frame to the recorder and to ``on_frame``). On the wall clock the render schedules the next pair a frame
interval on, where the interval is the longest of the asked frame time and the measured cost, so the
frame rate follows the load and every frame is shown on time; on the virtual clock frames are evenly
spaced and a run is the same every time. Commands — perform a verb, change adverbs — are normal events:
given a time (``at=``) they wait for it in the queue; otherwise they act at once. A command the graph
cannot carry out is refused with a message; a scheduled one is recorded in :attr:`Simulation.log` and
the run goes on.

Adverb changes are eased: from the value shown to the one asked for over ``over`` seconds with a
smoothstep, so a slider's jump does not pop the pose; by default (``over=None``) over as long as the change needs
for no part of the body to turn faster than its verbs' own (:func:`~adverbs.graph.easing.ease_length`, 0.5 to 3 s,
about 2 ms a change to work out: a crowd steered every frame is better given ``over``).
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import AdverbsError, AdverbsWarning
from ..limits import check_frames
from ..graph.easing import Easing
from ..graph.planted import GraphFeet, know_levels, plant, planter
from ..graph.player import step
from ..graph.queue import command
from ..graph.state import GraphState, new_state
from ..graph.structure import REACH, CommandRefused, Graph
from ..kinematics.fk import forward_kinematics
from ..kinematics.floor import FlatFloor, Floor
from ..motion.clip import Clip
from ..feet.offline import PlantingReport, report_of_modes
from .events import NORMAL, SYNC, EventQueue, Processed, VirtualClock, WallClock, run_events
from .frame import FramePass, supported
from .recording import EventLog, Folder, Spool

MARGIN = 1.25  # the frame interval on the wall clock is at least this many times the measured render cost
MIN_FPS = 2.0  # the wall clock's frame rate never drops below this (a render slower than that lags)
COST_SMOOTHING = 0.3  # weight of the newest render cost in its running mean
MAX_SECONDS = 24 * 3600.0


@dataclass(eq=False)
class _Group:
    """The creatures of one graph: their graph state, planted feet, adverb easing and recording, as arrays."""

    graph: Graph
    names: list[str] = field(default_factory=list)
    starts: list[str | None] = field(default_factory=list)
    points: list[np.ndarray] = field(default_factory=list)
    roots: list[np.ndarray] = field(default_factory=list)
    wander: list[bool] = field(default_factory=list)
    state: GraphState | None = None
    feet: GraphFeet | None = None
    frame: FramePass | None = None  # the compiled frame (None: the reference path, player.step and plant)
    easing: Easing | None = None
    rotations: np.ndarray | None = None
    translations: np.ndarray | None = None
    spool: Spool | None = None  # the frames shown, kept on disk (recording.Spool), and the planter's modes and turns
    shown_active: np.ndarray | None = None  # the transition each creature was in at the last frame

    @property
    def size(self) -> int:
        return len(self.names)


class Creature:
    """A handle on one creature of a :class:`Simulation`: commands, and what it shows."""

    def __init__(self, sim: Simulation, group: _Group, index: int, name: str):
        self._sim, self._group, self.index, self.name = sim, group, index, name

    @property
    def graph(self) -> Graph:
        return self._group.graph

    # ----- commands ---------------------------------------------------------------------------------
    def perform(self, verb: str, at: float | None = None, stay: bool = True) -> None:
        """Perform ``verb`` through the graph's planner: now, or at simulation time ``at``. ``stay``: keep playing it
        (a cycle, or a verb with a loop) until the next command; otherwise the graph draws what comes next.

        Now: an unknown or unreachable verb raises :class:`CommandRefused` and nothing changes. At a time:
        it is checked then, and a refusal is logged (the run goes on)."""
        self._sim._command(self, "perform", {"verb": verb, "stay": bool(stay)}, at)

    def set_adverbs(
        self, values: Mapping[str, float] | None = None, over: float | None = None, at: float | None = None, **adverbs: float
    ) -> None:
        """Ease the adverbs named (by keyword or in ``values``) to new values over ``over`` seconds (0: a jump; None:
        as long as the change needs, :func:`~adverbs.graph.easing.ease_length`),
        now or at simulation time ``at``. Unknown names, non-numbers and values outside the graph's range
        (:meth:`Graph.adverb_range`) are refused as :meth:`perform`'s are."""
        merged = {**(dict(values) if values else {}), **adverbs}
        self._sim._command(self, "adverbs", {"adverbs": merged, "over": over}, at)

    # ----- what it shows -----------------------------------------------------------------------------
    @property
    def adverbs(self) -> dict[str, float]:
        """The adverbs it plays at now (mid-ease: the eased values)."""
        g = self._group
        p = g.state.points[self.index] if g.state is not None else g.points[self.index]
        return {a: float(x) for a, x in zip(g.graph.adverb_names, p)}

    @property
    def playing(self) -> str:
        """What it is doing, in words (a verb, or a transition and how far it has gone)."""
        g = self._group
        if g.state is None:
            return f"{self.verb} (not started)"
        return g.state.playing(self.index)

    @property
    def verb(self) -> str:
        """The verb it plays (in a transition: the one it is entering)."""
        g = self._group
        if g.state is None:
            return g.graph.verb_names[g.graph.verb_index(g.starts[self.index] or g.graph.start)]
        s = g.state
        v = s.into[self.index] if s.active[self.index] >= 0 else s.verb[self.index]
        return g.graph.verb_names[int(v)]

    @property
    def root(self) -> tuple[float, float, float]:
        """``(x, z, heading)``: where it stands (metres) and faces (degrees)."""
        g = self._group
        r = g.state.root[self.index] if g.state is not None else g.roots[self.index]
        return float(r[0]), float(r[1]), float(np.degrees(r[2]))

    @property
    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations ``(J, 4)`` and translations ``(J, 3)`` of the last frame (feet planted if planting)."""
        g = self._group
        if g.rotations is None:
            raise AdverbsError(f"creature {self.name!r}: no frame yet (run the simulation first)")
        return g.rotations[self.index].copy(), g.translations[self.index].copy()

    def positions(self) -> np.ndarray:
        """World joint positions ``(J, 3)`` of the last frame."""
        rot, trans = self.pose
        pos, _ = forward_kinematics(self.graph.skeleton.parents, rot, trans)
        return pos

    def clip(self) -> Clip:
        """Every frame shown so far, as a clip at the simulation's frame rate (resampled if frames came unevenly)."""
        return self._sim._clip(self)

    def holds(self) -> PlantingReport | None:
        """What the planter held at every frame of :meth:`clip` (its phases, as :func:`~adverbs.feet.planter.plant_feet`
        reports them), for :func:`~adverbs.feet.planter.measure_feet`; None if no foot is planted on this graph."""
        return self._sim._holds(self)

    def __repr__(self) -> str:
        return f"Creature({self.name!r}, {self.playing})"


class Simulation:
    """Creatures on verb graphs, on a clock.

    ``graphs``: one graph or several (creatures are added to the first unless told); ``fps``: the frame rate
    asked for (on the wall clock, the highest); ``seed``: every creature's draws; ``floor``: where feet are
    planted (default flat at 0); ``plant``: plant feet (can be switched while running); ``record``: keep every
    frame for :meth:`Creature.clip` and :meth:`write`; ``realtime``: run on the wall clock (times ``speed``)
    rather than the virtual one; ``compiled``: step each group's frame in one compiled pass
    (:mod:`adverbs.runtime.frame`; False: the readable reference path, :func:`adverbs.graph.player.step` then
    :func:`~adverbs.graph.planted.plant`, which any graph the pass cannot take uses anyway).
    """

    def __init__(
        self,
        graphs: Graph | Sequence[Graph],
        fps: float = 30.0,
        seed: int = 0,
        floor: Floor | None = None,
        plant: bool = True,
        record: bool = True,
        realtime: bool = False,
        speed: float = 1.0,
        compiled: bool = True,
    ):
        graphs = [graphs] if isinstance(graphs, Graph) else list(graphs)
        if not graphs or not all(isinstance(g, Graph) for g in graphs):
            raise AdverbsError("a simulation needs one graph or more (adverbs.load_graph reads one)")
        if not (isinstance(fps, int | float) and math.isfinite(fps) and 1 <= fps <= 1000):
            raise AdverbsError(f"fps must be a number from 1 to 1000, got {fps!r}")
        self.graphs = graphs
        self.fps = float(fps)
        self.seed = int(seed)
        self.floor = FlatFloor(0.0) if floor is None else floor
        self._plant = bool(plant)
        self.compiled = bool(compiled)
        self.record = bool(record)
        self.clock = WallClock(speed) if realtime else VirtualClock()
        self.queue = EventQueue()
        self.processed = Processed()
        self.time = 0.0  # the simulation time of the last frame
        self.frames = 0
        self.frame_times: list[float] = []  # when each frame was shown (simulation seconds)
        self.lags: list[float] = []  # how late each frame was shown (clock − its time; 0 on the virtual clock)
        self.costs: list[float] = []  # wall seconds each render took
        self.wall_seconds = 0.0  # wall seconds spent in run(), all runs
        # The commands that ran or were refused, the transitions started, the verbs arrived at: read as a list, kept
        # on disk past a few thousand entries (recording.EventLog).
        self.log = EventLog(self._recording_folder)
        self._groups: dict[int, _Group] = {}
        self._creatures: list[Creature] = []
        self._cost = 0.0
        self._started = False
        self._pending: list[tuple[Creature, str, bool]] = []
        self._scheduled: dict[int, dict] = {}  # commands given a time still to come, in the order given
        self._folder: Folder | None = None  # where the recording is kept (made with the first frame recorded)
        self._scheduled_count = 0
        self._on_frame: Callable | None = None
        self._on_render: Callable | None = None

    # ----- creatures ----------------------------------------------------------------------------------
    def add_creature(
        self,
        at: Sequence[float] = (0.0, 0.0),
        heading: float = 0.0,
        graph: Graph | str | None = None,
        name: str | None = None,
        verb: str | None = None,
        adverbs: Mapping[str, float] | None = None,
        wander: bool = False,
    ) -> Creature:
        """A new creature standing at ``at = (x, z)`` metres, facing ``heading`` degrees (0: along +z, positive
        turning left), playing ``verb`` (default its graph's start) at ``adverbs`` (default the graph's).
        ``graph``: one of the simulation's graphs, or its name (default the first). It keeps playing its verb
        until told otherwise; ``wander``: it goes on by transitions drawn by likelihood instead (the paper's
        default), until a command says ``stay``. Creatures are added before the first frame."""
        if self._started:
            raise AdverbsError("add creatures before the simulation's first frame: its arrays are fixed once it runs")
        g = self._graph(graph)
        name = f"{g.name}{sum(c.graph is g for c in self._creatures) + 1}" if name is None else str(name)
        if any(c.name == name for c in self._creatures):
            raise AdverbsError(f"a creature is already called {name!r}")
        at = np.asarray(at, dtype=float)
        if at.shape != (2,) or not np.all(np.isfinite(at)) or not math.isfinite(float(heading)):
            raise AdverbsError(f"creature {name!r}: at must be two finite numbers (x, z) and heading a finite angle")
        if verb is not None:
            g.verb_index(verb)
        point = g.check_point(g.point(dict(adverbs) if adverbs else None), REACH)
        group = self._groups.setdefault(id(g), _Group(g))
        group.names.append(name)
        group.starts.append(verb)
        group.points.append(point)
        group.roots.append(np.array([at[0], at[1], math.radians(float(heading))]))
        group.wander.append(bool(wander))
        c = Creature(self, group, group.size - 1, name)
        self._creatures.append(c)
        return c

    @property
    def creatures(self) -> list[Creature]:
        return list(self._creatures)

    def creature(self, name: str) -> Creature:
        for c in self._creatures:
            if c.name == name:
                return c
        raise AdverbsError(f"no creature {name!r}; there are {', '.join(c.name for c in self._creatures) or 'none'}")

    def _graph(self, graph: Graph | str | None) -> Graph:
        if graph is None:
            return self.graphs[0]
        for g in self.graphs:
            if g is graph or g.name == graph:
                return g
        raise AdverbsError(f"no graph {getattr(graph, 'name', graph)!r} in this simulation; it has {', '.join(g.name for g in self.graphs)}")

    @property
    def plant(self) -> bool:
        """Whether feet are planted; switching it on again starts the planter afresh from the pose shown."""
        return self._plant

    @plant.setter
    def plant(self, on: bool) -> None:
        if on and not self._plant:
            for g in self._groups.values():
                g.feet = None if g.feet is None else planter(g.graph, g.size, self.floor)
                if g.frame is not None:
                    g.frame.use_feet(g.feet)  # the pass plants with the new planter too
        self._plant = bool(on)

    def set_plant(self, on: bool, at: float | None = None) -> None:
        """Switch planted feet on or off: now, or at simulation time ``at`` (an event, logged)."""
        if at is None:
            self.plant = on
            return
        if not (math.isfinite(float(at)) and at >= self.time):
            raise AdverbsError(f"set_plant: the time must be a number ≥ now ({self.time:g} s), got {at}")

        def switch(t: float) -> None:
            self.plant = on
            self.log.append({"time": round(t, 9), "creature": "*", "command": "plant", "on": bool(on), "status": "ran"})

        self.queue.push(at, switch, NORMAL, "plant")

    # ----- commands ----------------------------------------------------------------------------------
    def schedule(self, at: float, callback: Callable[[float], object], kind: str = NORMAL, name: str = "") -> None:
        """Queue ``callback(time)`` at simulation time ``at`` (an event of ``kind``: normal, sync or optional)."""
        self.queue.push(at, callback, kind, name)

    def _command(self, creature: Creature, kind: str, args: dict, at: float | None, source: str = "") -> None:
        if at is None:
            self._do(creature, kind, args, self.time, source, raise_refused=True)
            return
        at = float(at)
        if not math.isfinite(at) or at < self.time:
            raise AdverbsError(f"creature {creature.name!r}: a command's time must be a number ≥ now ({self.time:g} s), got {at}")
        key = self._scheduled_count
        self._scheduled_count += 1
        self._scheduled[key] = {"time": round(at, 9), "creature": creature.name, "command": kind, **_jsonable(args)}
        if source:
            self._scheduled[key]["source"] = source

        def due(t: float) -> None:
            self._scheduled.pop(key, None)
            self._do(creature, kind, args, t, source)

        self.queue.push(at, due, NORMAL, f"{kind} {creature.name}")

    def _do(self, creature: Creature, kind: str, args: dict, t: float, source: str, raise_refused: bool = False) -> None:
        entry = {"time": round(float(t), 9), "creature": creature.name, "command": kind, **_jsonable(args)}
        if source:
            entry["source"] = source
        try:
            if kind == "perform":
                self._perform(creature, args["verb"], args.get("stay", True))
            else:
                entry["eased"] = self._ease(creature, args["adverbs"], args["over"], t)
        except AdverbsError as e:  # CommandRefused and bad values alike: nothing was changed
            entry.update(status="refused", reason=str(e))
            self.log.append(entry)
            if raise_refused:
                raise CommandRefused(str(e)) from None
            warnings.warn(f"{source + ': ' if source else ''}at {t:.3f} s, {creature.name}: {e}", AdverbsWarning, stacklevel=2)
            return
        entry["status"] = "ran"
        self.log.append(entry)

    def _perform(self, creature: Creature, verb: str, stay: bool) -> None:
        g = creature._group
        if not isinstance(verb, str | int) or isinstance(verb, bool):
            raise CommandRefused(f"a verb is named by a string, got {verb!r}")
        if g.state is None:  # before the first frame: checked now, carried out as it starts
            g.graph.path(g.starts[creature.index] or g.graph.start, verb)
            self._pending.append((creature, verb, stay))
            return
        command(g.state, creature.index, verb, stay)

    def _ease(self, creature: Creature, values: Mapping[str, float], over: float | None, t: float) -> float:
        """Ease ``creature``'s adverbs to ``values`` from time ``t``; the seconds it eases over."""
        g = creature._group
        graph = g.graph
        if over is not None:
            try:
                over = float(over)
            except (TypeError, ValueError):
                raise CommandRefused(f"over must be a number of seconds, got {over!r}") from None
            if not (math.isfinite(over) and 0.0 <= over <= 3600.0):
                raise CommandRefused(f"over must be a number of seconds from 0 to 3600, got {over}")
        for k, x in values.items():
            if k not in graph.adverb_names:
                raise CommandRefused(f"graph {graph.name!r} has no adverb {k!r}; its adverbs are {', '.join(graph.adverb_names)}")
            if isinstance(x, bool) or not isinstance(x, int | float | np.number):
                raise CommandRefused(f"adverb {k!r} must be a number, got {x!r}")
        i = creature.index
        target = (g.easing.to[i] if g.state is not None else g.points[i]).copy()
        for k, x in values.items():
            target[graph.adverb_names.index(k)] = float(x)
        graph.check_point(target, REACH)
        if g.state is None:  # before the first frame: nothing shown yet to ease from
            g.points[i] = target
            return 0.0
        return round(g.easing.ease_to(graph, g.state, i, target, t, over), 6)

    # ----- running -----------------------------------------------------------------------------------
    def _start(self) -> None:
        """Make every group's arrays (once: the creatures are fixed from here)."""
        if self._started:
            return
        if not self._creatures:
            raise AdverbsError("the simulation has no creatures: add_creature first")
        for k, g in enumerate(self._groups.values()):
            seed = int(np.random.SeedSequence([self.seed, k]).generate_state(1)[0])
            points = np.array(g.points)
            g.state = new_state(g.graph, g.size, seed, g.starts, points, np.array(g.roots), ~np.array(g.wander))
            if any(v.holds for v in g.graph.verbs):
                g.feet = planter(g.graph, g.size, self.floor)
            if self.compiled and supported(g.graph) is None and (g.feet is None or g.feet.planter._compiled is not None):
                g.frame = FramePass(g.state, g.feet)
            g.easing = Easing(points)
        self._started = True
        for creature, verb, stay in self._pending:
            command(creature._group.state, creature.index, verb, stay)
        self._pending.clear()

    def run(
        self,
        seconds: float,
        on_frame: Callable[[Simulation], object] | None = None,
        on_render: Callable[[Simulation], object] | None = None,
        progress: Callable[[float, float], object] | None = None,
    ) -> Simulation:
        """Run ``seconds`` on: frames at the asked rate (on the wall clock: as fast as the load allows, up to it),
        events in time order. ``on_frame(sim)``: each frame as it is shown; ``on_render(sim)``: each frame as it
        is made (its cost counts in the frame rate); ``progress(done, total)``: seconds done. Runs again carry on
        where the last stopped."""
        seconds = float(seconds)
        if not (math.isfinite(seconds) and 0 < seconds <= MAX_SECONDS):
            raise AdverbsError(f"seconds must be a number in (0, {MAX_SECONDS:g}], got {seconds}")
        if self.record:  # every frame is kept (on disk), each creature's clip read back alone: refused now if too long
            frames = len(self.frame_times) + seconds * self.fps
            joints = max(g.graph.skeleton.num_joints for g in self._groups.values()) if self._groups else 1
            check_frames(frames, joints, f"recording {self.time + seconds:g} s at {self.fps:g} fps")
        self._start()
        self._on_frame, self._on_render, self._progress = on_frame, on_render, progress
        begin, end = self.time, self.time + seconds
        self._end, self._begin = end, begin
        if self.clock.realtime:
            self.clock.start(self.time)
        self.queue.push(self.time + 1.0 / self.fps, self._render, NORMAL, "render")
        started = time.perf_counter()
        try:
            run_events(self.queue, self.clock, end + 1e-9, self.processed)
        finally:
            self.wall_seconds += time.perf_counter() - started
            # a frame left queued (the run was stopped by an error) is dropped: the next run queues its own
            self.queue.discard("render")
            self.queue.discard("display")
        return self

    def _render(self, t: float) -> None:
        """The render event: every creature stepped to time ``t``, its cost measured, the frame's display and the
        next render scheduled."""
        wall = time.perf_counter()
        if self.clock.realtime:  # reached late (the last frame lagged): aim this frame where it can be on time
            t = max(t, self.clock.now() + MARGIN * self._cost)
        dt = t - self.time
        if dt <= 0:
            return
        for g in self._groups.values():
            self._step_group(g, t, dt)
        self.time = t
        if self._on_render is not None:
            self._on_render(self)
        cost = time.perf_counter() - wall
        self._cost = cost if not self.costs else (1 - COST_SMOOTHING) * self._cost + COST_SMOOTHING * cost
        self.costs.append(cost)
        self.queue.push(t, self._display, SYNC, "display")
        interval = 1.0 / self.fps
        if self.clock.realtime:
            interval = min(max(interval, MARGIN * self._cost), 1.0 / MIN_FPS)
        else:  # evenly spaced, counted from the run's start so they do not drift
            interval = (round((t - self._begin) * self.fps) + 1) / self.fps - (t - self._begin)
        nxt = t + interval
        if nxt <= self._end + 1e-9:
            self.queue.push(nxt, self._render, NORMAL, "render")

    def _display(self, t: float) -> None:
        """The display event: the frame made for ``t``, now that the clock has reached it."""
        self.frames += 1
        self.frame_times.append(t)
        self.lags.append(max(self.clock.now() - t, 0.0) if self.clock.realtime else 0.0)
        if self.record:
            for k, g in enumerate(self._groups.values()):
                if g.spool is None:
                    feet = 0 if g.feet is None else g.feet.mode.shape[1]
                    g.spool = Spool(self._recording_folder(), f"group{k}", g.size, g.graph.skeleton.num_joints, feet)
                if g.feet is not None and self._plant:
                    g.spool.append(g.rotations, g.translations, g.feet.mode, g.feet.turn)
                else:  # every foot free (FREE is 0) while planting is off
                    g.spool.append(g.rotations, g.translations, None, None)
            for g in self._groups.values():  # to disk once every group has this frame (Ctrl-C in a write loses none)
                if g.spool.full:
                    g.spool.flush()
        if self._on_frame is not None:
            self._on_frame(self)
        if self._progress is not None:
            self._progress(t - self._begin, self._end - self._begin)

    def _step_group(self, g: _Group, t: float, dt: float) -> None:
        s = g.state
        g.easing.apply(s.points, t)
        before = g.shown_active if g.shown_active is not None else np.full(g.size, -1)
        if g.frame is not None:  # one compiled pass
            g.rotations, g.translations = g.frame.step(dt, plant=self._plant)
        else:
            if g.feet is not None and self._plant:
                know_levels(g.feet, s)
            frame = step(s, dt)
            if g.feet is not None and self._plant:
                g.rotations, g.translations, _ = plant(g.feet, frame, dt, s.alone, s.standing)
            else:
                g.rotations, g.translations = frame.rotations, frame.translations
        g.shown_active = s.active.copy()
        for c, name, seconds in s.latencies:  # commands whose verb now plays alone: into the log, which keeps them
            self.log.append({
                "time": round(t, 9), "creature": g.names[c], "command": "arrived", "verb": name,
                "seconds": round(float(seconds), 6), "status": "ran",
            })  # fmt: skip
        s.latencies.clear()  # (a long run's state would otherwise keep one entry per command)
        for c in np.flatnonzero((s.active != before) & (s.active >= 0)):
            tr = g.graph.transitions[s.active[c]]
            names = g.graph.verb_names
            self.log.append({
                "time": round(t, 9), "creature": g.names[c], "command": "transition",
                "from": names[tr.source], "to": names[tr.target], "seconds": round(float(s.length[c]), 6), "status": "ran",
            })  # fmt: skip

    # ----- recording ---------------------------------------------------------------------------------
    def _frames(self, n: int) -> np.ndarray | None:
        """Where the clip's frames fall among the ``n`` recorded ones (fractional), if they came unevenly (the wall
        clock) and are resampled; else None."""
        times = np.asarray(self.frame_times[-n:])
        steps = np.diff(times)
        if len(steps) and np.ptp(steps) > 1e-6 / self.fps:
            grid = np.arange(times[0], times[-1] + 1e-9, 1.0 / self.fps)
            return np.interp(grid, times, np.arange(len(times)))
        return None

    def _clip(self, creature: Creature) -> Clip:
        g = creature._group
        if g.spool is None or not g.spool.frames:
            raise AdverbsError(
                f"creature {creature.name!r}: nothing recorded ({'no frame yet' if self.record else 'the simulation does not record'})"
            )
        rot, trans = g.spool.creature(creature.index)
        clip = Clip(g.graph.skeleton, rot, trans, self.fps, name=creature.name)
        at = self._frames(g.spool.frames)
        return clip if at is None else clip.at(at)

    def _holds(self, creature: Creature) -> PlantingReport | None:
        g = creature._group
        if g.feet is None or g.spool is None or not g.spool.frames:
            return None
        modes, turns = g.spool.held(creature.index)
        at = self._frames(g.spool.frames)
        if at is not None:  # the nearest recorded frame's
            rows = np.rint(at).astype(int)
            modes, turns = modes[rows], turns[rows]
        return report_of_modes(modes, turns, np.zeros(len(modes)))

    def write(self, out: str | Path, formats: Sequence[str] = ("bvh",), portable: bool = False) -> dict[str, Path]:
        """Write every creature's recording in each of ``formats`` (``"bvh"``: ``out/NAME.bvh``, portable if asked —
        position channels on the root only; ``"glb"``: ``out/NAME.glb``) and the log of what ran (``out/events.json``).
        Returns the paths by creature name (the first format's), ``NAME.glb`` and so on for the others, and ``"events"``."""
        from ..io import write_motion
        from ..io.bvh import write_bvh_blocks

        kinds = [str(f).lower().lstrip(".") for f in formats]
        bad = [f for f in kinds if f not in ("bvh", "glb")]
        if bad or not kinds:
            raise AdverbsError(f"formats {list(formats)!r}: each must be 'bvh' or 'glb'")
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        paths: dict[str, Path] = {}
        for c in self._creatures:
            g = c._group
            kinds_here = list(dict.fromkeys(kinds))
            # A BVH file of frames evenly spaced is written from the recording a block at a time (a long run holds
            # one block in memory, not the clip); the other files are made from the whole clip.
            streamed = kinds_here[0] == "bvh" and not portable and g.spool is not None and g.spool.frames
            if streamed and self._frames(g.spool.frames) is None:
                blocks = (Clip(g.graph.skeleton, r, t, self.fps, name=c.name) for r, t in g.spool.blocks(c.index))
                paths[c.name] = write_bvh_blocks(out / f"{c.name}.bvh", blocks, g.spool.frames)
                kinds_here = kinds_here[1:]
                if not kinds_here:
                    continue
            clip = c.clip()
            for kind in kinds_here:
                p = write_motion(clip, out / f"{c.name}.{kind}", portable=portable)
                paths[c.name if kind == kinds[0] else f"{c.name}.{kind}"] = p
        events = out / "events.json"
        self._write_report(events)
        paths["events"] = events
        return paths

    def _write_report(self, path: Path) -> None:
        """:meth:`report` as JSON at ``path``, its events written one by one from the log (a long run's log is
        never held whole in memory); whole or not at all."""
        from ..io.files import atomic_path

        rest = json.dumps(self.report(events=False), indent=1)
        with atomic_path(path) as tmp, open(tmp, "x", encoding="utf-8") as f:
            f.write('{\n "events": [')
            for i, e in enumerate(self.log):
                f.write(("," if i else "") + "\n  " + json.dumps(e))
            f.write("\n ],\n" + rest[2:] + "\n")

    def _recorded_from(self, creature: Creature) -> float | None:
        """The simulation time of a creature's first recorded frame (None when nothing is recorded)."""
        spool = creature._group.spool
        n = 0 if spool is None else spool.frames
        return round(float(self.frame_times[-n]), 9) if n else None

    def _recording_folder(self) -> Path:
        """The temporary folder the recording and the log are kept in (made when first needed)."""
        if self._folder is None:
            self._folder = Folder()
        return self._folder.path

    def close(self) -> None:
        """Let go of the recording (its files on disk); the simulation records afresh if run again."""
        for g in self._groups.values():
            if g.spool is not None:
                g.spool.close()
                g.spool = None
        if self._folder is not None:
            self.log.to_memory()  # the log stays readable without the folder
            self._folder.close()
            self._folder = None

    def not_run(self) -> list[dict]:
        """The commands given a time the run has not reached (scheduled past its end), each saying so."""
        return [
            {**e, "status": "not run", "reason": f"not reached: the run stopped at {self.time:g} s"}
            for e in self._scheduled.values()
        ]

    def report(self, events: bool = True) -> dict:
        """What ran: the frame rate, the creatures, the commands and transitions (the log), and skipped events."""
        frames = np.asarray(self.frame_times)
        steps = np.diff(frames)
        return {
            "seconds": round(self.time, 9),
            "frames": self.frames,
            "fps_asked": self.fps,
            "fps_mean": float(1.0 / steps.mean()) if len(steps) else None,
            "clock": "wall" if self.clock.realtime else "virtual",
            "seed": self.seed,
            "creatures": [
                {"name": c.name, "graph": c.graph.name, "verb": c.verb, "root": list(c.root), "adverbs": c.adverbs,
                 "recorded_from": self._recorded_from(c)}
                for c in self._creatures
            ],
            **({"events": list(self.log)} if events else {}),
            "not_run": self.not_run(),
            "skipped": [{"time": t, "event": n} for t, n in self.processed.skipped],
        }


def _jsonable(args: dict) -> dict:
    out = {}
    for k, v in args.items():
        if isinstance(v, Mapping):
            out[k] = {str(a): _number(x) for a, x in v.items()}
        else:
            out[k] = _number(v)
    return out


def _number(x):
    if isinstance(x, bool | str) or x is None:
        return x
    try:
        f = float(x)
    except (TypeError, ValueError):
        return repr(x)
    return f if math.isfinite(f) else str(f)
