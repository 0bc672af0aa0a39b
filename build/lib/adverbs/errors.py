"""Error types raised on bad input: each names the file, line or field at fault."""

from __future__ import annotations

from pathlib import Path


class AdverbsError(ValueError):
    """Base class of every error about bad user input."""


class BVHError(AdverbsError):
    """A BVH file that cannot be read: the message names the file and the line.

    Attributes
    ----------
    path : str or None
        The file (``None`` when reading from a string).
    line : int or None
        1-based line number of the fault, when there is one.
    reason : str
        What is wrong, without the location.
    """

    def __init__(self, reason: str, path: str | Path | None = None, line: int | None = None):
        self.path = None if path is None else str(path)
        self.line = line
        self.reason = reason
        where = self.path or "<string>"
        if line is not None:
            where = f"{where}:{line}"
        super().__init__(f"{where}: {reason}")


class AdverbsWarning(UserWarning):
    """Something worth knowing that does not stop the work: an adverb point far outside the examples."""
