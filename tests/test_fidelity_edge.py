"""The critical distance of Table 3.3 as the thesis' measurement resolves it
(validation/edge.py; docs/validation.md, "Against the thesis' recordings")."""

import json
import math

import pytest

import benchmarks as bench
from synth.constants import GRAVITY
from validation import edge
from validation.modal import modal_critical_distance
from validation.rows import thesis_pair

V1 = math.sqrt(2.0 * GRAVITY * 0.1)  # the thesis' drop of 10 cm (m/s), as the study uses


@pytest.fixture(scope="module")
def fitted():
    """The fitted model's readings of all nine pairs at 2 and 3 %."""
    models = {"fitted model": edge.EDGE_MODELS["fitted model"]}
    return edge.edge_study(models=models, resolutions=(0.02, 0.03))


@pytest.mark.slow
def test_fitted_model_critical_distances_as_measured_table_3_3(fitted):
    # the target: each of the nine pairs inside its measured range (Table 3.3) +- 5 mm,
    # e read at the measurements' repeatability (3 %, thesis section 3.2). Read at 2 % seven
    # are inside too and two (10 mm steel on 12 mm, 17 mm glass on 6 mm: 35.1 mm against 30
    # mm + 5) lie 0.1 mm beyond (asserted as those misses, under 1 mm): the result does not
    # hinge on the exact figure of the repeatability.
    assert len(fitted) == len(bench.THESIS_IMPACTS) == 9
    misses = set()
    for reading in fitted:
        assert reading.within_allowance(edge.THESIS_RESTITUTION_REPEATABILITY), reading
        if not reading.within_allowance(0.02):
            assert 0.0 < reading.distances[0.02] - (reading.measured[1] + 5e-3) < 1e-3, reading
            misses.add((reading.ball, reading.board))
    assert misses == {("steel 10.0 mm", "12 mm"), ("glass 17.0 mm", "6 mm")}


@pytest.mark.slow
def test_resolved_distance_is_where_e_crosses_the_resolution():
    # the reading is the crossing of (1 - r) e_middle, to the bisection's 0.1 mm; a finer
    # resolution lies farther in; every reading lies inside the model's own critical distance
    # (where e stops rising, the curve's first maximum)
    ball, plate = thesis_pair("steel 10.0 mm", "18 mm")
    walk = edge.MidlineWalk(ball, plate, V1, surface="fitted")
    d = walk.resolved_distances((0.01, 0.03, 0.05), tol=1e-4)
    for r, distance in d.items():
        target = (1.0 - r) * walk.middle
        assert walk.restitution(distance - 1e-4) < target <= walk.restitution(distance + 1e-4)
    assert d[0.05] < d[0.03] < d[0.01]
    assert d[0.01] < modal_critical_distance(ball, plate, V1, step=2e-3, surface="fitted")


def test_edge_study_table_and_json():
    # the sensitivity table counts the pairs within the allowance per resolution, and the
    # readings round-trip through JSON (the --json output of synth bench thesis)
    reading = edge.EdgeReading(
        "fitted model", "steel 10.0 mm", "18 mm", (35e-3, 45e-3), {0.02: 0.0353, 0.05: 0.025}
    )
    data = json.loads(json.dumps(edge.edge_study_json([reading])))
    assert edge.EdgeReading.from_json(data[0]) == reading
    table = edge.format_edge_study(data)
    assert "| steel 10.0 mm on 18 mm | fitted model | 35-45 | 35.3 | 25.0 |" in table
    assert "| pairs within the range +- 5 mm | fitted model | | 1 / 1 | 0 / 1 |" in table
