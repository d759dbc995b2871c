"""Memory ordering between the trigger threads and the audio thread.

A slot of a body's pending ring (:mod:`synth.live.queue`) is handed over by writing its
data, then its state word; the audio thread reads the state word, then the data. x86 keeps
stores in order and loads in order, but ARM64 (Apple silicon, Raspberry Pi) may reorder
either: the producer puts a full fence between its data and its state word
(:func:`publish`), the audio thread one between the state word it read and the data
(:func:`fence`, in :mod:`synth.live.kernel`), and another before it frees a slot.
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
    """A sequentially consistent fence: no load or store moves across it (compiler and
    processor)."""
    _fence()


@compiled(nogil=True)
def publish(state, slot, value):
    """``state[slot] = value`` after every earlier store of the calling thread (the slot's
    data) is visible to other threads."""
    _fence()
    state[slot] = value


@intrinsic
def pointer_to(typingctx, address):
    """The int64 ``address`` as a ``void*`` (for ``numba.carray``)."""
    sig = types.voidptr(types.int64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return sig, codegen
