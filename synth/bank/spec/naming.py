"""The rows' labels and file names: the spec's ``labels`` and its ``name`` template filled
with each row's values, checked to be distinct and portable."""

from __future__ import annotations

import string
from types import SimpleNamespace

from synth.bank.spec.model import BankSpec, spec_error

#: Longest file name most file systems take, bytes (NAME_MAX of ext4, APFS, NTFS).
MAX_NAME_BYTES = 255


class _Labelled:
    """A row's value in the name template: formatted as the value itself, or with the
    format spec ``label`` as its label from the spec's ``[labels]`` table."""

    def __init__(self, key: str, value, table: dict | None):
        self.key, self.value, self.table = key, value, table

    def __getitem__(self, i):
        return self.value[i]

    def __format__(self, fmt: str) -> str:
        if fmt != "label":
            return format(self.value, fmt)
        label = _label_of(self.table or {}, self.value)
        if label is None:
            raise ValueError(
                f"labels.{self.key} has no label for {self.value!r} "
                f"(labels: {', '.join(self.table or {}) or 'none'})"
            )
        return label


def _label_of(table: dict, value):
    """The label of ``value`` in a ``[labels]`` table keyed by the values as text."""
    for text, label in table.items():
        if text == str(value):
            return label
        try:
            if float(text) == float(value):
                return label
        except (TypeError, ValueError):
            continue
    return None


def row_labels(spec: BankSpec, values: dict) -> dict | None:
    """The labels of a row's values (varied key: label) from the spec's ``[labels]``,
    for the keys whose table labels the row's value; None if the spec has none."""
    if not spec.labels:
        return None
    labels = {key: _label_of(table, values.get(key)) for key, table in spec.labels.items()}
    return {key: label for key, label in labels.items() if label is not None}


def _mapping(spec: BankSpec, index: int, values: dict) -> dict:
    m = {"preset": spec.preset_name, "index": index}
    sections: dict = {}
    for key, v in values.items():
        v = _Labelled(key, v, spec.labels.get(key))
        m[key.replace(".", "_")] = v
        if "." in key:
            section, field = key.split(".", 1)
            sections.setdefault(section, {})[field] = v
    for section, fields in sections.items():
        m[section] = SimpleNamespace(**fields)
    return m


def file_name(spec: BankSpec, index: int, values: dict) -> str:
    """The file of row ``index`` (relative to the bank's folder), from the template."""
    try:
        stem = spec.name.format_map(_mapping(spec, index, values))
    except (KeyError, AttributeError, IndexError, ValueError, TypeError) as exc:
        raise _name_error(
            spec,
            f"cannot be filled ({type(exc).__name__}: {exc}); "
            f"fields: preset, index, {', '.join(_field_names(spec))}",
        ) from None
    parts = stem.split("/")
    if "\\" in stem or "\0" in stem or any(not part or part.startswith(".") for part in parts):
        raise _name_error(
            spec,
            f"makes the file name {stem!r}: a name's folders and file must not be empty or "
            f"start with '.' (no '..', no absolute path), and '/' is the only separator",
        )
    name = f"{stem}.{spec.suffix}"
    longest = max((p for p in name.split("/")), key=lambda p: len(p.encode("utf-8")))
    if len(longest.encode("utf-8")) > MAX_NAME_BYTES:
        raise _name_error(
            spec,
            f"makes the name {longest!r} of {len(longest.encode('utf-8'))} bytes for row "
            f"{index}: a file or folder name may have at most {MAX_NAME_BYTES} bytes",
        )
    return name


def _name_error(spec: BankSpec, why: str):
    return spec_error("name", spec.name, why)


def _field_names(spec: BankSpec) -> list[str]:
    return [name for k in spec.keys for name in dict.fromkeys((k.replace(".", "_"), k))]


def check_template(spec: BankSpec) -> None:
    allowed_roots = (
        {"preset", "index"}
        | {k.replace(".", "_") for k in spec.keys}
        | {k.split(".", 1)[0] for k in spec.keys if "." in k}
    )
    try:
        fields = [f for _, f, _, _ in string.Formatter().parse(spec.name) if f is not None]
    except ValueError as exc:
        raise spec_error("name", spec.name, f"is not a format string: {exc}") from None
    for f in fields:
        root = f.split(".", 1)[0].split("[", 1)[0]
        if root not in allowed_roots:
            raise _name_error(
                spec,
                f"names {{{f}}}, which is not an axis; fields: preset, index, "
                f"{', '.join(_field_names(spec)) or '(no axes)'}",
            )
        if (
            root not in ("preset", "index")
            and f.startswith(root + ".")
            and f.split("[", 1)[0] not in spec.keys
        ):
            raise _name_error(
                spec, f"names {{{f}}}, which is not an axis; axes: {', '.join(spec.keys)}"
            )
