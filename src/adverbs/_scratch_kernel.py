"""The kernels' working arrays, carved from one allocation.

A compiled frame of a small crowd spent a third of its time allocating: every kernel call made its dozen or two
small working arrays (3-vectors, 3×3 matrices, a chunk's poses) one ``np.empty`` at a time, about 0.1 µs each with
the free. Each kernel now allocates one buffer and :func:`carve` cuts its arrays out of it: views, so they live as
long as any of them does.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, inline="always")
def carve(buf, at, shape):  # pragma: no cover - compiled
    """The view of ``buf`` (1-D, contiguous) from index ``at`` with ``shape`` (a tuple), and the index after it."""
    n = 1
    for s in shape:
        n *= s
    return buf[at : at + n].reshape(shape), at + n
