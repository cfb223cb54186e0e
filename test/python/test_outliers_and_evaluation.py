"""Outlier injection, truth files, scoring and the ATE alignment."""
import gzip
import math
import os
import random
import subprocess
import sys
import time

import pytest
from conftest import DATA, SCRIPTS
from rrr_graphslam.evaluation import (Decision, absolute_trajectory_error, align_se2, read_decisions,
                                      read_truth, score)
from rrr_graphslam.graph_io import (Edge, GraphFileError, PoseGraph, between, compose, read_graph,
                                    write_graph)
from rrr_graphslam.outliers import KINDS, add_outliers, chi2_against, gate, outlier_room


@pytest.mark.parametrize("kind", KINDS)
def test_outliers_are_labelled_and_of_their_kind(kind):
    graph = read_graph(os.path.join(DATA, "intel.g2o.gz"))
    corrupted, labels = add_outliers(graph, kind, 100, seed=3, group_size=10, local_window=20)
    loops = corrupted.loops()
    assert len(loops) == len(labels) == len(graph.loops()) + 100
    assert [(e.source, e.target) for e in loops] == [(i, j) for i, j, _ in labels]
    added = loops[len(graph.loops()):]
    assert all(label == 0 for _, _, label in labels[len(graph.loops()):])
    pairs = {(e.source, e.target) for e in graph.edges}
    assert not any((e.source, e.target) in pairs for e in added)
    if kind.startswith("local"):
        assert all(2 <= e.target - e.source <= 20 for e in added)
    if kind.endswith("grouped") or kind == "aliased":
        # groups of 10 consecutive links
        for g in range(0, 100, 10):
            group = added[g:g + 10]
            assert [e.source - group[0].source for e in group] == list(range(10))
            assert [e.target - group[0].target for e in group] == list(range(10))
            # a *-grouped group shares one measurement, an aliased one one rigid offset
            assert len({e.measurement for e in group}) == (1 if kind != "aliased" else 10)


def test_an_aliased_group_agrees_with_itself_and_the_odometry_on_both_sides():
    # Around every cycle link k -> odometry on the `to` side -> link k+1 -> odometry back on the
    # `from` side, the measurements compose to the identity, by the poses the links were drawn
    # from; none of the links agrees with those poses (the offset is wrong).
    graph = read_graph(os.path.join(DATA, "intel.g2o.gz"))
    poses = graph.poses
    added = add_outliers(graph, "aliased", 60, seed=2, group_size=20)[0].loops()[len(graph.loops()):]
    for g in range(0, 60, 20):
        group = added[g:g + 20]
        assert len({(e.source - e.target) for e in group}) == 1
        for k, (e, f) in enumerate(zip(group, group[1:])):
            around = compose(e.measurement, between(poses[e.target], poses[f.target]))
            back = compose(between(poses[e.source], poses[f.source]), f.measurement)
            assert between(around, back) == pytest.approx((0.0, 0.0, 0.0), abs=1e-9), (g, k)
    truth = {i: p for i, p in poses.items()}
    assert all(chi2_against(truth, e.source, e.target, e.measurement, e.information) > gate(0.95)
               for e in add_outliers(graph, "aliased", 60, seed=2, group_size=20,
                                     reference=truth)[0].loops()[len(graph.loops()):])


def test_same_seed_same_outliers():
    graph = read_graph(os.path.join(DATA, "ring.g2o.gz"))
    a = add_outliers(graph, "random", 20, seed=5)[1]
    b = add_outliers(graph, "random", 20, seed=5)[1]
    assert a == b


def test_gate_is_the_tabulated_chi2_quantile():
    # chi2(p, k) quantiles: k = 3: 0.5 -> 2.366, 0.95 -> 7.815, 0.99 -> 11.345; k = 2: 0.95 -> 5.991
    assert gate(0.5) == pytest.approx(2.3660, abs=1e-4)
    assert gate(0.95) == pytest.approx(7.8147, abs=1e-4)
    assert gate(0.99) == pytest.approx(11.3449, abs=1e-4)
    assert gate(0.95, 2) == pytest.approx(5.9915, abs=1e-4)


