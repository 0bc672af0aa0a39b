"""Built verbs on disk: one zip file holding ``verb.json`` (metadata) and ``.npy`` arrays; no pickles.

Versioned: a file of another version is refused with a message saying to rebuild it from its spec.
Written next to its destination and renamed into place, so a crash never leaves half a verb.
"""

from __future__ import annotations

import io
import json
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from ..errors import AdverbsError
from ..kinematics.skeleton import Skeleton
from ..motion.encoding import DofEncoding
from .constraints import Constraint, Hold
from .tables import Adverb, ExampleRecord, Verb

FORMAT = "adverbs-verb"  # 2 added keytime names, constraints, floor; 3 generic keytimes, smoothing; 4 holds
VERSION = 4


def save_verb(verb: Verb, path: str | Path) -> None:
    """Write the verb as one zip file: ``verb.json`` (metadata) and ``.npy`` arrays; no pickles.

    The file is written next to its destination and renamed into place, so a crash never
    leaves half a verb.
    """
    path = Path(path)
    enc, skel = verb.encoding, verb.skeleton
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "name": verb.name,
        "cyclic": verb.cyclic,
        "fps": verb.fps,
        "num_cp": verb.num_cp,
        "keytime_names": list(verb.keytime_names),
        "constraints": [c.to_dict() for c in verb.constraints],
        "holds": [h.to_dict() for h in verb.holds],
        "floor": verb.floor,
        "smoothing": verb.smoothing,
        "shrinkage": verb.shrinkage,
        "adverbs": [{"name": a.name, "unit": a.unit, "measure": a.measure} for a in verb.adverbs],
        "examples": [
            {
                "name": x.name,
                "source": x.source,
                "part": x.part,
                "fit_error": x.fit_error,
                "refine": x.refine,
                "fine_error": x.fine_error,
            }
            for x in verb.examples
        ],
        "encoding": {
            "kind": enc.kind,
            "body_root": enc.body_root,
            "names": list(enc.names),
            "heading_smoothing": enc.smoothing,
        },
        "skeleton": {
            "names": list(skel.names),
            "channels": [list(c) for c in skel.channels],
            "unit_scale": skel.unit_scale,
            "units": skel.units,
        },
    }
    arrays = {
        "points": verb.points,
        "keytimes": verb.keytimes_table,
        "generic_keytimes": verb.generic_keytimes,
        "hold_table": verb.hold_table,
        "coefficients": verb.coefficients,
        "parents": skel.parents,
        "offsets": skel.offsets,
        "end_site_parents": skel.end_site_parents,
        "end_site_offsets": skel.end_site_offsets,
        "lateral": enc.lateral,
        "reference": enc.reference,
        "base_translations": enc.base_translations,
        "translated": enc.translated,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f, zipfile.ZipFile(f, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("verb.json", json.dumps(meta, indent=1))
            for key, value in arrays.items():
                buf = io.BytesIO()
                np.lib.format.write_array(buf, np.ascontiguousarray(value), allow_pickle=False)
                z.writestr(f"{key}.npy", buf.getvalue())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)

def load_verb(path: str | Path) -> Verb:
    """Read a verb written by :meth:`save`; other versions and damaged files raise AdverbsError."""
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as z:
            meta = json.loads(z.read("verb.json"))
            if not isinstance(meta, dict) or meta.get("format") != FORMAT:
                raise AdverbsError(f"{path}: not an adverbs verb file")
            if meta.get("version") != VERSION:
                raise AdverbsError(
                    f"{path}: verb file version {meta.get('version')!r}; this adverbs reads version {VERSION}. "
                    "Rebuild it from its spec with `adverbs build`."
                )
            arrays = {
                n[:-4]: np.lib.format.read_array(io.BytesIO(z.read(n)), allow_pickle=False)
                for n in z.namelist()
                if n.endswith(".npy")
            }
    except FileNotFoundError:
        raise AdverbsError(f"{path}: no such verb file") from None
    except (zipfile.BadZipFile, KeyError, ValueError, EOFError, OSError) as e:
        if isinstance(e, AdverbsError):
            raise
        raise AdverbsError(f"{path}: damaged verb file ({e})") from None
    try:
        sk = meta["skeleton"]
        skel = Skeleton(
            tuple(sk["names"]),
            arrays["parents"],
            arrays["offsets"],
            tuple(tuple(c) for c in sk["channels"]),
            arrays["end_site_parents"],
            arrays["end_site_offsets"],
            float(sk["unit_scale"]),
            sk["units"],
        )
        e = meta["encoding"]
        enc = DofEncoding(
            e["kind"],
            skel,
            int(e["body_root"]),
            arrays["lateral"],
            arrays["reference"],
            arrays["base_translations"],
            arrays["translated"],
            tuple(e["names"]),
            float(e["heading_smoothing"]),
        )
        adverbs = [Adverb(a["name"], a.get("unit", ""), a.get("measure")) for a in meta["adverbs"]]
        examples = [
            ExampleRecord(
                x["name"], x["source"], x["part"], float(x["fit_error"]), bool(x["refine"]), float(x["fine_error"])
            )
            for x in meta["examples"]
        ]
        return Verb(
            meta["name"],
            enc,
            adverbs,
            examples,
            arrays["points"],
            arrays["keytimes"],
            arrays["coefficients"],
            bool(meta["cyclic"]),
            float(meta["fps"]),
            tuple(meta["keytime_names"]),
            [Constraint(c["effector"], int(c["open"]), int(c["close"])) for c in meta["constraints"]],
            float(meta["floor"]),
            arrays["generic_keytimes"],
            float(meta["smoothing"]),
            float(meta["shrinkage"]),
            [Hold.from_dict(h) for h in meta["holds"]],
            arrays["hold_table"],
        )
    except AdverbsError as e:
        raise AdverbsError(f"{path}: {e}") from None
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
        raise AdverbsError(f"{path}: damaged verb file (missing or malformed {e})") from None
