"""Making a dataset: the spec read and checked, its verbs and graphs built once, every clip planned, then its shards made
in this process or on a Dask cluster and written as they finish, each with its manifest part and, last, its marker.

Layout of the output folder ``DIR``::

    dataset.json                  what the dataset is (name, its identity, clips, shards, sources); written first
    spec.toml                     the spec it was made from
    sources/NAME.verb|.graph      each verb (a verb file) and graph (its verbs' files and structure), as shipped
    shards/NNNNNN/arrays.npz      per clip cNNNNNNNN_rotations (F, J, 4) and cNNNNNNNN_positions (F, J, 3), float32
    shards/NNNNNN/cNNNNNNNN.bvh   (and .glb) when asked
    manifest/shard-NNNNNN.parquet the shard's manifest rows
    shards/NNNNNN/done.json       the shard's marker, written last: its files and their sizes and SHA-256
    manifest.parquet              every row, when every shard is done

Every file is written to a temporary name beside it and renamed into place, so a run killed at any moment leaves whole
files; a shard without its marker is made again by the next run, and a shard with it is skipped. Workers only compute:
they return a shard's bytes and rows to this process, which writes them, so a cluster needs no shared disk.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import AdverbsError
from ..io.files import write_atomic
from . import manifest
from .clip import ShardResult, render_shard, shard_folder
from .plan import ClipTask, plan
from .sources import Source, build_sources, loaded
from .spec import DatasetSpec, load_dataset_spec

FORMAT = "adverbs-dataset"
VERSION = 1


class DatasetError(AdverbsError):
    """A dataset that cannot be made as asked (an output folder holding another dataset, shards that failed)."""


@dataclass
class Summary:
    """What a run did: ``clips`` in the dataset, ``made`` and ``failed`` clips this run, ``shards`` in all, ``skipped``
    (done before), ``shard_errors`` (shard, why) for shards that could not be made, and the wall ``seconds``."""

    out: Path
    clips: int
    shards: int
    made: int = 0
    failed: int = 0
    skipped: int = 0
    shard_errors: list[tuple[int, str]] = field(default_factory=list)
    seconds: float = 0.0
    workers: int = 0

    @property
    def complete(self) -> bool:
        return not self.shard_errors

    @property
    def clips_per_second(self) -> float:
        return (self.made + self.failed) / self.seconds if self.seconds > 0 else 0.0

    def line(self) -> str:
        where = f"{self.workers} worker{'s' if self.workers != 1 else ''}" if self.workers else "one process"
        done = f"{self.made + self.failed:,} clips made ({self.failed:,} failed) in {self.seconds:.1f} s on {where}"
        if self.made + self.failed:
            done += f" ({self.clips_per_second:.1f} clips/s)"
        elif not self.shard_errors:
            done = "nothing left to make"
        skipped = f"; {self.skipped} of {self.shards} shards done before, skipped" if self.skipped else ""
        bad = f"; {len(self.shard_errors)} shards failed (run again to retry them)" if self.shard_errors else ""
        return f"{self.out}: {self.clips:,} clips in {self.shards} shards; {done}{skipped}{bad}"


@dataclass
class Prepared:
    """A dataset ready to make: the spec, its sources (built) and the plan, cut into shards."""

    spec: DatasetSpec
    sources: list[Source]
    tasks: list[ClipTask]
    shards: list[list[ClipTask]]
    identity: str

    @property
    def description(self) -> dict:
        return {
            "format": FORMAT,
            "version": VERSION,
            "name": self.spec.name,
            "identity": self.identity,
            "clips": len(self.tasks),
            "shards": len(self.shards),
            "shard_size": self.spec.shard_size,
            "formats": list(self.spec.formats),
            "sources": [{"name": s.name, "kind": s.kind, "file": f"sources/{s.name}{s.suffix}", "sha256": s.digest} for s in self.sources],  # fmt: skip
        }


def prepare(spec: DatasetSpec | str | Path, say: Callable[[str], None] | None = None) -> Prepared:
    """Read and check the spec, build its verbs and graphs (once each) and plan every clip: all that can be refused is
    refused here, before any clip is made or any cluster started."""
    if not isinstance(spec, DatasetSpec):
        spec = load_dataset_spec(spec)
    sources = build_sources(spec, say)
    objects = [loaded(s.kind, s.digest, s.data) for s in sources]
    tasks = plan(spec, objects)
    size = spec.shard_size
    shards = [tasks[i : i + size] for i in range(0, len(tasks), size)]
    ident = hashlib.sha256()
    for s in sources:
        ident.update(s.digest.encode())
    ident.update(json.dumps([spec.formats, spec.portable, size]).encode())
    for t in tasks:
        ident.update(repr(t).encode())
    return Prepared(spec, sources, tasks, shards, ident.hexdigest())


def _marker(shard: int) -> str:
    return f"{shard_folder(shard)}/done.json"


def finished(out: Path, shard: int) -> bool:
    """Whether shard ``shard`` is done: its marker is there and every file it lists is, at its size."""
    try:
        listed = json.loads((out / _marker(shard)).read_text())["files"]
        return all((out / rel).stat().st_size == entry["bytes"] for rel, entry in listed.items())
    except (OSError, ValueError, KeyError, TypeError):
        return False


def _start(prepared: Prepared, out: Path) -> None:
    """The folder's description and sources, or a refusal when it holds another dataset."""
    described = out / "dataset.json"
    if described.exists():
        try:
            old = json.loads(described.read_text())
        except (OSError, ValueError):
            old = {}
        if old.get("identity") != prepared.identity:
            raise DatasetError(
                f"{out}: holds another dataset ({old.get('name', '?')!r}, made from another spec or other verbs); "
                "give another --out, or delete it to start again"
            )
    elif out.exists() and not out.is_dir():
        raise DatasetError(f"{out}: not a folder")
    elif out.exists() and any(out.iterdir()):
        raise DatasetError(f"{out}: a folder that is not empty and holds no dataset; give an empty or new folder")
    for s in prepared.sources:
        target = out / "sources" / f"{s.name}{s.suffix}"
        if not (target.exists() and target.stat().st_size == len(s.data)):
            write_atomic(target, s.data)
    write_atomic(out / "spec.toml", prepared.spec.path.read_bytes())
    write_atomic(described, (json.dumps(prepared.description, indent=1) + "\n").encode())