def test_chi2_against_is_the_quadratic_form_written_out():
    rng = random.Random(7)
    for _ in range(100):
        reference = {0: (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-3, 3)),
                     1: (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-3, 3))}
        z = (rng.gauss(0, 1), rng.gauss(0, 1), rng.gauss(0, 1))
        xx, xy, xt, yy, yt, tt = info = (40.0, 3.0, -2.0, 25.0, 1.0, 90.0)
        e = between(z, between(reference[0], reference[1]))
        written_out = (xx * e[0] ** 2 + yy * e[1] ** 2 + tt * e[2] ** 2
                       + 2 * (xy * e[0] * e[1] + xt * e[0] * e[2] + yt * e[1] * e[2]))
        assert chi2_against(reference, 0, 1, z, info) == pytest.approx(written_out, rel=1e-12)


@pytest.mark.parametrize("kind", ["local", "local-grouped"])
def test_outliers_that_agree_with_the_reference_are_drawn_again(kind):
    # A robot that never moves: every relative pose is the identity, so vertigo's near-zero
    # measurements often agree with the truth and must be drawn again.
    graph = read_graph(os.path.join(DATA, "intel.g2o.gz"))
    still = {i: (0.0, 0.0, 0.0) for i in graph.poses}
    plain = add_outliers(graph, kind, 100, seed=4)[0].loops()[len(graph.loops()):]
    gated = add_outliers(graph, kind, 100, seed=4, reference=still)[0].loops()[len(graph.loops()):]

    def inside(edges):
        return sum(chi2_against(still, e.source, e.target, e.measurement, e.information) < gate(0.95)
                   for e in edges)

    assert inside(plain) > 0
    assert len(gated) == 100 and inside(gated) == 0
    with pytest.raises(ValueError, match="reference poses lack node"):
        add_outliers(graph, kind, 10, reference={0: (0.0, 0.0, 0.0)})
    with pytest.raises(ValueError, match="alpha must be in"):
        add_outliers(graph, kind, 10, reference=still, alpha=1.0)


ADD_OUTLIERS = os.path.join(SCRIPTS, "add_outliers")


def test_add_outliers_command_gates_on_a_reference_file(tmp_path):
    # A reference in which the robot never moves: vertigo's near-zero measurements often agree
    # with it, so without the gate some outliers lie inside it, with the gate none.
    ring = os.path.join(DATA, "ring.g2o.gz")
    graph = read_graph(ring)
    still = tmp_path / "still.g2o"
    write_graph(PoseGraph({i: (0.0, 0.0, 0.0) for i in graph.poses}, graph.edges), str(still))
    out = tmp_path / "ring_local.g2o"

    def run(*args):
        return subprocess.run([sys.executable, ADD_OUTLIERS, ring, str(out), "--kind", "local",
                               "--count", "40", *args], capture_output=True, text=True)

    def inside():
        added = read_graph(str(out)).loops()[len(graph.loops()):]
        assert len(added) == 40
        reference = read_graph(str(still)).poses
        return sum(chi2_against(reference, e.source, e.target, e.measurement, e.information) < gate(0.99)
                   for e in added)

    assert run().returncode == 0 and inside() > 0
    result = run("--reference", still, "--alpha", "0.99")
    assert result.returncode == 0, result.stderr
    assert inside() == 0
    labels = (tmp_path / "ring_local.g2o.labels").read_text().splitlines()
    assert [line.split()[2] for line in labels[-40:]] == ["0"] * 40

    bad = run("--reference", ring, "--alpha", "1.5")
    assert bad.returncode == 2 and "--alpha must be in (0, 1)" in bad.stderr  # a usage error
    partial = tmp_path / "partial.g2o"
    partial.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n")
    missing = run("--reference", str(partial))
    assert missing.returncode == 1
    assert missing.stderr == (f"add_outliers: {partial}: reference poses lack node 2 "
                              f"and {len(graph.poses) - 3} more of {ring}\n")


