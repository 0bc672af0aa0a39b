"""See it live: ``adverbs view`` serves a web page (viser) where creatures move on the runtime's real-time clock.

The page shows each creature as capsule-like bones on a ground grid, its planted feet marked and a trail of its
root; a slider per adverb (its range: the examples' span and the graph's extrapolation margin), a button per verb
(performed through the graph's planner), play/pause, playback speed, planted feet on/off, a command line that
takes ``run`` or ``valence=0.5``, and what each creature plays and the frame rate.

Everything the page sends goes through :meth:`Viewer.apply`, checked on the way in: a value out of range is
clamped to the slider's range; one that is not a number (a boolean, a string that does not read as one, an integer
past a float), a verb that does not exist, a switch that is not ``true`` or ``false`` and a request of any other
shape are refused with a message on the page. The simulation runs in its own thread; commands reach it through a
queue of at most :data:`MAX_QUEUED` requests (past that a request is refused: the page is sending faster than the
simulation plays), between frames, and each is carried out on its own: one that fails is refused and the rest go
on, so no request stops the simulation. The messages the page shows are written from both threads under a lock.
"""

from __future__ import annotations

import math
import queue
import sys
import threading
import time
from collections import deque
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import AdverbsError
from ..graph.structure import REACH, Graph
from ..kinematics import quat
from ..kinematics.fk import forward_kinematics
from ..runtime.simulation import Simulation
from ..feet.planter import FREE

TRAIL_SECONDS = 4.0
BONE_RADIUS = 0.025  # metres
SPACING = 1.5  # metres between creatures, side by side
FOLLOW_EVERY = 5  # frames between camera moves when it follows the creatures
LOOK_HEIGHT = 0.9  # metres: where the camera looks, above the ground under the creatures' middle
GRID_SECTION = 2.0  # metres: the ground grid's major lines (it moves by whole sections)
UP_Z = np.array([0.0, 0.0, 1.0])  # the bone mesh's axis
COLORS = [(230, 140, 60), (70, 140, 220), (90, 180, 110), (200, 90, 160), (150, 120, 220), (220, 200, 70)]
MAX_QUEUED = 256  # requests waiting for the simulation: a page sends a few a second, a flood is refused past this
MESSAGES = 6  # the last messages the page shows
LOG_KEPT = 1000  # events of the simulation's log the viewer keeps (it records nothing; a page open for days sends more)


def _short(value: object) -> str:
    """``repr(value)`` cut to a line, for the page."""
    text = repr(value)
    return text if len(text) <= 60 else f"{text[:40]}… ({len(text)} characters)"


def _number(value: object, name: str) -> float:
    """A finite number from the page: a number (not a boolean) or text that reads as one."""
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise AdverbsError(f"{name}: {_short(value)} is not a number")
    try:
        number = float(value)
    except ValueError:
        raise AdverbsError(f"{name}: {_short(value)} is not a number") from None
    except OverflowError:  # an integer of hundreds of digits
        raise AdverbsError(f"{name}: {_short(value)} is not a finite number") from None
    if not math.isfinite(number):
        raise AdverbsError(f"{name}: {number} is not a finite number")
    return number


