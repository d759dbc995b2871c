"""One gain for a whole bank (docs/banks.md, "One gain for the bank"): to the loudest true
peak (dBTP) or the median integrated loudness (LUFS, ITU-R BS.1770), each file decoded,
scaled, encoded again into another folder, published once and recorded, so the pass resumes
as the bank does; the source bank is never touched."""

from __future__ import annotations

import json
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import synth
from synth.bank import manifest as mf
from synth.bank import spec as bank_spec
from synth.bank.executors import BankRunError
from synth.bank.row import encode, integrated_loudness
from synth.bank.runner import engine_problem
from synth.bank.spec import BankSpecError
from synth.bank.spec.model import spec_number

#: Targets of the gain and their defaults (dBTP, LUFS).
TARGETS = {"true_peak": -1.0, "loudness": -23.0}
#: File stored beside the scaled bank's manifest: the gain, its target and the source.
GAIN_FILE = "gain.json"
#: Gains tried by :func:`loudness_gain`, and how close the scaled median loudness must come
#: to the level, LU (a thousandth of the smallest step anyone hears, about 1 LU).
LOUDNESS_TRIALS = 8
LOUDNESS_TOLERANCE = 1e-3
#: A row's peak levels, which move by the gain exactly (dBFS, dBTP).
PEAKS = ("peak_dbfs", "true_peak_dbtp")


@dataclass(kw_only=True)
class GainResult(mf.Outcome):
    """The outcome of :func:`apply_gain` (:class:`~synth.bank.manifest.Outcome`): the gain
    (dB), its target and level, and the level ``reached`` (dBTP or LUFS, :func:`_reached`)."""

    gain_db: float
    target: str
    level: float
    reached: float | None = None

    def summary(self) -> str:
        reached = "" if self.reached is None else f", reached {self.reached:.3f}"
        return (
            f"{self.out_dir}: gain {self.gain_db:+.3f} dB ({self.target} to {self.level:g}"
            f"{reached}); {self.done} files scaled, {self.skipped} already done, in "
            f"{self.elapsed:.1f} s{self.files_note()}"
        )


def bank_gain(rows: list[dict], target: str, level: float) -> float:
    """The bank's gain, dB, from its manifest rows: ``level`` less their :func:`_reached`
    level (for ``"loudness"`` the first estimate of :func:`loudness_gain`)."""
    reached = _reached(rows, target)
    if reached is not None:
        return level - reached
    if target == "true_peak":
        raise BankSpecError("target='true_peak': no row has a true peak (silent bank)")
    raise BankSpecError(
        "target='loudness': no row has a loudness (pyloudnorm missing: pip install "
        "'impact-synth[loudness]', or every row below the -70 LUFS gate)"
    )


def _median_loudness(bank_dir: Path, rows: list[dict], gain_db: float) -> float | None:
    """The median integrated loudness, LUFS, of the files of ``rows`` scaled by ``gain_db``
    (those below the -70 LUFS gate left out; None if all are)."""
    import soundfile

    values = []
    for row in rows:
        audio, samplerate = soundfile.read(bank_dir / row["file"], dtype="float64")
        value = integrated_loudness(audio * 10.0 ** (gain_db / 20.0), samplerate)
        if value is not None:
            values.append(value)
    return statistics.median(values) if values else None


def loudness_gain(bank_dir: Path, rows: list[dict], level: float) -> float:
    """The gain, dB, that brings the median loudness of the scaled files to ``level`` LUFS.
    BS.1770's gates make loudness not homogeneous in the gain: each trial measures the
    scaled files and moves the gain by the median's miss (the closest of
    :data:`LOUDNESS_TRIALS`, or the first within :data:`LOUDNESS_TOLERANCE`)."""
    gain = bank_gain(rows, "loudness", level)
    best = None
    for _ in range(LOUDNESS_TRIALS):
        median = _median_loudness(bank_dir, rows, gain)
        if median is None:
            break
        miss = level - median
        if best is None or abs(miss) < abs(best[1]):
            best = (gain, miss)
        if abs(miss) <= LOUDNESS_TOLERANCE:
            break
        gain += miss
    return gain if best is None else best[0]


def _reached(rows: list[dict], target: str) -> float | None:
    """The loudest true peak (dBTP) or the median loudness (LUFS) of ``rows``; None if none
    has one."""
    peak = target == "true_peak"
    key, pick = ("true_peak_dbtp", max) if peak else ("loudness_lufs", statistics.median)
    values = [r[key] for r in rows if r.get(key) is not None]
    return pick(values) if values else None


def _check_target(target: str, level) -> float:
    if target not in TARGETS:
        raise BankSpecError(f"target={target!r} must be one of {', '.join(map(repr, TARGETS))}")
    level = TARGETS[target] if level is None else level
    spec_number("level", level, "must be a finite number (dBTP or LUFS)")
    if target == "true_peak" and level > 0.0:
        raise BankSpecError(f"level={level!r} must be <= 0 dBTP for target='true_peak'")
    if target == "loudness" and not level < 0.0:
        raise BankSpecError(f"level={level!r} must be < 0 LUFS for target='loudness'")
    return float(level)


def _finished_rows(bank_dir: Path) -> tuple[dict, list[dict]]:
    """The stored spec and the rows of a complete bank, else a BankRunError."""
    spec = mf.read_spec(bank_dir)
    if spec is None:
        raise BankRunError(f"bank_dir={str(bank_dir)!r} holds no bank ({mf.SPEC} missing)")
    rows = mf.read_rows(bank_dir)
    bad = [r["index"] for r in rows if r.get("status") != "ok" or not mf.intact(bank_dir, r)]
    if bad or not rows:
        raise BankRunError(
            f"bank_dir={str(bank_dir)!r} is not a finished bank ({len(bad)} rows not ok or "
            f"changed since: {bad[:10]}): run the bank to the end first"
        )
    return spec, rows


