"""What the hostile-input tests (issue 33) share: a bound on each case's time and memory, and a field of a parsed
document (JSON or TOML as Python objects) drawn to be damaged."""

from __future__ import annotations

import contextlib
import resource
import signal

from test_spec_safety import _paths

SECONDS = 10  # a case that runs longer than this has hung (each takes milliseconds to a fraction of a second)
MEGABYTES = 512  # a case that raises the process's peak memory by more than this has blown up (each takes a few MB)


@contextlib.contextmanager
def bounded(seconds: float = SECONDS, megabytes: float = MEGABYTES):
    """Fail, rather than hang, when the block runs past ``seconds`` (SIGALRM: the tests run in the main thread), and
    fail when it raised the process's peak resident memory by more than ``megabytes``."""

    def stop(*_):
        raise TimeoutError(f"still running after {seconds} s: a hang")

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # kilobytes on Linux
    old = signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - peak) / 1024
    assert grown <= megabytes, f"the case raised peak memory by {grown:.0f} MB (at most {megabytes} MB)"


def draw_field(draw, strategies, doc, under: tuple = (), keep=lambda path: True) -> tuple[object, object, tuple]:
    """A field of ``doc`` (an object or array anywhere inside it, or inside ``doc[under...]``) drawn with Hypothesis's
    ``draw`` among those ``keep(path)`` accepts: its parent, its key in the parent, and its path from ``doc``."""
    node = doc
    for k in under:
        node = node[k]
    path = draw(strategies.sampled_from([p for p, _ in _paths(node, under) if p and keep(p)]))
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    return parent, path[-1], path
