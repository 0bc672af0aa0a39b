"""A run's recording kept on disk as it goes, so memory stays flat whatever the run's length.

A :class:`Spool` holds one group of creatures' frames: every frame shown is appended (a few dozen at a time) to a
file of ``(C, J, 7)`` float64 rows — each joint's local rotation then translation, bit for bit what was shown —
and the planter's modes and turns per foot to another. Nothing is kept in memory but the batch being filled. A
creature's clip is read back alone when it is written (:meth:`Spool.creature`), so writing a long run holds one
creature's frames at a time, not the whole crowd's. The files live in a temporary folder of the simulation's,
removed when it is closed or collected, or when the process ends.
"""

from __future__ import annotations

import shutil
import tempfile
import weakref
from pathlib import Path

import numpy as np

from ..errors import AdverbsError

BATCH = 64  # frames held in memory before they are appended to the file
READ_BYTES = 4 << 20  # bytes read at a time when a creature's frames are read back


class Folder:
    """A temporary folder for a simulation's spools, removed by :meth:`close`, when collected, or at exit."""

    def __init__(self) -> None:
        self.path = Path(tempfile.mkdtemp(prefix="adverbs-recording-"))
        self._remove = weakref.finalize(self, shutil.rmtree, str(self.path), True)

    def close(self) -> None:
        self._remove()


