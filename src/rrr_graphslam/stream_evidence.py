"""When the data could first tell a false group from a true one. For a group of false links an
online decision accepted, two moments:

- first_contradiction: the first at which the outlier-free data the robot had so far (odometry
  and the true loops among the nodes already arrived) contradicts it. Until then no test on the
  stated noise can reject it, however it is made. It knows which loops are true, which no verifier
  does: a bound on what the data can tell, not a decision one could make.
- first_batch_rejection: the first at which batch RRR, deciding every candidate of the graph so
  far from scratch, rejects it: what the product's own full decision makes of the same data.

The test at node count n: optimize the outlier-free prefix (nodes < n) with and without the
group; the group is contradicted when it raises the optimum's chi2 by chi2(alpha, 3 x its links)
or more (the far retry's and the online increase test's statistic, here against the true data
alone)."""

import os
import subprocess
import tempfile
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

from scipy.stats import chi2

from .evaluation import read_decisions
from .graph_io import PoseGraph, read_graph, write_graph
from .outliers import chi2_against


def prefix(graph: PoseGraph, nodes: int) -> PoseGraph:
    """Nodes < `nodes` with every edge among them (the graph as the robot had it); dense factors
    (a trimmed map's) are not kept."""
    return PoseGraph({i: p for i, p in graph.poses.items() if i < nodes},
                     [e for e in graph.edges if e.source < nodes and e.target < nodes])


def outlier_free_prefix(graph: PoseGraph, truth: Sequence[Optional[bool]], nodes: int,
                        extra: Sequence[int] = ()) -> PoseGraph:
    """prefix() with odometry and true loops only, and the loop candidates `extra` (indices among
    graph.loops(), in file order). Candidates of unknown truth are left out."""
    keep, edges, k = set(extra), [], -1
    for e in graph.edges:
        if e.is_loop:
            k += 1
            if truth[k] is not True and k not in keep:
                continue
        edges.append(e)
    return prefix(PoseGraph(graph.poses, edges), nodes)


def optimum_chi2(graph: PoseGraph, optimizer: str, workdir: str) -> float:
    """chi2 of `graph` at its optimum (rrr_optimize, Levenberg-Marquardt from LAGO when the start
    is far: a false group can leave Gauss-Newton crawling), summed over its edges with their
    information. RuntimeError with rrr_optimize's message if it fails."""
    path = os.path.join(workdir, "prefix.g2o")
    optimized = os.path.join(workdir, "prefix.opt.g2o")
    write_graph(graph, path)
    run = subprocess.run([optimizer, path, "--output", optimized, "--method", "lm",
                          "--max-iterations", "1000"], capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"{optimizer} on a prefix of {len(graph.poses)} nodes: "
                           f"{run.stderr.strip() or run.stdout.strip()}")
    poses = read_graph(optimized).poses
    return sum(chi2_against(poses, e.source, e.target, e.measurement, e.information)
               for e in graph.edges)


@dataclass
class Evidence:
    contradicted_at: Optional[int]  # first node count tried at which the data contradicts it
    increase: float                 # its chi2 increase there (or at the last count tried)
    gate: float                     # chi2(alpha, 3 x its links)


def _counts(start: int, stop: int, step: int) -> List[int]:
    return list(range(start, stop, step)) + [stop]


def first_contradiction(graph: PoseGraph, truth: Sequence[Optional[bool]], group: Sequence[int],
                        start: int, stop: int, optimizer: str, step: int = 50,
                        alpha: float = 0.95, cache: Optional[Dict[int, float]] = None) -> Evidence:
    """The first node count in start, start + step, ..., stop (stop always tried) at which the
    outlier-free prefix contradicts the false candidates `group`; None if none does. `cache`
    keeps the outlier-free optimum's chi2 per node count between calls on one graph."""
    cache = {} if cache is None else cache
    gate = float(chi2.ppf(alpha, 3 * len(group)))
    counts = _counts(start, stop, step)
    increase = 0.0
    with tempfile.TemporaryDirectory(prefix="rrr_evidence_") as workdir:
        for n in counts:
            if n not in cache:
                cache[n] = optimum_chi2(outlier_free_prefix(graph, truth, n), optimizer, workdir)
            increase = optimum_chi2(outlier_free_prefix(graph, truth, n, group), optimizer,
                                    workdir) - cache[n]
            if increase >= gate:
                return Evidence(n, increase, gate)
    return Evidence(None, increase, gate)


def first_batch_rejection(graph: PoseGraph, group: Sequence[int], start: int, stop: int,
                          rrr_offline: str, step: int = 50) -> Optional[int]:
    """The first node count in start, start + step, ..., stop at which batch RRR (rrr_offline with
    its defaults) on the graph's prefix rejects every candidate of `group` (indices among
    graph.loops()); None if none does. RuntimeError with rrr_offline's message if it fails."""
    loops = list(enumerate(graph.loops()))
    with tempfile.TemporaryDirectory(prefix="rrr_evidence_") as workdir:
        path = os.path.join(workdir, "prefix.g2o")
        decisions = os.path.join(workdir, "prefix.tsv")
        for n in _counts(start, stop, step):
            write_graph(prefix(graph, n), path)
            run = subprocess.run([rrr_offline, path, "--decisions", decisions, "--quiet"],
                                 capture_output=True, text=True)
            if run.returncode != 0:
                raise RuntimeError(f"{rrr_offline} on a prefix of {n} nodes: "
                                   f"{run.stderr.strip() or run.stdout.strip()}")
            index = [k for k, e in loops if e.source < n and e.target < n]
            verdict = dict(zip(index, (d.verdict for d in read_decisions(decisions))))
            if all(verdict.get(k) == "rejected" for k in group):
                return n
    return None
