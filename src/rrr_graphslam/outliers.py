"""False loop closures for robustness experiments, the four kinds of the robust-SLAM literature
(Suenderhauf and Protzel's vertigo generator): random, local, random-grouped, local-grouped.

random   both ends anywhere (from < to, not consecutive)
local    the second end within `local_window` nodes of the first
*-grouped  groups of `group_size` consecutive, mutually consistent links (from+k, to+k) that
           share one measurement, like a place recognizer fooled along a stretch of corridor.
Measurements are x, y ~ N(0, 0.3 m), theta ~ N(0, 10 deg); information is copied from the
graph's first loop edge (or its first edge). Pairs that already are an edge are drawn again.

With reference poses (ground truth, or the clean graph optimized), a group is also drawn again
when one of its measurements agrees with the reference's relative pose, i.e. its chi2 against it
under the copied information is inside the alpha gate (vertigo does not check this). Such a link
is no false loop: it is as good as the graph's own loops, and every consistency test must accept it.
On manhattanOlson3500, where the robot often stands where it stood a few nodes earlier, 8 of the
11 "false" links RRR accepted among 1000 local-grouped ones were inside the 0.95 gate of the truth.
"""

import math
import random
from typing import Dict, List, Optional, Tuple

import numpy as np
from scipy.stats import chi2

from .graph_io import Edge, Pose, PoseGraph, between, information_matrix

KINDS = ("random", "local", "random-grouped", "local-grouped")


def chi2_against(reference: Dict[int, Pose], source: int, target: int, measurement: Pose,
                 information: Tuple[float, ...]) -> float:
    """Squared Mahalanobis distance of a measurement from the reference's relative pose (g2o's
    error, z^-1 (x_source^-1 x_target), weighted by the information in g2o order)."""
    e = np.array(between(measurement, between(reference[source], reference[target])))
    return float(e @ information_matrix(information) @ e)


def gate(alpha: float, dof: int = 3) -> float:
    """The chi-square gate: a squared Mahalanobis distance below it is consistent at `alpha`."""
    return float(chi2.ppf(alpha, dof))


def add_outliers(graph: PoseGraph, kind: str, count: int, seed: int = 1, group_size: int = 10,
                 local_window: int = 20, reference: Optional[Dict[int, Pose]] = None,
                 alpha: float = 0.95) -> Tuple[PoseGraph, List[Tuple[int, int, int]]]:
    """Returns the corrupted graph and labels (from, to, 1 = original loop / 0 = outlier) for
    every loop edge in output order. With `reference`, no outlier's measurement lies inside the
    chi2(alpha, 3) gate of the reference relative pose. Raises ValueError for impossible requests."""
    if kind not in KINDS:
        raise ValueError(f"unknown outlier kind '{kind}' (expected one of {', '.join(KINDS)})")
    if count < 0 or group_size < 1 or local_window < 2:
        raise ValueError("count must be >= 0, group_size >= 1 and local_window >= 2")
    ids = sorted(graph.poses)
    n = len(ids)
    if reference is not None:
        missing = [i for i in ids if i not in reference]
        if missing:
            more = f" and {len(missing) - 1} more" if len(missing) > 1 else ""
            raise ValueError(f"reference poses lack node {missing[0]}{more}")
    grouped = kind.endswith("grouped")
    size = group_size if grouped else 1
    if n < size + 3:
        raise ValueError(f"graph has {n} nodes, too few for outliers in groups of {size}")
    loops = graph.loops()
    info = (loops[0] if loops else graph.edges[0]).information
    if reference is not None and not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    threshold = gate(alpha) if reference is not None else math.inf
    rng = random.Random(seed)
    existing = {(e.source, e.target) for e in graph.edges} | {(e.target, e.source) for e in graph.edges}

    added: List[Edge] = []
    attempts = 0
    while len(added) < count:
        attempts += 1
        if attempts > 1000 * (count + 10):
            raise ValueError(f"could not place {count} outliers of kind {kind} in this graph")
        a = rng.randint(0, n - 1 - size)
        if kind.startswith("random"):
            b = rng.randint(0, n - 1 - size)
        else:
            b = a + rng.randint(2, local_window)
            if b > n - 1 - size:
                continue
        a, b = min(a, b), max(a, b)
        if b - a < 2:
            continue
        group = [(ids[a + k], ids[b + k]) for k in range(min(size, count - len(added)))]
        if any(p in existing for p in group):
            continue
        z = (rng.gauss(0.0, 0.3), rng.gauss(0.0, 0.3), rng.gauss(0.0, math.radians(10.0)))
        if reference is not None and any(
                chi2_against(reference, i, j, z, info) < threshold for i, j in group):
            continue
        for p in group:
            existing.add(p)
            existing.add((p[1], p[0]))
            added.append(Edge(p[0], p[1], z, info))

    out = PoseGraph(dict(graph.poses), list(graph.edges) + added)
    labels = [(e.source, e.target, 1) for e in graph.loops()] + [(e.source, e.target, 0) for e in added]
    return out, labels