def test_scoring_with_labels_and_pairs(tmp_path):
    decisions = [Decision(10, 1, 0, "accepted"), Decision(20, 2, 0, "rejected"),
                 Decision(30, 3, 1, "accepted"), Decision(40, 4, 2, "rejected")]
    labels = tmp_path / "labels"
    labels.write_text("10 1 1\n20 2 1\n30 3 0\n40 4 0\n")
    s = score(decisions, read_truth(str(labels), decisions))
    assert (s.tp, s.fp, s.fn, s.tn) == (1, 1, 1, 1)
    assert s.precision == 0.5 and s.recall == 0.5 and s.f1 == 0.5
    pairs = tmp_path / "pairs"
    pairs.write_text("1 10\n2 20\n")  # KITTI style, either direction
    assert read_truth(str(pairs), decisions) == [True, True, False, False]
    labels.write_text("10 1 1\n21 2 1\n30 3 0\n40 4 0\n")
    with pytest.raises(GraphFileError):
        read_truth(str(labels), decisions)


def test_decisions_file_is_checked(tmp_path):
    path = tmp_path / "d.tsv"
    path.write_text("from\tto\tcluster\tverdict\n1\t5\t0\taccepted\n2\t6\t0\tmaybe\n")
    with pytest.raises(GraphFileError) as error:
        read_decisions(str(path))
    assert error.value.line == 3
    path.write_text("a\tb\n")
    with pytest.raises(GraphFileError):
        read_decisions(str(path))
    # The reason column: read when the header names it, and then required on every row.
    path.write_text("from\tto\tcluster\tverdict\treason\n1\t5\t0\taccepted\trealize: CI 0.1 < 1\n")
    assert read_decisions(str(path))[0].reason == "realize: CI 0.1 < 1"
    path.write_text("from\tto\tcluster\tverdict\treason\n1\t5\t0\taccepted\n")
    with pytest.raises(GraphFileError) as error:
        read_decisions(str(path))
    assert error.value.line == 2


def test_ate_is_zero_after_a_rigid_motion_and_alignment_recovers_it():
    rng = random.Random(1)
    truth = {i: (rng.uniform(-10, 10), rng.uniform(-10, 10), 0.0) for i in range(50)}
    angle, dx, dy = 0.7, 3.0, -2.0
    c, s = math.cos(angle), math.sin(angle)
    moved = {i: (c * x - s * y + dx, s * x + c * y + dy, 0.0) for i, (x, y, _) in truth.items()}
    assert absolute_trajectory_error(moved, truth) == pytest.approx(0.0, abs=1e-9)
    found, (tx, ty) = align_se2([p[:2] for p in truth.values()], [p[:2] for p in moved.values()])
    assert (found, tx, ty) == pytest.approx((angle, dx, dy))
    noisy = {i: (x + 0.1, y, t) for i, (x, y, t) in moved.items()}
    assert absolute_trajectory_error(noisy, truth) == pytest.approx(0.0, abs=1e-9)  # a shift aligns away


def test_ate_is_the_smallest_rmse_over_every_rotation():
    """The closed-form alignment against a search over the angle (for each angle the best
    translation moves the centroids onto each other)."""
    rng = random.Random(2)
    truth = {i: (rng.uniform(-10, 10), rng.uniform(-10, 10), 0.0) for i in range(40)}
    c, s = math.cos(2.5), math.sin(2.5)
    estimate = {i: (c * x - s * y + 4.0 + rng.gauss(0, 0.3), s * x + c * y - 1.0 + rng.gauss(0, 0.3), 0.0)
                for i, (x, y, _) in truth.items()}
    p = [estimate[i][:2] for i in truth]
    q = [truth[i][:2] for i in truth]

    def rmse(angle):
        ca, sa = math.cos(angle), math.sin(angle)
        moved = [(ca * x - sa * y, sa * x + ca * y) for x, y in p]
        dx = sum(b[0] - a[0] for a, b in zip(moved, q)) / len(q)
        dy = sum(b[1] - a[1] for a, b in zip(moved, q)) / len(q)
        return math.sqrt(sum((a[0] + dx - b[0]) ** 2 + (a[1] + dy - b[1]) ** 2 for a, b in zip(moved, q)) / len(q))

    best = min((rmse(k * 2 * math.pi / 20000), k) for k in range(20000))
    ate = absolute_trajectory_error(estimate, truth)
    assert 0.3 < ate <= best[0] + 1e-12
    assert ate == pytest.approx(best[0], abs=1e-6)
    angle, _ = align_se2(p, q)
    assert math.remainder(angle - best[1] * 2 * math.pi / 20000, 2 * math.pi) == pytest.approx(0.0, abs=1e-3)
    assert absolute_trajectory_error({0: (0.0, 0.0, 0.0)}, truth) is None


