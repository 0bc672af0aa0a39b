"""The README's Python tour runs as written, and the commands it shows exist."""

from __future__ import annotations

import re
from pathlib import Path

from test_cli import run

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def test_the_python_tour_runs(tmp_path, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert blocks, "the README has no Python example"
    for name in ("data", "specs", "graphs", "datasets"):
        (tmp_path / name).symlink_to(ROOT / name)
    (tmp_path / "out").mkdir()
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    assert (tmp_path / "out" / "walk.verb").exists() and (tmp_path / "out" / "left_60fps.bvh").exists()


def test_every_command_in_the_readme_exists():
    block = re.search(r"## Command line\n\n```sh\n(.*?)```", README, flags=re.S).group(1)
    commands = sorted({line.split()[1] for line in block.splitlines() if line.startswith("adverbs ")})
    assert commands
    for command in commands:
        r = run(command, "--help")
        assert r.returncode == 0, (command, r.stderr)
