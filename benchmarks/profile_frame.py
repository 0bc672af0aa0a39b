"""Where a crowd's frame goes, by compiled function: the crowd benchmark's frame run under Linux ``perf`` with the
kernels' machine code named.

    perf record -F 999 -o /tmp/perf.data .venv/bin/python benchmarks/profile_frame.py [CREATURES] [SECONDS] [GRAPH]
    perf report -i /tmp/perf.data --no-children --sort sym

(defaults: 1,000 creatures, 15 s of frames, the Bandai graph; one thread). numba's machine code lives in memory
``perf`` cannot name, so at the end this writes ``/tmp/perf-PID.map`` (the format ``perf`` reads for JIT code):
every compiled function loaded in the process, its address and size read from the object code numba loads from
its cache, named ``module.function`` (``_planting_kernel.advance``, ``_frame_kernel._creature``). Functions numba
inlines (``inline="always"``) are counted in their callers. Two more unnamed addresses are numba's reference
counting (``NRT_incref`` and ``NRT_decref``, the short functions testing a null pointer). It needs ``readelf``
(binutils) and runs on the kernels as cached (``python -m adverbs.apps.warm`` first): a kernel compiled in the
process is not in the map.

Session 49 found with it that the planter passed its whole state, word by word, to a helper called for every foot
(``_shown``, now inlined): 80% of the planter's time.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import warnings

from numba.core import codegen

_OBJECTS: dict[int, tuple[object, bytes]] = {}  # every code library loaded from numba's cache, with its object code
_load = codegen.CPUCodeLibrary._set_compiled_object


def _recorded(self, value):
    _OBJECTS[id(self)] = (self, value)
    return _load(self, value)


codegen.CPUCodeLibrary._set_compiled_object = _recorded  # before any kernel loads


def _name(symbol: str) -> str:
    """``module.function`` of a numba symbol (``_ZN7adverbs4feet16_planting_kernel7advanceB4v6...``)."""
    s, i, names = symbol.removeprefix("cfunc."), 3, []
    if not s.startswith("_ZN"):
        return symbol[:60]
    while i < len(s) and s[i].isdigit():
        j = i
        while s[j].isdigit():
            j += 1
        n = int(s[i:j])
        names.append(s[j : j + n])
        i = j + n
    return ".".join(names[-2:])


def write_map() -> int:
    """``/tmp/perf-PID.map`` of every function in the code loaded so far; how many."""
    entries: dict[int, tuple[int, str]] = {}
    for library, obj in _OBJECTS.values():
        with tempfile.NamedTemporaryFile(suffix=".o", delete=False) as fh:
            fh.write(obj)
        try:
            table = subprocess.run(["readelf", "-s", "-W", fh.name], capture_output=True, text=True, check=True).stdout
        finally:
            os.unlink(fh.name)
        functions = []
        for line in table.splitlines():
            f = line.split()
            if len(f) >= 8 and f[3] == "FUNC":
                functions.append((int(f[1], 16), int(f[2], 0), f[4], f[7]))
        base = None  # where the object's code section sits: from one global function numba can find
        for value, _, binding, symbol in functions:
            if binding == "GLOBAL":
                try:
                    address = library.get_pointer_to_function(symbol)
                except Exception:  # noqa: BLE001 - a symbol numba does not export
                    continue
                if address:
                    base = address - value
                    break
        if base is not None:
            for value, size, _, symbol in functions:
                entries[base + value] = (size, _name(symbol))
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as fh:
        for address, (size, name) in sorted(entries.items()):
            fh.write(f"{address:x} {size:x} {name}\n")
    return len(entries)


def main() -> None:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import crowd  # noqa: PLC0415 - after the hook above

    from adverbs.errors import AdverbsWarning  # noqa: PLC0415
    from adverbs.graph import load_graph  # noqa: PLC0415

    args = sys.argv[1:]
    creatures = int(args[0]) if args else 1000
    seconds = float(args[1]) if len(args) > 1 else 15.0
    name = args[2] if len(args) > 2 else "bandai"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AdverbsWarning)
        graph = load_graph(crowd.GRAPHS / f"{name}.toml")
    ms = crowd.frame_ms(graph, creatures, "1 thread", seconds)
    print(f"{name}, {creatures:,} creatures, one thread: median {ms:.2f} ms a frame ({ms * 1e3 / creatures:.1f} µs a creature)")
    print(f"{write_map()} compiled functions named in /tmp/perf-{os.getpid()}.map")


if __name__ == "__main__":
    main()
