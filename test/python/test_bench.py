"""The benchmark's targets summary: what it counts as met and what it names as not; the ablation
table, with a stand-in for rrr_offline."""
import contextlib
import io
import math
import os
import re
import sys
from types import SimpleNamespace

from rrr_graphslam.bench import (ABLATION_SWITCHES, AliasingRow, Row, aliasing_summary, main,
                                 online_lines, target_lines)
from rrr_graphslam.decision_stream import OnlineScore


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
            latency="p50 0.00 ms, p99 31.15 ms, max 646.22 ms per update, 59 over 50 ms"),
        row("KITTI 00", "alpha 0.00", "DLoopDetector", "batch", 1.0, 1.0),
    ])
    text = "\n".join(lines)
    assert "synthetic precision 1.000: 2 of 3; not: manhattanOlson3500_olson random 1000 (0.9995)" in text
    assert "synthetic recall >= 0.98: 2 of 3; not: csail local 500 (0.9700)" in text
    assert "KITTI precision 1.000: 1 of 1" in text
    assert "M3500 + 1000 random, batch, under 1 s: 0.40 s (met)" in text
    assert ("City10000 + 1000 random, batch, under 10 s: 12.00 s (NOT met; full-graph intra tests "
            "in this run: 240.00 s, 20x)") in text
    assert "p99 under 50 ms per update: 31.1 ms (met)" in text


def test_online_rows_of_several_seeds_are_named_by_seed_and_each_judged():
    def online(seed, held):
        score = OnlineScore(outliers=100, transient_false_accepts=len(held),
                            false_accept_nodes=dict(enumerate(held)),
                            first_verdict_nodes=[3, 5], first_verdict_seconds=[0.01, 0.02])
        return row("intel", "aliased", "100", "incremental", 1.0, 1.0)._replace(
            seed=seed, online=score)
    text = "\n".join(online_lines([online(2, []), online(3, [150, 20])]))
    assert "| intel aliased 100 seed 2 | 0 (100) |" in text
    assert "| intel aliased 100 seed 3 | 2 (100) | 0 | 150 | 1 |" in text
    assert ("no false link accepted for longer than 100 nodes: 1 of 2; not: intel aliased 100 "
            "seed 3 (1, longest 150)") in text
    assert "transient false accepts at most 1% of the outliers: 1 of 2; not: intel aliased 100 seed 3 (2 of 100)" in text


def test_targets_a_run_did_not_cover_are_left_out():
    lines = target_lines([row("intel", "random", "100", "batch", 1.0, 1.0)])
    assert lines == ["targets:", "  synthetic precision 1.000: 1 of 1", "  synthetic recall >= 0.98: 1 of 1"]


FAKE_OFFLINE = """#!{python}
# rrr_offline's stand-in: four candidates, the first two true; the default preset decides them
# right, the paper preset rejects every one, --joint-link-check false accepts a false one.
import sys
args = sys.argv[1:]
with open({log!r}, "a") as log:
    log.write(" ".join(args) + "\\n")
accepted = {{0, 1}}
if "--preset" in args and args[args.index("--preset") + 1] == "paper":
    accepted = set()
if "--joint-link-check" in args:
    accepted.add(2)
if "--verifier" in args and args[args.index("--verifier") + 1] == "scgp":
    accepted.add(3)
rows = ["from\\tto\\tcluster\\tverdict\\treason"]
for k in range(4):
    verdict = "accepted" if k in accepted else "rejected"
    rows.append(f"{{k}}\\t{{k + 5}}\\t{{k}}\\t{{verdict}}\\tfake")
with open(args[args.index("--decisions") + 1], "w") as f:
    f.write("\\n".join(rows) + "\\n")
if "--decision-stream" in args:  # candidate 2 (false) accepted from node 10 to node 200
    with open(args[args.index("--decision-stream") + 1], "w") as f:
        f.write("when\\tscan\\tnodes\\tstamp\\tcandidate\\tfrom\\tto\\tcluster\\tprevious\\tverdict\\treason\\n")
        for k in range(4):
            f.write(f"online\\t{{k + 5}}\\t{{k + 5}}\\t0.1\\t{{k}}\\t{{k}}\\t{{k + 5}}\\t-1\\tpending\\tpending\\t\\n")
        for k, (nodes, previous, verdict) in enumerate(((10, "pending", "accepted"),
                                                          (10, "pending", "accepted"),
                                                          (10, "pending", "accepted"),
                                                          (10, "pending", "rejected"))):
            f.write(f"online\\t{{nodes}}\\t{{nodes}}\\t0.2\\t{{k}}\\t{{k}}\\t{{k + 5}}\\t{{k}}\\t{{previous}}\\t{{verdict}}\\tr\\n")
        f.write("online\\t200\\t200\\t0.3\\t2\\t2\\t7\\t2\\taccepted\\trejected\\tr\\n")
if "--output" in args:  # the map: the clean optimum of fake_bench's cache, one pose off
    with open(args[args.index("--output") + 1], "w") as f:
        f.write({graph!r}.replace("VERTEX_SE2 2 2 0 0", "VERTEX_SE2 2 2 0.5 0"))
print("optimizations  " + str(10 + len(args)))
print("time           0.250 s")
"""
# A clean optimum for the map harm: three poses on a line.
LINE_GRAPH = ("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n"
              "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n")
