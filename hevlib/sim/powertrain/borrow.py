"""Borrowed array views for the kernels' inner loops (numba): no reference counting on the hot path.

Every array a numba function hands to a compiled (not inlined) callee is reference-counted on the way in
and out: an atomic increment and decrement of the array's ``meminfo``. The drive kernels call their
driveline, controller and thermal functions several times per design-step with the component maps
(the engine alone carries nine tables), so those atomic operations were a sixth of the kernel's time on one
thread, and more on two, where both threads bounce the same shared counters between their caches.

:func:`borrowed` returns the same array (data, shape, strides) without a ``meminfo``: numba skips the
reference counting of such a view (its ``NRT_incref``/``NRT_decref`` return at once on a null pointer).
A borrowed view does not keep its memory alive; the owner must outlive it. The kernels borrow at the top
of a per-design function the arrays their caller owns for the whole call (the maps, the cycle, the output
rows), and the per-design thermal scratch arrays, whose owners they keep to the end of the function.
:func:`borrowed` also maps over tuples and ``NamedTuple`` records (each array in them borrowed, scalars as
they are), so a kernel borrows its whole argument list in one line. It works on the LLVM values directly
(an ``intrinsic``): nothing is inlined at numba's IR level, which would cost compile time.

Measured on the hybrid kernel (one thread, flat UDDS, ``perf`` with the kernels' symbols): the reference
counting took 15 % of the time before, under 4 % (the calls on null pointers) after; results are bit for bit
the same.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


def _has_array(ty) -> bool:
    return isinstance(ty, types.Array) or (isinstance(ty, types.BaseTuple) and any(map(_has_array, ty.types)))


def _strip(context, builder, ty, val):
    """``val`` of type ``ty`` with the ``meminfo`` and ``parent`` of every array in it nulled."""
    if isinstance(ty, types.Array):
        ary = context.make_array(ty)(context, builder, val)
        ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
        ary.parent = cgutils.get_null_value(ary.parent.type)
        return ary._getvalue()
    if isinstance(ty, types.BaseTuple):  # tuples and NamedTuples: one LLVM struct of their fields
        for i, t in enumerate(ty.types):
            if _has_array(t):
                val = builder.insert_value(val, _strip(context, builder, t, builder.extract_value(val, i)), i)
    return val


@intrinsic
def borrowed(typingctx, x):
    """``x`` (an array, or a tuple or NamedTuple of arrays, scalars and such tuples) with every array a view
    that is not reference-counted; the owner must outlive it. Numba-compiled code only."""

    def codegen(context, builder, sig, args):
        return _strip(context, builder, sig.args[0], args[0])  # owns nothing: no incref

    return x(x), codegen
