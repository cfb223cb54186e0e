"""The command-line contracts of rrr_offline and rrr_optimize: file formats, exit codes, errors.

The build passes the binaries' paths (RRR_OFFLINE, RRR_OPTIMIZE); run by hand without them,
these tests are skipped.
"""
import math
import os
import re
import subprocess

import numpy as np
import pytest
from conftest import DATA
from rrr_graphslam.decision_stream import read_decision_stream
from rrr_graphslam.evaluation import read_decisions, read_truth, score
from rrr_graphslam.graph_io import read_graph, write_graph
from rrr_graphslam.outliers import add_outliers

OFFLINE = os.environ.get("RRR_OFFLINE")
OPTIMIZE = os.environ.get("RRR_OPTIMIZE")
needs_binaries = pytest.mark.skipif(not (OFFLINE and OPTIMIZE), reason="binaries not given")


def run(*args):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True)


@pytest.fixture(scope="module")
def spoiled(tmp_path_factory):
    folder = tmp_path_factory.mktemp("spoiled")
    graph, labels = add_outliers(read_graph(os.path.join(DATA, "intel.g2o.gz")), "random", 50, seed=2)
    path = folder / "intel_r50.g2o"
    write_graph(graph, str(path))
    (folder / "truth").write_text("".join(f"{i} {j} {label}\n" for i, j, label in labels))
    return folder, path


@needs_binaries
def test_offline_writes_decisions_and_the_accepted_graph(spoiled):
    folder, path = spoiled
    decisions, optimized = folder / "d.tsv", folder / "opt.g2o"
    result = run(OFFLINE, path, "--decisions", decisions, "--output", optimized, "--quiet")
    assert result.returncode == 0, result.stderr
    assert "candidates     945" in result.stdout
    header = decisions.read_text().splitlines()[0]
    assert header == "from\tto\tcluster\tverdict\treason"
    rows = read_decisions(str(decisions))
    # Every decision names the step that made it.
    steps = ("intra-cluster: ", "robust ordering: ", "realize: ", "recover: ", "reverse: ",
             "far retry: ", "leave-one-out: ", "joint link check: ")
    assert all(d.reason.startswith(steps) for d in rows), {d.reason for d in rows}
    assert all(d.reason.startswith(("realize: CI ", "recover: CI ", "far retry: "))
               for d in rows if d.verdict == "accepted")
    graph = read_graph(str(path))
    assert [(d.source, d.target) for d in rows] == [(e.source, e.target) for e in graph.loops()]
    s = score(rows, read_truth(str(folder / "truth"), rows))
    assert s.fp == 0 and s.recall > 0.95
    out = read_graph(str(optimized))
    accepted = sum(d.verdict == "accepted" for d in rows)
    assert len(out.loops()) == accepted
    assert out.poses != graph.poses  # optimized, not the initial guess


@needs_binaries
def test_offline_profile_names_the_steps_where_the_time_went(spoiled):
    _, path = spoiled
    result = run(OFFLINE, path, "--profile", "--quiet")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    total = int(next(l.split()[1] for l in lines if l.startswith("optimizations ")))
    table = lines[lines.index("profile") + 1:]
    assert table[0].split()[:2] == ["step", "calls"]
    rows = {}
    for line in table[1:]:
        if line.startswith("(outside the steps)"):
            break
        # The step's name may hold spaces; the seven numbers follow it.
        fields = line.split()
        rows[" ".join(fields[:-7])] = fields[-7:]
    assert {"intra-cluster test", "decision from scratch", "realize"} <= rows.keys(), rows
    # Every optimization of the decision is charged to one step.
    assert sum(int(r[3]) for r in rows.values()) == total
    # Another verifier has no named steps, and says so.
    other = run(OFFLINE, path, "--profile", "--quiet", "--verifier", "pcm")
    assert other.returncode == 0, other.stderr
    assert "profile        none: --verifier pcm has no named steps" in other.stdout


@needs_binaries
def test_joint_leave_out_rejects_two_false_groups_that_mask_each_other(tmp_path):
    # M3500 + 100 aliased (groups of 10), seed 3, gated as the bench makes it: two false groups
    # each hold the other's bend, so the leave-one-out check keeps both; left out together they
    # fail (doc/rrr_extensions.md#joint-leave-out).
    from rrr_graphslam.bench import synthetic_input
    graph, truth = synthetic_input(DATA, str(tmp_path), OPTIMIZE, "manhattanOlson3500_olson", "aliased",
                                   100, seed=3)
    false_accepted = {}
    for label, extra in (("off", ("--loo-joint-min-index", 0)), ("on", ())):
        decisions = tmp_path / f"{label}.tsv"
        result = run(OFFLINE, graph, "--decisions", decisions, "--quiet", *extra)
        assert result.returncode == 0, result.stderr
        rows = read_decisions(str(decisions))
        labels = read_truth(truth, rows)
        false_accepted[label] = [d for d, t in zip(rows, labels) if d.verdict == "accepted" and t is False]
        if label == "on":
            assert any(d.reason.startswith("joint leave-out: ") for d in rows)
    assert false_accepted["off"], "rejected without it: the case no longer shows masking"
    assert false_accepted["on"] == []


@needs_binaries
def test_paper_preset_and_parameter_flags(spoiled):
    folder, path = spoiled
    decisions = folder / "paper.tsv"
    result = run(OFFLINE, path, "--decisions", decisions, "--preset", "paper", "--quiet")
    assert result.returncode == 0, result.stderr
    rows = read_decisions(str(decisions))
    assert not any(d.reason.startswith(("robust ordering", "far retry", "leave-one-out",
                                        "joint link check")) for d in rows)
    # A bad value: the parameter named with its range, exit 2.
    result = run(OFFLINE, path, "--alpha", "1.5")
    assert result.returncode == 2
    assert "alpha = 1.5 is out of range: must be in [" in result.stderr
    result = run(OFFLINE, path, "--joint-link-check", "maybe")
    assert result.returncode == 2 and "--joint-link-check must be true or false" in result.stderr
    result = run(OFFLINE, path, "--max-rounds", "1e300")
    assert result.returncode == 2 and "max_rounds = 1e300 is out of range" in result.stderr
    result = run(OFFLINE, path, "--max-rounds", "2.5")
    assert result.returncode == 2 and "--max-rounds must be an integer" in result.stderr
    result = run(OFFLINE, path, "--alpha", "1")
    assert result.returncode == 2 and "must be in [1e-06, 0.999999999]" in result.stderr
    result = run(OFFLINE, path, "--preset", "papers")
    assert result.returncode == 2 and "preset must be default or paper" in result.stderr