class Spool:
    """The frames of ``creatures`` creatures of a ``joints``-joint skeleton with ``feet`` planted feet, on disk in
    ``folder`` (see the module). :attr:`frames` counts the frames appended."""

    def __init__(self, folder: Path, name: str, creatures: int, joints: int, feet: int):
        self.shape = (int(creatures), int(joints), 7)
        self.feet = int(feet)
        self.frames = 0
        self._poses = folder / f"{name}.poses.f8"
        self._modes_path = folder / f"{name}.modes.i1"
        self._turns_path = folder / f"{name}.turns.f8"
        try:  # kept open while recording
            self._files = tuple(open(p, "wb") for p in (self._poses, self._modes_path, self._turns_path))  # noqa: SIM115
        except OSError as e:
            raise AdverbsError(f"{folder}: cannot write the recording kept as the run goes: {e.strerror or e}") from None
        # Closed by close(), or when the spool is collected: a simulation never closed (dropped by its caller) left its
        # three files open until exit, and Python warned of each as the collector found it, inside whatever ran then.
        self._close = weakref.finalize(self, _close_all, self._files)
        self._batch = np.empty((BATCH, *self.shape))
        self._modes = np.empty((BATCH, creatures, feet), dtype=np.int8)
        self._turns = np.empty((BATCH, creatures, feet))
        self._n = 0  # frames in the batch, not yet on disk
        self._flushed = 0  # frames on disk

    def append(self, rotations: np.ndarray, translations: np.ndarray, modes: np.ndarray | None, turns: np.ndarray | None) -> None:
        """One frame: rotations ``(C, J, 4)``, translations ``(C, J, 3)`` and the planter's modes and turns ``(C, L)``
        (None: no planter, or planting off: every foot free)."""
        k = self._n
        if k == BATCH:  # a flush was cut short: written again first
            self.flush()
            k = self._n
        self._batch[k, :, :, :4] = rotations
        self._batch[k, :, :, 4:] = translations
        if modes is None:
            self._modes[k], self._turns[k] = 0, 0.0
        else:
            self._modes[k], self._turns[k] = modes, turns
        self._n += 1
        self.frames += 1

    @property
    def full(self) -> bool:
        """Whether the frames held in memory are a whole batch, to :meth:`flush` (the caller's to do, after every group
        has its frame: an interrupted flush then loses no group's frame)."""
        return self._n >= BATCH

    def flush(self) -> None:
        """Append the frames held in memory to the files."""
        if not self._n:
            return
        n = self._n
        try:
            for f, rows in zip(self._files, (self._batch, self._modes, self._turns)):
                # From where the frames on disk end: a flush cut short (Ctrl-C, a full disk) is written again whole.
                f.seek(self._flushed * rows[0].nbytes)
                rows[:n].tofile(f)
                f.truncate()
                f.flush()
        except OSError as e:
            raise AdverbsError(f"{self._poses.parent}: cannot write the recording kept as the run goes: {e.strerror or e}") from None
        self._flushed += n
        self._n = 0

    def creature(self, c: int) -> tuple[np.ndarray, np.ndarray]:
        """Creature ``c``'s recorded rotations ``(F, J, 4)`` and translations ``(F, J, 3)``."""
        self.flush()
        j = self.shape[1]
        rot, trans = np.empty((self.frames, j, 4)), np.empty((self.frames, j, 3))
        frame = int(np.prod(self.shape))  # float64s a frame, every creature
        step = max(1, READ_BYTES // (8 * frame))
        with open(self._poses, "rb") as f:  # read a block of frames at a time: a mapped file's pages would all stay
            for start in range(0, self.frames, step):
                n = min(step, self.frames - start)
                block = np.fromfile(f, dtype=np.float64, count=n * frame).reshape(n, *self.shape)
                rot[start : start + n] = block[:, c, :, :4]
                trans[start : start + n] = block[:, c, :, 4:]
        return rot, trans

    def blocks(self, c: int):
        """Creature ``c``'s recorded rotations and translations, a block of frames at a time (as many as fit in
        ``READ_BYTES`` for every creature): ``(n, J, 4)``, ``(n, J, 3)``."""
        self.flush()
        frame = int(np.prod(self.shape))
        frames = max(1, READ_BYTES // (8 * frame))
        with open(self._poses, "rb") as f:
            for start in range(0, self.frames, frames):
                n = min(frames, self.frames - start)
                block = np.fromfile(f, dtype=np.float64, count=n * frame).reshape(n, *self.shape)
                yield np.ascontiguousarray(block[:, c, :, :4]), np.ascontiguousarray(block[:, c, :, 4:])

    def held(self, c: int) -> tuple[np.ndarray, np.ndarray]:
        """Creature ``c``'s planter modes ``(F, L)`` and turns ``(F, L)``, frame by frame."""
        self.flush()
        shape = (self.frames, self.shape[0], self.feet)
        modes = np.fromfile(self._modes_path, dtype=np.int8).reshape(shape)
        turns = np.fromfile(self._turns_path, dtype=np.float64).reshape(shape)
        return modes[:, c].copy(), turns[:, c].copy()

    def close(self) -> None:
        """Close the files (the folder they are in is removed with it)."""
        self._close()


def _close_all(files) -> None:
    for f in files:
        f.close()


class EventLog:
    """A simulation's log (commands, refusals, transitions, arrivals: one dict each), read as a list — iterated,
    indexed, counted, compared — and kept on disk as JSON lines once past :data:`IN_MEMORY` entries, so a long run's
    log does not grow in memory. ``folder()`` gives the folder to keep it in (made when first needed)."""

    IN_MEMORY = 4096  # entries held in memory before they are appended to the file

    def __init__(self, folder) -> None:
        self._folder = folder
        self._path: Path | None = None
        self._on_disk = 0
        self._recent: list[dict] = []

    def append(self, entry: dict) -> None:
        self._recent.append(entry)
        if len(self._recent) >= self.IN_MEMORY:
            self._spill()

    def _spill(self) -> None:
        import json

        if self._path is None:
            self._path = self._folder() / "events.jsonl"
        try:
            with open(self._path, "a", encoding="utf-8") as f:
                f.write("".join(json.dumps(e) + "\n" for e in self._recent))
        except OSError as e:
            raise AdverbsError(f"{self._path}: cannot write the log kept as the run goes: {e.strerror or e}") from None
        self._on_disk += len(self._recent)
        self._recent = []

    def __len__(self) -> int:
        return self._on_disk + len(self._recent)

    def __iter__(self):
        import json

        recent = list(self._recent)  # what was in memory when the reading began
        if self._on_disk:
            with open(self._path, encoding="utf-8") as f:
                for _, line in zip(range(self._on_disk), f):
                    yield json.loads(line)
        yield from recent

    def __getitem__(self, k):
        if isinstance(k, slice):
            return list(self)[k]
        n = len(self)
        k = k + n if k < 0 else k
        if not 0 <= k < n:
            raise IndexError("log index out of range")
        if k >= self._on_disk:
            return self._recent[k - self._on_disk]
        return next(e for i, e in enumerate(self) if i == k)

    def __delitem__(self, k) -> None:
        kept = list(self)
        del kept[k]
        self.clear()
        self._recent = kept  # (a trimmed log: the viewer keeps its last entries)

    def to_memory(self) -> None:
        """Hold every entry in memory again (its file is about to go)."""
        entries = list(self)
        self.clear()
        self._recent = entries

    def clear(self) -> None:
        if self._path is not None:
            self._path.unlink(missing_ok=True)
        self._path = None  # made again (in the folder of the moment) when next needed
        self._on_disk, self._recent = 0, []

    def __eq__(self, other) -> bool:
        return isinstance(other, EventLog | list) and list(self) == list(other)

    def __repr__(self) -> str:
        return f"EventLog({len(self)} entries)"