def _compared(record: dict) -> dict:
    """The part of a ``gain.json`` record that makes the scaled sounds: the source, target,
    level, gain, the spec's :func:`~synth.bank.spec.compared_form` and the source's engine
    (the pass' engine is checked on its own, :func:`~synth.bank.runner.engine_problem`)."""
    out = dict(record)
    out.pop(bank_spec.ENGINE, None)
    if isinstance(out.get("spec"), dict):
        out["source_engine"] = out["spec"].get(bank_spec.ENGINE)
        out["spec"] = bank_spec.compared_form(out["spec"])
    return out


def _done_rows(out: Path, rows: list[dict], fmt: str) -> tuple[list[dict], int]:
    """The source's ``rows`` whose scaled file in ``out`` is complete, with its levels, gain
    and hashes, moved to the source's names (:func:`~synth.bank.manifest.renamed`); and how
    many were moved."""
    source = {r["index"]: r for r in rows}
    complete = [r for r in mf.read_rows(out) if r["index"] in source and mf.intact(out, r)]
    names = {i: r["file"] for i, r in source.items()}
    moved, renamed = mf.renamed(out, fmt, complete, names)
    scaled = ("gain_db", *PEAKS, "loudness_lufs", "sha256", "audio_sha256")
    return [dict(source[r["index"]], **{k: r.get(k) for k in scaled}) for r in moved], renamed


def _check_scaled_before(out: Path, record: dict) -> None:
    """Refuse an ``out`` scaled otherwise (its :data:`GAIN_FILE` differs) or by another engine."""
    stored = out / GAIN_FILE
    previous = json.loads(stored.read_text()) if stored.is_file() else None
    problem = engine_problem(
        f"out_dir={str(out)!r} ({GAIN_FILE})",
        previous,
        "scale into another folder, or empty this one to scale the bank again",
    )
    if problem is not None:
        raise BankSpecError(problem)
    if previous is not None and _compared(previous) != _compared(record):
        raise BankSpecError(
            f"out_dir={str(out)!r} holds a bank scaled otherwise ({GAIN_FILE} differs): "
            f"use another folder"
        )


def _scale_row(src: Path, out: Path, row: dict, spec: dict, gain_db: float) -> dict:
    """Scale ``row``'s file into ``out`` by ``gain_db`` (dB), encoded again
    (:func:`synth.bank.row.encode`) and written once; its new row: peaks moved by the gain
    (they scale exactly), loudness measured before quantization as a render's row is."""
    import soundfile

    target = out / row["file"]
    target.parent.mkdir(parents=True, exist_ok=True)  # the name's subfolders
    target.unlink(missing_ok=True)  # stale: not recorded with its hash
    audio, samplerate = soundfile.read(src / row["file"], dtype="float64")
    audio = audio * 10.0 ** (gain_db / 20.0)
    advice = f"the gain of {gain_db:+.2f} dB is too high: choose a lower level"
    data = encode(audio, samplerate, spec["format"], spec["subtype"], row["file"], advice)
    loudness = {"loudness_lufs": integrated_loudness(audio, samplerate)}
    if not mf.write_once(target, data):
        data = target.read_bytes()
    peaks = {k: round(row[k] + gain_db, 6) for k in PEAKS if row.get(k) is not None}
    return dict(row, gain_db=gain_db, **peaks, **loudness, **mf.file_hashes(data))


def apply_gain(
    bank_dir, out_dir, *, target: str = "true_peak", level=None, prune: bool = False
) -> GainResult:
    """Scale the finished bank in ``bank_dir`` by one gain into ``out_dir``. ``target``:
    "true_peak" (``level`` dBTP, default -1) or "loudness" (``level`` LUFS, default -23);
    ``prune``: delete the audio files its manifest does not name."""
    level = _check_target(target, level)
    if not isinstance(prune, bool):
        raise BankSpecError(f"prune={prune!r} must be True or False")
    src, out = Path(bank_dir), Path(out_dir)
    if src.resolve() == out.resolve():
        raise BankSpecError(f"out_dir={str(out)!r} must be another folder than the bank's")
    spec, rows = _finished_rows(src)
    spec = bank_spec.canonical(spec)  # as a run stores it, whichever version stored it
    gain = bank_gain(rows, target, level) if target == "true_peak" else None
    gain_db = round(loudness_gain(src, rows, level) if gain is None else gain, 9)
    record = {"source": str(src.resolve()), "spec": spec, "target": target, "level": level}
    record.update(gain_db=gain_db, **{bank_spec.ENGINE: synth.__version__})
    t0 = time.perf_counter()
    _check_scaled_before(out, record)
    out.mkdir(parents=True, exist_ok=True)
    mf.write_json(out / GAIN_FILE, record)
    mf.clean_temporaries(out)
    book = mf.Manifest(out, mf.columns(list(spec.get("vary", {}))) + ["gain_db"])
    kept, renamed = _done_rows(out, rows, spec["format"])
    done = {r["index"] for r in kept}
    result = GainResult(
        out, gain_db=gain_db, target=target, level=level, skipped=len(kept), renamed=renamed
    )
    book.rewrite(kept)
    try:
        for row in (r for r in rows if r["index"] not in done):
            new = _scale_row(src, out, row, spec, gain_db)
            book.append(new)
            kept.append(new)
            result.done += 1
    finally:
        book.rewrite(kept)
    result.reached = _reached(kept, target)
    result.prune([r["file"] for r in kept], prune)
    result.elapsed = time.perf_counter() - t0
    return result