@needs_binaries
def test_incremental_mode_reaches_the_batch_decisions(spoiled):
    folder, path = spoiled
    batch, incremental = folder / "b.tsv", folder / "i.tsv"
    assert run(OFFLINE, path, "--decisions", batch, "--quiet").returncode == 0
    result = run(OFFLINE, path, "--decisions", incremental, "--mode", "incremental", "--quiet")
    assert result.returncode == 0, result.stderr
    assert "latency" in result.stdout
    verdicts = lambda p: [d.verdict for d in read_decisions(str(p))]  # noqa: E731
    assert verdicts(incremental) == verdicts(batch)
    # The stream of what the replay decided on the way ends in the same verdicts.
    stream = folder / "stream.tsv"
    result = run(OFFLINE, path, "--mode", "incremental", "--decision-stream", stream, "--quiet")
    assert result.returncode == 0, result.stderr
    last = {}
    for r in read_decision_stream(str(stream)):
        last[r.candidate] = r.verdict
    assert [last[k] for k in range(len(last))] == verdicts(batch)
    result = run(OFFLINE, path, "--decision-stream", stream)
    assert result.returncode == 2 and "--decision-stream needs --mode incremental" in result.stderr


@needs_binaries
def test_other_verifiers_write_the_same_decision_table(spoiled):
    folder, path = spoiled
    loops = [(e.source, e.target) for e in read_graph(str(path)).loops()]
    for verifier, extra in (("pcm", []), ("scgp", []), ("gnc", []), ("gnc", ["--gnc-loss", "gm"])):
        decisions, optimized = folder / f"{verifier}.tsv", folder / f"{verifier}.g2o"
        result = run(OFFLINE, path, "--verifier", verifier, *extra, "--decisions", decisions,
                     "--output", optimized, "--quiet")
        assert result.returncode == 0, result.stderr
        assert f"verifier       {verifier}" in result.stdout
        rows = read_decisions(str(decisions))
        assert [(d.source, d.target) for d in rows] == loops
        assert all(d.reason.startswith(verifier + " ") or d.reason.startswith(verifier + ":")
                   for d in rows), {d.reason for d in rows}
        accepted = sum(d.verdict == "accepted" for d in rows)
        assert f"accepted       {accepted}" in result.stdout
        assert len(read_graph(str(optimized)).loops()) == accepted
        if verifier != "scgp":  # SCGP accepts a false loop that is alone in its time cluster
            s = score(rows, read_truth(str(folder / "truth"), rows))
            assert s.fp == 0 and s.recall > 0.95, (verifier, extra, s)
    result = run(OFFLINE, path, "--verifier", "ransac")
    assert result.returncode == 2 and "verifier 'ransac' is not rrr, pcm, scgp or gnc" in result.stderr
    result = run(OFFLINE, path, "--verifier", "gnc", "--mode", "incremental")
    assert result.returncode == 2 and "--mode incremental is RRR's" in result.stderr
    result = run(OFFLINE, path, "--gnc-loss", "huber")
    assert result.returncode == 2 and "gnc loss 'huber' is not tls or gm" in result.stderr
    result = run(OFFLINE, path, "--verifier", "pcm", "--gnc-loss", "gm")
    assert result.returncode == 2 and "--gnc-loss needs --verifier gnc" in result.stderr
    result = run(OFFLINE, path, "--scgp-ratio", "3")
    assert result.returncode == 2 and "--scgp-ratio needs --verifier scgp" in result.stderr


@needs_binaries
def test_a_false_group_that_bends_the_map_goes_before_the_true_clusters_it_pulls(tmp_path):
    # CSAIL + 300 aliased false loops in groups of 20, seed 4: a group accepted early bends the
    # map toward itself and fits it best, so when only the joint test fails the highest index is
    # a true cluster's; removing those one by one lost 44 of 128 true loops. conflict_removal
    # removes the cluster whose removal lowers the chi2 most: the false group.
    clean = os.path.join(DATA, "csail.toro.gz")
    reference = tmp_path / "reference.g2o"
    optimized = run(OPTIMIZE, clean, "--output", reference)
    assert optimized.returncode == 0
    # rrr_optimize states its CPU time beside the wall time, split as the wall time is.
    cpu = re.search(r"^cpu time +([0-9.]+) s \(initialization ([0-9.]+) s, optimization ([0-9.]+) s\)$",
                    optimized.stdout, re.M)
    assert cpu, optimized.stdout
    total, init, opt = (float(v) for v in cpu.groups())
    assert total > 0 and total == pytest.approx(init + opt, abs=2e-4)
    graph, labels = add_outliers(read_graph(clean), "aliased", 300, seed=4, group_size=20,
                                 reference=read_graph(str(reference)).poses)
    path = tmp_path / "csail_aliased.g2o"
    write_graph(graph, str(path))
    (tmp_path / "truth").write_text("".join(f"{i} {j} {label}\n" for i, j, label in labels))

    def decide(*options):
        decisions = tmp_path / "d.tsv"
        result = run(OFFLINE, path, "--decisions", decisions, "--quiet", *options)
        assert result.returncode == 0, result.stderr
        rows = read_decisions(str(decisions))
        return score(rows, read_truth(str(tmp_path / "truth"), rows)), rows

    s, rows = decide()
    assert s.fp == 0 and s.recall >= 0.98, s
    assert any("most conflicting: leave-one-out index" in d.reason for d in rows)
    paper_rule, _ = decide("--conflict-removal", "false")
    assert paper_rule.fp == 0 and paper_rule.recall < 0.8, paper_rule


