"""The online scratch check (RrrParams::online_scratch_check) on a real case: ringCity with 300
aliased outliers (seed 1), its first 1350 poses. Without the check the online decisions accept a
group of ten false links at node 1228, beside a true revisit of the same stretch of the path, and
hold it to the end (122 nodes); a decision from scratch of the clusters so far rejects it there,
and with the check no false group is held over 100 nodes."""
import os
import subprocess

import pytest
from conftest import DATA

from rrr_graphslam.bench import synthetic_input
from rrr_graphslam.decision_stream import held_false_groups, read_decision_stream
from rrr_graphslam.graph_io import read_graph, write_graph
from rrr_graphslam.stream_evidence import prefix

OFFLINE = os.environ.get("RRR_OFFLINE")
OPTIMIZE = os.environ.get("RRR_OPTIMIZE")


@pytest.mark.skipif(not (OFFLINE and OPTIMIZE), reason="RRR_OFFLINE, RRR_OPTIMIZE not given")
def test_a_false_revisit_the_decision_from_scratch_rejects_is_not_held(tmp_path):
    source, labels = synthetic_input(DATA, str(tmp_path), OPTIMIZE, "ringCity", "aliased", 300, 1)
    graph, nodes = read_graph(source), 1350
    path = str(tmp_path / "ringCity_aliased300_s1_1350.g2o")
    write_graph(prefix(graph, nodes), path)
    with open(labels) as f:
        is_true = [line.split()[2] == "1" for line in f]
    truth = [is_true[k] for k, e in enumerate(graph.loops()) if e.source < nodes and e.target < nodes]

    def held(*options):
        stream = path + ".stream.tsv"
        subprocess.run([OFFLINE, path, "--mode", "incremental", "--decisions", path + ".tsv",
                        "--decision-stream", stream, "--quiet", *options], check=True,
                       capture_output=True)
        rows = read_decision_stream(stream)
        return rows, [(g.accepted_at, g.held, len(g.candidates))
                      for g in held_false_groups(rows, truth, 100)]

    _, without = held("--online-scratch-check", "false")
    assert without == [(1228, 122, 10)]
    rows, with_check = held()
    assert with_check == []
    assert any("a decision from scratch rejects it" in r.reason for r in rows if not r.final)
