"""The spec's variations: the full grid of its lists, or its count of rows drawn at random, by
Latin hypercube or on a grid, with a least distance between rows when asked.
"""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np

from synth.bank.spec.model import BankSpec, ListAxis, RangeAxis, spec_error

#: Draws tried for a row before a ``min_distance`` is declared too large; largest ``count``
#: with ``min_distance`` (each row is compared with every earlier one).
MIN_DISTANCE_ATTEMPTS = 1000
MIN_DISTANCE_MAX_ROWS = 20_000
#: How ranges are drawn with ``count`` ("random", "lhs": Latin hypercube block by block)
#: or set without it ("grid": ``steps`` values per range, evenly or, with log, geometrically).
SAMPLINGS = ("random", "lhs", "grid")
#: Rows of one Latin-hypercube block: in each, every range axis has one row per stratum.
LHS_BLOCK = 32

#: Most combinations of the list axes drawn as whole permutations, block by block
#: (:class:`_ListDraws`); not below :data:`MAX_ROWS`, so that beyond it a count never
#: fills a block. Part of the plan's rules (:data:`PLAN_VERSION`).
PERMUTED_COMBINATIONS = 100_000


def grid_axis(axis):
    """A range as the list of its ``steps`` values, ends included (``sampling = "grid"``)."""
    if isinstance(axis, ListAxis):
        return axis
    if axis.steps is None:
        raise spec_error(f"vary.{axis.key}.steps", None, "is needed by sampling = 'grid'")
    n = np.atleast_1d(np.asarray(axis.low, dtype=float)).size
    fractions = np.linspace(0.0, 1.0, axis.steps)
    return ListAxis(axis.key, tuple(axis.position(np.full(n, f)) for f in fractions))


def _lhs_fraction(spec: BankSpec, number: int, size: int, index: int, rng) -> np.ndarray:
    """Row ``index``'s fractions (one per component) of range axis ``number`` with
    ``sampling = "lhs"``: in each block of :data:`LHS_BLOCK` rows, each component's
    strata ``[j, j + 1) / LHS_BLOCK`` are dealt to the rows by a permutation drawn from
    ``default_rng([seed, number, block, 2])`` (one per component), and the row's point in
    its stratum by ``rng``; a row depends on its index alone."""
    block, position = divmod(index, LHS_BLOCK)
    perms = np.random.default_rng([spec.seed, number, block, 2])
    strata = np.array([perms.permutation(LHS_BLOCK)[position] for _ in range(size)])
    return (strata + rng.random(size)) / LHS_BLOCK


class _ListDraws:
    """The values of the list axes of the rows with ``count``, drawn without replacement over
    their ``total`` combinations (numbered as in the grid, the first list axis slowest). With
    ``total`` <= :data:`PERMUTED_COMBINATIONS`, block ``k`` of ``total`` rows takes them in the
    order of a permutation from ``default_rng([seed, a, b, ..., k, 1])`` (``a, b, ...`` the list
    axes' positions in ``[vary]``), so a row depends on its index alone; with more, row ``i``
    draws from ``default_rng([seed, a, b, ..., i, 3])`` until it finds a combination no earlier
    row has. Either way a larger count keeps the first rows."""

    def __init__(self, spec: BankSpec):
        self.axes = [a for a in spec.axes if isinstance(a, ListAxis)]
        self.entropy = [spec.seed] + [
            n for n, a in enumerate(spec.axes) if isinstance(a, ListAxis)
        ]  # the generators' seed: the spec's seed and the list axes' positions
        self.total = math.prod(len(a.values) for a in self.axes)
        self._block, self._order = None, None
        self._drawn: list[int] = []  # beyond PERMUTED_COMBINATIONS: each row's combination
        self._taken: set[int] = set()

    def values(self, index: int) -> dict:
        """Row ``index``'s values of the list axes (varied key: value)."""
        if not self.axes:
            return {}
        c = self._combination(index)
        out = {}
        for axis in reversed(self.axes):
            c, k = divmod(c, len(axis.values))
            out[axis.key] = axis.values[k]
        return out

    def _combination(self, index: int) -> int:
        if self.total <= PERMUTED_COMBINATIONS:
            block, position = divmod(index, self.total)
            if block != self._block:
                rng = np.random.default_rng(self.entropy + [block, 1])
                self._block, self._order = block, rng.permutation(self.total)
            return int(self._order[position])
        while len(self._drawn) <= index:
            c = self._unused(len(self._drawn))
            self._drawn.append(c)
            self._taken.add(c)
        return self._drawn[index]

    def _unused(self, index: int) -> int:
        """A combination no row before ``index`` has, drawn from row ``index``'s generator
        (each draw is new with probability 1 - ``index`` / ``total`` > 0)."""
        rng = np.random.default_rng(self.entropy + [index, 3])
        while True:
            c = 0
            for axis in self.axes:
                c = c * len(axis.values) + int(rng.integers(len(axis.values)))
            if c not in self._taken:
                return c


