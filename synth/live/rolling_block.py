"""The audio thread's share of a rolling voice (docs/live.md, "Rolling"): its contact
integrated and its force driving the plate's modes, block by block. A voice holds the same
slot at each ear; the first ear's (the *contact slot*, ``I_C_*``) holds its contact, rolled
once a block for every ear by :func:`synth.physics.rolling_kernels.roll`. The game's updates
reach the callback through a lock-free triple buffer (an atomic :func:`exchange`)."""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic

from synth.compilation import compiled
from synth.live.kernel import EVENT_EARS, HPI, HPR, SEQ_PUT, fence, pointer_to, post_event
from synth.physics import rolling_kernels
from synth.physics.rolling_kernels import N_STATE, Constants, roll, touching_points
from synth.sound.modal_bank.pulse import response_per_transform
from synth.sound.rolling import drive_sample

#: The most integration steps a sample of a live rolling may take: a bound on the callback's work.
MAX_STEPS_PER_SAMPLE = 16

#: Slot states (WRITING: taken by the game's thread, not yet published), and the middle
#: buffer's flag: the game put an update there that the callback has not taken.
FREE, LIVE, WRITING, FRESH = 0, 1, 2, 4

#: int64 fields of a slot (``ints``; (c): read in the contact slot): state, voice id; (c) the
#: middle buffer (| FRESH), the callback's, the game's; (c) the stop fade asked (frames, -1
#: none), the fade's first frame (-1 none), its length, the fade of a voice ending by itself;
#: 1 once preloaded; (c) why it ended (END_*), steps, frames; samples beyond the table; (c) the
#: envelope's spline coefficients' and contact offsets' addresses and lengths; the body's ears;
#: the ``heard_seq`` heard through; 1: accelerometer; (c) the first frame of the block last
#: rolled; the contact slot's ints', floats', state's and work buffer's addresses.
(
    I_STATE, I_ID, I_MIDDLE, I_FRONT, I_BACK, I_STOP, I_FADE_FROM, I_FADE_LEN, I_END_FADE,
    I_STARTED, I_ENDED, I_STEPS, I_FRAMES, I_OVERRUN, I_ENV, I_ENV_N, I_OFF, I_OFF_N, I_EARS,
    I_HEARD, I_DIRECT, I_BLOCK, I_C_INTS, I_C_FLOATS, I_C_Y, I_C_BUF, N_INTS,
) = range(27)  # fmt: skip

#: Why a rolling voice ended (``I_ENDED``).
END_STOPPED, END_SURFACE, END_FAILED = 1, 2, 3

#: float64 fields of a slot (``floats``): (contact) the kernel's :class:`Constants`, the
#: envelope's spacing and length, the next step, the segment's anchor; the ear's gains; (contact)
#: the last force, the speed, the force before the block last rolled.
(
    F_M, F_K, F_N, F_MU, F_B, F_BETA, F_G, F_FS, F_RTOL, F_DREF, F_HMAX,
    F_DX, F_LENGTH, F_H, F_ANCHOR, F_GAIN, F_GAIN_NOW, F_PREVIOUS, F_SPEED, F_BEFORE,
    N_FLOATS,
) = range(21)  # fmt: skip

#: A buffer's scalars (``meta``): the speed (m/s), the table's start and step (m), its rows.
M_SPEED, M_START, M_STEP, M_ROWS, N_META = range(5)

#: Rows of a slot's coefficients (``coef``, (N_COEF, K), each complex one re, im): ``e^(p/fs)``,
#: the listener's response now, the hold's gain ``(e^(p/fs) - 1) / p`` (as
#: :func:`synth.sound.rolling.drive_modes`), ``-1 / p`` (the preload's deflection), the
#: response's target after a move, what turns a heard gain ``G_k`` into the response (``-i s /
#: omega_dk``, ``s`` the full-scale factor) and into the accelerometer's direct weight (``s /
#: p_k^2``); that weight (real) now and its target.
(
    C_ER, C_EI, C_LR, C_LI, C_HR, C_HI, C_QR, C_QI, C_TR, C_TI, C_OR, C_OI, C_AR, C_AI,
    C_D, C_DT, N_COEF,
) = range(17)  # fmt: skip