def test_labels_from_a_ground_truth_trajectory():
    from rrr_graphslam.evaluation import label_by_ground_truth
    from rrr_graphslam.graph_io import Edge, PoseGraph

    # Nodes 0..3 at x = 0, 10, 20, 0 (node 3 revisits node 0), sampled by the ground truth at
    # other times; node 2 has no sample close enough in time.
    graph = PoseGraph({i: (0.0, 0.0, 0.0) for i in range(4)}, [
        Edge(3, 0, (0.5, 0.0, 0.0), (1, 0, 0, 1, 0, 1)),    # true (0.5 m off)
        Edge(3, 1, (3.0, 0.0, 0.0), (1, 0, 0, 1, 0, 1)),    # 7 m off: false
        Edge(0, 2, (20.0, 0.0, 0.0), (1, 0, 0, 1, 0, 1)),   # no ground truth at node 2
        Edge(1, 3, (-6.5, 0.0, 0.0), (1, 0, 0, 1, 0, 1)),   # 3.5 m off: between the thresholds
    ])
    node_times = [0.0, 1.0, 2.0, 3.0]
    samples = [(0.1, 0.0, 0.0, 0.0), (0.9, 10.0, 0.0, 0.0), (5.0, 20.0, 0.0, 0.0), (3.2, 0.0, 0.0, 0.0)]
    samples.sort()
    labels = label_by_ground_truth(graph, node_times, samples)
    assert labels == [(3, 0, 1), (3, 1, 0), (0, 2, -1), (1, 3, -1)]
    decisions = [Decision(i, j, 0, "accepted") for i, j, _ in labels]
    truth = [None if label < 0 else label == 1 for _, _, label in labels]
    s = score(decisions, truth)
    assert (s.tp, s.fp, s.fn, s.tn) == (1, 1, 0, 0)  # unknowns are not scored


def chain(n, extra=()):
    """Nodes 0..n-1 on a line, odometry between neighbours, plus the edges `extra`."""
    edges = [(i, i + 1) for i in range(n - 1)] + list(extra)
    return PoseGraph({i: (float(i), 0.0, 0.0) for i in range(n)},
                     [Edge(a, b, (1.0, 0.0, 0.0), (1, 0, 0, 1, 0, 1)) for a, b in edges])


def room_by_search(graph, kind, size, window):
    """The most links add_outliers could place, by trying every set of disjoint groups it can
    draw (a, b in [0, n - 1 - size], b - a >= 2, b - a <= window for the local kinds) plus the
    longest shorter last group that still fits."""
    ids = sorted(graph.poses)
    n = len(ids)
    existing = {frozenset((e.source, e.target)) for e in graph.edges}

    def groups(length):
        found = []
        for a in range(n - size):
            for b in range(a + 2, n - size):
                if kind.startswith("local") and b - a > window:
                    continue
                links = frozenset(frozenset((ids[a + k], ids[b + k])) for k in range(length))
                if not links & existing:
                    found.append(links)
        return found

    full = groups(size)
    if size == 1:
        return len(full)
    shorter = {r: groups(r) for r in range(1, size)}
    best = 0

    def search(start, used, placed):
        nonlocal best
        last = max((r for r in shorter if any(not g & used for g in shorter[r])), default=0)
        best = max(best, placed * size + last)
        for k in range(start, len(full)):
            if not full[k] & used:
                search(k + 1, used | full[k], placed + 1)

    search(0, frozenset(), 0)
    return best


def test_outlier_room_is_the_most_an_exhaustive_search_places():
    rng = random.Random(11)
    for _ in range(60):
        n = rng.randint(5, 10)
        extra = [tuple(rng.sample(range(n), 2)) for _ in range(rng.randint(0, 5))]
        graph = chain(n, extra)
        kind = rng.choice(KINDS)
        size = rng.randint(2, 3) if kind.endswith("grouped") else 1
        window = rng.randint(2, 5)
        assert outlier_room(graph, kind, size, window) == room_by_search(graph, kind, size, window), \
            (n, extra, kind, size, window)