def _write(out: Path, result: ShardResult) -> None:
    """A shard's files, then its manifest part, then its marker (last: a shard is done when its marker is there)."""
    listed = {}
    for rel, data in result.files.items():
        write_atomic(out / rel, data)
        listed[rel] = {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    part = manifest.parquet_bytes(manifest.table(result.rows))
    rel = manifest.part_path(result.shard)
    write_atomic(out / rel, part)
    listed[rel] = {"bytes": len(part), "sha256": hashlib.sha256(part).hexdigest()}
    marker = {"shard": result.shard, "clips": len(result.rows), "failed": sum(r["status"] != "ok" for r in result.rows), "files": listed}  # fmt: skip
    write_atomic(out / _marker(result.shard), (json.dumps(marker, indent=1) + "\n").encode())


def _work(shard: int, tasks: list[ClipTask], formats: tuple[str, ...], portable: bool, kinds: list[str], digests: list[str], *datas: bytes) -> ShardResult:  # fmt: skip
    """What a worker runs for one shard: its sources loaded once per process (from the bytes shipped to it), then
    :func:`render_shard`."""
    sources = [loaded(k, d, data) for k, d, data in zip(kinds, digests, datas)]
    return render_shard(shard, tasks, sources, formats, portable)


class _Progress:
    """A bar on a terminal (tqdm), else a line per shard on stderr; or nothing."""

    def __init__(self, show: bool, total: int, done: int):
        self.show, self.total, self.count, self.first, self.started = show, total, done, done, time.perf_counter()
        self.bar = None
        if show and sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done, unit="clip", desc="clips", file=sys.stderr)

    def shard(self, result: ShardResult, shards_done: int, shards: int) -> None:
        self.count += len(result.rows)
        if not self.show:
            return
        failed = sum(r["status"] != "ok" for r in result.rows)
        if self.bar is not None:
            self.bar.update(len(result.rows))
            return
        rate = (self.count - self.first) / max(time.perf_counter() - self.started, 1e-9)
        print(f"shard {result.shard} done ({shards_done}/{shards}): {len(result.rows)} clips, {failed} failed; "
              f"{self.count:,}/{self.total:,} clips, {rate:.1f} clips/s", file=sys.stderr, flush=True)  # fmt: skip

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def dataset(
    spec: DatasetSpec | str | Path,
    out: str | Path,
    workers: int | None = None,
    scheduler: str | None = None,
    dashboard: str | bool = False,
    progress: bool = False,
    on_shard: Callable[[ShardResult], None] | None = None,
) -> Summary:
    """Make the dataset ``spec`` (a dataset spec file, or one read) describes, in folder ``out``; a run that stopped is
    resumed: shards already done are skipped.

    ``workers=0``: in this process, no cluster. Otherwise on :mod:`dask.distributed`: the cluster at ``scheduler``
    (``"tcp://host:8786"``) if given, else a ``LocalCluster`` of ``workers`` processes (default: one per core) on
    127.0.0.1, with a dashboard only if ``dashboard`` (True: port 8787, or an address). The verbs and graphs are built
    here, once, and shipped to each worker as the bytes of their files. Every clip is a pure function of its task, so
    the files are the same bytes whichever way it runs. ``progress``: a bar on a terminal, else a line per shard, on
    stderr; ``on_shard(result)`` is called as each shard is written. A clip that fails is a manifest row with its
    error; a shard that fails (its worker lost too often) is reported in :attr:`Summary.shard_errors` and made again by
    the next run."""
    started = time.perf_counter()
    out = Path(out)
    say = (lambda s: print(f"  {s}", file=sys.stderr)) if progress else None
    prepared = prepare(spec, say)
    _start(prepared, out)
    shards = prepared.shards
    pending = [i for i in range(len(shards)) if not finished(out, i)]
    summary = Summary(out, len(prepared.tasks), len(shards), skipped=len(shards) - len(pending))
    waiting = set(pending)
    bar = _Progress(progress, len(prepared.tasks), sum(len(shards[i]) for i in range(len(shards)) if i not in waiting))
    done = [len(shards) - len(pending)]

    def finish(result: ShardResult) -> None:
        _write(out, result)
        summary.failed += sum(r["status"] != "ok" for r in result.rows)
        summary.made += sum(r["status"] == "ok" for r in result.rows)
        done[0] += 1
        bar.shard(result, done[0], len(shards))
        if on_shard is not None:
            on_shard(result)

    try:
        if pending and workers == 0 and scheduler is None:
            objects = [loaded(s.kind, s.digest, s.data) for s in prepared.sources]
            for i in pending:
                finish(render_shard(i, shards[i], objects, prepared.spec.formats, prepared.spec.portable))
        elif pending:
            summary.workers = _distributed(prepared, pending, workers, scheduler, dashboard, finish, summary, say)
    finally:
        bar.close()
    if all(finished(out, i) for i in range(len(shards))):
        manifest.combine(out, len(shards))
    summary.seconds = time.perf_counter() - started
    return summary


