"""The files of a bank's folder: ``manifest.jsonl`` and ``manifest.csv``, one row per sound
(docs/banks.md, "Manifest"), the stored spec (``bank.json``), and what a run and a gain pass
share. The parent alone appends rows, each line whole and fsynced after its file is in place
(a ``kill -9`` loses no finished row); a run's start and end rewrite both files atomically.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from synth.store.atomic import temporary_name, write_atomically
from synth.store.atomic import write_once as write_once
from synth.store.reproducible import decoded_sha256, reproducible

JSONL = "manifest.jsonl"
CSV = "manifest.csv"
SPEC = "bank.json"
LOCK = ".bank.lock"

#: Columns after the varied keys.
RESULT_COLUMNS = tuple(
    "labels tags seed status error duration audible_duration stop_reason length_reason ticks "
    "first_restitution first_speed first_contact_time first_peak_force peak_dbfs "
    "true_peak_dbtp loudness_lufs spectral_centroid sha256 audio_sha256 scene".split()
)

#: Temporary files of :mod:`synth.store.atomic` beside their targets: hidden, 12 hex digits,
#: then ``.part[.ext]`` (``.{name}.{hex}.part.wav``, ``.synth-{pid}-{hex}.part.wav``).
TEMPORARY = re.compile(r"^\..+[.-][0-9a-f]{12}\.part(\.[A-Za-z0-9]+)?$")

#: Suffixes of the audio files a bank writes: the files :func:`orphans` looks for.
AUDIO_SUFFIXES = (".wav", ".flac", ".ogg")


@dataclass
class Outcome:
    """What a pass over a bank's folder did: files ``done`` now, ``skipped`` (complete;
    ``renamed`` of them), ``orphans`` (audio files in neither the manifest nor the plan,
    deleted if ``pruned``), ``elapsed`` s."""

    out_dir: Path
    done: int = 0
    skipped: int = 0
    renamed: int = 0
    orphans: list = field(default_factory=list)
    pruned: bool = False
    elapsed: float = 0.0

    @property
    def rate(self) -> float:
        return self.done / self.elapsed if self.elapsed > 0 else 0.0

    def files_note(self) -> str:
        """The summary's lines on files renamed and orphans (removed with ``--prune``, or
        left), each after a newline."""
        text = f"\n  {self.renamed} files renamed (same sounds, new names)" if self.renamed else ""
        if not (names := self.orphans):
            return text
        shown = ", ".join(names[:5]) + (f" ... ({len(names) - 5} more)" if len(names) > 5 else "")
        if self.pruned:
            return text + f"\n  {len(names)} files not in the manifest removed (--prune): {shown}"
        return text + (
            f"\n  {len(names)} files in the folder are not in the manifest (left in place; "
            f"--prune removes them): {shown}"
        )

    def prune(self, names, prune: bool) -> None:
        """Find the :func:`orphans` of the folder beside ``names``, deleted if ``prune``."""
        self.orphans = orphans(self.out_dir, names, prune)
        self.pruned = prune and bool(self.orphans)


def columns(keys) -> list[str]:
    return ["index", "file", *keys, *RESULT_COLUMNS]


def write_atomic(target: Path, data: bytes) -> None:
    """Write ``data`` to ``target`` atomically (:func:`synth.store.atomic.write_atomically`)."""
    write_atomically(target, lambda tmp: Path(tmp).write_bytes(data))


def clean_temporaries(folder: Path) -> None:
    """Delete the temporaries a killed run left in ``folder`` and below."""
    for p in folder.rglob(".*"):
        if TEMPORARY.match(p.name) and p.is_file():
            p.unlink(missing_ok=True)


def orphans(folder: Path, kept_names, prune=False) -> list[str]:
    """The audio files below ``folder`` (relative names, sorted) not in ``kept_names`` (the
    manifest's and the plan's), temporaries not counted; with ``prune`` they are deleted,
    and the subfolders they leave empty."""
    kept = set(kept_names)
    out = []
    for p in folder.rglob("*"):
        name = p.relative_to(folder).as_posix()
        if p.suffix.lower() in AUDIO_SUFFIXES and not TEMPORARY.match(p.name) and p.is_file():
            if name not in kept:
                out.append(name)
    for name in out if prune else ():
        (folder / name).unlink(missing_ok=True)
        remove_empty_folders(folder, (folder / name).parent)
    return sorted(out)


def remove_empty_folders(folder: Path, sub: Path) -> None:
    """Remove ``sub`` and its parents below ``folder`` while empty."""
    while inside(folder, sub):
        try:
            sub.rmdir()
        except OSError:  # not empty
            return
        sub = sub.parent


def inside(folder: Path, path: Path) -> bool:
    """True if ``path`` lies below ``folder`` (a manifest's file name is trusted no further)."""
    try:
        where, top = path.resolve(), folder.resolve()
        return where.is_relative_to(top) and where != top
    except OSError:
        return False


def intact(folder: Path, row: dict) -> bool:
    """True if ``row``'s file lies below ``folder`` with the SHA-256 the row records."""
    path = folder / str(row.get("file"))
    return (
        isinstance(row.get("file"), str)
        and inside(folder, path)
        and path.is_file()
        and sha256_file(path) == row.get("sha256")
    )


def move_files(out_dir: Path, fmt: str, moves: dict) -> dict:
    """Move the files ``moves`` (index: (old name, new name) in ``out_dir``) through
    temporaries (a new name may be another's old one), each as the bytes a render gives
    under its new name (:func:`synth.store.reproducible.reproducible`); index: bytes."""
    aside = {}
    for index, (old_name, new_name) in moves.items():
        if old_name != new_name:
            old = out_dir / old_name
            aside[index] = out_dir / temporary_name(old.suffix)
            os.replace(old, aside[index])
            remove_empty_folders(out_dir, old.parent)
    moved = {}
    for index, temporary in aside.items():
        new_name = moves[index][1]
        moved[index] = reproducible(temporary.read_bytes(), fmt, new_name)
        target = out_dir / new_name
        target.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(target, moved[index])
        temporary.unlink()
    return moved


def renamed(out_dir: Path, fmt: str, rows: list[dict], names: dict) -> tuple[list[dict], int]:
    """The complete ``rows`` with their files moved to ``names`` (index: new name,
    :func:`move_files`) and their hashes recomputed where moved; and how many moved."""
    moved = move_files(out_dir, fmt, {r["index"]: (r["file"], names[r["index"]]) for r in rows})
    out = [
        dict(r, file=names[r["index"]], **file_hashes(moved[r["index"]]))
        if r["index"] in moved
        else r
        for r in rows
    ]
    return out, len(moved)


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def file_hashes(data: bytes) -> dict:
    """``sha256`` of ``data`` and ``audio_sha256`` of its decoded samples."""
    return {"sha256": hashlib.sha256(data).hexdigest(), "audio_sha256": decoded_sha256(data)}


def _csv_line(row: dict, cols) -> str:
    """A CSV line; None empty, lists and tables as JSON text."""
    buf = io.StringIO()
    cells = [row.get(c) for c in cols]
    cells = [json.dumps(v) if isinstance(v, list | tuple | dict) else v for v in cells]
    csv.writer(buf, lineterminator="\n").writerow(cells)
    return buf.getvalue()


def _json_line(row: dict, cols) -> str:
    return json.dumps({c: row.get(c) for c in cols}, allow_nan=False) + "\n"


def read_rows(folder: Path) -> list[dict]:
    """The rows of ``folder``'s JSON Lines manifest, the last of each index; a line that is
    not a whole JSON object (cut by a crash) is skipped."""
    path = folder / JSONL
    if not path.is_file():
        return []
    rows = {}
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(row, dict) and isinstance(row.get("index"), int) and line.endswith("\n"):
                rows[row["index"]] = row
    return [rows[i] for i in sorted(rows)]


class Manifest:
    """The two manifest files of a bank's ``folder``."""

    def __init__(self, folder: Path, cols: list[str]):
        self.folder = Path(folder)
        self.cols = list(cols)
        self._files = None

    def rewrite(self, rows) -> None:
        """Replace both files, atomically, by ``rows``."""
        self.close()
        rows = sorted(rows, key=lambda r: r["index"])
        header = _csv_line({c: c for c in self.cols}, self.cols)
        csv_text = header + "".join(_csv_line(r, self.cols) for r in rows)
        write_atomic(self.folder / CSV, csv_text.encode())
        write_atomic(self.folder / JSONL, "".join(_json_line(r, self.cols) for r in rows).encode())

    def append(self, row: dict) -> None:
        """Add one row to both files, each line written whole, flushed and fsynced."""
        if self._files is None:  # held open for the run
            self._files = [
                open(self.folder / JSONL, "a", encoding="utf-8"),  # noqa: SIM115
                open(self.folder / CSV, "a", encoding="utf-8", newline=""),  # noqa: SIM115
            ]
        for fh, line in zip(self._files, (_json_line(row, self.cols), _csv_line(row, self.cols))):
            fh.write(line)
            fh.flush()
            os.fsync(fh.fileno())

    def close(self) -> None:
        for fh in self._files or ():
            with contextlib.suppress(OSError):
                fh.close()
        self._files = None


def read_spec(folder: Path) -> dict | None:
    path = folder / SPEC
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None


def write_spec(folder: Path, spec: dict) -> None:
    write_json(folder / SPEC, spec)


def write_json(path: Path, obj: dict) -> None:
    """``obj`` as indented JSON with sorted keys, written atomically."""
    write_atomic(path, (json.dumps(obj, indent=1, sort_keys=True) + "\n").encode())