#: Rows of a slot's work buffer ((N_BUF, mix frames); the contact slot's is read).
W_SPEED, W_FORCE, W_MINPEN, W_CENTRE, N_BUF = range(5)


@intrinsic
def _xchg(typingctx, array, index, value):
    """``old = array[index]; array[index] = value`` as one atomic exchange (int64)."""
    sig = types.int64(array, types.intp, types.int64)

    def codegen(context, builder, signature, args):
        arr_t, _, _ = signature.args
        arr = context.make_array(arr_t)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, arr_t, arr, [args[1]])
        return builder.atomic_rmw("xchg", ptr, args[2], "seq_cst")

    return sig, codegen


@intrinsic
def _read_only(typingctx, array):
    """``array`` typed read-only, the same data: the envelope as Python hands it to
    :func:`~synth.physics.rolling_kernels.roll` (read-only), so that the rolling kernels
    compile once for both callers."""
    sig = array.copy(readonly=True)(array)

    def codegen(context, builder, signature, args):
        return impl_ret_borrowed(context, builder, signature.return_type, args[0])

    return sig, codegen


@compiled(nogil=True)
def exchange(array, index, value):
    """Atomically swap ``array[index]`` (int64) with ``value``; returns the old value."""
    return _xchg(array, index, value)


def rolling_arrays(slots: int, modes: int, rows: int, frames: int) -> dict:
    """A body's rolling arrays by body-record field: ``slots`` slots of ``modes`` modes, tables of
    ``rows`` rows, work buffers of ``frames``."""
    return dict(
        roll_ints=np.zeros((slots, N_INTS), dtype=np.int64),
        roll_floats=np.zeros((slots, N_FLOATS)), roll_y=np.zeros((slots, N_STATE)),
        roll_buf=np.zeros((slots, N_BUF, frames)), roll_z=np.zeros((slots, 2, modes)),
        roll_coef=np.zeros((slots, N_COEF, modes)), roll_tables=np.zeros((slots, 3, rows, modes)),
        roll_meta=np.zeros((slots, 3, N_META)), n_rolls=slots, roll_rows=rows, roll_frames=frames,
    )  # fmt: skip


@compiled(nogil=True, inline="always")
def _direct_weights(d, row):
    """``sum_k d_k row_k``: an accelerometer's direct term per newton at a table row."""
    acc = 0.0
    for k in range(d.shape[0]):
        acc += d[k] * row[k]
    return acc


@compiled(nogil=True, inline="always")
def _heard_change(coef, zr, zi):
    """``sum_k Re[(target_k - response_k) zeta_k]``: what the listener's move adds to the
    heard signal of the modes ``zr + i zi`` when the ramp is complete."""
    tr, ti, lr, li = coef[C_TR], coef[C_TI], coef[C_LR], coef[C_LI]
    acc = 0.0
    for k in range(zr.shape[0]):
        acc += (tr[k] - lr[k]) * zr[k] - (ti[k] - li[k]) * zi[k]
    return acc


