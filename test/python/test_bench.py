"""The benchmark's targets summary: what it counts as met and what it names as not."""
from types import SimpleNamespace

from rrr_graphslam.bench import Row, target_lines


def row(dataset, kind, count, mode, precision, recall, time=0.1, latency=""):
    return Row(dataset, kind, count, mode, SimpleNamespace(precision=precision, recall=recall),
               {"time": time, "latency": latency, "optimizations": 1, "wall": time})


def test_targets_name_the_inputs_that_miss_them():
    lines = target_lines([
        row("manhattanOlson3500_olson", "random", "1000", "batch", 0.9995, 1.0, time=0.4),
        row("csail", "local", "500", "batch", 1.0, 0.97),
        row("city10000", "random", "1000", "batch", 1.0, 1.0, time=12.0),
        row("city10000", "random", "1000", "batch --full-intra", 1.0, 1.0, time=240.0),
        row("city10000", "random", "1000", "incremental", 1.0, 1.0, time=11.0,
            latency="p50 0.00 ms, p99 31.15 ms, max 646.22 ms per candidate, 59 over 50 ms"),
        row("KITTI 00", "alpha 0.00", "DLoopDetector", "batch", 1.0, 1.0),
    ])
    text = "\n".join(lines)
    assert "synthetic precision 1.000: 2 of 3; not: manhattanOlson3500_olson random 1000 (0.9995)" in text
    assert "synthetic recall >= 0.98: 2 of 3; not: csail local 500 (0.9700)" in text
    assert "KITTI precision 1.000: 1 of 1" in text
    assert "M3500 + 1000 random, batch, under 1 s: 0.40 s (met)" in text
    assert ("City10000 + 1000 random, batch, under 10 s: 12.00 s (NOT met; full-graph intra tests "
            "in this run: 240.00 s, 20x)") in text
    assert "p99 under 50 ms per candidate: 31.1 ms (met)" in text


def test_targets_a_run_did_not_cover_are_left_out():
    lines = target_lines([row("intel", "random", "100", "batch", 1.0, 1.0)])
    assert lines == ["targets:", "  synthetic precision 1.000: 1 of 1", "  synthetic recall >= 0.98: 1 of 1"]
