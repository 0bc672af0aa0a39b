"""Arrays passed into a kernel: held in one object, and borrowed inside it.

**Held.** numba unboxes every array of a call's arguments from its Python object, about 75 ns each; the frame's
pass takes some 140 arrays in nested tuples, so a call cost 10 µs before any creature moved — half of one
creature's frame. :func:`hold` puts such a tuple into a :class:`Held` (a numba structref, made once, whenever an
array in it is replaced), and a kernel given a ``Held`` unboxes one pointer and reads ``.box``: the same arrays,
written in place as before.

**Borrowed.** numba counts references to every array it holds (its *meminfo*), and every view it takes — a creature's row, a
verb's columns of a packed table, a slice handed to another compiled function — adds one and takes it away again.
Each is an atomic instruction. The frame's pass takes several hundred views per creature: a quarter of a
10,000-creature frame went to those two instructions alone (measured with ``perf``), and on two threads both
cores count on the same arrays, so each count waits for the other core's cache.

:func:`borrowed_box` gives back a :class:`Held`'s box — arrays in tuples nested any way — with each array's
meminfo (and its parent object) set to null, read straight from the structref (``.box`` would count each array in
and out once more). The arrays are the same memory, shape and strides; only their counting is gone, and numba's own
``NRT_incref``/``NRT_decref`` skip a null meminfo. That is safe for what a kernel is *given*: the ``Held`` keeps its
arrays for as long as it lives, and its caller holds it for the whole call. Never for an array the kernel allocates
itself: numba frees that once its own reference is dropped, whatever views of it a borrowed copy still has.
"""

from __future__ import annotations

from numba import njit, types
from numba.core import cgutils
from numba.core.runtime import nrtdynmod
from numba.experimental import structref
from numba.extending import intrinsic


@structref.register
class HeldType(types.StructRef):
    """The numba type of :class:`Held`: one field, ``box``, of the tuple's own type."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class Held(structref.StructRefProxy):
    """A kernel's arguments, a tuple of arrays and numbers nested any way, as one object (see :func:`hold`)."""

    @property
    def box(self):
        return _box(self)


structref.define_constructor(Held, HeldType, ["box"])
structref.define_boxing(HeldType, Held)


@njit(cache=True)
def _box(held):  # pragma: no cover - compiled
    return held.box


@njit(cache=True)
def hold(box):  # pragma: no cover - compiled
    """``box`` held in a :class:`Held`: unboxed once here, then passed to kernels as one pointer."""
    return Held(box)


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


def _data(context, builder, ty, value):
    """The payload of structref ``value`` of type ``ty``: ``structref._Utils.get_data_struct``, its meminfo's data
    pointer read as ``NRT_MemInfo_data_fast`` reads it (the fourth word), which needs no reference counting (a function
    compiled without it may read a ``Held`` it is given)."""
    meminfo = structref._Utils(context, builder, ty).get_struct_ref(value).meminfo
    info = builder.bitcast(meminfo, nrtdynmod._meminfo_struct_type.as_pointer())
    data = builder.load(cgutils.gep(builder, info, 0, 3))
    payload = context.data_model_manager[ty.get_data_type()].get_value_type()
    return cgutils.create_struct_proxy(ty.get_data_type())(context, builder, ref=builder.bitcast(data, payload.as_pointer()))


@intrinsic
def borrowed_box(typingctx, held):  # pragma: no cover - compiled
    """The box of ``held`` with every array's meminfo null, read from the structref without counting its arrays in
    and out (``held.box`` would: two atomic instructions per array per call)."""
    box = held.field_dict["box"]

    def codegen(context, builder, signature, args):
        return _strip(context, builder, box, _data(context, builder, signature.args[0], args[0]).box)

    return box(held), codegen