@needs_binaries
def test_bad_input_and_bad_options(tmp_path):
    bad = tmp_path / "bad.g2o"
    bad.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 nan 0 1 0 1\n")
    for binary, extra in ((OFFLINE, []), (OPTIMIZE, ["--output", str(tmp_path / "o.g2o")])):
        result = run(binary, bad, *extra)
        assert result.returncode == 1
        assert f"{bad}:3:" in result.stderr and "not finite" in result.stderr
        assert not (tmp_path / "o.g2o").exists()
    assert run(OFFLINE, bad, "--alpha", "1.5").returncode == 2
    assert run(OFFLINE, bad, "--no-such-option").returncode == 2
    assert run(OPTIMIZE, bad).returncode == 2  # --output missing


@needs_binaries
def test_optimize_reaches_the_reference_chi2(tmp_path):
    for method in ("gn", "lm"):
        result = run(OPTIMIZE, os.path.join(DATA, "intel.g2o.gz"), "--output", tmp_path / "o.g2o",
                     "--method", method)
        assert result.returncode == 0, result.stderr
        final = float(next(l for l in result.stdout.splitlines() if l.startswith("final chi2")).split()[2])
        assert final == pytest.approx(546.461, rel=1e-3)


@needs_binaries
def test_optimize_starts_far_off_graphs_from_lago(tmp_path):
    m3500 = os.path.join(DATA, "manhattanOlson3500_olson.g2o.gz")
    for init, expected in (("auto", "lago"), ("file", "file"), ("lago", "lago")):
        result = run(OPTIMIZE, m3500, "--output", tmp_path / "o.g2o", "--init", init)
        assert result.returncode == 0, result.stderr
        lines = result.stdout.splitlines()
        assert next(l for l in lines if l.startswith("initialization")).split()[1] == expected
        final = float(next(l for l in lines if l.startswith("final chi2")).split()[2])
        assert final == pytest.approx(146.077, rel=1e-3)
    intel = run(OPTIMIZE, os.path.join(DATA, "intel.g2o.gz"), "--output", tmp_path / "o.g2o")
    assert "initialization file" in intel.stdout, "a graph near its minimum keeps its poses"
    bad = run(OPTIMIZE, m3500, "--output", tmp_path / "o.g2o", "--init", "guess")
    assert bad.returncode != 0 and "--init" in bad.stderr


SLAM_OFFLINE = os.environ.get("RRR_SLAM_OFFLINE")
needs_slam = pytest.mark.skipif(not SLAM_OFFLINE, reason="rrr_slam_offline not given")
ACES_HEAD = os.path.join(DATA, "carmen", "aces_head.clf.gz")


@needs_slam
def test_slam_offline_builds_graph_trajectory_and_map_from_a_log(tmp_path):
    from rrr_graphslam.carmen import read_carmen
    from rrr_graphslam.relations import read_tum
    out = {k: tmp_path / v for k, v in
           dict(graph="g.g2o", decisions="d.tsv", trajectory="t.txt", map="map").items()}
    result = run(SLAM_OFFLINE, ACES_HEAD, "--output", out["graph"], "--decisions", out["decisions"],
                 "--trajectory", out["trajectory"], "--map", out["map"], "--scans-per-submap", 10,
                 "--min-node-separation", 15, "--quiet")
    assert result.returncode == 0, result.stderr
    log = read_carmen(ACES_HEAD)
    # One TUM row per scan, stamped with the scan's ipc_timestamp, in log order.
    stamps, poses = read_tum(str(out["trajectory"]))
    assert stamps == pytest.approx([r.timestamp for r in log.lasers], abs=1e-6)
    # Local SLAM stays near the (good, short-range) odometry of this 60 s, 1 m head of ACES.
    first, last = log.lasers[0].odom_pose, log.lasers[-1].odom_pose
    travelled = ((last[0] - first[0]) ** 2 + (last[1] - first[1]) ** 2) ** 0.5
    estimated = ((poses[-1][0] - poses[0][0]) ** 2 + (poses[-1][1] - poses[0][1]) ** 2) ** 0.5
    assert abs(travelled - estimated) < 0.2
    # The graph: one node per motion-filtered scan, loop candidates between submap nodes and nodes.
    graph = read_graph(str(out["graph"]))
    decisions = read_decisions(str(out["decisions"]))
    assert len(graph.poses) > 30
    assert len(decisions) == len(graph.loops()) > 0
    assert all(d.verdict in ("accepted", "rejected") for d in decisions)
    # map_server files: PGM (P5) with the YAML's image, resolution, origin and thresholds.
    yaml = (tmp_path / "map.yaml").read_text()
    assert "image: map.pgm" in yaml and "resolution: 0.05" in yaml and "origin: [" in yaml
    assert "occupied_thresh: 0.65" in yaml and "free_thresh: 0.196" in yaml
    pgm = (tmp_path / "map.pgm").read_bytes()
    assert pgm.startswith(b"P5")
    width, height = (int(v) for v in pgm.split(b"\n")[2].split())
    pixels = pgm[-width * height:]
    assert set(pixels) <= {0, 205, 254} and pixels.count(0) > 500 and pixels.count(254) > 5000
    assert (tmp_path / "map.png").read_bytes().startswith(b"\x89PNG")
    assert not list(tmp_path.glob("*.tmp*"))  # written atomically, nothing left behind


@needs_slam
def test_slam_offline_decides_with_another_verifier_as_rrr_offline_would(tmp_path):
    # --verifier pcm decides the front end's candidates online; the run ends with the verdicts
    # rrr_offline --verifier pcm gives its saved graph with the same cluster gap (PCM's clique
    # does not depend on the poses the graph is saved at).
    graph, decisions = tmp_path / "g.g2o", tmp_path / "d.tsv"
    result = run(SLAM_OFFLINE, ACES_HEAD, "--output", graph, "--decisions", decisions,
                 "--scans-per-submap", 10, "--min-node-separation", 15, "--refine-resolution", 0,
                 "--verifier", "pcm", "--quiet")
    assert result.returncode == 0, result.stderr
    assert "verifier       pcm" in result.stdout
    online = read_decisions(str(decisions))
    assert online and all(d.reason.startswith("pcm:") for d in online)
    offline_path = tmp_path / "offline.tsv"
    offline = run(OFFLINE, graph, "--verifier", "pcm", "--cluster-gap", 10, "--decisions",
                  offline_path, "--quiet")
    assert offline.returncode == 0, offline.stderr
    assert [(d.source, d.target, d.verdict) for d in read_decisions(str(offline_path))] == \
        [(d.source, d.target, d.verdict) for d in online]
    refused = run(SLAM_OFFLINE, ACES_HEAD, "--verifier", "pcm", "--gnc-loss", "gm")
    assert refused.returncode == 2 and "--gnc-loss needs --verifier gnc" in refused.stderr


