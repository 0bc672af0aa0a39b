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


def print_table(header: str, rows: list[tuple[str, str]]) -> None:
    width = max(len(header), *(len(r[0]) for r in rows))
    print(f"| {header.ljust(width)} | result |")
    print(f"| {'-' * width} | --- |")
    for what, value in rows:
        print(f"| {what.ljust(width)} | {value} |")