@compiled(nogil=True, sums=True)
def _drive(out, n, force, coordinate, start, step, rows, table, coef, zr, zi, gain0, gain1,
           fade_at, fade_len, ramp, direct, previous):  # fmt: skip
    """Drive the modes ``zr + i zi`` with ``force`` at ``coordinate`` (m along the table, held at
    its ends) as :func:`synth.sound.rolling.drive_modes`, adding what the listener hears (ramped
    when ``ramp``; ``direct``: an accelerometer's term, ``previous`` the force before) times the
    gain ramped ``gain0`` to ``gain1`` and the fade from ``fade_at`` (-1 none) into ``out``.
    Returns the samples held at a table end."""
    er, ei, lr, li, hr, hi = coef[C_ER], coef[C_EI], coef[C_LR], coef[C_LI], coef[C_HR], coef[C_HI]
    overrun = 0
    g_step = (gain1 - gain0) / n
    weights = -1  # the table interval whose direct weights are da0 .. db1
    da0 = da1 = db0 = db1 = 0.0
    for j in range(n):
        u = (coordinate[j] - start) / step
        if u > rows - 1.0:
            u = rows - 1.0
            overrun += 1
        elif u < 0.0:
            u = 0.0
            overrun += 1
        i = int(math.floor(u))
        if i > rows - 2:
            i = rows - 2
        t = u - i
        F = force[j]
        wa, wb = (1.0 - t) * F, t * F
        row_a, row_b = table[i], table[i + 1]
        w = (j + 1.0) / n  # the listener's ramp, as the body's impact voices' (kernel.py)
        moved = _heard_change(coef, zr, zi) if ramp else 0.0
        acc = drive_sample(wa, wb, row_a, row_b, er, ei, lr, li, hr, hi, zr, zi) + w * moved
        if direct:
            if i != weights:
                da0 = _direct_weights(coef[C_D], row_a)
                db0 = _direct_weights(coef[C_D], row_b)
                da1 = _direct_weights(coef[C_DT], row_a) if ramp else da0
                db1 = _direct_weights(coef[C_DT], row_b) if ramp else db0
                weights = i
            da, db = da0 + w * (da1 - da0), db0 + w * (db1 - db0)
            acc += 0.5 * (F + previous) * ((1.0 - t) * da + t * db)
            previous = F
        g = gain0 + g_step * (j + 1)
        if fade_at >= 0:
            at = fade_at + j
            g = g * 0.5 * (1.0 + math.cos(math.pi * at / fade_len)) if at < fade_len else 0.0
        out[j] += g * acc
    return overrun


@compiled(nogil=True, inline="always")
def _take_heard(iv, coef, heard, seq):
    """Gains handed over since the slot's (whole under the producer's sequence number) become its
    target for the block; returns whether."""
    put = seq[SEQ_PUT]
    if put == iv[I_HEARD] or put % 2 == 1:
        return False
    fence()  # the gains after their sequence number
    for k in range(coef.shape[1]):
        gr, gi = heard[HPR, k], heard[HPI, k]
        coef[C_TR, k] = gr * coef[C_OR, k] - gi * coef[C_OI, k]
        coef[C_TI, k] = gr * coef[C_OI, k] + gi * coef[C_OR, k]
        coef[C_DT, k] = gr * coef[C_AR, k] - gi * coef[C_AI, k]
    fence()
    if seq[SEQ_PUT] != put:  # rewritten meanwhile: try again at the next block
        return False
    iv[I_HEARD] = put
    return True


def heard_coefficients(gains, poles, scale: float, accelerometer: bool) -> dict:
    """A slot's listener rows for the complex ``gains`` (K,) of modes of ``poles`` (rad/s) at
    full-scale factor ``scale`` (:func:`synth.sound.modal_bank.pulse.response_per_transform`)."""
    p = np.asarray(poles, dtype=complex)
    to_response = response_per_transform(p, scale, 1.0)
    to_direct = scale / (p * p) if accelerometer else np.zeros(p.size, dtype=complex)
    response = gains * to_response
    return {
        C_LR: response.real, C_LI: response.imag, C_OR: to_response.real,
        C_OI: to_response.imag, C_AR: to_direct.real, C_AI: to_direct.imag,
        C_D: (gains * to_direct).real,
    }  # fmt: skip


@compiled(nogil=True, inline="always")
def _preload(coef, row_a, row_b, t, F, zr, zi):
    """The modes in their static deflection ``-b F / p`` under ``F`` (N) at the row at ``t``."""
    for k in range(zr.shape[0]):
        bf = ((1.0 - t) * row_a[k] + t * row_b[k]) * F
        zr[k] = bf * coef[C_QR, k]
        zi[k] = bf * coef[C_QI, k]


@compiled(nogil=True, inline="always")
def _take_update(iv, fv, y):
    """Take the game's newest update, anchoring its segment at the centre's path now."""
    if (iv[I_MIDDLE] & FRESH) != 0:
        old = _xchg(iv, I_MIDDLE, iv[I_FRONT])
        iv[I_FRONT] = old & 3
        fv[F_ANCHOR] = y[rolling_kernels.S]