@needs_slam
def test_slam_offline_injects_false_loops_that_rrr_decides_and_a_seed_repeats(tmp_path):
    # --false-loops: about that share of the candidates are injected false ones (close to an
    # older node than the loop search may match), decided by RRR among the search's own.
    small = ("--scans-per-submap", 10, "--min-node-separation", 15, "--refine-resolution", 0, "--quiet")
    plain = tmp_path / "plain.tsv"
    assert run(SLAM_OFFLINE, ACES_HEAD, "--decisions", plain, *small).returncode == 0
    runs = []
    for name, seed in (("a", 1), ("b", 1), ("c", 2)):
        decisions = tmp_path / f"{name}.tsv"
        result = run(SLAM_OFFLINE, ACES_HEAD, "--decisions", decisions, "--false-loops", 0.5,
                     "--false-loops-seed", seed, *small)
        assert result.returncode == 0, result.stderr
        line = next(l for l in result.stdout.splitlines() if l.startswith("false loops"))
        injected = int(line.split()[2])
        runs.append((injected, [(d.source, d.target, d.verdict) for d in read_decisions(str(decisions))]))
    searched = len(read_decisions(str(plain)))
    (injected, rows), (again, rows_again), (other, rows_other) = runs
    assert 0.2 < injected / len(rows) < 0.8, (injected, len(rows))
    # The search's own candidates stay about as they were (false loops RRR accepted would move
    # the map its search windows follow).
    assert abs(len(rows) - injected - searched) <= max(2, searched // 5), (len(rows), injected, searched)
    assert (again, rows_again) == (injected, rows), "the same seed injects the same loops"
    assert rows_other != rows
    refused = run(SLAM_OFFLINE, ACES_HEAD, "--false-loops", 0.95)
    assert refused.returncode != 0 and "--false-loops" in refused.stderr


@needs_slam
def test_slam_offline_decision_stream_holds_every_arrival_and_ends_in_the_final_verdicts(tmp_path):
    import csv
    stream, decisions = tmp_path / "stream.tsv", tmp_path / "d.tsv"
    result = run(SLAM_OFFLINE, ACES_HEAD, "--decisions", decisions, "--decision-stream", stream,
                 "--scans-per-submap", 10, "--min-node-separation", 15, "--refine-resolution", 0,
                 "--quiet")
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader(stream.open(), delimiter="\t"))
    final = read_decisions(str(decisions))
    assert len(final) > 0 and f"({len(rows)} rows)" in result.stdout
    arrivals = [r for r in rows if r["previous"] == r["verdict"] == "pending"]
    # Each candidate arrives once, online, in arrival order, between its own two nodes.
    assert [int(r["candidate"]) for r in arrivals] == list(range(len(final)))
    assert all(r["when"] == "online" for r in arrivals)
    assert [(int(r["from"]), int(r["to"])) for r in arrivals] == [(d.source, d.target) for d in final]
    # Scans, nodes and stamps never go back; changes follow their candidate's arrival.
    from rrr_graphslam.carmen import read_carmen
    for column in ("scan", "nodes"):
        values = [int(r[column]) for r in rows]
        assert values == sorted(values)
    scans = len(read_carmen(ACES_HEAD).lasers)
    assert all(int(r["scan"]) == scans for r in rows if r["when"] == "final")
    assert all(1 <= int(r["scan"]) <= scans for r in rows)
    assert [float(r["stamp"]) for r in rows] == sorted(float(r["stamp"]) for r in rows)
    last = {}
    for r in rows:
        c = int(r["candidate"])
        if r["previous"] == r["verdict"] == "pending":
            assert c not in last
            last[c] = "pending"
        else:
            assert c in last, "a change follows its candidate's arrival"
            assert r["previous"] == last[c], "a change starts from the last verdict"
            last[c] = r["verdict"]
    # The last verdict of each candidate is the decisions table's.
    assert [last.get(c, "pending") for c in range(len(final))] == [d.verdict for d in final]
    assert any(r["when"] == "online" and r["verdict"] != "pending" for r in rows), \
        "some decisions are made during the run"


