"""Encoded audio whose bytes depend only on its samples and a chosen identity: :func:`reproducible`
zeroes a float WAV's ``PEAK`` time stamp and sets an Ogg stream's serial (RFC 3533, checksums
recomputed)."""

from __future__ import annotations

import hashlib
import io
import struct

import numpy as np

__all__ = ["decoded_sha256", "ogg_serial_for", "reproducible", "set_ogg_serial"]


def _crc_entry(i: int) -> int:
    r = i << 24
    for _ in range(8):
        r = ((r << 1) ^ 0x04C11DB7) if r & 0x80000000 else (r << 1)
    return r & 0xFFFFFFFF


_CRC_TABLE = [_crc_entry(i) for i in range(256)]


def ogg_crc(page: bytes) -> int:
    """The Ogg CRC-32 of ``page`` (its CRC field must be zero)."""
    crc = 0
    for b in page:
        crc = ((crc << 8) & 0xFFFFFFFF) ^ _CRC_TABLE[((crc >> 24) ^ b) & 0xFF]
    return crc


def ogg_serial_for(name: str) -> int:
    """A stream serial number (32 bits) that is a function of ``name`` alone."""
    return int.from_bytes(hashlib.sha256(name.encode("utf-8")).digest()[:4], "little")


def set_ogg_serial(data: bytes, serial: int) -> bytes:
    """The Ogg file ``data`` (one logical stream) with every page's serial number set
    to ``serial`` and its CRC recomputed. Raises ValueError on bytes that are not a
    sequence of whole Ogg pages."""
    out = bytearray(data)
    pos = 0
    while pos < len(out):
        if out[pos : pos + 4] != b"OggS" or pos + 27 > len(out):
            raise ValueError(f"not an Ogg page at byte {pos}")
        n_segments = out[pos + 26]
        table_end = pos + 27 + n_segments
        end = table_end + sum(out[pos + 27 : table_end])
        if table_end > len(out) or end > len(out):
            raise ValueError(f"Ogg page at byte {pos} is cut")
        struct.pack_into("<I", out, pos + 14, serial)
        struct.pack_into("<I", out, pos + 22, 0)
        struct.pack_into("<I", out, pos + 22, ogg_crc(bytes(out[pos:end])))
        pos = end
    return bytes(out)


def riff_chunks(f):
    """The chunks of the RIFF/WAVE file object ``f`` up to ``data``: ``(id, size in bytes,
    offset of its content)``, ``f`` at that offset; none if ``f`` is not RIFF/WAVE."""
    head = f.read(12)
    if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WAVE":
        return
    while len(chunk := f.read(8)) == 8:
        cid, size, at = chunk[:4], struct.unpack("<I", chunk[4:])[0], f.tell()
        yield cid, size, at
        if cid == b"data":
            return
        f.seek(at + size + (size & 1))


def _zero_wav_peak_timestamp(data: bytes) -> bytes:
    """WAV ``data`` with the timestamp of its ``PEAK`` chunk (if any) set to 0."""
    out = bytearray(data)
    for cid, size, at in riff_chunks(io.BytesIO(data)):
        if cid == b"PEAK" and size >= 8:
            struct.pack_into("<I", out, at + 4, 0)  # after the chunk's version field
            break
    return bytes(out)


def reproducible(data: bytes, fmt: str, identity: str) -> bytes:
    """``data`` encoded as ``fmt`` ("wav", "flac", "ogg") made a function of its samples
    and ``identity`` (the Ogg serial is :func:`ogg_serial_for` of it)."""
    if fmt == "ogg":
        return set_ogg_serial(data, ogg_serial_for(identity))
    return _zero_wav_peak_timestamp(data) if fmt == "wav" else data


def decoded_sha256(data: bytes) -> str:
    """SHA-256 (hex) of the decoded samples of an encoded file: 32-bit floats,
    little-endian, frames in order, channels interleaved (exact for PCM up to 24 bits;
    for a lossy format the decoder's output, the same on every run of one decoder)."""
    import soundfile

    samples, _ = soundfile.read(io.BytesIO(data), dtype="float32", always_2d=True)
    return hashlib.sha256(np.ascontiguousarray(samples, dtype="<f4").tobytes()).hexdigest()