# rrr_optimize's stand-in: the input's poses are its optimum.
FAKE_OPTIMIZE = """#!{python}
import shutil, sys
shutil.copy(sys.argv[1], sys.argv[sys.argv.index("--output") + 1])
"""
# fake_bench's input: 201 poses on a line, exact odometry and loops 0 -> 5, 1 -> 6, 3 -> 8; the
# false 2 -> 7 lies 3 m aside (chi2 9 at the poses, the fake optimum, against chi2(0.95, 3) 7.8).
CORRIDOR = "".join(f"VERTEX_SE2 {i} {i} 0 0\n" for i in range(201)) + "".join(
    f"EDGE_SE2 {i} {i + 1} 1 0 0 1 0 0 1 0 1\n" for i in range(200)) + "".join(
    f"EDGE_SE2 {i} {i + 5} 5 {3 if i == 2 else 0} 0 1 0 0 1 0 1\n" for i in range(4))
HEADER = ("| input | configuration | precision | recall | time s | optimizations | "
          "fp / fn vs default |")


def fake_bench(tmp_path, *options):
    """bench.main with a fake rrr_offline and one cached input, g random 4, every other input
    deselected; its stdout lines, the fake's calls and the cache folder."""
    cache = tmp_path / "cache"
    cache.mkdir(parents=True, exist_ok=True)
    (cache / "g_random4_s1_gated.g2o").write_text(CORRIDOR)  # the fake rrr_offline reads nothing
    (cache / "g_random4_s1_gated.g2o.labels").write_text("0 5 1\n1 6 1\n2 7 0\n3 8 0\n")
    log = tmp_path / "calls"
    fake = tmp_path / "rrr_offline"
    fake.write_text(FAKE_OFFLINE.format(python=sys.executable, log=str(log), graph=LINE_GRAPH))
    fake.chmod(0o755)
    optimize = tmp_path / "rrr_optimize"
    optimize.write_text(FAKE_OPTIMIZE.format(python=sys.executable))
    optimize.chmod(0o755)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["--rrr-offline", str(fake), "--rrr-optimize", str(optimize),
                     "--data", str(tmp_path), "--cache", str(cache), "--datasets", "--no-kitti",
                     "--no-b25b", "--incremental", *options]) == 0
    calls = log.read_text().splitlines() if log.exists() else []
    return out.getvalue().splitlines(), calls, cache


def test_ablation_counts_each_switch_against_the_default(tmp_path):
    lines, calls, cache = fake_bench(tmp_path, "--baseline", "--ablation", "g:random:4")
    # The ablation alone: its table and nothing else (the fake's optimizations: 10 + its options).
    assert lines[:5] == [
        HEADER, "|---|---|---|---|---|---|---|",
        "| g random 4 | paper | 1.0000 | 0.0000 | 0.25 | 16 | +0 / +2 |",
        "| g random 4 | default | 1.0000 | 1.0000 | 0.25 | 14 | fp 0, fn 0 |",
        "| g random 4 | default --reduced-intra-graph false | 1.0000 | 1.0000 | 0.25 | 16 | "
        "+0 / +0 |",
    ]
    assert ("| g random 4 | default --joint-link-check false | 0.6667 | 1.0000 | 0.25 | 16 | "
            "+1 / +0 |") in lines
    assert ("| g random 4 | default --recover-gate inf | 1.0000 | 1.0000 | 0.25 | 16 | "
            "+0 / +0 |") in lines
    assert len(lines) == 2 + 2 + len(ABLATION_SWITCHES)
    # One run per configuration, the default first; nothing written over the bench's own files.
    assert len(calls) == 2 + len(ABLATION_SWITCHES)
    assert calls[0].endswith("g_random4_s1_gated.g2o.ablation-default.tsv --quiet")
    assert calls[1].endswith(".ablation-paper.tsv --quiet --preset paper")
    fraction = 2 + [switch for switch, _ in ABLATION_SWITCHES].index("batch-removal-fraction")
    assert calls[fraction].endswith(".ablation-batch-removal-fraction-1.tsv --quiet "
                                    "--batch-removal-fraction 1")
    assert (cache / "g_random4_s1_gated.g2o.ablation-recover-gate-inf.tsv").exists()
    assert not list(cache.glob("*.batch.tsv"))


