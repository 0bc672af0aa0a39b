"""Motion datasets at scale (``adverbs dataset``): clips of verbs over their adverb spaces and graph performances under
random scripts, made in one process or on a Dask cluster, written in shards with a Parquet manifest, and read back.

``adverbs.dataset`` is this subpackage, and calling it makes a dataset: ``adverbs.dataset(SPEC, OUT, workers=2)`` is
:func:`adverbs.dataset.run.dataset`. :func:`load_dataset` reads one back (:class:`MotionDataset`: NumPy arrays and the
manifest's rows, what a PyTorch ``DataLoader`` takes).
"""

import sys
import types

from .clip import Made, clip, render_shard
from .loader import MotionDataset, load_dataset
from .manifest import COLUMNS, SCHEMA
from .plan import ClipTask, draw_points, plan
from .run import DatasetError, Summary, dataset, prepare
from .sources import Source, build_sources, graph_bytes, graph_from_bytes
from .spec import DatasetSpec, DatasetSpecError, load_dataset_spec

__all__ = [
    "COLUMNS",
    "SCHEMA",
    "ClipTask",
    "DatasetError",
    "DatasetSpec",
    "DatasetSpecError",
    "Made",
    "MotionDataset",
    "Source",
    "Summary",
    "build_sources",
    "clip",
    "dataset",
    "draw_points",
    "graph_bytes",
    "graph_from_bytes",
    "load_dataset",
    "load_dataset_spec",
    "plan",
    "prepare",
    "render_shard",
]


class _Package(types.ModuleType):
    """This subpackage, callable: ``adverbs.dataset(spec, out, ...)`` makes a dataset (:func:`dataset`)."""

    def __call__(self, *args, **kwargs) -> Summary:
        return dataset(*args, **kwargs)


sys.modules[__name__].__class__ = _Package