def _cylinder(segments: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """A closed unit cylinder along +Z from z = 0 to 1, radius 1: vertices ``(V, 3)``, faces ``(F, 3)``."""
    a = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    ring = np.stack([np.cos(a), np.sin(a)], axis=1)
    verts = np.concatenate([np.c_[ring, np.zeros(segments)], np.c_[ring, np.ones(segments)], [[0, 0, 0], [0, 0, 1]]])
    faces = []
    for i in range(segments):
        j = (i + 1) % segments
        faces += [[i, j, segments + j], [i, segments + j, segments + i]]
        faces += [[2 * segments, j, i], [2 * segments + 1, segments + i, segments + j]]
    return verts.astype(np.float32), np.array(faces, dtype=np.uint32)


def _bones(graph: Graph) -> np.ndarray:
    """``(B, 2)`` parent → child joint pairs drawn as bones: every joint but the root, unless it sits on its parent."""
    skel = graph.skeleton
    pairs = [(int(skel.parents[j]), j) for j in range(1, skel.num_joints) if np.linalg.norm(skel.offsets[j]) > 0.01]
    body = skel.body_root()
    return np.array([p for p in pairs if p[1] != body], dtype=np.int64).reshape(-1, 2)


class Viewer:
    """A live page of ``creatures`` creatures per graph (side by side), served at ``http://host:port``."""

    def __init__(
        self, graphs: Graph | Sequence[Graph], creatures: int = 1, host: str = "127.0.0.1", port: int = 8080,
        fps: float = 60.0, seed: int = 0, plant: bool = True,
    ):  # fmt: skip
        import viser

        graphs = [graphs] if isinstance(graphs, Graph) else list(graphs)
        if isinstance(creatures, bool) or not isinstance(creatures, int) or not 1 <= creatures <= 100:
            raise AdverbsError(f"creatures must be a whole number from 1 to 100, got {creatures!r}")
        if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
            raise AdverbsError(f"port must be a whole number from 1 to 65535, got {port!r}")
        self.graphs = graphs
        self.sim = Simulation(graphs, fps=fps, seed=seed, plant=plant, record=False, realtime=True)
        n = 0
        for g in graphs:
            for _ in range(creatures):
                x = SPACING * (n - 0.5 * (creatures * len(graphs) - 1))
                self.sim.add_creature(at=(x, 0.0), heading=0.0, graph=g)
                n += 1
        self.creatures = self.sim.creatures
        self.commands: queue.Queue = queue.Queue(maxsize=MAX_QUEUED)
        self._messages: deque[str] = deque(maxlen=MESSAGES)  # what the page is told: refusals, clamps, commands
        self._messages_lock = threading.Lock()  # _say runs in the page's threads and the simulation's
        self.updates = 0  # frames sent to the page
        self.playing = True
        self.speed = 1.0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._shown_at: deque[float] = deque(maxlen=60)
        self._trails = {c.name: deque(maxlen=int(TRAIL_SECONDS * fps)) for c in self.creatures}
        self.positions: dict[str, np.ndarray] = {}  # world joint positions (J, 3) of each creature, last frame shown
        self._lock = threading.Lock()

        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.host, self.port = host, self.server.get_port()
        self.server.scene.set_up_direction("+y")
        width = SPACING * creatures * len(graphs)
        self.server.initial_camera.position = (0.6 * width + 2.5, 1.8, 4.0 + 0.4 * width)
        self.server.initial_camera.look_at = (0.0, LOOK_HEIGHT, 0.0)
        self._ground = self.server.scene.add_grid(
            "/ground", width=40.0, height=40.0, plane="xz", cell_size=0.5, section_size=GRID_SECTION
        )  # fmt: skip
        self._build_gui()
        self._bones = [_bones(g) for g in graphs]
        verts, faces = _cylinder()
        total = sum(len(b) * creatures for b in self._bones)
        colors = np.concatenate([np.tile(COLORS[k % len(COLORS)], (len(b) * creatures, 1)) for k, b in enumerate(self._bones)])
        self._bone_mesh = self.server.scene.add_batched_meshes_simple(
            "/bones", verts, faces, batched_wxyzs=np.tile([1.0, 0, 0, 0], (total, 1)),
            batched_positions=np.zeros((total, 3)), batched_scales=np.zeros((total, 3)), batched_colors=colors.astype(np.uint8),
        )  # fmt: skip
        feet = sum(len(g.feet) * creatures for g in graphs)
        ball_v, ball_f = _cylinder(12)
        self._feet_mesh = self.server.scene.add_batched_meshes_simple(
            "/feet", ball_v, ball_f, batched_wxyzs=np.tile([1.0, 0, 0, 0], (max(feet, 1), 1)),
            batched_positions=np.zeros((max(feet, 1), 3)), batched_scales=np.zeros((max(feet, 1), 3)), batched_colors=(255, 120, 0),
        )  # fmt: skip
        self._trail = self.server.scene.add_line_segments("/trails", np.zeros((1, 2, 3)), (90, 90, 90), thickness=0.02)

    # ----- the page -------------------------------------------------------------------------------------
    def _build_gui(self) -> None:
        gui = self.server.gui
        self._status = gui.add_markdown("starting…")
        self._said = gui.add_markdown("")
        names = ["all"] + [c.name for c in self.creatures]
        self._who = gui.add_dropdown("creature", names, initial_value="all") if len(self.creatures) > 1 else None
        self._sliders = {}
        adverbs = list(dict.fromkeys(a for g in self.graphs for a in g.adverb_names))
        with gui.add_folder("Adverbs"):
            for a in adverbs:
                lo, hi = self._range(a)
                g = next(g for g in self.graphs if a in g.adverb_names)
                start = float(g.defaults[g.adverb_names.index(a)])
                step = float(10 ** math.floor(math.log10(max(hi - lo, 1e-9) / 100)))
                s = gui.add_slider(a, min=lo, max=hi, step=step, initial_value=min(max(start, lo), hi))
                s.on_update(lambda event, a=a: self.apply({"adverb": a, "value": event.target.value}))
                self._sliders[a] = s
        with gui.add_folder("Verbs"):
            verbs = list(dict.fromkeys(v for g in self.graphs for v in g.verb_names))
            for v in verbs:
                gui.add_button(v).on_click(lambda _, v=v: self.apply({"perform": v}))
        with gui.add_folder("Playback"):
            play = gui.add_checkbox("playing", initial_value=True)
            play.on_update(lambda e: self.apply({"playing": e.target.value}))
            speed = gui.add_slider("speed", min=0.1, max=3.0, step=0.1, initial_value=1.0)
            speed.on_update(lambda e: self.apply({"speed": e.target.value}))
            ik = gui.add_checkbox("planted feet (IK)", initial_value=self.sim.plant)
            ik.on_update(lambda e: self.apply({"plant": e.target.value}))
            self._follow = gui.add_checkbox("camera follows", initial_value=True)
        self._command = gui.add_text("command", initial_value="", hint="a verb (run) or an adverb (valence=0.5), Enter")
        self._command.on_update(lambda e: self.apply({"text": e.target.value}) if e.target.value.strip() else None)

    def _range(self, adverb: str) -> tuple[float, float]:
        """The slider's range of ``adverb``: over the graphs that have it, the examples' span and the margin."""
        lo, hi = math.inf, -math.inf
        for g in self.graphs:
            if adverb in g.adverb_names:
                a, b = g.adverb_range(REACH)
                i = g.adverb_names.index(adverb)
                lo, hi = min(lo, float(a[i])), max(hi, float(b[i]))
        return lo, hi

    def _say(self, text: str) -> None:
        with self._messages_lock:
            self._messages.append(text)
            self._said.content = "\n\n".join(f"`{m}`" for m in self._messages)

    @property
    def messages(self) -> tuple[str, ...]:
        """The last messages shown on the page, oldest first."""
        with self._messages_lock:
            return tuple(self._messages)

    # ----- what the page asks -----------------------------------------------------------------------------
    def apply(self, message: dict) -> bool:
        """Check one request from the page and queue it for the simulation; False (and a message) if refused.

        ``{"adverb": NAME, "value": x}`` (clamped to the slider's range), ``{"perform": VERB}``,
        ``{"playing": bool}``, ``{"speed": x}``, ``{"plant": bool}``, ``{"text": "run" | "valence=0.5"}``.
        """
        try:
            request = self._check(message)
        except AdverbsError as e:
            self._say(f"refused: {e}")
            return False
        try:
            self.commands.put_nowait(request)
        except queue.Full:
            self._say(f"refused: {MAX_QUEUED} requests are waiting for the simulation; send this one again")
            return False
        return True

    def _check(self, message: dict) -> tuple:
        if not isinstance(message, dict):
            raise AdverbsError(f"not a request: {_short(message)}")
        if "text" in message:
            text = message["text"]
            if not isinstance(text, str):
                raise AdverbsError(f"a command is text, got {_short(text)}")
            text = text.strip()
            if "=" in text:
                name, _, value = text.partition("=")
                return self._check({"adverb": name.strip(), "value": value.strip()})
            return self._check({"perform": text})
        if "adverb" in message:
            name = message["adverb"]
            if not isinstance(name, str) or name not in self._sliders:
                raise AdverbsError(f"no adverb {_short(name)}; there are {', '.join(self._sliders)}")
            if "value" not in message:
                raise AdverbsError(f"{name}: no value")
            value = _number(message["value"], name)
            lo, hi = self._range(name)
            kept = min(max(value, lo), hi)
            if kept != value:
                self._say(f"{name}={value:g} clamped to {kept:g} (the examples' range and its margin)")
            return ("adverb", name, kept)
        if "perform" in message:
            verb = message["perform"]
            if not any(isinstance(verb, str) and verb in g.verb_names for g in self.graphs):
                raise AdverbsError(f"no verb {_short(verb)}; there are {', '.join(dict.fromkeys(v for g in self.graphs for v in g.verb_names))}")  # fmt: skip
            return ("perform", verb)
        for switch in ("playing", "plant"):
            if switch in message:
                if not isinstance(message[switch], bool):
                    raise AdverbsError(f"{switch} must be true or false, got {_short(message[switch])}")
                return (switch, message[switch])
        if "speed" in message:
            speed = _number(message["speed"], "speed")
            if not speed > 0:
                raise AdverbsError(f"speed must be a positive number, got {speed:g}")
            return ("speed", min(max(speed, 0.1), 3.0))
        raise AdverbsError(f"unknown request with keys {_short(list(message))}")

    def _targets(self):
        who = self._who.value if self._who is not None else "all"
        return [c for c in self.creatures if who in ("all", c.name)]

    def _drain(self, sim: Simulation) -> None:
        """Carry out the queued requests, in the simulation's thread, between frames: at most :data:`MAX_QUEUED` at a
        time (a page that keeps sending cannot hold up the frame), each on its own (one that fails is refused and
        the simulation goes on)."""
        for _ in range(MAX_QUEUED):
            try:
                request = self.commands.get_nowait()
            except queue.Empty:
                break
            try:
                self._carry_out(request, sim)
            except Exception as e:  # noqa: BLE001 - whatever one request does, the simulation thread must go on
                self._say(f"refused: {request[0]}: {type(e).__name__}: {_short(str(e))}")
        if len(sim.log) > 2 * LOG_KEPT:  # in the thread that appends to it
            del sim.log[:-LOG_KEPT]

    def _carry_out(self, request: tuple, sim: Simulation) -> None:
        kind = request[0]
        if kind == "adverb":
            for c in self._targets():
                if request[1] in c.graph.adverb_names:
                    try:
                        c.set_adverbs({request[1]: request[2]}, over=0.3)
                    except AdverbsError as e:
                        self._say(f"{c.name}: refused: {e}")
        elif kind == "perform":
            for c in self._targets():
                if request[1] in c.graph.verb_names:
                    try:
                        c.perform(request[1])
                        self._say(f"{c.name}: {request[1]} queued")
                    except AdverbsError as e:
                        self._say(f"{c.name}: refused: {e}")
        elif kind == "plant":
            sim.plant = request[1]
        elif kind == "playing":
            self.playing = request[1]
        elif kind == "speed":
            self.speed = request[1]

    # ----- the loop -----------------------------------------------------------------------------------------
    def _show(self, sim: Simulation) -> None:
        """Send the frame just shown to the page: bones, held feet, trails, status."""
        positions, directions, scales, feet_at = [], [], [], []
        for k, g in enumerate(self.graphs):
            mine = [c for c in self.creatures if c.graph is g]
            group = mine[0]._group
            pos, _ = forward_kinematics(g.skeleton.parents, group.rotations, group.translations)  # (C, J, 3)
            bones = self._bones[k]
            start, end = pos[:, bones[:, 0]], pos[:, bones[:, 1]]
            d = (end - start).reshape(-1, 3)
            positions.append(start.reshape(-1, 3))
            directions.append(d)
            length = np.linalg.norm(d, axis=1)
            scales.append(np.stack([np.full_like(length, BONE_RADIUS), np.full_like(length, BONE_RADIUS), length], axis=1))
            tips = list(g.feet)
            if group.feet is not None and sim.plant and tips:
                held = group.feet.mode != FREE  # (C, L)
                on_ground = pos[:, tips] * [1.0, 0.0, 1.0] + [0.0, 0.004, 0.0]  # a disc on the floor under the held toe
                feet_at.append(np.where(held[..., None], on_ground, np.nan).reshape(-1, 3))
            elif tips:
                feet_at.append(np.full((len(mine) * len(tips), 3), np.nan))
            body = g.skeleton.body_root()
            with self._lock:
                for i, c in enumerate(mine):
                    self.positions[c.name] = pos[i]
                    self._trails[c.name].append((pos[i, body, 0], 0.005, pos[i, body, 2]))
        d = np.concatenate(directions)
        feet = np.concatenate(feet_at) if feet_at else np.full((1, 3), np.nan)
        shown = np.isfinite(feet[:, 0])
        with self.server.atomic():
            self._bone_mesh.batched_positions = np.concatenate(positions).astype(np.float32)
            self._bone_mesh.batched_wxyzs = quat.between(UP_Z, d)[:, [3, 0, 1, 2]].astype(np.float32)  # viser: (w, x, y, z)
            self._bone_mesh.batched_scales = np.concatenate(scales).astype(np.float32)
            self._feet_mesh.batched_positions = np.where(shown[:, None], feet, 0.0).astype(np.float32)
            self._feet_mesh.batched_scales = np.where(shown[:, None], [0.06, 0.06, 0.006], 0.0).astype(np.float32)
            self._feet_mesh.batched_wxyzs = np.tile(np.float32([0.7071068, -0.7071068, 0, 0]), (len(feet), 1))  # discs flat
            segments = [np.stack([np.array(t)[:-1], np.array(t)[1:]], axis=1) for t in self._trails.values() if len(t) > 1]
            if segments:
                self._trail.points = np.concatenate(segments).astype(np.float32)
        if self.updates % FOLLOW_EVERY == 0:
            self._follow_camera()
        now = time.perf_counter()
        self._shown_at.append(now)
        self.updates += 1
        if self.updates % 10 == 0:
            lines = [f"**{self.rate:.0f} frames/s** · t = {sim.time:.1f} s · speed {self.speed:g}× · feet {'planted' if sim.plant else 'free'}"]
            lines += [f"- {c.name}: {c.playing}" for c in self.creatures[:12]]
            self._status.content = "\n".join(lines)

    def _follow_camera(self) -> None:
        """Keep the creatures in view as they travel: every page's camera looks at the creatures' middle, from where
        its viewer has orbited and zoomed to (the camera's offset from what it looks at is kept), and the ground grid
        moves with them in whole grid sections. ``camera follows`` off: the cameras stay where they are."""
        with self._lock:
            ends = [t[-1] for t in self._trails.values() if t]
        if not ends or not self._follow.value:
            return
        middle = np.mean(ends, axis=0)
        target = np.array([middle[0], LOOK_HEIGHT, middle[2]])
        if not np.all(np.isfinite(target)):
            return
        for client in self.server.get_clients().values():
            look = np.asarray(client.camera.look_at, dtype=float)
            if np.abs(look - target).max() > 1e-3:  # viser moves what the camera looks at with its position
                client.camera.position = np.asarray(client.camera.position, dtype=float) + (target - look)
        self._ground.position = (GRID_SECTION * round(middle[0] / GRID_SECTION), 0.0, GRID_SECTION * round(middle[2] / GRID_SECTION))

    @property
    def rate(self) -> float:
        """Frames sent to the page per second, over the last ones."""
        t = self._shown_at
        return (len(t) - 1) / (t[-1] - t[0]) if len(t) > 1 and t[-1] > t[0] else 0.0

    def _loop(self) -> None:
        while not self._stop.is_set():
            self._drain(self.sim)
            if not self.playing:
                time.sleep(0.05)
                continue
            self.sim.clock.speed = self.speed
            self.sim.run(0.5 * self.speed, on_frame=self._show, on_render=self._drain)

    def start(self) -> Viewer:
        """Run the simulation in a background thread (the page is served already)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._loop, name="adverbs-viewer", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self.server.stop()

    @property
    def url(self) -> str:
        return f"http://{'127.0.0.1' if self.host in ('0.0.0.0', '') else self.host}:{self.port}"


def load_for_view(target: str | Path | None, progress: bool = True):
    """The graphs to show: a graph spec (default the shipped Bandai graph), or one verb — a verb spec (built now) or a
    built verb file — as a graph of its own that plays it over and over (:meth:`Graph.of_verb`)."""
    from ..graph import Graph, load_graph
    from ..verb.fit import verb_from
    from ..verb.spec import read_toml

    root = Path(__file__).resolve().parents[3]
    path = Path(target) if target is not None else root / "graphs" / "bandai.toml"
    if path.suffix.lower() == ".toml" and "verbs" in read_toml(path, "graph or verb spec", lambda p, why: AdverbsError(f"{p}: {why}")):
        return [load_graph(path, progress=progress)]
    if progress:
        print(f"building {path}" if path.suffix.lower() == ".toml" else f"loading {path}", file=sys.stderr)
    return [Graph.of_verb(verb_from(path), source=str(path))]
