"""The verbs and graphs a dataset draws from, built once (on the machine that reads the spec) and shipped as data.

A verb travels as the bytes of its verb file (:func:`~adverbs.verb.store.verb_bytes`: JSON and ``.npy`` in a zip, no
pickles); a graph as a zip of its verbs' files and a ``graph.json`` of its structure (transitions, adverb defaults,
start verb). A worker turns the bytes back into a verb or graph once and keeps it (:func:`loaded`, keyed by the
bytes' SHA-256), so no clip rebuilds or rereads anything; :data:`LOADS` counts those loads, per process.
"""

from __future__ import annotations

import hashlib
import io
import json
import threading
import warnings
import zipfile
from dataclasses import asdict, dataclass, replace
from pathlib import Path

from threadpoolctl import threadpool_limits

from ..errors import AdverbsError, AdverbsWarning
from ..graph.spec import load_graph
from ..graph.structure import Graph, Transition
from ..verb.fit import build_from_spec
from ..verb.store import load_verb, verb_bytes, verb_from_bytes
from ..verb.tables import Verb
from .spec import DatasetSpec, DatasetSpecError, Entry

GRAPH_FORMAT = "adverbs-graph"
GRAPH_VERSION = 1
_EPOCH = (1980, 1, 1, 0, 0, 0)


@dataclass(frozen=True)
class Source:
    """A built verb or graph as data: ``kind`` ("verb" or "graph"), its ``name``, the ``data`` (a verb file's bytes,
    or a graph archive's) and their SHA-256 ``digest``."""

    kind: str
    name: str
    data: bytes
    digest: str

    @property
    def suffix(self) -> str:
        return ".verb" if self.kind == "verb" else ".graph"


def build_sources(spec: DatasetSpec, progress=None) -> list[Source]:
    """One :class:`Source` per entry of ``spec``; each file is built (or read) once, however many entries name it. A
    verb or graph that cannot be built is a :class:`DatasetSpecError` naming the entry's field."""
    built: dict[tuple[str, Path], Verb | Graph] = {}
    out = []
    for e in spec.entries:
        key = (e.kind, e.file)
        if key not in built:
            built[key] = _build(spec.path, e)
            if progress is not None:
                progress(f"{'read' if e.built else 'built'} {e.kind} {built[key].name!r} from {e.file.name}")
        thing = built[key]
        if isinstance(thing, Graph) and e.start is not None and e.start not in thing.verb_names:
            raise DatasetSpecError(spec.path, f"graph {thing.name!r} has no verb {e.start!r}; its verbs are {', '.join(thing.verb_names)}", f"{e.where}.start")  # fmt: skip
        if e.name is not None:
            thing = replace(thing, name=e.name)
        data = graph_bytes(thing) if isinstance(thing, Graph) else verb_bytes(thing)
        out.append(Source(e.kind, thing.name, data, hashlib.sha256(data).hexdigest()))
    names: dict[str, str] = {}
    for s in out:
        if names.setdefault(s.name, s.digest) != s.digest:
            raise DatasetSpecError(spec.path, f"two different sources are named {s.name!r}: give one a name = \"...\"", "name")
    return out


def _build(path: Path, e: Entry) -> Verb | Graph:
    """The entry's verb or graph, built on one BLAS thread: a build's last bits depend on how many threads OpenBLAS
    splits its sums over (the bow's verb file differs between one thread and two), and a dataset's bytes must not
    depend on the cores of the machine that reads its spec."""
    key = "graph" if e.kind == "graph" else "verb" if e.built else "spec"
    try:
        with warnings.catch_warnings(), threadpool_limits(1):
            warnings.simplefilter("ignore", AdverbsWarning)
            if e.kind == "graph":
                return load_graph(e.file)
            return load_verb(e.file) if e.built else build_from_spec(e.file)
    except AdverbsError as err:
        raise DatasetSpecError(path, str(err), f"{e.where}.{key}") from None


# ----- graphs as data ------------------------------------------------------------------------------


def graph_bytes(graph: Graph) -> bytes:
    """A graph as one zip: ``graph.json`` (its structure) and ``verbs/K.verb`` (each verb's file); the same bytes for the
    same graph."""
    meta = {
        "format": GRAPH_FORMAT,
        "version": GRAPH_VERSION,
        "name": graph.name,
        "defaults": dict(zip(graph.adverb_names, map(float, graph.defaults))),
        "start": graph.start,
        "source": graph.source,
        "clamped": list(graph.clamped),
        "transitions": [asdict(t) for t in graph.transitions],
    }
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as z:
        z.writestr(zipfile.ZipInfo("graph.json", _EPOCH), json.dumps(meta, indent=1, allow_nan=False))
        for k, v in enumerate(graph.verbs):
            z.writestr(zipfile.ZipInfo(f"verbs/{k}.verb", _EPOCH), verb_bytes(v))
    return buf.getvalue()


def graph_from_bytes(data: bytes, name: str = "<graph bytes>") -> Graph:
    """The graph :func:`graph_bytes` wrote; a damaged archive is an :class:`AdverbsError` naming ``name``."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            meta = json.loads(z.read("graph.json"))
            if meta.get("format") != GRAPH_FORMAT or meta.get("version") != GRAPH_VERSION:
                raise AdverbsError(f"{name}: not a version {GRAPH_VERSION} adverbs graph archive")
            verbs = [verb_from_bytes(z.read(f"verbs/{k}.verb"), f"{name}:verbs/{k}.verb") for k in range(len(z.namelist()) - 1)]
    except (zipfile.BadZipFile, KeyError, ValueError) as e:
        if isinstance(e, AdverbsError):
            raise
        raise AdverbsError(f"{name}: damaged graph archive ({e})") from None
    transitions = [
        Transition(**{**t, "source_region": tuple(t["source_region"]), "target_region": tuple(t["target_region"])})
        for t in meta["transitions"]
    ]
    return Graph.make(meta["name"], verbs, transitions, meta["defaults"], meta["start"], None, meta["source"], meta["clamped"])


# ----- on a worker: loaded once, kept --------------------------------------------------------------

_LOADED: dict[str, Verb | Graph] = {}
_LOCK = threading.Lock()
LOADS = {"verb": 0, "graph": 0}  # how many sources this process turned from bytes into a verb or graph


def loaded(kind: str, digest: str, data: bytes | None) -> Verb | Graph:
    """The verb or graph whose bytes have SHA-256 ``digest``: loaded from ``data`` the first time in this process, then
    the same object every time (it is immutable, shared by every clip)."""
    with _LOCK:
        found = _LOADED.get(digest)
        if found is None:
            if data is None:
                raise AdverbsError(f"{kind} {digest[:12]} is not loaded in this process and was not sent")
            found = verb_from_bytes(data, f"<verb {digest[:12]}>") if kind == "verb" else graph_from_bytes(data, f"<graph {digest[:12]}>")
            _LOADED[digest] = found
            LOADS[kind] += 1
        return found


def load_counts() -> dict[str, int]:
    """:data:`LOADS` of this process (what a test asks each worker)."""
    return dict(LOADS)
