"""Arrays passed into a kernel, borrowed: the same arrays without the reference count numba keeps on them.

numba counts references to every array it holds (its *meminfo*), and every view it takes — a creature's row, a
verb's columns of a packed table, a slice handed to another compiled function — adds one and takes it away again.
Each is an atomic instruction. The frame's pass takes several hundred views per creature: a quarter of a
10,000-creature frame went to those two instructions alone (measured with ``perf``), and on two threads both
cores count on the same arrays, so each count waits for the other core's cache.

:func:`borrowed` gives back its argument — an array, or a tuple of them nested any way — with each array's
meminfo (and its parent object) set to null. The arrays are the same memory, shape and strides; only their
counting is gone, and numba's own ``NRT_incref``/``NRT_decref`` skip a null meminfo. That is safe for what a
kernel is *given*: its caller holds the arrays for the whole call. Never for an array the kernel allocates itself:
numba frees that once its own reference is dropped, whatever views of it a borrowed copy still has.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


def _strip(context, builder, ty, value):
    """``value`` of type ``ty`` with every array's meminfo and parent null (tuples walked into)."""
    if isinstance(ty, types.Array):
        ary = context.make_array(ty)(context, builder, value=value)
        ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
        ary.parent = cgutils.get_null_value(ary.parent.type)
        return ary._getvalue()
    if isinstance(ty, types.BaseTuple):
        for i, item in enumerate(ty):
            value = builder.insert_value(value, _strip(context, builder, item, builder.extract_value(value, i)), i)
        return value
    return value


@intrinsic
def borrowed(typingctx, x):  # pragma: no cover - compiled
    """``x`` (an array, a tuple of arrays and other values, nested) with its arrays' reference counting removed."""

    def codegen(context, builder, signature, args):
        return _strip(context, builder, signature.args[0], args[0])

    return x(x), codegen
