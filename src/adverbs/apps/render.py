"""Pictures of motion: figures drawn as bones on a floor grid, foot contacts marked, the root's path trailing.

:func:`render` writes an animation (``.gif``, ``.mp4``) or a filmstrip (``.png``: evenly spaced frames side by
side) of one or more clips seen from a chosen camera (an orthographic view from an azimuth and elevation).
Matplotlib draws each frame; Pillow encodes a GIF, imageio's FFmpeg plugin an MP4.

The camera follows the figures (the mean of their roots, smoothed) and widens to keep them all in view;
``follow=False`` frames the whole motion once. Left limbs are blue, right red, each figure's trunk its own
colour; a foot on the ground (found from its height and speed, :func:`adverbs.motion.contacts.find_contacts`)
is marked with a dot on the floor. The floor is level by default; given a :class:`~adverbs.kinematics.floor.Floor`
(a slope, a height map) its grid, the dots and the trail follow its surface.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import AdverbsError
from ..io.files import atomic_path
from ..kinematics.floor import LEVEL_LIMIT, FlatFloor, Floor
from ..motion.clip import Clip
from ..motion.contacts import find_contacts

CAMERAS = {"three-quarter": (40.0, 18.0), "side": (90.0, 4.0), "front": (0.0, 4.0), "back": (180.0, 4.0), "top": (0.0, 89.0)}
FORMATS = (".gif", ".mp4", ".png")
TRUNK = ("0.25", "tab:green", "tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:pink", "tab:orange")
MAX_DISTANCE = LEVEL_LIMIT  # metres from the origin: joints farther than this are not drawn (a damaged file)
MAX_FRAMES = 20_000
GRID_SAMPLES = 48  # points along each grid line on a floor that is not level


def camera(name: str) -> tuple[float, float]:
    """Azimuth and elevation (degrees) of a named camera (``three-quarter``, ``side``, ``front``, ``back``, ``top``) or of
    ``"AZ,EL"``; the camera looks from there at the figures (azimuth 0: from +z, 90: from +x)."""
    if name in CAMERAS:
        return CAMERAS[name]
    try:
        az, el = (float(x) for x in name.split(","))
    except ValueError:
        raise AdverbsError(f"camera must be one of {', '.join(CAMERAS)} or AZIMUTH,ELEVATION in degrees, got {name!r}") from None
    if not (np.isfinite(az) and np.isfinite(el) and -90.0 <= el <= 90.0):
        raise AdverbsError(f"camera elevation must be from -90 to 90 degrees, got {name!r}")
    return az, el


@dataclass
class _Figure:
    """One clip ready to draw: world positions ``(F, J, 3)``, parents, colours per bone, contacts, trail joint."""

    positions: np.ndarray
    parents: np.ndarray
    bones: list[int]
    colours: list
    feet: list[int]
    planted: np.ndarray
    trail: int
    fps: float


def _figure(clip: Clip, k: int, floor: Floor | None = None) -> _Figure:
    pos = clip.global_positions()
    skel = clip.skeleton
    trunk = TRUNK[k % len(TRUNK)]
    colours = [{"left": "tab:blue", "right": "tab:red"}.get(skel.side(j), trunk) for j in range(skel.num_joints)]
    try:
        contacts = find_contacts(clip, floor=floor)
        feet = [f.toe if f.toe is not None else f.ankle for f in contacts.feet]
        planted = contacts.planted
    except AdverbsError:  # no feet named: nothing to mark
        feet, planted = [], np.zeros((clip.num_frames, 0), dtype=bool)
    travel = np.linalg.norm(np.diff(pos[:, : min(3, skel.num_joints)][..., [0, 2]], axis=0), axis=-1).sum(axis=0)
    # bones: joints a rigid link from their parent (a root that stays at the origin while the hips travel is none)
    bones = []
    for j, p in enumerate(skel.parents):
        if p >= 0:
            length = np.linalg.norm(pos[:, j] - pos[:, p], axis=-1)
            if length.max() > 1e-6 and np.ptp(length) < 0.01:
                bones.append(j)
    return _Figure(pos, skel.parents, bones, colours, feet, planted, int(np.argmax(travel)), clip.fps)


def _basis(az: float, el: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a, e = np.radians(az), np.radians(el)
    eye = np.array([np.sin(a) * np.cos(e), np.sin(e), np.cos(a) * np.cos(e)])
    up_world = np.array([0.0, 1.0, 0.0]) if abs(el) < 89.9 else np.array([-np.sin(a), 0.0, -np.cos(a)])
    right = np.cross(up_world, eye)
    right /= np.linalg.norm(right)
    return right, np.cross(eye, right), eye


class _Painter:
    """Draws frames of figures into one matplotlib axes: its artists are made once and moved frame after frame."""

    def __init__(self, ax, figures: Sequence[_Figure], az: float, el: float, floor: Floor, trail: float):
        self.figures, self.floor, self.trail = figures, floor, trail
        self.right, self.up, self.eye = _basis(az, el)
        self.attach(ax)

    def attach(self, ax) -> None:
        """Draw into ``ax`` from now on (a filmstrip's next panel)."""
        from matplotlib.collections import LineCollection

        self.ax = ax
        ax.set_axis_off()
        ax.set_aspect("equal")
        self.grid = ax.add_collection(LineCollection([], colors="0.85", linewidths=0.6, zorder=0))
        self.bones = ax.add_collection(LineCollection([], linewidths=2.2, capstyle="round", zorder=3))
        self.trails = [ax.plot([], [], color="0.55", lw=1.2, zorder=1)[0] for _ in self.figures]
        self.spots = ax.plot([], [], "o", color="tab:orange", ms=5, zorder=2)[0]
        self.clock = ax.text(0.01, 0.98, "", transform=ax.transAxes, va="top", fontsize=9, color="0.3")

    def project(self, p: np.ndarray) -> np.ndarray:
        return np.stack([p @ self.right, p @ self.up], axis=-1)

    def _on_floor(self, xz: np.ndarray) -> np.ndarray:
        """Points ``(..., 3)`` on the floor's surface below horizontal positions ``xz (..., 2)``."""
        return np.stack([xz[..., 0], self.floor.height(xz), xz[..., 1]], axis=-1)

    def draw(self, t: float, centre: np.ndarray, half: float, aspect: float, title: str = "", clock: bool = False) -> None:
        ax = self.ax
        step = 1.0 if half < 12 else 5.0 if half < 60 else 10.0 ** np.ceil(np.log10(half / 6))  # the floor: a grid
        x0, z0 = np.floor((centre[[0, 2]] - 2 * half) / step) * step
        n = int(np.ceil(4 * half / step)) + 1
        ticks = np.arange(n + 1) * step
        along = np.linspace(0.0, n * step, 2 if self.floor.is_flat else GRID_SAMPLES)
        a, b = np.meshgrid(ticks, along, indexing="ij")  # (lines, points): a line's offset, a point's along it
        xz = np.concatenate([np.stack([x0 + a, z0 + b], axis=-1), np.stack([x0 + b, z0 + a], axis=-1)])
        self.grid.set_segments(self.project(self._on_floor(xz)))
        segments, colours, depths, spots = [], [], [], []
        for fig, line in zip(self.figures, self.trails):
            f = min(int(round(t * fig.fps)), len(fig.positions) - 1)
            pos = fig.positions[f]
            if self.trail > 0:
                a = max(0, f - int(self.trail * fig.fps))
                line.set_data(*self.project(self._on_floor(fig.positions[a : f + 1, fig.trail][:, [0, 2]])).T)
            for i, j in enumerate(fig.feet):
                if fig.planted[f, i]:
                    spots.append(self.project(self._on_floor(pos[j, [0, 2]])))
            for j in fig.bones:
                p = fig.parents[j]
                segments.append(self.project(pos[[p, j]]))
                colours.append(fig.colours[j])
                depths.append(0.5 * (pos[p] + pos[j]) @ self.eye)
        order = np.argsort(depths)
        self.bones.set_segments([segments[i] for i in order])
        self.bones.set_color([colours[i] for i in order])
        self.spots.set_data(*(np.array(spots).T if spots else ([], [])))
        c = self.project(centre)
        ax.set_xlim(c[0] - half, c[0] + half)
        ax.set_ylim(c[1] - half / aspect, c[1] + half / aspect)
        self.clock.set_text(f"{t:5.1f} s" if clock else "")
        if title:
            ax.set_title(title, fontsize=9)


def _framing(figures: Sequence[_Figure], times: np.ndarray, follow: bool, painter: _Painter, aspect: float):
    """Per output time: the point the camera looks at ``(T, 3)`` and the half-width of the view ``(T,)``."""
    roots = np.stack([
        np.stack([f.positions[min(int(round(t * f.fps)), len(f.positions) - 1), f.trail] for f in figures]) for t in times
    ])  # fmt: skip (T, K, 3)
    if not follow:
        flat = painter.project(np.concatenate([f.positions.reshape(-1, 3) for f in figures]))
        lo, hi = flat.min(axis=0), flat.max(axis=0)
        centre_2d = 0.5 * (lo + hi)
        half = 0.55 * max(hi[0] - lo[0], (hi[1] - lo[1]) * aspect, 1.0)
        # a point whose projection is the centre of the view
        centre = centre_2d[0] * painter.right + centre_2d[1] * painter.up
        return np.tile(centre, (len(times), 1)), np.full(len(times), half)
    frames = [[f.positions[min(int(round(t * f.fps)), len(f.positions) - 1), :, 1] for f in figures] for t in times]
    lows = np.array([min(y.min() for y in ys) for ys in frames])  # (T,): the lowest joint shown at each time
    height = float(max(max(y.max() for y in ys) - low for ys, low in zip(frames, lows)))  # the tallest at one time
    centre = roots.mean(axis=1)
    centre[:, 1] = lows
    spread = np.linalg.norm((roots - centre[:, None])[..., [0, 2]], axis=-1).max(axis=1)
    # smoothed both ways (a critically damped look-at would lag): a moving average over about a second
    width = max(1, int(round(len(times) / max(times[-1] - times[0], 1e-9)))) if len(times) > 1 else 1
    kernel = np.ones(width) / width
    pad = lambda x: np.concatenate([np.repeat(x[:1], width // 2, 0), x, np.repeat(x[-1:], width - 1 - width // 2, 0)])  # noqa: E731
    centre = np.stack([np.convolve(pad(centre[:, i]), kernel, mode="valid") for i in range(3)], axis=1)
    spread = np.convolve(pad(spread), kernel, mode="valid")
    centre[:, 1] += 0.5 * height  # up and down with the ground under them (a slope), smoothed
    half = np.maximum(spread + 0.6 * height, 0.7 * height * aspect)
    return centre, half


def render(
    clips: Sequence[Clip],
    output: str | Path,
    view: str = "three-quarter",
    fps: float | None = None,
    size: tuple[int, int] = (640, 400),
    panels: int = 8,
    follow: bool = True,
    trail: float = 4.0,
    floor: float | Floor | None = None,
    split: bool = False,
    progress: Callable[[int, int], object] | None = None,
    at: Sequence[float] | None = None,
) -> Path:
    """Draw ``clips`` (one scene: they play together from time 0) into ``output``: ``.gif`` or ``.mp4`` (every frame
    at ``fps``, default the first clip's up to 30) or ``.png`` (``panels`` evenly spaced frames). ``view``: a
    named camera or ``"AZ,EL"``; ``trail``: seconds of root path shown (0: none); ``floor``: the ground, a
    :class:`~adverbs.kinematics.floor.Floor` (the one the feet were planted on) or a level's height (default: level
    at 0, or where the feet are if they stand well off it); ``split``: each clip in its own view, side by
    side (a filmstrip: a row each), rather than all in one; ``at``: a filmstrip's panel times in seconds (instead of
    ``panels`` evenly spaced)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    output = Path(output)
    if output.suffix.lower() not in FORMATS:
        raise AdverbsError(f"{output}: pictures are written as {', '.join(FORMATS)}, not {output.suffix or 'no extension'!r}")
    if not clips:
        raise AdverbsError("nothing to render: give one clip or more")
    az, el = camera(view)
    figures = [_figure(c, k, floor if isinstance(floor, Floor) else None) for k, c in enumerate(clips)]
    for c, f in zip(clips, figures):
        far = float(np.abs(f.positions).max(initial=0.0))
        if not far <= MAX_DISTANCE:  # NaN too
            raise AdverbsError(
                f"clip {c.name!r}: a joint is {far:.3g} m from the origin; pictures show motion within {MAX_DISTANCE:g} m"
            )
    if floor is None:
        lowest = float(np.percentile(np.concatenate([f.positions[..., 1].min(axis=1) for f in figures]), 2))
        floor = 0.0 if abs(lowest) < 0.1 else lowest
    if not isinstance(floor, Floor):
        floor = FlatFloor(floor)
    seconds = max((len(f.positions) - 1) / f.fps for f in figures)
    fps = min(clips[0].fps, 30.0) if fps is None else float(fps)
    if not (np.isfinite(fps) and 0 < fps <= 120):
        raise AdverbsError(f"fps must be a number from 0 to 120, got {fps}")
    w, h = (int(s) for s in size)
    if not (16 <= w <= 4096 and 16 <= h <= 4096):
        raise AdverbsError(f"size must be from 16 to 4096 pixels each way, got {w}x{h}")
    still = output.suffix.lower() == ".png"
    if still:
        if at is not None:
            times = np.asarray(at, dtype=float).reshape(-1)
            if not (1 <= len(times) <= 64 and np.all(np.isfinite(times))):
                raise AdverbsError(f"at: 1 to 64 finite panel times, got {len(times)}")
            times = np.clip(times, 0.0, seconds)
            panels = len(times)
        elif not 1 <= panels <= 64:
            raise AdverbsError(f"panels must be from 1 to 64, got {panels}")
        else:
            times = np.linspace(0.0, seconds, panels)
    else:
        n = int(np.floor(seconds * fps + 1e-9)) + 1
        if n > MAX_FRAMES:
            raise AdverbsError(f"{seconds:.1f} s at {fps:g} fps is {n:,} frames; render at most {MAX_FRAMES:,} (a lower --fps)")
        times = np.arange(n) / fps
    w, h = w + w % 2, h + h % 2  # video encoders want even sizes
    output.parent.mkdir(parents=True, exist_ok=True)
    scenes = [[f] for f in figures] if split else [figures]  # who shares a view
    names = [c.name for c in clips] if split else [""]
    if still:
        cols = min(panels, 4) if len(scenes) == 1 else panels
        rows = int(np.ceil(panels / cols)) * len(scenes)
        fig = Figure(figsize=(cols * w / 200, rows * h / 200 * 1.1), dpi=100)
        axes = fig.subplots(rows, cols, squeeze=False)
        aspect = w / h
        per = rows // len(scenes)
        for k, scene in enumerate(scenes):
            cells = axes[k * per : (k + 1) * per].ravel()
            painter = _Painter(cells[0], scene, az, el, floor, trail)
            centres, halves = _framing(scene, times, follow, painter, aspect)
            for i, ax in enumerate(cells):
                if i >= len(times):
                    ax.set_axis_off()
                    continue
                if i:
                    painter.attach(ax)
                label = f"{names[k]}, {times[i]:.1f} s" if names[k] else f"{times[i]:.1f} s"
                painter.draw(times[i], centres[i], halves[i], aspect, label)
                if progress:
                    progress(k * len(times) + i + 1, len(times) * len(scenes))
        fig.tight_layout()
        with atomic_path(output) as tmp:
            fig.savefig(tmp, dpi=100)
        return output
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=(w / 100, h / 100), dpi=100)
    FigureCanvasAgg(fig)
    width = 1.0 / len(scenes)
    aspect = w / h / len(scenes)
    painters, framings = [], []
    for k, scene in enumerate(scenes):
        ax = fig.add_axes((k * width, 0, width, 1))
        painters.append(_Painter(ax, scene, az, el, floor, trail))
        framings.append(_framing(scene, times, follow, painters[-1], aspect))
        if names[k]:
            ax.text(0.5, 0.98, names[k], transform=ax.transAxes, ha="center", va="top", fontsize=10)
    frames = np.empty((len(times), h, w, 3), dtype=np.uint8)
    for i, t in enumerate(times):
        for k, painter in enumerate(painters):
            centres, halves = framings[k]
            painter.draw(t, centres[i], halves[i], aspect, clock=k == 0)
        fig.canvas.draw()
        frames[i] = np.asarray(fig.canvas.buffer_rgba())[:h, :w, :3]
        if progress:
            progress(i + 1, len(times))
    _encode(frames, output, fps)
    return output


def _encode(frames: np.ndarray, output: Path, fps: float) -> None:
    """Write ``frames (T, H, W, 3)`` to ``output`` (GIF or MP4) through a temporary file, so a failed write leaves
    what was there. A GIF takes one palette for every frame (made from a few of them: the pictures have few
    colours), which is much faster than a palette per frame and does not flicker."""
    with atomic_path(output) as tmp:
        if output.suffix.lower() == ".gif":
            from PIL import Image

            from matplotlib.colors import to_rgb

            sample = frames[np.linspace(0, len(frames) - 1, min(len(frames), 8)).astype(int)]
            named = ["tab:blue", "tab:red", "tab:orange", "0.55", "0.85", *TRUNK]  # each colour drawn, whole
            swatch = np.repeat((255 * np.array([to_rgb(c) for c in named])).astype(np.uint8)[None], 64, axis=0)
            swatch = np.repeat(swatch, frames.shape[2] // len(named) + 1, axis=1)[:, : frames.shape[2]]
            palette = Image.fromarray(np.concatenate([*sample, swatch], axis=0)).quantize(colors=64, method=Image.Quantize.MEDIANCUT)
            images = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
            images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=round(1000.0 / fps), loop=0)
        else:
            import imageio.v2 as imageio

            with imageio.get_writer(tmp, format="FFMPEG", fps=fps, codec="libx264", quality=7, macro_block_size=2) as w:
                for f in frames:
                    w.append_data(f)
