"""What the benchmark scripts share: timing and printing a Markdown table."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def median_seconds(fn: Callable[[], object], repeats: int = 7) -> float:
    """Median wall time of ``fn()`` over ``repeats`` runs, after one warm-up run."""
    fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def print_table(header: str | tuple[str, ...], rows: list[tuple[str, ...]]) -> None:
    """A Markdown table: ``header`` names the first column (then "result"), or every column."""
    header = (header, "result") if isinstance(header, str) else header
    widths = [max(len(str(r[c])) for r in [header, *rows]) for c in range(len(header))]
    print("| " + " | ".join(h.ljust(w) for h, w in zip(header, widths)) + " |")
    print("| " + " | ".join("-" * w for w in widths) + " |")
    for row in rows:
        print("| " + " | ".join(str(v).ljust(w) for v, w in zip(row, widths)) + " |")
