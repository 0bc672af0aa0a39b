"""Web viewer benchmark: `adverbs view` with 10 creatures walking (Bandai graph, feet planted, the real-time clock
aiming at 60 frames/s), a page open in headless Chromium (Debian's, driven by Playwright; without one, no page);
frames the server sends to the page per second, over 10 s.

    make bench            (or: .venv/bin/python benchmarks/viewer.py)
"""

from __future__ import annotations

import shutil
import socket
import time
import warnings
from contextlib import nullcontext
from pathlib import Path

from timing import print_table

from adverbs.apps.viewer import Viewer
from adverbs.errors import AdverbsWarning
from adverbs.graph import load_graph

GRAPHS = Path(__file__).resolve().parent.parent / "graphs"
TARGET = 30.0  # updates per second the issue asks for, with 10 creatures
ARGS = ["--no-sandbox", "--headless=new", "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]  # fmt: skip


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def measure(graph, creatures: int, seconds: float = 10.0) -> tuple[float, str]:
    viewer = Viewer(graph, creatures=creatures, port=_port()).start()
    viewer.apply({"perform": "walk"})
    chromium = shutil.which("chromium")
    try:
        from playwright.sync_api import sync_playwright

        browser_context = sync_playwright() if chromium else nullcontext(None)
    except ImportError:
        browser_context, chromium = nullcontext(None), None
    try:
        with browser_context as p:
            page = None
            if p is not None:
                browser = p.chromium.launch(executable_path=chromium, args=ARGS)
                page = browser.new_page(viewport={"width": 1200, "height": 800})
                page.goto(viewer.url)
                page.get_by_text("frames/s").first.wait_for(timeout=60000)
            time.sleep(2.0)  # past the start: verbs cached, the walk under way
            n, t = viewer.updates, time.perf_counter()
            time.sleep(seconds)
            rate = (viewer.updates - n) / (time.perf_counter() - t)
            if page is not None:
                browser.close()
    finally:
        viewer.stop()
    return rate, "a page open in headless Chromium" if chromium else "no page (no Chromium here)"


def main() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        graph = load_graph(GRAPHS / "bandai.toml")
    rows = []
    for creatures in (1, 10):
        rate, how = measure(graph, creatures)
        asked = f"≥ {TARGET:.0f}" if creatures == 10 else "reported"
        rows.append((f"{creatures} creature{'s' if creatures > 1 else ''} walking, feet planted, {how}", f"{rate:.0f} updates/s", asked))
    print_table(("adverbs view (Bandai graph, aiming at 60 frames/s)", "measured", "asked"), rows)


if __name__ == "__main__":
    main()