@compiled(nogil=True, inline="always")
def _contact_coordinates(centre, speed, fs, offsets, dx, anchor):
    """The touching point's distance along the segment (m) mid-period, over the centre's path
    coordinates ``centre`` (in place): as :meth:`synth.physics.rolling.Roller.contact_coordinates`,
    less the ``anchor`` (m)."""
    half = 0.5 * speed / fs
    for j in range(centre.shape[0]):
        centre[j] += half
    touching_points(centre, offsets, dx, centre)
    for j in range(centre.shape[0]):
        centre[j] -= anchor


@compiled(nogil=True, inline="always")
def _start_fade(cv, t0, length, why):
    """The voice fades from frame ``t0`` over ``length`` frames, ended ``why`` (END_*)."""
    cv[I_FADE_FROM], cv[I_FADE_LEN], cv[I_ENDED] = t0, max(length, 1), why


@compiled(nogil=True, inline="always")
def _hold_still(cf, y, buf, n):
    """The ball held where it is over the block, its last force on the plate."""
    for j in range(n):
        buf[W_FORCE, j] = cf[F_PREVIOUS]
        buf[W_CENTRE, j] = y[rolling_kernels.S]


@compiled(nogil=True)
def _roll_contact(n, t0, cv, cf, y, buf, speed):
    """Roll a voice's contact (``cv``, ``cf``, state ``y``) over ``n`` frames from ``t0`` at
    ``speed`` (m/s) into ``buf``; its fade started if stopped, leaving the envelope or failed."""
    cv[I_BLOCK], cf[F_BEFORE] = t0, cf[F_PREVIOUS]
    if cv[I_STOP] >= 0 and cv[I_FADE_FROM] < 0:
        _start_fade(cv, t0, cv[I_STOP], END_STOPPED)
    fs = cf[F_FS]
    if cv[I_ENDED] == 0 and y[rolling_kernels.S] + speed * n / fs > cf[F_LENGTH]:
        _start_fade(cv, t0, cv[I_END_FADE], END_SURFACE)  # it would leave the envelope
    force = buf[W_FORCE]
    if cv[I_ENDED] == END_SURFACE or cv[I_ENDED] == END_FAILED:
        _hold_still(cf, y, buf, n)
        speed = 0.0
    else:
        speeds = buf[W_SPEED]
        for j in range(n):
            speeds[j] = speed
        env = _read_only(numba.carray(pointer_to(cv[I_ENV]), (cv[I_ENV_N], 4), np.float64))
        c = Constants(cf[F_M], cf[F_K], cf[F_N], cf[F_MU], cf[F_B], cf[F_BETA], cf[F_G], fs,
                      cf[F_RTOL], cf[F_DREF], cf[F_HMAX])  # fmt: skip
        status, steps, _, _, h = roll(
            y, cf[F_H], env, cf[F_DX], speeds[:n], c, MAX_STEPS_PER_SAMPLE * n, force[:n],
            buf[W_MINPEN, :n], buf[W_CENTRE, :n],
        )  # fmt: skip
        cf[F_H] = h
        cv[I_STEPS] += steps
        if status != rolling_kernels.OK:
            _start_fade(cv, t0, cv[I_END_FADE], END_FAILED)
            for j in range(n):
                if not math.isfinite(force[j]):
                    force[j] = cf[F_PREVIOUS]
                    buf[W_CENTRE, j] = y[rolling_kernels.S]
            speed = 0.0
    offsets = _read_only(numba.carray(pointer_to(cv[I_OFF]), cv[I_OFF_N], np.float64))
    _contact_coordinates(buf[W_CENTRE, :n], speed, fs, offsets, cf[F_DX], cf[F_ANCHOR])
    cf[F_PREVIOUS], cf[F_SPEED] = force[n - 1], speed
    cv[I_FRAMES] += n