@pytest.mark.parametrize("kind", ["random", "local"])
def test_single_outliers_fill_the_room_and_not_one_more(kind):
    graph = chain(12, [(0, 5), (3, 9)])
    room = outlier_room(graph, kind, 1, 4)
    for seed in range(5):
        added = add_outliers(graph, kind, room, seed, local_window=4)[0].loops()[2:]
        assert len({frozenset((e.source, e.target)) for e in added}) == room
    with pytest.raises(ValueError, match=f"room for at most {room} {kind} outliers"):
        add_outliers(graph, kind, room + 1, local_window=4)


def test_outliers_on_a_graph_without_edges_are_refused():
    graph = PoseGraph({i: (float(i), 0.0, 0.0) for i in range(8)}, [])
    with pytest.raises(ValueError, match="no edges"):
        add_outliers(graph, "random", 1)
    assert add_outliers(graph, "random", 0) == (graph, [])


def test_groups_that_leave_only_gaps_stop_the_drawing_at_once():
    # Room for 45 groups of 5 when packed end to end; drawn at random they leave gaps of fewer
    # than 5 links long before that (without the check: 1000 draws per outlier, then a failure).
    graph = chain(80)
    room = outlier_room(graph, "local-grouped", 5, 4)
    assert room == 3 * 15 * 5 + 2
    start = time.monotonic()
    with pytest.raises(ValueError, match=r"no room left for a group of 5 after placing \d+ of 227"):
        add_outliers(graph, "local-grouped", room, seed=1, group_size=5, local_window=4)
    assert time.monotonic() - start < 2.0


def test_truth_rows_of_two_and_three_columns_together_are_an_error(tmp_path):
    decisions = [Decision(10, 1, 0, "accepted"), Decision(20, 2, 0, "rejected"),
                 Decision(30, 3, 1, "accepted")]
    path = tmp_path / "truth"
    # A labels file whose first row lost its label: read as pairs, its label-0 rows became true loops.
    path.write_text("10 1\n20 2 1\n30 3 0\n")
    with pytest.raises(GraphFileError) as error:
        read_truth(str(path), decisions)
    assert error.value.line == 2 and "line 1 has 2" in error.value.what
    path.write_text("# comment\n10 1 1\n20 2 1\n30 3\n")
    with pytest.raises(GraphFileError) as error:
        read_truth(str(path), decisions)
    assert error.value.line == 4 and "line 2 has 3" in error.value.what
    path.write_text("10 1 1\n20 2 1\n30 3 2\n")
    with pytest.raises(GraphFileError, match="label must be 1, 0 or -1") as error:
        read_truth(str(path), decisions)
    assert error.value.line == 3
    path.write_text("10 1 0\n20 2 -1\n30 3 1\n")
    assert read_truth(str(path), decisions) == [False, None, True]