@needs_slam
def test_slam_offline_refines_the_trajectory_against_the_final_map(tmp_path):
    from rrr_graphslam.relations import read_tum
    trajectories = {}
    for resolution in (0, 0.04):
        path = tmp_path / f"t{resolution}.txt"
        result = run(SLAM_OFFLINE, ACES_HEAD, "--trajectory", path, "--scans-per-submap", 10,
                     "--min-node-separation", 15, "--refine-resolution", resolution, "--quiet")
        assert result.returncode == 0, result.stderr
        trajectories[resolution] = read_tum(str(path))
    (stamps0, raw), (stamps1, refined) = trajectories[0], trajectories[0.04]
    assert stamps0 == stamps1
    moves = [((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2) ** 0.5 for a, b in zip(raw, refined)]
    # Refinement corrects matching error (millimetres to centimetres), never relocates a scan.
    assert max(moves) < 0.05
    assert sum(m > 1e-4 for m in moves) > len(moves) // 2
    result = run(SLAM_OFFLINE, ACES_HEAD, "--refine-resolution", -1, "--quiet")
    assert result.returncode == 2 and "--refine-resolution" in result.stderr


@needs_slam
def test_slam_offline_rejects_a_malformed_log_with_file_and_line(tmp_path):
    bad = tmp_path / "bad.clf"
    bad.write_text("FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 1.5 host 1.5\nFLASER 3 1.0 x 3.0 0 0 0 0 0 0 2 host 2\n")
    result = run(SLAM_OFFLINE, bad, "--quiet")
    assert result.returncode == 1
    assert f"{bad}:2" in result.stderr and "not a number" in result.stderr
    result = run(SLAM_OFFLINE, "--depth", 0, bad)
    assert result.returncode == 2 and "--depth" in result.stderr


@needs_slam
def test_slam_offline_takes_the_ros_parameter_names_and_its_older_flags(tmp_path):
    """--name-with-dashes of every ROS parameter, in its units; the older flags (degrees) agree."""
    def trajectory(name, *flags):
        path = tmp_path / f"{name}.txt"
        result = run(SLAM_OFFLINE, ACES_HEAD, "--trajectory", path, "--refine-resolution", 0,
                     "--quiet", *flags)
        assert result.returncode == 0, result.stderr
        return path.read_text()
    old = trajectory("old", "--min-rotation", 5, "--min-travel", 0.2, "--voxel", 0.08,
                     "--odometry-stddev", 0.02, "--local-refinement", "least-squares")
    new = trajectory("new", "--scan-min-rotation-rad", repr(5 * math.pi / 180),
                     "--scan-min-travel-m", 0.2, "--scan-voxel-size", 0.08,
                     "--scan-odometry-stddev", "0.02,0.02,0.01", "--scan-refinement", "least_squares")
    assert old == new
    assert old != trajectory("default")
    # The same messages as the ROS parameters: name, value and range.
    result = run(SLAM_OFFLINE, ACES_HEAD, "--min-score", 1.5)
    assert result.returncode == 2 and "min_score = 1.5 is out of range: must be in [0, 1]" in result.stderr
    result = run(SLAM_OFFLINE, ACES_HEAD, "--angular-window", 200)
    assert result.returncode == 2 and "--angular-window = 200 is out of range: must be in [0, 180]" in result.stderr
    result = run(SLAM_OFFLINE, ACES_HEAD, "--scan-refinement", "icp2")
    assert result.returncode == 2 and "scan_refinement must be least_squares or icp, not 'icp2'" in result.stderr
    result = run(SLAM_OFFLINE, ACES_HEAD, "--scan-odometry-stddev", "0.1,0.1")
    assert result.returncode == 2 and "three comma-separated numbers" in result.stderr
    result = run(SLAM_OFFLINE, ACES_HEAD, "--cluster-gap", 0)
    assert result.returncode == 2 and "cluster_gap = 0 is out of range online" in result.stderr


MAP_INFO = os.environ.get("RRR_MAP_INFO")
needs_map_info = pytest.mark.skipif(not (SLAM_OFFLINE and MAP_INFO), reason="rrr_slam_offline/rrr_map_info not given")
# ACES_HEAD drives 6 m: loops to the map 2 m apart along it confirm a tie.
SMALL_SUBMAPS = ("--scans-per-submap", 10, "--min-node-separation", 15, "--relocalization-confirm-distance", 2)


@needs_map_info
def test_a_saved_map_is_continued_as_a_new_session_from_another_odometry_frame(tmp_path):
    from rrr_graphslam.relations import read_tum
    first_map = tmp_path / "first.rrrmap"
    first = run(SLAM_OFFLINE, ACES_HEAD, "--save-map", first_map, "--trajectory", tmp_path / "t1.txt",
                "--refine-resolution", 0, "--quiet", *SMALL_SUBMAPS)
    assert first.returncode == 0, first.stderr
    info = run(MAP_INFO, first_map, "--graph", tmp_path / "g.g2o", "--map", tmp_path / "m",
               "--trajectory", tmp_path / "nodes.txt")
    assert info.returncode == 0, info.stderr
    keys = dict(line.split(" ", 1) for line in info.stdout.splitlines())
    for key in ("format_version", "sessions", "nodes", "edges", "loop_edges_accepted",
                "loop_edges_rejected", "submaps", "scans", "bytes"):
        assert key in keys, key
    assert keys["format_version"] == "6" and keys["sessions"] == "1"
    # One session: every loop the search around the estimate's.
    assert keys["loop_edges_local_search"] == keys["loop_edges"] != "0"
    assert keys["loop_edges_local_search_accepted"] == keys["loop_edges_accepted"]
    assert keys["loop_edges_whole_map_search"] == keys["loop_edges_unknown_source"] == "0"
    assert keys["loop_edges_rival_search"] == "0"
    assert keys["remembered_patches"] == "0" and keys["remembered_cells"] == "0"
    assert int(keys["bytes"]) == first_map.stat().st_size
    assert len(read_graph(str(tmp_path / "g.g2o")).poses) == int(keys["nodes"])
    assert (tmp_path / "m.pgm").read_bytes().startswith(b"P5")
    node_stamps, node_poses = read_tum(str(tmp_path / "nodes.txt"))
    assert len(node_poses) == int(keys["nodes"])
    run_stamps = set(read_tum(str(tmp_path / "t1.txt"))[0])
    assert all(t in run_stamps for t in node_stamps)  # each node is one of the run's scans

    # The same log again, its odometry 100 m away and turned: a new session tied to the map.
    from rrr_graphslam.carmen import write_moved_log
    moved = tmp_path / "moved.clf"
    write_moved_log(ACES_HEAD, str(moved), (100.0, -40.0, 2.0))
    second = run(SLAM_OFFLINE, moved, "--load-map", first_map, "--save-map", first_map,
                 "--session-trajectory", tmp_path / "t2.txt", "--trajectory", tmp_path / "all.txt",
                 "--output", tmp_path / "g2.g2o", "--node-stamps", tmp_path / "stamps.txt",
                 "--refine-resolution", 0, "--quiet", *SMALL_SUBMAPS)
    assert second.returncode == 0, second.stderr
    # --node-stamps: every node of --output's graph with its scan's stamp, the loaded ones first.
    rows = [line.split() for line in (tmp_path / "stamps.txt").read_text().splitlines()
            if not line.startswith("#")]
    ids = [int(r[0]) for r in rows]
    stamps = [float(r[1]) for r in rows]
    sessions = [int(r[2]) for r in rows]
    assert ids == sorted(read_graph(str(tmp_path / "g2.g2o")).poses)
    loaded = len(node_stamps)
    assert stamps[:loaded] == pytest.approx(node_stamps, abs=1e-6)
    own = stamps[loaded:]
    assert own and own == sorted(own) and all(t in run_stamps for t in own)
    assert sessions == [0] * loaded + [1] * len(own)
    assert "relocalized    at node" in second.stdout, second.stdout
    info = run(MAP_INFO, first_map)
    keys = dict(line.split(" ", 1) for line in info.stdout.splitlines())
    assert keys["sessions"] == "2"
    # The new session was tied by relocalization's whole-map search.
    assert int(keys["loop_edges_whole_map_search_accepted"]) > 0
    # From the moment it was tied on, the replayed log's scans lie where the first run put them
    # (same timestamps).
    tied_after = float(re.search(r"relocalized +at node \d+ \(the session's node \d+, ([0-9.]+) s after",
                                 second.stdout).group(1))
    stamps1, poses1 = read_tum(str(tmp_path / "t1.txt"))
    stamps2, poses2 = read_tum(str(tmp_path / "t2.txt"))
    assert stamps1 == stamps2
    errors = [math.hypot(a[0] - b[0], a[1] - b[1]) for t, a, b in zip(stamps1, poses1, poses2)
              if t >= stamps1[0] + tied_after]
    # Tied once agreeing loops 2 m apart along the replay were accepted: 41 s into its 46 s.
    assert len(errors) > 25
    # 2-10 cm apart, depending on which loops the two runs found (a wrong tie: metres).
    assert sorted(errors)[len(errors) // 2] < 0.1 and max(errors) < 0.15, errors
    stamps_all, _ = read_tum(str(tmp_path / "all.txt"))
    assert len(stamps_all) > len(stamps2)  # the first session's nodes, then this run's scans


@needs_map_info
def test_damaged_or_incompatible_maps_are_refused_naming_the_file(tmp_path):
    good = tmp_path / "good.rrrmap"
    assert run(SLAM_OFFLINE, ACES_HEAD, "--save-map", good, "--max-scans", 60, "--quiet").returncode == 0
    data = good.read_bytes()
    bad = tmp_path / "bad.rrrmap"
    bad.write_bytes(data[:len(data) // 2])
    for tool in (MAP_INFO, SLAM_OFFLINE):
        args = (bad,) if tool == MAP_INFO else (ACES_HEAD, "--load-map", bad, "--quiet")
        result = run(tool, *args)
        assert result.returncode == 1 and f"{bad}" in result.stderr and "truncated" in result.stderr
    result = run(SLAM_OFFLINE, ACES_HEAD, "--load-map", good, "--min-score", 0.7, "--max-scans", 30, "--quiet")
    assert result.returncode == 0 and "parameter      min_score is 0.7 here, 0.6 in the map" in result.stdout
    result = run(SLAM_OFFLINE, ACES_HEAD, "--load-map", good, "--submap-resolution", 0.1, "--quiet")
    assert result.returncode == 1 and "submap_resolution is 0.1 here but the map was made with 0.05" in result.stderr
    result = run(MAP_INFO, ACES_HEAD)
    assert result.returncode == 1 and "not an rrr_graphslam map file" in result.stderr
    # The same log from a laser with 150 beams over its 180 degrees: another sensor setup.
    import gzip
    other = tmp_path / "other_laser.clf"
    with gzip.open(ACES_HEAD, "rt") as src, open(other, "w") as out:
        for line in src:
            f = line.split()
            if f and f[0] == "FLASER":
                n = int(f[1])
                f = ["FLASER", "150"] + f[2:2 + 150] + f[2 + n:]
            out.write(" ".join(f) + "\n")
    result = run(SLAM_OFFLINE, other, "--load-map", good, "--quiet")
    assert result.returncode == 1, result.stdout
    assert re.search(rf"{re.escape(str(other))}:\d+: scan 1 cannot continue {re.escape(str(good))}: "
                     r"the scan's laser has 150 beams 1\.200 deg apart .*; the map's scans have 180 beams "
                     r"1\.000 deg apart", result.stderr), result.stderr


def map_info(path):
    """rrr_map_info's `key value` lines of the map at `path`."""
    return dict(line.split(" ", 1) for line in run(MAP_INFO, path).stdout.splitlines())


def trim_values(result):
    """The `trim_` lines a lifelong run of rrr_slam_offline printed, as key -> value."""
    return dict(line.split(" ", 1) for line in result.stdout.splitlines() if line.startswith("trim_"))


def aces_head_twice(tmp_path):
    """The head of ACES mapped and saved, and the same scans from another odometry frame:
    (first map, its rrr_map_info values, the moved log)."""
    from rrr_graphslam.carmen import write_moved_log
    first_map = tmp_path / "lifelong.rrrmap"
    first = run(SLAM_OFFLINE, ACES_HEAD, "--save-map", first_map, "--refine-resolution", 0, "--quiet",
                *SMALL_SUBMAPS)
    assert first.returncode == 0, first.stderr
    before = map_info(first_map)
    moved = tmp_path / "moved.clf"
    write_moved_log(ACES_HEAD, str(moved), (30.0, 10.0, -1.0))
    return first_map, before, moved


@needs_map_info
def test_lifelong_trims_covered_submaps_when_the_map_is_saved(tmp_path):
    # The head of ACES twice as two sessions: the second covers the first, whose submaps go.
    first_map, before, moved = aces_head_twice(tmp_path)
    second = run(SLAM_OFFLINE, moved, "--load-map", first_map, "--save-map", first_map, "--lifelong",
                 "--trim-kl", "--trim-overlap", 0.5, "--keep-recent-submaps", 2, "--refine-resolution", 0, "--quiet",
                 *SMALL_SUBMAPS)
    assert second.returncode == 0, second.stderr
    assert "lifelong       trimmed" in second.stdout, second.stdout
    trim = trim_values(second)
    assert int(trim["trim_submaps"]) > 0 and int(trim["trim_nodes"]) > 0, second.stdout
    assert float(trim["trim_kl_delete"]) > 0.0
    after = map_info(first_map)
    assert int(after["trimmed_submaps"]) == int(trim["trim_submaps"])
    assert int(after["marginalized_nodes"]) == int(trim["trim_nodes"])
    assert int(after["marginal_edges"]) > 0
    assert int(after["nodes"]) < 2 * int(before["nodes"])
    # The trimmed submaps' decided cells were remembered; the file holds them.
    assert int(trim["trim_remembered_patches"]) > 0, second.stdout
    assert after["remembered_cells"] == trim["trim_remembered_cells"]
    assert int(after["remembered_patches"]) <= int(trim["trim_remembered_patches"])
    # The trimmed map is continued like any other. A third drive the same way trims the second
    # session's submaps: their patches decide the cells the first session's hold, which are
    # forgotten, so the memory holds one value per cell.
    from rrr_graphslam.carmen import write_moved_log
    moved_again = tmp_path / "moved_again.clf"
    write_moved_log(ACES_HEAD, str(moved_again), (-20.0, 5.0, 2.0))
    third = run(SLAM_OFFLINE, moved_again, "--load-map", first_map, "--save-map", first_map, "--lifelong",
                "--trim-overlap", 0.5, "--keep-recent-submaps", 2, "--refine-resolution", 0, "--quiet",
                *SMALL_SUBMAPS)
    assert third.returncode == 0, third.stderr
    trim = trim_values(third)
    assert int(trim["trim_forgotten_cells"]) > 0, third.stdout
    after = map_info(first_map)
    assert after["remembered_cells"] == trim["trim_remembered_cells"]


@needs_map_info
@needs_binaries
def test_lifelong_dense_keeps_the_exact_marginal(tmp_path):
    # --sparsification dense: nothing lost at the trims (KL zero, where the tree's is not), the
    # marginals kept as dense factors in the map and in g2o exports, which rrr_optimize reads.
    first_map, before, moved = aces_head_twice(tmp_path)
    out_map = tmp_path / "dense.rrrmap"
    second = run(SLAM_OFFLINE, moved, "--load-map", first_map, "--save-map", out_map, "--lifelong",
                 "--sparsification", "dense", "--trim-kl", "--trim-overlap", 0.5, "--keep-recent-submaps", 2,
                 "--refine-resolution", 0, "--quiet", *SMALL_SUBMAPS)
    assert second.returncode == 0, second.stderr
    trim = trim_values(second)
    assert int(trim["trim_submaps"]) > 0 and int(trim["trim_dense_factors_kept"]) > 0, second.stdout
    assert int(trim["trim_marginal_edges"]) == 0
    assert float(trim["trim_kl"]) < 1e-6 < float(trim["trim_kl_clt"]), second.stdout
    after = map_info(out_map)
    assert int(after["dense_factors"]) == int(trim["trim_dense_factors_kept"])
    assert int(after["dense_factor_nodes"]) >= 2 * int(after["dense_factors"])
    assert int(after["marginal_edges"]) == 0
    exported = tmp_path / "exported.g2o"
    assert run(MAP_INFO, out_map, "--graph", exported).returncode == 0
    dense_lines = [line for line in open(exported) if line.startswith("RRR_DENSE_SE2 ")]
    assert len(dense_lines) == int(after["dense_factors"])
    optimized = run(OPTIMIZE, exported, "--output", tmp_path / "optimized.g2o")
    assert optimized.returncode == 0, optimized.stderr
    # rrr_offline decides the exported graph with its dense factors and writes them back.
    decided = run(OFFLINE, exported, "--output", tmp_path / "decided.g2o")
    assert decided.returncode == 0, decided.stderr
    assert sum(1 for line in open(tmp_path / "decided.g2o") if line.startswith("RRR_DENSE_SE2 ")) == len(dense_lines)
    assert run(MAP_INFO, out_map, "--graph", tmp_path / "exported.toro").returncode != 0  # TORO cannot
    third = run(SLAM_OFFLINE, moved, "--load-map", out_map, "--max-scans", 40, "--refine-resolution", 0,
                "--quiet", *SMALL_SUBMAPS)
    assert third.returncode == 0, third.stderr


@needs_map_info
def test_lifelong_trims_while_the_session_maps(tmp_path):
    # The head of ACES twice: once the second session is tied, the first one's covered submaps
    # go while it maps, every 10 of its nodes.
    first_map, before, moved = aces_head_twice(tmp_path)
    out_map = tmp_path / "online_out.rrrmap"
    second = run(SLAM_OFFLINE, moved, "--load-map", first_map, "--save-map", out_map, "--lifelong",
                 "--trim-overlap", 0.5, "--keep-recent-submaps", 2, "--trim-every-n-nodes", 10,
                 "--refine-resolution", 0, "--quiet", *SMALL_SUBMAPS)
    assert second.returncode == 0, second.stderr
    trims = [dict(zip(f[1::2], f[2::2])) for f in
             (line.replace("->", "after").split() for line in second.stdout.splitlines()
              if line.startswith("online_trim "))]
    assert trims, second.stdout
    assert sum(int(t["submaps_trimmed"]) for t in trims) > 0, second.stdout
    assert re.search(r"^online trims   \d+ \(every 10 nodes once tied\)", second.stdout, re.M), second.stdout
    # Without --trim-kl the KL divergences are not measured, and say so.
    saved = trim_values(second)
    assert saved["trim_kl_clt"] == "nan" and saved["trim_kl_delete"] == "nan", second.stdout
    after = map_info(out_map)
    assert int(after["trimmed_submaps"]) > 0 and int(after["marginal_edges"]) > 0
    assert int(after["nodes"]) < 2 * int(before["nodes"])


@needs_map_info
def test_lifelong_trims_an_endless_sessions_own_submaps(tmp_path):
    # One session (no map before) that drives the head of ACES there and back: with
    # --keep-current-session false its own older submaps go while it maps (the robot moves a few
    # metres: at overlap 0.5 the newest submaps cover nearly all the older ones).
    from rrr_graphslam.carmen import write_there_and_back_log
    log = tmp_path / "there_and_back.clf"
    write_there_and_back_log(ACES_HEAD, str(log))
    plain_map, trimmed_map = tmp_path / "plain.rrrmap", tmp_path / "trimmed.rrrmap"
    common = ("--refine-resolution", 0, "--quiet", *SMALL_SUBMAPS)
    plain_traj = tmp_path / "plain.txt"
    plain = run(SLAM_OFFLINE, log, "--save-map", plain_map, "--trajectory", plain_traj, *common)
    assert plain.returncode == 0, plain.stderr
    traj = tmp_path / "trimmed.txt"
    trimmed = run(SLAM_OFFLINE, log, "--save-map", trimmed_map, "--lifelong", "--keep-current-session",
                  "false", "--trim-overlap", 0.5, "--keep-recent-submaps", 2, "--trim-every-n-nodes", 10,
                  "--trajectory", traj, *common)
    assert trimmed.returncode == 0, trimmed.stderr
    trims = [dict(zip(f[1::2], f[2::2])) for f in
             (line.replace("->", "after").split() for line in trimmed.stdout.splitlines()
              if line.startswith("online_trim "))]
    assert sum(int(t["submaps_trimmed"]) for t in trims) > 0, trimmed.stdout
    before = map_info(plain_map)
    # While it maps, not only in the map it saves (which --lifelong trims once more).
    assert max(int(t["nodes"]) for t in trims) < 0.6 * int(before["nodes"]), trimmed.stdout
    after = map_info(trimmed_map)
    assert int(after["sessions"]) == 1 and int(after["trimmed_submaps"]) > 0
    assert int(after["nodes"]) < int(before["nodes"]) // 2
    # Every scan keeps its pose, those of the removed nodes too, near where the untrimmed run has
    # it (up to the gauge: the trimmed map's first node is another; 0.13 m at most when written).
    def poses(path):
        return np.array([[float(v) for v in line.split()[1:3]] for line in open(path)
                         if line.strip() and not line.startswith("#")])
    mine, theirs = poses(traj), poses(plain_traj)
    assert len(mine) == len(theirs) == sum(1 for line in open(log) if line.startswith("FLASER"))
    u, _, vt = np.linalg.svd((mine - mine.mean(0)).T @ (theirs - theirs.mean(0)))
    rotation = (u @ vt).T
    aligned = (mine - mine.mean(0)) @ rotation.T + theirs.mean(0)
    assert np.linalg.norm(aligned - theirs, axis=1).max() < 0.2


@needs_slam
def test_lifelong_flags_are_checked(tmp_path):
    out = tmp_path / "m.rrrmap"
    for args, message in (
            (("--trim-overlap", 0.5, "--save-map", out), "--trim-overlap needs --lifelong"),
            (("--lifelong",), "--lifelong trims the map when it is saved: it needs --save-map"),
            (("--lifelong", "--save-map", out, "--sparsification", "tree"), "is not clt, dense or delete"),
            (("--lifelong", "--save-map", out, "--keep-recent-submaps", 0), "--keep-recent-submaps"),
            (("--lifelong", "--save-map", out, "--keep-current-session", "yes"),
             "--keep-current-session must be true or false"),
            (("--keep-current-session", "false", "--save-map", out),
             "--keep-current-session needs --lifelong"),
            (("--trim-every-n-nodes", 10, "--save-map", out), "--trim-every-n-nodes needs --lifelong"),
            (("--clt-conservative", "false", "--save-map", out), "--clt-conservative needs --lifelong"),
            (("--clt-per-edge-scaling", "false", "--save-map", out),
             "--clt-per-edge-scaling needs --lifelong"),
            (("--lifelong", "--save-map", out, "--trim-every-n-nodes", 0), "--trim-every-n-nodes"),
            (("--lifelong", "--save-map", out, "--trim-every-n-nodes", 10, "--sparsification", "delete"),
             "--trim-every-n-nodes needs --sparsification clt"),
            (("--lifelong", "--save-map", out, "--trim-every-n-nodes", 10, "--decision-stream",
              tmp_path / "s.tsv"), "cannot be combined with --decision-stream"),
            (("--lifelong", "--save-map", out, "--trim-rule", "fresh"), "--trim-rule"),
            (("--lifelong", "--save-map", out, "--trim-min-fresh-area", 10),
             "--trim-min-fresh-area is the fresh-area rule's: it needs --trim-rule fresh-area"),
            (("--lifelong", "--save-map", out, "--trim-rule", "fresh-area", "--trim-overlap", 0.5),
             "--trim-overlap is the overlap-ratio rule's: not with --trim-rule fresh-area"),
            (("--trim-rule", "fresh-area", "--save-map", out), "--trim-rule needs --lifelong")):
        result = run(SLAM_OFFLINE, ACES_HEAD, *args)
        assert result.returncode != 0 and message in result.stderr, (args, result.stderr)


@needs_map_info
def test_map_render_flags_are_checked_and_written_maps_use_them(tmp_path):
    for tool, first in ((SLAM_OFFLINE, ACES_HEAD), (MAP_INFO, tmp_path / "none.rrrmap")):
        for args, message in ((("--map-miss-probability", 0.6),
                               "map_miss_probability = 0.6 is out of range: must be in [0.01, 0.499]"),
                              (("--map-hit-probability", "high"), "--map-hit-probability must be a number")):
            result = run(tool, first, *args)
            assert result.returncode != 0 and message in result.stderr, (tool, args, result.stderr)
    # The same run's map, rendered with the submaps' weak updates and with the default ones:
    # more cells decided free by the latter.
    saved = tmp_path / "m.rrrmap"
    assert run(SLAM_OFFLINE, ACES_HEAD, "--save-map", saved, "--quiet").returncode == 0
    free = {}
    for name, args in (("weak", ("--map-hit-probability", 0.55, "--map-miss-probability", 0.49)),
                       ("default", ())):
        assert run(MAP_INFO, saved, "--map", tmp_path / name, *args).returncode == 0
        with open(tmp_path / f"{name}.pgm", "rb") as f:
            data = f.read()
        free[name] = data.count(bytes([254]))
    assert free["default"] > 1.2 * free["weak"], free
