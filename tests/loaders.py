"""Third-party readers of our files, run for real: three.js's BVHLoader and GLTFLoader and the Khronos glTF validator
(Node.js, the npm packages of tests/js, installed by `make test` / `.ci/run`), and pybvh.

Each returns what that reader makes of a file — world joint positions per frame, in metres — for the tests to
compare with our own forward kinematics.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

JS = Path(__file__).resolve().parent / "js"
MODULES = JS / "node_modules"


def node_missing() -> str | None:
    """Why the Node.js checks cannot run here, or None."""
    if shutil.which("node") is None:
        return "Node.js is not installed (Debian: apt-get install nodejs npm; .ci/run installs it)"
    for package in ("three", "gltf-validator"):
        if not (MODULES / package / "package.json").exists():
            return f"the npm package {package!r} is not installed (run: cd tests/js && npm ci; make test does)"
    return None


needs_node = pytest.mark.skipif(node_missing() is not None, reason=node_missing() or "")


def _node(script: str, *args: str, timeout: float = 300.0) -> subprocess.CompletedProcess:
    run = subprocess.run(["node", str(JS / script), *args], capture_output=True, text=True, timeout=timeout, cwd=JS)
    if run.returncode != 0:
        raise AssertionError(f"node {script} {' '.join(args)} failed:\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}")
    return run


def _positions_from(script: str, path: Path) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.json"
        _node(script, str(path), str(out))
        got = json.loads(out.read_text())
    got["positions"] = np.asarray(got["positions"], dtype=float)
    return got


def three_bvh(path: Path) -> dict:
    """three.js ``BVHLoader``: ``names`` (joints, End Sites left out), ``positions (F, J, 3)`` in the file's units."""
    return _positions_from("bvh_positions.mjs", path)


def three_gltf(path: Path) -> dict:
    """three.js ``GLTFLoader``: the skin's joints' ``names`` and ``positions (F, J, 3)`` in metres, ``fps``, ``meshes``."""
    return _positions_from("gltf_positions.mjs", path)


def validate(*paths: Path) -> list[dict]:
    """The Khronos glTF validator's report per file: ``errors``, ``warnings``, ``infos``, ``hints``, ``messages``."""
    return json.loads(_node("validate.mjs", *map(str, paths)).stdout)


def pybvh_positions(path: Path) -> tuple[list[str], np.ndarray, float]:
    """pybvh's joint names, world positions ``(F, J, 3)`` (file units) and frame rate."""
    import warnings

    import pybvh

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its guess of the up axis, which positions do not depend on
        b = pybvh.read_bvh_file(str(path))
        return list(b.joint_names), np.asarray(b.joint_positions(), dtype=float), float(b.fps)