def test_decisions_that_are_no_text_name_the_file_and_line(tmp_path):
    text = "from\tto\tcluster\tverdict\n1\t5\t0\taccepted\n2\t6\t0\trejected\n"
    path = tmp_path / "d.tsv"
    path.write_bytes(text.encode() + b"\xff\xfe3\t7\t0\taccepted\n")
    with pytest.raises(GraphFileError, match=r"d.tsv:4: byte 0xff at column 1 is not UTF-8"):
        read_decisions(str(path))
    path.write_bytes(text.encode().replace(b"2\t6", b"2\t\x006"))
    with pytest.raises(GraphFileError, match=r"d.tsv:3: NUL byte at column 3"):
        read_decisions(str(path))
    packed = gzip.compress(text.encode() * 50)
    path.write_bytes(packed[:len(packed) // 2])  # whatever its name: gzip is told by its first bytes
    with pytest.raises(GraphFileError, match=r"d.tsv:\d+: read error"):
        read_decisions(str(path))
    # Still read as before: gzip by name, CRLF line ends, the reason column's text.
    gz = tmp_path / "d.tsv.gz"
    gz.write_bytes(gzip.compress(text.replace("\n", "\r\n").encode()))
    rows = read_decisions(str(gz))
    assert [(d.source, d.verdict) for d in rows] == [(1, "accepted"), (2, "rejected")]
    path.write_text("from\tto\tcluster\tverdict\treason\n1\t5\t0\taccepted\tD2_l 9.12 ≥ 7.815\n")
    assert read_decisions(str(path))[0].reason == "D2_l 9.12 ≥ 7.815"


def test_map_harm_against_the_clean_optimum_and_against_ground_truth():
    from rrr_graphslam.evaluation import map_harm
    line = {i: (float(i), 0.0, 0.0) for i in range(100)}
    moved = {i: (x + 3.0, y - 1.0, t) for i, (x, y, t) in line.items()}  # the same map elsewhere
    bent = dict(line)
    bent[50] = (50.0, 0.5, 0.0)  # one pose 0.5 m off: ATE about 5 cm over 100 nodes
    assert not map_harm(moved, line).harmed
    harm = map_harm(bent, line)
    assert harm.harmed and harm.limit == 0.01 and harm.ate == pytest.approx(0.05, abs=0.002)
    # With ground truth: the clean optimum's own ATE plus max(1 cm, 2% of it) is allowed.
    truth = {i: (x, 0.1 * (-1) ** i, t) for i, (x, y, t) in line.items()}  # clean ATE 0.1 m
    within = map_harm(line, line, truth)
    assert within.clean_ate == pytest.approx(0.1, abs=1e-3) and not within.harmed
    assert within.limit == pytest.approx(within.clean_ate + 0.01)
    # RMS errors add in quadrature: 0.5 m on one node of 100 stays within the limit, 1.5 m not.
    assert not map_harm(bent, line, truth).harmed
    bent[50] = (50.0, 1.5, 0.0)
    assert map_harm(bent, line, truth).harmed
    assert map_harm({0: (0.0, 0.0, 0.0)}, line) is None


def test_evaluate_prints_the_map_harm_against_a_reference(tmp_path):
    ring = read_graph(os.path.join(DATA, "ring.g2o.gz"))
    reference = tmp_path / "clean.g2o"
    write_graph(ring, str(reference))
    # The map: node 3 0.5 m off, and one accepted false loop 3 -> 9 whose measurement is 2 m off
    # the reference's relative pose.
    ids = sorted(ring.poses)
    false = Edge(ids[3], ids[9], tuple(a + b for a, b in zip(
        between(ring.poses[ids[3]], ring.poses[ids[9]]), (2.0, 0.0, 0.0))), ring.loops()[0].information)
    assert not any({e.source, e.target} == {false.source, false.target} for e in ring.edges)
    off = PoseGraph({i: (x, y + (0.5 if i == ids[3] else 0.0), t) for i, (x, y, t) in ring.poses.items()},
                    ring.edges + [false])
    estimate = tmp_path / "opt.g2o"
    write_graph(off, str(estimate))
    loops = ring.loops()
    (tmp_path / "d.tsv").write_text("from\tto\tcluster\tverdict\n" + "".join(
        f"{e.source}\t{e.target}\t0\taccepted\n" for e in loops + [false]))
    (tmp_path / "truth").write_text("".join(f"{e.source} {e.target} 1\n" for e in loops)
                                    + f"{false.source} {false.target} 0\n")

    def evaluate(*args):
        return subprocess.run([sys.executable, os.path.join(SCRIPTS, "evaluate"), "--truth",
                               str(tmp_path / "truth"), "--decisions", str(tmp_path / "d.tsv"),
                               *map(str, args)], capture_output=True, text=True)

    same = evaluate("--graph", reference, "--reference", reference)
    assert same.returncode == 0 and "map harm none: ATE 0.0000 m" in same.stdout, same.stderr
    assert f"accepted false {ids[3]} {ids[9]}: not in the --graph" in same.stdout
    harmed = evaluate("--graph", estimate, "--reference", reference)
    assert "map harm HARMED" in harmed.stdout and "limit 0.0100 m" in harmed.stdout
    listed = [line for line in harmed.stdout.splitlines() if line.startswith("accepted false")]
    assert len(listed) == 1 and listed[0].startswith(f"accepted false {ids[3]} {ids[9]}: chi2 ")
    chi2 = float(listed[0].split("chi2 ")[1].split()[0])
    assert chi2 == pytest.approx(chi2_against(ring.poses, ids[3], ids[9], false.measurement,
                                              false.information), rel=1e-3) and chi2 > gate(0.95)
    assert "map off it by 0.5" in listed[0]  # node 3's 0.5 m
    assert evaluate("--reference", reference).returncode == 2  # needs --graph