def _ranges(spec: BankSpec) -> list[RangeAxis]:
    return [a for a in spec.axes if isinstance(a, RangeAxis)]


def _unit_point(spec: BankSpec, values: dict) -> np.ndarray:
    """A row's range values as a point of the unit cube (log ranges in log)."""
    out = []
    for axis in _ranges(spec):
        v = np.atleast_1d(np.asarray(values[axis.key], dtype=float))
        lo = np.atleast_1d(np.asarray(axis.low, dtype=float))
        hi = np.atleast_1d(np.asarray(axis.high, dtype=float))
        if axis.log:
            v, lo, hi = np.log(v), np.log(lo), np.log(hi)
        span = np.where(hi > lo, hi - lo, 1.0)
        out.extend((v - lo) / span)
    return np.array(out)


def _spaced_variations(spec: BankSpec):
    """Rows with ``min_distance``: row ``i`` draws its ranges from ``default_rng([seed,
    i])`` until its point is at least ``min_distance`` from every earlier row's (not
    depending on the count); its lists as without it (:class:`_ListDraws`)."""
    points, lists = [], _ListDraws(spec)
    for i in range(spec.count):
        rng = np.random.default_rng([spec.seed, i])
        for _ in range(MIN_DISTANCE_ATTEMPTS):
            values = _draw(spec, i, lists.values(i), rng)
            p = _unit_point(spec, values)
            nearest = np.min(np.linalg.norm(np.array(points) - p, axis=1)) if points else np.inf
            if nearest >= spec.min_distance:
                break
        else:
            raise spec_error(
                "min_distance",
                spec.min_distance,
                f"leaves no room for row {i} after {MIN_DISTANCE_ATTEMPTS} draws: lower it "
                f"or the count",
            )
        points.append(p)
        yield values


def _draw(spec: BankSpec, index: int, lists: dict, rng=None) -> dict:
    """Row ``index``'s values: its list axes' ``lists`` (a grid point, or drawn by
    :class:`_ListDraws`) and its ranges drawn with ``rng`` (default
    ``default_rng([seed, index])``), in the spec's order of the axes."""
    rng = np.random.default_rng([spec.seed, index]) if rng is None else rng
    values = {}
    for number, axis in enumerate(spec.axes):
        if isinstance(axis, ListAxis):
            values[axis.key] = lists[axis.key]
        elif spec.sampling == "lhs":
            size = np.atleast_1d(np.asarray(axis.low)).size
            values[axis.key] = axis.position(_lhs_fraction(spec, number, size, index, rng))
        else:
            values[axis.key] = axis.draw(rng)
    return values


def row_count(spec: BankSpec) -> int:
    return spec.count if spec.count is not None else _ListDraws(spec).total


class RepeatedRowsWarning(UserWarning):
    """A ``count`` above the number of distinct rows a spec can make: rows repeat."""


def warn_repeated_rows(spec: BankSpec) -> None:
    """Warn when ``count`` passes the distinct rows of a spec without a range axis: rows
    repeat (a randomised block design, valid for stimuli, not for a game's container)."""
    distinct = _ListDraws(spec).total
    if spec.count is None or spec.count <= distinct or _ranges(spec):
        return
    lists = " x ".join(f"{a.key} ({len(a.values)})" for a in spec.axes) or "no axis"
    warnings.warn(
        f"count={spec.count} is more than the {distinct} distinct rows of the list axes "
        f"({lists}) with no range axis: rows repeat, each combination once in every "
        f"{distinct} rows; lower count to {distinct} for distinct sounds",
        RepeatedRowsWarning,
        stacklevel=3,
    )


def variations(spec: BankSpec):
    """The varied values of every row, in index order (a generator of dicts)."""
    if spec.count is not None and spec.min_distance is not None:
        yield from _spaced_variations(spec)
    elif spec.count is not None:
        lists = _ListDraws(spec)
        yield from (_draw(spec, i, lists.values(i)) for i in range(spec.count))
    else:
        axes = [a for a in spec.axes if isinstance(a, ListAxis)]
        for i, combo in enumerate(itertools.product(*(a.values for a in axes))):
            yield _draw(spec, i, {a.key: v for a, v in zip(axes, combo)})
