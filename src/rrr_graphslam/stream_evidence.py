"""When the data could first tell a false group from a true one: for a group of false links an
online decision accepted, the first moment at which the outlier-free data the robot had so far
(odometry and the true loops among nodes already arrived) contradicts it. Until then no test on the
stated noise can reject it, however it is made; from then on, holding it is the decision's own
shortfall. A reference the decisions did not produce: the truth labels and the stated noise.

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

from .graph_io import PoseGraph, read_graph, write_graph
from .outliers import chi2_against


def outlier_free_prefix(graph: PoseGraph, truth: Sequence[Optional[bool]], nodes: int,
                        extra: Sequence[int] = ()) -> PoseGraph:
    """Nodes < `nodes` with their odometry and true loops, and the loop candidates `extra`
    (indices among graph.loops(), in file order) whose ends have arrived. Candidates of unknown
    truth are left out."""
    keep = set(extra)
    edges, k = [], 0
    for e in graph.edges:
        if e.is_loop:
            wanted = truth[k] is True or k in keep
            k += 1
            if not wanted:
                continue
        if e.source < nodes and e.target < nodes:
            edges.append(e)
    return PoseGraph({i: p for i, p in graph.poses.items() if i < nodes}, edges)


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


def first_contradiction(graph: PoseGraph, truth: Sequence[Optional[bool]], group: Sequence[int],
                        start: int, stop: int, optimizer: str, step: int = 50,
                        alpha: float = 0.95, cache: Optional[Dict[int, float]] = None) -> Evidence:
    """The first node count in start, start + step, ..., stop (stop always tried) at which the
    outlier-free prefix contradicts the false candidates `group`; None if none does. `cache`
    keeps the outlier-free optimum's chi2 per node count between calls on one graph."""
    cache = {} if cache is None else cache
    gate = float(chi2.ppf(alpha, 3 * len(group)))
    counts = list(range(start, stop, step)) + [stop]
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
