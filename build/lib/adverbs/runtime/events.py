"""The discrete-event loop of §6: events in timestamp order, three kinds, and the two clocks they run against.

An :class:`Event` has a timestamp, a kind and a callback. The :class:`EventQueue` hands them out in
timestamp order, ties in the order they were pushed. :func:`run_events` processes them against a clock:

* ``NORMAL`` events run when they are reached, whatever the clock says;
* ``SYNC`` events wait for the clock to reach their timestamp (at once if it is already past it);
* ``OPTIONAL`` events are skipped when the clock has passed their timestamp, otherwise run like normal ones.

Two clocks: :class:`WallClock` is real time (seconds since it started, times a speed), and waiting on it
sleeps; :class:`VirtualClock` is the time of the last sync event reached, so waiting on it costs nothing and a
run is as fast as the machine allows and the same every time.
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from ..errors import AdverbsError

NORMAL, SYNC, OPTIONAL = "normal", "sync", "optional"
KINDS = (NORMAL, SYNC, OPTIONAL)
LATE = 1e-9  # seconds: an optional event this close behind the clock is not yet late


@dataclass(order=True)
class Event:
    """At ``time`` seconds, call ``callback(time)``; ``seq`` orders ties (the order events were pushed)."""

    time: float
    seq: int
    kind: str = field(compare=False)
    callback: Callable[[float], object] = field(compare=False)
    name: str = field(default="", compare=False)


class EventQueue:
    """Events in timestamp order, ties in insertion order."""

    def __init__(self) -> None:
        self._heap: list[Event] = []
        self._seq = 0

    def push(self, at: float, callback: Callable[[float], object], kind: str = NORMAL, name: str = "") -> Event:
        at = float(at)
        if not math.isfinite(at):
            raise AdverbsError(f"event {name or callback!r}: its time must be a finite number of seconds, got {at}")
        if kind not in KINDS:
            raise AdverbsError(f"event {name or callback!r}: kind must be one of {', '.join(KINDS)}, got {kind!r}")
        event = Event(at, self._seq, kind, callback, name)
        self._seq += 1
        heapq.heappush(self._heap, event)
        return event

    def pop(self) -> Event:
        return heapq.heappop(self._heap)

    def peek(self) -> Event | None:
        return self._heap[0] if self._heap else None

    def discard(self, name: str) -> int:
        """Drop every queued event called ``name``; how many there were."""
        kept = [e for e in self._heap if e.name != name]
        dropped = len(self._heap) - len(kept)
        if dropped:
            self._heap = kept
            heapq.heapify(self._heap)
        return dropped

    def __len__(self) -> int:
        return len(self._heap)


class VirtualClock:
    """Offline time: it reads the timestamp of the last event that waited for it; waiting costs nothing."""

    realtime = False

    def __init__(self, start: float = 0.0) -> None:
        self._now = float(start)

    def now(self) -> float:
        return self._now

    def wait_until(self, t: float) -> None:
        self._now = max(self._now, float(t))


class WallClock:
    """Real time: seconds since :meth:`start` (or since it was made), times ``speed`` (2: twice as fast as real)."""

    realtime = True

    def __init__(self, speed: float = 1.0, start: float = 0.0, sleep: Callable[[float], None] = time.sleep) -> None:
        if not (math.isfinite(speed) and speed > 0):
            raise AdverbsError(f"clock speed must be a positive number, got {speed}")
        self.speed = float(speed)
        self._sleep = sleep
        self.start(start)

    def start(self, at: float = 0.0) -> None:
        """From now on, the clock reads ``at`` plus the time since."""
        self._origin = time.perf_counter() - float(at) / self.speed

    def now(self) -> float:
        return (time.perf_counter() - self._origin) * self.speed

    def wait_until(self, t: float) -> None:
        while True:
            left = (float(t) - self.now()) / self.speed
            if left <= 0:
                return
            self._sleep(min(left, 0.05))


@dataclass
class Processed:
    """What :func:`run_events` did: events run and skipped (late optional ones), by name."""

    ran: int = 0
    skipped: list[tuple[float, str]] = field(default_factory=list)


def run_events(queue: EventQueue, clock, until: float = math.inf, done: Processed | None = None) -> Processed:
    """Process ``queue`` against ``clock`` up to and including timestamp ``until`` (later events stay queued).

    Callbacks may push new events; they are processed in order with the rest.
    """
    done = Processed() if done is None else done
    while queue:
        event = queue.peek()
        if event.time > until:
            break
        queue.pop()
        if event.kind == SYNC:
            clock.wait_until(event.time)
        elif event.kind == OPTIONAL and clock.now() > event.time + LATE:
            done.skipped.append((event.time, event.name))
            continue
        event.callback(event.time)
        done.ran += 1
    return done
