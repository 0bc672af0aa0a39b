"""The manifest: one Parquet row per clip (pyarrow), a part per shard written as the shard finishes
(``manifest/shard-NNNNNN.parquet``), and all of them in one ``manifest.parquet`` when the dataset is whole.

No column holds a time of day or a duration of work, so the same spec gives the same manifest bytes wherever it runs.
"""

from __future__ import annotations

import io
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from ..io.files import write_atomic

SCHEMA = pa.schema(
    [
        ("clip", pa.int64()),  # the clip's id: 0, 1, … in the spec's order
        ("name", pa.string()),  # c00000042: its files' and arrays' name
        ("kind", pa.string()),  # "verb" or "graph"
        ("source", pa.string()),  # the verb's or graph's name (sources/NAME.verb or .graph)
        ("adverbs", pa.map_(pa.string(), pa.float64())),  # the adverb point (a graph: where the performance starts)
        ("script", pa.string()),  # a graph's cues, JSON: [{"at": s, "perform": verb, "adverbs": {...}}]
        ("seed", pa.int64()),  # the clip's own seed (from the dataset's and the clip id)
        ("floor", pa.string()),  # "flat", "flat:LEVEL" or "slope:DEGREES"
        ("duration", pa.float64()),  # seconds asked (NaN: one cycle of the verb)
        ("fps", pa.float64()),
        ("frames", pa.int64()),  # frames written (0 when the clip failed)
        ("seconds", pa.float64()),  # frames / fps
        ("played", pa.string()),  # the verbs played, in order ("idle > walk > run")
        ("toe_drift_median_mm", pa.float64()),  # planted feet, measured on the frames written (adverbs.feet.measures)
        ("toe_drift_max_mm", pa.float64()),
        ("heel_drift_max_mm", pa.float64()),
        ("lowest_mm", pa.float64()),  # the lowest constrained foot, over the floor plus its contact height
        ("held_height_mm", pa.float64()),
        ("slide_max_mm", pa.float64()),
        ("aloft_max_mm", pa.float64()),  # the highest of the feet's lowest points over their contact heights
        ("unreachable", pa.int64()),  # effector-frames the IK could not reach
        ("never_down", pa.string()),  # feet that never came down (comma-separated joint names)
        ("shard", pa.int64()),
        ("arrays", pa.string()),  # the shard's .npz holding NAME_rotations (F, J, 4) and NAME_positions (F, J, 3)
        ("bvh", pa.string()),  # the clip's files, relative to the dataset's folder ("" when not asked)
        ("glb", pa.string()),
        ("status", pa.string()),  # "ok" or "failed"
        ("error", pa.string()),  # why it failed
        ("warnings", pa.string()),  # what was worth knowing (a point far past the examples, a command refused)
    ]
)
COLUMNS = tuple(SCHEMA.names)


def table(rows: list[dict]) -> pa.Table:
    """Rows (dicts with every column of :data:`SCHEMA`) as a table."""
    return pa.Table.from_pylist(rows, schema=SCHEMA)


def parquet_bytes(t: pa.Table) -> bytes:
    buf = io.BytesIO()
    pq.write_table(t, buf, compression="zstd")
    return buf.getvalue()


def part_path(shard: int) -> str:
    return f"manifest/shard-{shard:06d}.parquet"


def write_part(out: Path, shard: int, rows: list[dict]) -> str:
    """Write a shard's rows as its manifest part, whole or not at all; returns its path in the dataset."""
    rel = part_path(shard)
    write_atomic(out / rel, parquet_bytes(table(rows)))
    return rel


def combine(out: Path, shards: int) -> Path:
    """Every shard's part, in shard order, as ``manifest.parquet``."""
    parts = [pq.read_table(out / part_path(s), schema=SCHEMA) for s in range(shards)]
    return write_atomic(out / "manifest.parquet", parquet_bytes(pa.concat_tables(parts) if parts else table([])))
