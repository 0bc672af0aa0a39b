"""The kernels' working arrays, carved from one allocation, and borrowed.

A compiled frame of a small crowd spent a third of its time allocating: every kernel call made its dozen or two
small working arrays (3-vectors, 3×3 matrices, a chunk's poses) one ``np.empty`` at a time, about 0.1 µs each with
the free. Each kernel now allocates one buffer and :func:`carve` cuts its arrays out of it.

The arrays carved are *borrowed*: C-contiguous views made straight from the buffer's pointer, with a null meminfo
(as ``runtime._borrow_kernel`` does for the arrays a kernel is given). numba counts every reference to an array it
holds — two atomic instructions each time a view is passed to another compiled function — and reshaping a slice
of a 1-D array calls a C helper (``numba_attempt_nocopy_reshape``); profiled with ``perf``, the two took an eighth
of a one-creature frame, most of it on these working arrays. The price: a borrowed view does not keep its buffer
alive, so the function that allocates the buffer ends with :func:`keep` of it, which numba counts as the buffer's
last use (it frees a variable right after its last use, not at the function's end).
"""

from __future__ import annotations

from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import populate_array


@intrinsic
def _view(typingctx, buf, at, shape):  # pragma: no cover - compiled
    """``buf[at:at + prod(shape)].reshape(shape)`` (``buf`` 1-D and contiguous), C-contiguous, its meminfo null."""
    if not (isinstance(buf, types.Array) and buf.ndim == 1 and buf.layout == "C"):
        return None
    ndim = len(shape) if isinstance(shape, types.BaseTuple) else 0
    if ndim == 0:
        return None
    out = types.Array(buf.dtype, ndim, "C")

    def codegen(context, builder, signature, args):
        src = context.make_array(signature.args[0])(context, builder, value=args[0])
        view = context.make_array(out)(context, builder)
        intp = context.get_value_type(types.intp)
        itemsize = intp(context.get_abi_sizeof(context.get_data_type(buf.dtype)))
        dims = [context.cast(builder, d, t, types.intp) for d, t in zip(cgutils.unpack_tuple(builder, args[2]), shape)]
        strides, step = [], itemsize
        for d in reversed(dims):
            strides.insert(0, step)
            step = builder.mul(step, d)
        start = context.cast(builder, args[1], signature.args[1], types.intp)
        data = builder.gep(src.data, [start], inbounds=True)
        populate_array(view, data=data, shape=dims, strides=strides, itemsize=itemsize, meminfo=None)
        return view._getvalue()

    return out(buf, at, shape), codegen


@intrinsic
def keep(typingctx, value):  # pragma: no cover - compiled
    """Nothing, but a use of ``value``: the allocating function's last line, so its buffer outlives its carved views."""

    def codegen(context, builder, signature, args):
        return context.get_dummy_value()

    return types.none(value), codegen


@njit(cache=True, inline="always")
def carve(buf, at, shape):  # pragma: no cover - compiled
    """The borrowed view of ``buf`` (1-D, contiguous) from index ``at`` with ``shape`` (a tuple), and the index after
    it. The caller keeps ``buf`` alive for as long as the view is used (:func:`keep`)."""
    n = 1
    for s in shape:
        n *= s
    if at < 0 or at + n > buf.shape[0]:
        raise IndexError("carve: the working buffer is too small")
    return _view(buf, at, shape), at + n
