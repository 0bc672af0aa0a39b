"""``adverbs view``: the live page, opened in real headless Chromium (Debian's package) driven by Playwright.

The page connects, an adverb slider moved in the browser reaches the creature, a verb button queues the verb, bad
input typed on the page is clamped or refused while the creature keeps moving, and the screenshot shows a figure.
"""

from __future__ import annotations

import re
import shutil
import socket
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from adverbs.errors import AdverbsWarning

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = [
    "--no-sandbox", "--headless=new", "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip


def _missing() -> str | None:
    if CHROMIUM is None:
        return "no Chromium here (Debian: apt-get install chromium; .ci/run installs it)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "Playwright's Python package is not installed (pip install -e '.[test]')"
    return None


pytestmark = pytest.mark.skipif(_missing() is not None, reason=_missing() or "")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _until(check, seconds: float = 20.0, what: str = "") -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if check():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


@pytest.fixture(scope="module")
def viewer():
    from adverbs.apps.viewer import Viewer
    from adverbs.graph import load_graph

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        graph = load_graph(ROOT / "graphs" / "cmu.toml")
    v = Viewer(graph, creatures=1, port=_free_port()).start()
    yield v
    v.stop()


@pytest.fixture(scope="module")
def page(viewer):
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        page = browser.new_page(viewport={"width": 1200, "height": 800})
        page.goto(viewer.url)
        page.get_by_text("frames/s").first.wait_for(timeout=30000)  # the server's status reached the page
        yield page
        browser.close()


def test_the_page_connects_and_shows_the_creature_moving(viewer, page, tmp_path):
    assert viewer.host == "127.0.0.1"
    _until(lambda: len(viewer.server.get_clients()) >= 1, what="a client")
    assert page.get_by_text("Connected").count() >= 1
    for name in viewer.graphs[0].adverb_names + viewer.graphs[0].verb_names:
        assert page.get_by_text(name, exact=True).count() >= 1, name
    first = viewer.updates
    _until(lambda: viewer.updates >= first + 30, what="frames sent to the page")
    from PIL import Image

    shot = tmp_path / "viewer.png"

    def scene() -> np.ndarray:  # the 3D view, left of the control panel: the figure and the grid
        page.screenshot(path=str(shot))
        return np.asarray(Image.open(shot).convert("RGB"), dtype=float)[100:700, 300:800]

    # Software WebGL on a busy machine can show a frame or two before the scene is drawn: look again until it is.
    _until(lambda: scene().std() > 8.0, 30, "the scene drawn (a blank screenshot)")
    dark = (scene().mean(axis=2) < 200).mean()
    assert 0.002 < dark < 0.5, dark  # grid lines and bones, on a light background


def test_the_camera_and_the_ground_follow_the_walking_creature(viewer, page):
    creature = viewer.creatures[0]
    body = viewer.graphs[0].skeleton.body_root()
    client = next(iter(viewer.server.get_clients().values()))

    def looking_at_it() -> bool:
        here = viewer.positions[creature.name][body]
        look = np.asarray(client.camera.look_at)
        return np.hypot(*(look - here)[[0, 2]]) < 0.5 and abs(look[1] - 0.9) < 1e-6

    start = viewer.positions[creature.name][body].copy()
    _until(lambda: np.hypot(*(viewer.positions[creature.name][body] - start)[[0, 2]]) > 2.0, 30, "the creature walking 2 m")
    _until(looking_at_it, what="the page's camera looking at the creature")
    ground = np.asarray(viewer._ground.position)
    assert np.hypot(*(ground - viewer.positions[creature.name][body])[[0, 2]]) <= np.sqrt(2) + 0.5  # within a section


def test_a_slider_moved_in_the_browser_reaches_the_creature(viewer, page):
    name = viewer.graphs[0].adverb_names[0]
    lo, hi = viewer._range(name)
    creature = viewer.creatures[0]
    before = creature.adverbs[name]
    pose_before = viewer.positions[creature.name].copy()
    slider = page.get_by_role("slider").first  # the first adverb's
    slider.focus()
    slider.press("End")  # to the top of its range
    _until(lambda: abs(viewer._sliders[name].value - hi) < 1e-6, what="the slider's value on the server")
    _until(lambda: abs(creature.adverbs[name] - hi) < 1e-6, what="the creature's adverb (eased in)")
    assert before != pytest.approx(hi)
    assert np.abs(viewer.positions[creature.name] - pose_before).max() > 0.01  # the pose the server reports moved


def test_a_verb_button_queues_the_verb(viewer, page):
    creature = viewer.creatures[0]
    verb = next(v for v in viewer.graphs[0].verb_names if v != creature.verb)
    page.get_by_role("button", name=verb, exact=True).click()
    _until(lambda: any(m.endswith(f"{verb} queued") for m in viewer.messages), what="the command on the server")
    # and on the page: the message, or the status line showing the creature on its way (both come from the server)
    page.get_by_text(re.compile(rf"{verb} queued|: \S+ → {verb} \(|: {verb} at ")).first.wait_for(timeout=30000)
    _until(lambda: creature.verb == verb, what=f"the creature on its way to {verb}")


def test_bad_input_from_the_page_is_clamped_or_refused_and_the_creature_keeps_moving(viewer, page):
    box = page.get_by_role("textbox").last  # the command line: the panel's last text box
    for text, said in (
        ("fly", "refused: no verb 'fly'"),
        ("walk_speed=nan", "refused: walk_speed: nan is not a finite number"),
        ("walk_speed=fast", "refused: walk_speed: 'fast' is not a number"),
        ("mood=1", "refused: no adverb 'mood'"),
        ("turn=1e9", "turn=1e+09 clamped to"),
    ):
        box.fill(text)
        box.press("Enter")
        page.get_by_text(said).first.wait_for(timeout=30000)
    _, hi = viewer._range("turn")
    _until(lambda: viewer._sliders is not None and abs(viewer.creatures[0].adverbs["turn"] - hi) < 1e-6, what="turn clamped to its range")
    # Straight to the server too: whatever a client sends is checked the same way.
    assert viewer.apply({"adverb": "walk_speed", "value": float("inf")}) is False
    assert viewer.apply({"perform": 3}) is False
    assert viewer.apply({"speed": -1}) is False
    assert viewer.apply({"nonsense": 1}) is False
    assert viewer.apply("run") is False
    n = viewer.updates
    _until(lambda: viewer.updates > n + 10, what="frames after the refusals")
    assert viewer._thread.is_alive()


def test_pause_stops_the_clock_and_play_goes_on(viewer, page):
    viewer.apply({"playing": False})
    time.sleep(0.8)
    t = viewer.sim.time
    time.sleep(0.5)
    assert viewer.sim.time == t
    viewer.apply({"playing": True})
    _until(lambda: viewer.sim.time > t + 0.2, what="the clock again")


@pytest.mark.parametrize("port", [0, 65536, 99999, -1, 8080.5, True])
def test_a_bad_port_is_refused_before_anything_starts(viewer, port):
    """``--port 99999`` raised OverflowError from the socket after the simulation had started, and hung."""
    from adverbs.apps.viewer import Viewer
    from adverbs.errors import AdverbsError

    with pytest.raises(AdverbsError, match="port must be a whole number from 1 to 65535"):
        Viewer(viewer.graphs, port=port)
