"""Reading a dataset back: its manifest and its arrays, as NumPy, without PyTorch.

:class:`MotionDataset` is what a PyTorch ``DataLoader`` takes (``len`` and ``[i]``), and works as well without it::

    ds = adverbs.load_dataset("out/ds")
    len(ds), ds[0]["rotations"].shape        # the clips made, (F, J, 4)
    ds.manifest                              # pyarrow Table: every row, failed clips too
    ds.column("toe_drift_max_mm")            # a manifest column as a NumPy array (of the clips made)
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from ..errors import AdverbsError
from . import manifest as schema


class MotionDataset:
    """The clips of a dataset folder that were made (status "ok"), in clip order.

    ``ds[i]`` is a dict: ``rotations (F, J, 4)`` local joint rotations (scalar-last quaternions) and ``positions
    (F, J, 3)`` world joint positions in metres (float32, from the shard's ``arrays.npz``, read with
    ``allow_pickle=False``), and the clip's manifest row (``clip``, ``source``, ``adverbs`` as a dict, ``fps``, …);
    ``transform`` (if given) is applied to it. A dataset still being made reads the shards finished so far.
    """

    def __init__(self, folder: str | Path, transform=None, cache: int = 2):
        self.folder = Path(folder)
        try:
            self.description = json.loads((self.folder / "dataset.json").read_text())
        except (OSError, ValueError) as e:
            raise AdverbsError(f"{self.folder}: not a dataset folder (no readable dataset.json: {e})") from None
        whole = self.folder / "manifest.parquet"
        if whole.exists():
            self.manifest = pq.read_table(whole, schema=schema.SCHEMA)
        else:
            parts = sorted((self.folder / "manifest").glob("shard-*.parquet"))
            self.manifest = pa.concat_tables([pq.read_table(p, schema=schema.SCHEMA) for p in parts]) if parts else schema.table([])
        self.rows = self.manifest.filter(pc.equal(self.manifest["status"], "ok")).to_pylist()
        for r in self.rows:
            r["adverbs"] = dict(r["adverbs"])
        self.transform = transform
        self._open: dict[str, dict[str, np.ndarray]] = {}
        self._cache = max(int(cache), 1)

    def __len__(self) -> int:
        return len(self.rows)

    def __getitem__(self, i: int) -> dict:
        if not -len(self) <= i < len(self):
            raise IndexError(f"clip {i} of a dataset of {len(self)}")
        row = dict(self.rows[i])
        arrays = self._arrays(row["arrays"]) if row["arrays"] else {}
        if arrays:
            row["rotations"] = arrays[f"{row['name']}_rotations"]
            row["positions"] = arrays[f"{row['name']}_positions"]
        return self.transform(row) if self.transform is not None else row

    def __iter__(self):
        for i in range(len(self)):
            yield self[i]

    def _arrays(self, rel: str) -> dict[str, np.ndarray]:
        """A shard's arrays, read whole and kept (the last ``cache`` shards): clips are read in order, shard by shard."""
        if rel not in self._open:
            if len(self._open) >= self._cache:
                self._open.pop(next(iter(self._open)))
            with np.load(self.folder / rel, allow_pickle=False) as z:
                self._open[rel] = {k: z[k] for k in z.files}
        return self._open[rel]

    def column(self, name: str) -> np.ndarray:
        """A manifest column of the clips made, as a NumPy array."""
        return np.array([r[name] for r in self.rows])

    @property
    def failed(self) -> list[dict]:
        """The rows of the clips that failed, with their ``error``."""
        return self.manifest.filter(pc.not_equal(self.manifest["status"], "ok")).to_pylist()

    def source(self, name: str):
        """The verb (or graph) a clip came from, read from the dataset's ``sources/`` (joint names, parents, adverbs)."""
        from .sources import graph_from_bytes
        from ..verb.store import load_verb

        for s in self.description["sources"]:
            if s["name"] == name:
                path = self.folder / s["file"]
                return load_verb(path) if s["kind"] == "verb" else graph_from_bytes(path.read_bytes(), str(path))
        raise KeyError(name)


def load_dataset(folder: str | Path, transform=None) -> MotionDataset:
    """The dataset in ``folder`` (what :func:`adverbs.dataset` wrote) as a :class:`MotionDataset`."""
    return MotionDataset(folder, transform)
