"""Memory ordering between trigger threads and the audio thread: data, then a fence, then the
state word (read in the other order); ARM64 may reorder either side without the fence.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from synth.compilation import compiled


@intrinsic
def _fence(typingctx):
    sig = types.none()

    def codegen(context, builder, signature, args):
        builder.fence("seq_cst")
        return context.get_dummy_value()

    return sig, codegen


@compiled(nogil=True, inline="always")
def fence():
    """A sequentially consistent fence (compiler and processor)."""
    _fence()


@compiled(nogil=True)
def publish(state, slot, value):
    """``state[slot] = value`` after the calling thread's earlier stores are visible."""
    _fence()
    state[slot] = value


@intrinsic
def pointer_to(typingctx, address):
    """The int64 ``address`` as a ``void*`` (for ``numba.carray``)."""
    sig = types.voidptr(types.int64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return sig, codegen
