"""Open BVH and glTF files in Blender's own importers (headless) and compare its joint positions with ours, frame
by frame.

    .venv/bin/python -m adverbs.apps.blender out/demo/bandai.bvh out/demo/cmu.bvh out/demo/bandai.glb

Runs ``blender -b --factory-startup`` with Blender's BVH importer (``bpy.ops.import_anim.bvh``, its defaults:
Y up, forward −Z, the file's rotation orders) or glTF importer (``bpy.ops.import_scene.gltf``, its defaults, the
scene's frame rate set to the file's first), reads every pose bone's head in world space at every frame, and
compares them with :meth:`adverbs.Clip.global_positions` of the same file as we read it, in metres. Prints, per
file, the frame counts and the largest difference. Needs Blender on the PATH (Debian: ``apt-get install blender``;
its glTF importer also needs ``python3-numpy``).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import AdverbsError
from ..io import motion_format, read_motion

INSIDE = r"""
import builtins, bpy, json, sys
path, out, fps = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
if path.lower().endswith(".glb"):
    import numpy
    numpy.bool = bool  # Blender 3.4's glTF importer uses an alias NumPy 1.24 (Debian's) no longer has
    scene = bpy.context.scene
    scene.render.fps = max(1, round(float(fps)))
    scene.render.fps_base = scene.render.fps / float(fps)
    bpy.ops.import_scene.gltf(filepath=path)
else:
    # Blender 3.4's BVH importer opens the file with mode "rU", which Python 3.11 (Debian's build) no longer
    # accepts; "r" is what it means there.
    _open = builtins.open
    builtins.open = lambda f, mode="r", *a, **k: _open(f, mode.replace("U", ""), *a, **k)
    bpy.ops.import_anim.bvh(filepath=path, rotate_mode="NATIVE", update_scene_fps=True, update_scene_duration=True)
arm = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
scene = bpy.context.scene
first, last = (int(round(x)) for x in arm.animation_data.action.frame_range)
positions = []
for f in range(first, last + 1):
    scene.frame_set(f)
    positions.append([list(arm.matrix_world @ b.head) for b in arm.pose.bones])
json.dump({"names": [b.name for b in arm.pose.bones], "positions": positions,
           "fps": scene.render.fps / scene.render.fps_base}, open(out, "w"))
"""


def blender() -> str | None:
    """Blender's executable, or None where it is not installed."""
    return shutil.which("blender")


def compare(path: str | Path, timeout: float = 600.0) -> dict:
    """Import ``path`` (.bvh or .glb) in Blender; its frame count and joint positions against ours (metres, Y up)."""
    exe = blender()
    if exe is None:
        raise AdverbsError("Blender is not installed (Debian: apt-get install blender)")
    path = Path(path)
    glb = motion_format(path) == ".glb"
    clip = read_motion(path)
    with tempfile.TemporaryDirectory() as tmp:
        script, out = Path(tmp) / "inside.py", Path(tmp) / "out.json"
        script.write_text(INSIDE)
        run = subprocess.run(
            [exe, "-b", "--factory-startup", "--python-exit-code", "1", "--python", str(script), "--", str(path), str(out), repr(clip.fps)],
            capture_output=True, text=True, timeout=timeout,
        )  # fmt: skip
        if glb and "No module named 'numpy'" in run.stdout + run.stderr:
            raise AdverbsError("Blender's glTF importer needs NumPy in Blender's Python (Debian: apt-get install python3-numpy)")
        if run.returncode != 0 or not out.exists():
            raise AdverbsError(f"{path}: Blender's import failed:\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}")
        got = json.loads(out.read_text())
    scale = 1.0 if glb else clip.skeleton.unit_scale  # BVH: Blender keeps the file's units; glTF is in metres
    theirs = np.asarray(got["positions"], dtype=float) * scale  # (F, bones, 3), Z up, metres
    theirs = np.stack([theirs[..., 0], theirs[..., 2], -theirs[..., 1]], axis=-1)  # back to Y up, forward -Z
    ours = clip.global_positions()
    names = list(clip.skeleton.names)
    idx = [names.index(n) for n in got["names"]]
    frames = min(len(theirs), len(ours))
    diff = np.linalg.norm(theirs[:frames] - ours[:frames, idx], axis=-1)
    return {
        "file": str(path),
        "frames": clip.num_frames,
        "blender_frames": len(theirs),
        "joints": len(idx),
        "fps": clip.fps,
        "blender_fps": got["fps"],
        "max_difference_m": float(diff.max()),
    }


def main(argv: list[str] | None = None) -> int:
    files = sys.argv[1:] if argv is None else argv
    if not files:
        print(__doc__)
        return 2
    worst = 0.0
    print("| file | frames (ours / Blender) | joints | largest joint difference |")
    print("| --- | --- | --- | --- |")
    for f in files:
        try:
            r = compare(f)
        except AdverbsError as e:
            print(f"adverbs.apps.blender: error: {e}", file=sys.stderr)
            return 1
        worst = max(worst, r["max_difference_m"])
        print(f"| {f} | {r['frames']} / {r['blender_frames']} | {r['joints']} | {r['max_difference_m'] * 1e3:.4f} mm |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