def test_ablation_beside_the_bench_and_only_when_asked(tmp_path):
    lines, calls, _ = fake_bench(tmp_path, "--baseline", "g:random:4")
    assert lines == [
        "| dataset | kind | outliers | mode | precision | recall | time s | optimizations | "
        "map harm |",
        "|---|---|---|---|---|---|---|---|---|",
        "| g | random | 4 | batch --full-intra | 1.0000 | 1.0000 | 0.25 | 17 | - |",
        "", "targets:", "", "worst precision 1.0000, worst recall 1.0000"]
    assert len(calls) == 1 and ".ablation-" not in calls[0]
    both, calls, _ = fake_bench(tmp_path / "both", "--baseline", "g:random:4", "--ablation",
                                "g:random:4")
    assert both[:len(lines)] == lines
    assert both[len(lines):len(lines) + 3] == ["", HEADER, "|---|---|---|---|---|---|---|"]
    assert len(calls) == 3 + len(ABLATION_SWITCHES)


def test_verifiers_table_runs_every_verifier_on_the_same_input(tmp_path):
    (tmp_path / "cache").mkdir()
    (tmp_path / "g.g2o.gz").write_text("")  # the map harm's source: its clean optimum is cached
    (tmp_path / "cache" / "g_reference.g2o").write_text(LINE_GRAPH)
    lines, calls, cache = fake_bench(tmp_path, "--baseline", "--verifiers", "g:random:4",
                                     "--verifier-seeds", "1", "--verifier-synthetic-only")
    assert lines[:2] == ["| input | seed | verifier | precision | recall | map harm | time s |",
                         "|---|---|---|---|---|---|---|"]
    rows = [line for line in lines if line.startswith("| g random 4 |")]
    assert [r.split(" | ")[2] for r in rows] == ["rrr", "pcm", "scgp", "gnc tls", "gnc gm"]
    assert "| g random 4 | 1 | scgp | 0.6667 | 1.0000 |" in rows[2]
    assert "| scgp | 1 | 0.6667 | 1.0000 | 1 of 1 (g random 4 s1) | 0.2 |" in lines
    assert "| rrr | 1 | 1.0000 | 1.0000 | 1 of 1 (g random 4 s1) | 0.2 |" in lines
    assert [c.split("--quiet")[1].split("--output")[0].strip() for c in calls] == [
        "", "--verifier pcm", "--verifier scgp", "--verifier gnc", "--verifier gnc --gnc-loss gm"]
    assert (cache / "g_random4_s1_gated.g2o.verifier-gnc-gm.tsv").exists()


def test_incremental_runs_are_scored_as_their_decisions_were_made(tmp_path):
    lines, calls, cache = fake_bench(tmp_path, "g:random:4", "--baseline")
    assert "--decision-stream" in calls[0] and "--mode incremental" in calls[0]
    assert "| g random 4 | 1 (2) | 0 | 190 | 1 | 0 | 3 / 5 / 5 | 0.100 | 0 |" in lines
    assert "  no false link accepted for longer than 100 nodes: 0 of 1; not: g random 4 (1, " \
           "longest 190)" in lines
    assert "  transient false accepts at most 1% of the outliers: 0 of 1; not: g random 4 (1 of 2)" \
           in lines
    # Beside the stream, each candidate's verdicts and when (nodes, seconds after its arrival).
    history = (cache / "g_random4_s1_gated.g2o.incremental.stream.history.tsv").read_text().splitlines()
    assert history[3] == "2\tfalse\tpending@0/0.000s accepted@3/0.100s rejected@193/0.200s"
    # The false link held over 100 nodes, against the outlier-free data (contradicted on arrival)
    # and against batch RRR on the graph so far (the fake's batch decision rejects it at once).
    assert "| g random 4 | 2 (1) | 10 | 190 | 10 | 9.0 / 7.8 | 10 |" in lines
    assert ("  of the 1 false links held over 100 nodes: 0 not contradicted within 100 nodes by the "
            "outlier-free data (no test on the stated noise could have rejected them in time), 0 "
            "contradicted but held as long by batch RRR on the same data, 1 rejected in time by "
            "batch RRR (the online decision's own shortfall)") in lines
    batch_runs = [c for c in calls if "rrr_evidence_" in c]
    assert len(batch_runs) == 1 and "--mode" not in batch_runs[0]


