"""The plan: a spec's rows (:class:`PlanItem`) with their file names and scenes, each held to
the render's cost budget, and the row lists of ``--redo``."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from synth import checks, cost
from synth.bank.spec.model import MAX_ROWS, RESTITUTION_SCALE, BankSpec, BankSpecError, spec_error
from synth.bank.spec.naming import file_name
from synth.bank.spec.sampling import row_count, variations, warn_repeated_rows
from synth.errors import ParameterError
from synth.io import presets


@dataclass(frozen=True)
class PlanItem:
    """One sound of the bank: ``index``, ``file`` (in the bank's folder), varied ``values``."""

    index: int
    file: str
    values: dict


def plan(spec: BankSpec, *, check_scenes: bool = True) -> tuple[PlanItem, ...]:
    """Every row of the bank, checked (distinct portable names; with ``check_scenes`` every
    row's scene, :func:`check_rows`), so a bank starts clean or is refused."""
    n = row_count(spec)
    if n > MAX_ROWS:
        raise spec_error(
            "count" if spec.count is not None else "vary",
            n if spec.count is not None else f"a grid of {n} rows",
            f"is more than the {MAX_ROWS} rows a bank may have: split it into several "
            f"banks (seeds or folders)",
        )
    items, seen = [], {}
    for index, values in enumerate(variations(spec)):
        f = file_name(spec, index, values)
        if f in seen:
            raise spec_error(
                "name",
                spec.name,
                f"makes two files the same name {f!r} (rows "
                f"{seen[f]} and {index}): use {{index}} or more axes in it",
            )
        seen[f] = index
        items.append(PlanItem(index, f, values))
    if check_scenes:
        check_rows(spec, items)
    warn_repeated_rows(spec)
    return tuple(items)


#: Rows named in the message of a plan refused for its rows' values.
ROWS_NAMED = 5


def row_problem(spec: BankSpec, item: PlanItem, budget: cost.Budget | None = None) -> str | None:
    """Why row ``item``'s scene cannot be rendered (None if it can): checked as a render
    checks it, its cost estimate held to ``budget`` (solving only the first contact by
    the impedance model: milliseconds)."""
    budget = cost.Budget.from_environment() if budget is None else budget
    try:
        if RESTITUTION_SCALE in item.values:
            checks.nonnegative(RESTITUTION_SCALE, item.values[RESTITUTION_SCALE], "dimensionless")
        scene, options = presets.scene_from_dict(scene_data(spec, item.values), f"row {item.index}")
        cost.estimate_render(scene, options, budget).check(budget)
    except ParameterError as exc:
        return str(exc).removeprefix(f"row {item.index}: ")
    except (TypeError, ValueError) as exc:  # a value of the wrong type deep in a section
        return f"{type(exc).__name__}: {exc}"
    return None


def check_rows(spec: BankSpec, items) -> None:
    """Refuse the plan if a row cannot be rendered, naming the rows, values and problems."""
    budget = cost.Budget.from_environment()
    bad = [(item, why) for item in items if (why := row_problem(spec, item, budget)) is not None]
    if not bad:
        return
    lines = [
        f"row {item.index} ({', '.join(f'{k}={v!r}' for k, v in item.values.items())}): {why}"
        for item, why in bad[:ROWS_NAMED]
    ]
    more = f"\n  ... and {len(bad) - ROWS_NAMED} more rows" if len(bad) > ROWS_NAMED else ""
    raise BankSpecError(
        f"vary: {len(bad)} of {len(items)} rows cannot be rendered:\n  " + "\n  ".join(lines) + more
    )


def scene_data(spec: BankSpec, values: dict) -> dict:
    """The preset dict of a row: the base with its values set as ``--set`` sets them (but
    the restitution scale, no preset key)."""
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in spec.base.items()}
    for key, value in values.items():
        if key != RESTITUTION_SCALE:
            presets.set_key(data, key, value, f"vary.{key}")
    return data


def differences(old: dict, new: dict, prefix: str = "") -> list[str]:
    """The dotted keys whose values differ between two spec dicts (:func:`canonical`)."""
    out = []
    for k in sorted(set(old) | set(new), key=str):
        a, b = old.get(k, dataclasses.MISSING), new.get(k, dataclasses.MISSING)
        key = f"{prefix}{k}"
        if isinstance(a, dict) and isinstance(b, dict):
            out.extend(differences(a, b, key + "."))
        elif a != b:
            out.append(key)
    return out


def parse_rows(text, planned: int) -> frozenset[int]:
    """The row indices of ``text`` (``"17,40-45"``), each in ``0 .. planned - 1``."""
    if isinstance(text, (set, frozenset, list, tuple)):
        parts = [str(v) for v in text]
    elif isinstance(text, str):
        parts = [p.strip() for p in text.split(",")]
    else:
        raise spec_error("redo", text, "must be row indices such as '17,40-45'")
    rows = set()
    for part in parts:
        lo, sep, hi = part.partition("-")
        try:
            first = int(lo)
            last = int(hi) if sep else first
        except ValueError:
            raise spec_error("redo", text, f"has {part!r}, not an index or a range a-b") from None
        if first < 0 or last < first or last >= planned:
            raise spec_error(
                "redo", text, f"has {part!r}: rows are 0 to {planned - 1}, ranges ascending"
            )
        rows.update(range(first, last + 1))
    return frozenset(rows)