@compiled(nogil=True)
def _roll_slot(out, n, t0, iv, fv, z, coef, tables, meta, heard, seq, events, frames):
    """One block of a live slot at one ear: its contact rolled (once for every ear), then the
    ear's modes driven. ``frames``: the work buffers' length."""
    cv = numba.carray(pointer_to(iv[I_C_INTS]), N_INTS, np.int64)
    cf = numba.carray(pointer_to(iv[I_C_FLOATS]), N_FLOATS, np.float64)
    buf = numba.carray(pointer_to(iv[I_C_BUF]), (N_BUF, frames), np.float64)
    if cv[I_BLOCK] != t0:
        y = numba.carray(pointer_to(iv[I_C_Y]), rolling_kernels.N_STATE, np.float64)
        _take_update(cv, cf, y)
        _roll_contact(n, t0, cv, cf, y, buf, meta[cv[I_FRONT], M_SPEED])
    ramp = _take_heard(iv, coef, heard, seq)
    m, table = meta[cv[I_FRONT]], tables[cv[I_FRONT]]
    rows, start, step = int(m[M_ROWS]), m[M_START], m[M_STEP]
    force, coordinate, zr, zi = buf[W_FORCE], buf[W_CENTRE], z[0], z[1]
    previous = cf[F_BEFORE]
    if iv[I_STARTED] == 0:
        previous = force[0]  # the plate starts loaded with it (as the offline preload)
        u = min(max((coordinate[0] - start) / step, 0.0), rows - 1.0)
        i = min(int(math.floor(u)), rows - 2)
        _preload(coef, table[i], table[i + 1], u - i, force[0], zr, zi)
        iv[I_STARTED] = 1
    fade_at = t0 - cv[I_FADE_FROM] if cv[I_FADE_FROM] >= 0 else -1
    iv[I_OVERRUN] += _drive(
        out, n, force, coordinate, start, step, rows, table, coef, zr, zi, fv[F_GAIN_NOW],
        fv[F_GAIN], fade_at, cv[I_FADE_LEN], ramp, iv[I_DIRECT] != 0, previous,
    )  # fmt: skip
    if ramp:
        _reach_heard(coef)
    fv[F_GAIN_NOW] = fv[F_GAIN]
    if fade_at >= 0 and fade_at + n >= cv[I_FADE_LEN]:
        _end_slot(iv, events)


@compiled(nogil=True, inline="always")
def _reach_heard(coef):
    """The listener's target reached at a ramp's end."""
    for k in range(coef.shape[1]):
        coef[C_LR, k], coef[C_LI, k], coef[C_D, k] = coef[C_TR, k], coef[C_TI, k], coef[C_DT, k]


@compiled(nogil=True, inline="always")
def _end_slot(iv, events):
    """A slot faded out: free it and post its voice's end at its ear."""
    vid = iv[I_ID]
    fence()  # done with the slot before the game's thread may take it
    iv[I_STATE] = FREE
    post_event(events, vid * EVENT_EARS + iv[I_EARS])


@compiled(nogil=True, inline="always")
def any_live(ints):
    """Whether a rolling slot rings."""
    for r in range(ints.shape[0]):
        if ints[r, I_STATE] == LIVE:
            return True
    return False


@compiled(nogil=True)
def mix_rolls(out, n, t0, form, events):
    """Add every live rolling slot's block into ``out`` (the body's mix); whether one rang."""
    ints, floats, _, bufs, zs, coefs, tables, metas, heard, seq = form
    rang = False
    for r in range(ints.shape[0]):
        if ints[r, I_STATE] != LIVE:
            continue
        fence()  # the slot's data, written before its state word
        _roll_slot(out, n, t0, ints[r], floats[r], zs[r], coefs[r], tables[r], metas[r],
                   heard, seq, events, bufs.shape[2])  # fmt: skip
        rang = True
    return rang


@compiled(nogil=True)
def silence_rolls(ints, events):
    """End every rolling slot now (the engine stops, or ``stop_all``)."""
    for r in range(ints.shape[0]):
        if ints[r, I_STATE] == LIVE:
            ints[r, I_ENDED] = END_STOPPED
            _end_slot(ints[r], events)