def test_aliasing_pairs_each_aliased_input_with_random_outliers_of_its_count_and_seed(tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir()
    for seed in (2, 3):
        (cache / f"g_random4_s{seed}_gated.g2o").write_text("")
        (cache / f"g_random4_s{seed}_gated.g2o.labels").write_text("0 5 1\n1 6 1\n2 7 0\n3 8 0\n")
        # seed 3's aliased set makes the fake's second acceptance false
        second = 0 if seed == 3 else 1
        (cache / f"g_aliased4_g2_s{seed}_gated.g2o").write_text("")
        (cache / f"g_aliased4_g2_s{seed}_gated.g2o.labels").write_text(
            f"0 5 1\n1 6 {second}\n2 7 0\n3 8 0\n")
    lines, calls, _ = fake_bench(tmp_path, "--baseline", "--aliasing", "g", "--aliasing-counts",
                                 "4", "--aliasing-seeds", "2", "3", "--aliasing-group-sizes", "2")
    assert lines[2:4] == [
        "| g | 2 | 4 | 2 | 1.0000 / 1.0000 | 0.25 | 1.0000 / 1.0000 | 0.25 | 1.0x |",
        "| g | 2 | 4 | 3 | 0.5000 / 1.0000 | 0.25 | 1.0000 / 1.0000 | 0.25 | 1.0x |"]
    assert "| g | 2 | 4 | 2,3 | 0.5000 | 1.0000 | 1.0x | 1.0x |" in lines
    assert "  precision 1.000: 1 of 2; not: g g2 4 s3 (0.5000)" in lines
    assert len(calls) == 4 and all(c.split()[0].endswith("_gated.g2o") for c in calls)


def test_seeds_run_every_synthetic_input_on_each_and_summarize_the_worst(tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir()
    for seed, label in ((2, 1), (3, 0)):  # seed 3's second link is false: precision 0.5
        (cache / f"csail_random4_s{seed}_gated.g2o").write_text("")
        (cache / f"csail_random4_s{seed}_gated.g2o.labels").write_text(
            f"0 5 1\n1 6 {label}\n2 7 0\n3 8 0\n")
    (cache / "csail_reference.g2o").write_text(LINE_GRAPH)
    lines, calls, _ = fake_bench(tmp_path, "--baseline", "--datasets", "csail", "--kinds", "random",
                                 "--counts", "4", "--seeds", "2", "3")
    # The fake's map has one of three poses 0.5 m off the clean optimum: harmed.
    assert lines[:4] == [
        "| dataset | kind | outliers | mode | precision | recall | time s | optimizations | "
        "map harm | seed |",
        "|---|---|---|---|---|---|---|---|---|---|",
        "| csail | random | 4 | batch | 1.0000 | 1.0000 | 0.25 | 18 | HARMED 12.1 cm > 1.0 | 2 |",
        "| csail | random | 4 | batch | 0.5000 | 1.0000 | 0.25 | 18 | HARMED 12.1 cm > 1.0 | 3 |"]
    assert ("| csail | random | 4 | 2,3 | 0.5000 / 0.7500 | 1.0000 / 1.0000 | 0.25 / 0.25 | "
            "2 of 2 (+12.1 cm) |" in lines)
    assert "  synthetic precision 1.000: 1 of 2; not: csail random 4 (0.5000)" in lines
    assert ("  synthetic map harm within max(1 cm, 2%): 0 of 2; not: csail random 4 s2 (HARMED "
            "12.1 cm > 1.0), csail random 4 s3 (HARMED 12.1 cm > 1.0)") in lines
    assert len(calls) == 2 and all("--output" in c for c in calls)


def aliasing_row(graph, size, count, seed, precision, recall, time, random_time, latency=None):
    score = SimpleNamespace(precision=precision, recall=recall)
    return AliasingRow(graph, size, count, seed, score, {"time": time}, score,
                       {"time": random_time}, time / random_time, latency)


def test_aliasing_targets_take_the_worst_seed():
    lines = aliasing_summary([
        aliasing_row("city10000", 20, 2000, 2, 1.0, 1.0, 9.0, 1.0, (20.0, 300.0)),
        aliasing_row("city10000", 20, 2000, 3, 1.0, 0.97, 12.0, 6.0, (60.0, 1500.0)),
        aliasing_row("csail", 5, 26, 2, 1.0, 1.0, 0.2, 0.1, (1.0, 2.0)),
    ])
    assert "| city10000 | 20 | 2000 | 2,3 | 1.0000 | 0.9700 | 9.0x | 5.5x |" in lines
    assert "  precision 1.000: 3 of 3" in lines
    assert "  recall >= 0.98: 2 of 3; not: city10000 g20 2000 s3 (0.9700)" in lines
    assert ("  batch time at most 3x random: 2 of 3; not: city10000 g20 2000 s2 (9.0x)") in lines
    assert ("  City10000 + 2000 aliased (groups of 20) under 10 s batch: s2 9.00 s, s3 12.00 s "
            "(NOT met)") in lines
    assert ("  incremental p99 under 50 ms, no candidate over 1 s: 2 of 3; not: city10000 g20 "
            "2000 s3 (p99 60.0 ms, max 1500 ms)") in lines


def test_aliasing_time_growth_is_judged_against_the_smallest_count_of_each_series():
    lines = aliasing_summary([
        aliasing_row("city10000", 20, 500, 2, 1.0, 1.0, 15.0, 0.7),
        aliasing_row("city10000", 20, 1000, 2, 1.0, 1.0, 21.0, 1.0),
        aliasing_row("city10000", 20, 4000, 2, 1.0, 1.0, 130.0, 1.1),
        aliasing_row("m3500", 20, 100, 2, 1.0, 1.0, 1.0, 0.1),
    ])
    assert ("  aliased batch time at most linear in the outliers (each count against the smallest "
            "of its graph, group size and seed): 1 of 2; not: city10000 g20 s2 4000 (130.00 s = "
            "8.7x the 500's 15.00 s for 8.0x the outliers)") in lines
    assert any(line.startswith("  random batch time at most linear in the outliers") and
               line.endswith(": 2 of 2") for line in lines)


def test_ablation_switches_are_those_the_paper_preset_changes():
    source = open(os.path.join(os.path.dirname(__file__), "..", "..", "src", "rrr",
                               "rrr_params.cpp")).read()
    paper = source[source.index('if (name == "paper")'):source.index("} else if")]
    changed = dict(re.findall(r"p\.(\w+) = ([^;]+);", paper))
    incremental_only = {"online_map_check", "online_untestable_ratio", "online_group_wait_nodes",
                        "online_increase_test", "online_scratch_check", "incremental_rebatch_every",
                        "incremental_factor_updates"}
    # Acts only with placement_min_spread_m, which SLAM runs set and the bench's graphs do not.
    slam_only = {"placement_wider_reading"}
    ablated = {switch.replace("-", "_"): value for switch, value in ABLATION_SWITCHES}
    assert set(ablated) == set(changed) - incremental_only - slam_only

    def number(value):
        words = {"false": 0.0, "true": 1.0, "std::numeric_limits<double>::infinity()": math.inf}
        return words[value] if value in words else float(value)

    assert all(number(ablated[name]) == number(changed[name]) for name in ablated)


def test_held_links_are_tallied_by_what_could_have_rejected_them_in_time():
    from rrr_graphslam.bench import held_lines
    from rrr_graphslam.decision_stream import HeldGroup
    from rrr_graphslam.stream_evidence import Evidence
    never = Evidence(None, 5.0, 7.8)
    late = Evidence(300, 9.0, 7.8)
    soon = Evidence(50, 9.0, 7.8)
    r = SimpleNamespace(held=[(HeldGroup(1, [0], 10, 500), never, None),         # out of reach
                              (HeldGroup(2, [1, 2], 10, 500), late, None),       # out of reach
                              (HeldGroup(3, [3], 10, 500), never, 110),          # batch rejects in time
                              (HeldGroup(4, [4, 5, 6], 10, 500), soon, None),    # batch keeps it
                              (HeldGroup(5, [7], 10, 500), soon, 111)])          # batch: too late
    lines = held_lines([r], lambda r: "g")
    assert "| g | 3 (1) | 10 | 500 | not by node 510 | 5.0 / 7.8 | 110 |" in lines
    assert lines[-1] == (
        "  of the 8 false links held over 100 nodes: 3 not contradicted within 100 nodes by the "
        "outlier-free data (no test on the stated noise could have rejected them in time), 4 "
        "contradicted but held as long by batch RRR on the same data, 1 rejected in time by batch "
        "RRR (the online decision's own shortfall)")
