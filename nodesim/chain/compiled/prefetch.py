"""A software prefetch for compiled loops that jump through large arrays in an order known ahead.

The compiled engine's phase 1 takes the run's events in time order, one node after another, and reads each event's
entry of (N, K) tables: every entry lies on another node's row, so on another page, and each access is a cache and
TLB miss the loop waits for (:mod:`nodesim.chain.compiled.events`).  Which entries the next events will touch is
known some events ahead (the ring of upcoming ticks), so the loop asks for them early: :func:`prefetch` is LLVM's
``llvm.prefetch`` intrinsic (x86 ``prefetcht0``), a read hint that loads the entry's cache line
(walking the page tables on a TLB miss) without waiting and without any effect on the values computed.  Measured
on the drilling day's event order (:func:`~nodesim.chain.compiled.events.next_events`, 146.5 M events,
2026-12-05): 5.4 s without, 3.5 s with the entries of the event 32 ahead.  (Phase 1's scattered record writes,
:func:`~nodesim.chain.compiled.events.scatter_records`, gained nothing from it: 18-20 against 21-22 ns an event.)
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

AHEAD = 32
"""How many events ahead the loops of :mod:`.events` prefetch (8: 3.8 s, 16: 3.6 s, 32 and 64: 3.5 s above)."""


@intrinsic
def prefetch(typingctx, array, index):
    """Hint that ``array[index]`` (``index`` a tuple of integers, one per dimension, in range) will be read soon; no
    effect on any value."""
    if not isinstance(array, types.Array) or not isinstance(index, types.BaseTuple) or len(index) != array.ndim:
        return None

    def codegen(context, builder, signature, args):
        array_type, index_type = signature.args[0], signature.args[1]
        arr = context.make_array(array_type)(context, builder, args[0])
        indices = [context.cast(builder, v, t, types.intp)
                   for v, t in zip(cgutils.unpack_tuple(builder, args[1], len(index_type)), index_type)]
        ptr = cgutils.get_item_pointer(context, builder, array_type, arr, indices, wraparound=False,
                                       boundscheck=False)
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]),
                                            "llvm.prefetch.p0")
        # (address, read 0, locality 3: keep in every cache level, data cache 1)
        builder.call(fn, [builder.bitcast(ptr, i8p), ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return types.void(array, index), codegen
