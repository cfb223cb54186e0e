"""The command-line contracts of rrr_offline and rrr_optimize: file formats, exit codes, errors.

The build passes the binaries' paths (RRR_OFFLINE, RRR_OPTIMIZE); run by hand without them,
these tests are skipped.
"""
import os
import subprocess

import pytest
from conftest import DATA
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
    assert header == "from\tto\tcluster\tverdict"
    rows = read_decisions(str(decisions))
    graph = read_graph(str(path))
    assert [(d.source, d.target) for d in rows] == [(e.source, e.target) for e in graph.loops()]
    s = score(rows, read_truth(str(folder / "truth"), rows))
    assert s.fp == 0 and s.recall > 0.95
    out = read_graph(str(optimized))
    accepted = sum(d.verdict == "accepted" for d in rows)
    assert len(out.loops()) == accepted
    assert out.poses != graph.poses  # optimized, not the initial guess


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