def _distributed(prepared: Prepared, pending: list[int], workers, scheduler, dashboard, finish, summary: Summary, say=None) -> int:
    """Make the ``pending`` shards on a Dask cluster; returns how many workers it had."""
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler is None:
        n = workers if workers is not None else (os.cpu_count() or 1)
        # No dashboard unless asked; the scheduler's bare HTTP endpoint (health, metrics) then takes any free port of
        # 127.0.0.1 (its default, 8787, is often taken by another cluster's dashboard).
        address = None if not dashboard else ("127.0.0.1:8787" if dashboard is True else str(dashboard))
        quiet = {} if dashboard else {"scheduler_kwargs": {"dashboard_address": "127.0.0.1:0"}}
        cluster = LocalCluster(
            n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=address,
            silence_logs=logging.ERROR, **quiet,
        )  # fmt: skip
        if dashboard and say is not None:
            say(f"dashboard: {cluster.dashboard_link}")
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        count = len(client.scheduler_info()["workers"]) if scheduler is not None else n
        spec = prepared.spec
        kinds = [s.kind for s in prepared.sources]
        digests = [s.digest for s in prepared.sources]
        shipped = [client.scatter(s.data, broadcast=True, hash=False) for s in prepared.sources]
        futures = [
            client.submit(_work, i, prepared.shards[i], spec.formats, spec.portable, kinds, digests, *shipped,
                          key=f"adverbs-shard-{prepared.identity[:12]}-{i}", pure=False)
            for i in pending
        ]  # fmt: skip
        index = {f.key: i for f, i in zip(futures, pending)}
        for future in as_completed(futures):
            try:
                result = future.result()
            except Exception as e:  # noqa: BLE001 - a shard lost (its worker killed too often): reported, run again
                summary.shard_errors.append((index[future.key], f"{type(e).__name__}: {e}"))
                continue
            finally:
                future.release()
            finish(result)
        return count
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
