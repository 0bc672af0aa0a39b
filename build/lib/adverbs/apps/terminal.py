"""Progress on a terminal: a bar (tqdm) on stderr when it is a terminal, nothing when it is not (a pipe, a log, CI)."""

from __future__ import annotations

import sys
from collections.abc import Callable


def progress_bar(what: str) -> tuple[Callable[[float, float], None] | None, Callable[[], None]]:
    """A progress callback ``(done, total)`` drawing a bar labelled ``what``, and a function that closes it; the
    callback is None when stderr is not a terminal."""
    if not sys.stderr.isatty():
        return None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=1.0, desc=what, unit="", bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}", file=sys.stderr)

    def update(done: float, total: float) -> None:
        bar.n = min(done / total, 1.0) if total else 1.0
        bar.refresh()

    return update, bar.close
