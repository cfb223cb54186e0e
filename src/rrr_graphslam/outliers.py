"""False loop closures for robustness experiments: the four kinds of the robust-SLAM literature
(Suenderhauf and Protzel's vertigo generator), random, local, random-grouped, local-grouped, and
perceptual aliasing, aliased.

random   both ends anywhere (from < to, not consecutive)
local    the second end within `local_window` nodes of the first
*-grouped  groups of `group_size` consecutive links (from+k, to+k) that share one measurement,
           like a place recognizer fooled along a stretch of corridor.
aliased  groups of `group_size` consecutive links (from+k, to+k), both ends anywhere, that share
         one wrong rigid offset: the stretch from `to` is moved rigidly onto the wrong place next to
         `from`, and every link measures the relative pose the poses would have there. The links
         agree with each other and with the odometry on both sides, as the loops of a robot that
         takes a long repeated corridor for another would (a *-grouped group does not: its one
         measurement fits only where both stretches happen to move alike). The poses moved are the
         reference's (see below), or the graph's own.
Measurements (of an aliased group: its first link's) are x, y ~ N(0, 0.3 m), theta ~ N(0, 10 deg);
information is copied from the graph's first loop edge (or its first edge). Pairs that already are
an edge are drawn again.

With reference poses (ground truth, or the clean graph optimized), a group is also drawn again
when one of its measurements agrees with the reference's relative pose, i.e. its chi2 against it
under the copied information is inside the alpha gate (vertigo does not check this). Such a link
is no false loop: it is as good as the graph's own loops, and every consistency test must accept it.
On manhattanOlson3500, where the robot often stands where it stood a few nodes earlier, 8 of the
11 "false" links RRR accepted among 1000 local-grouped ones were inside the 0.95 gate of the truth.
"""

import math
import random
from collections import defaultdict
from typing import Dict, Iterator, List, Optional, Set, Tuple

import numpy as np
from scipy.stats import chi2

from .graph_io import Edge, Pose, PoseGraph, between, compose, information_matrix, inverse

KINDS = ("random", "local", "random-grouped", "local-grouped", "aliased")
# Failed draws in a row after which add_outliers checks whether any place is left for the next
# group (random groups can leave only gaps shorter than a group long before the graph is full).
_DRAWS_BEFORE_ROOM_CHECK = 10000


def chi2_against(reference: Dict[int, Pose], source: int, target: int, measurement: Pose,
                 information: Tuple[float, ...]) -> float:
    """Squared Mahalanobis distance of a measurement from the reference's relative pose (g2o's
    error, z^-1 (x_source^-1 x_target), weighted by the information in g2o order)."""
    e = np.array(between(measurement, between(reference[source], reference[target])))
    return float(e @ information_matrix(information) @ e)


def gate(alpha: float, dof: int = 3) -> float:
    """The chi-square gate: a squared Mahalanobis distance below it is consistent at `alpha`."""
    return float(chi2.ppf(alpha, dof))


def missing_nodes(graph: PoseGraph, reference: Dict[int, Pose]) -> str:
    """'' when `reference` has a pose for every node of `graph`, else e.g. 'node 2 and 5 more'."""
    missing = [i for i in sorted(graph.poses) if i not in reference]
    if not missing:
        return ""
    return f"node {missing[0]}" + (f" and {len(missing) - 1} more" if len(missing) > 1 else "")


def _is_grouped(kind: str) -> bool:
    return kind.endswith("grouped") or kind == "aliased"


def _is_local(kind: str) -> bool:
    return kind.startswith("local")


def _aliased_measurements(poses: Dict[int, Pose], group: List[Tuple[int, int]], first: Pose) -> List[Pose]:
    """The measurements of an aliased group whose first link measures `first`: the rigid motion
    that puts the first link's `to` node at `first` from its `from` node, applied to every `to`
    node of the group, measured from the matching `from` node."""
    (a, b) = group[0]
    moved = compose(poses[a], compose(first, inverse(poses[b])))
    return [between(poses[i], compose(moved, poses[j])) for i, j in group]


def _diagonals(graph: PoseGraph, ids: List[int]) -> Dict[int, Set[int]]:
    """The graph's edges in the index space outliers are drawn in: for an edge between the nodes
    at sorted positions p < q, position p on diagonal q - p."""
    index = {i: k for k, i in enumerate(ids)}
    taken: Dict[int, Set[int]] = defaultdict(set)
    for e in graph.edges:
        if e.source in index and e.target in index:
            p, q = sorted((index[e.source], index[e.target]))
            taken[q - p].add(p)
    return taken


def _free_runs(n: int, kind: str, size: int, local_window: int,
               taken: Dict[int, Set[int]]) -> Iterator[Tuple[int, int, int]]:
    """(first, length, last_start) of every maximal run of link positions not taken, on every
    diagonal add_outliers draws from: a group of `size` links starting at position a of diagonal
    d links nodes a + k and a + d + k, with a <= last_start = n - 1 - size - d."""
    top = n - 1 - size
    if _is_local(kind):
        top = min(top, local_window)
    for d in range(2, top + 1):
        last_start = n - 1 - size - d
        end = last_start + size - 1
        first = 0
        for p in sorted(p for p in taken.get(d, ()) if p <= end) + [end + 1]:
            if p > first:
                yield first, p - first, last_start
            first = p + 1


def outlier_room(graph: PoseGraph, kind: str, group_size: int = 10, local_window: int = 20) -> int:
    """The most outliers of `kind` that add_outliers could place in `graph`: links between
    nodes that are no edge yet, packed as tightly as groups of `group_size` allow (the last group
    of a request may be shorter). Drawn at random, groups leave gaps and may fit fewer."""
    ids = sorted(graph.poses)
    size = group_size if _is_grouped(kind) else 1
    full = partial = 0
    for first, length, last_start in _free_runs(len(ids), kind, size, local_window, _diagonals(graph, ids)):
        full += length // size
        if first <= last_start:
            partial = max(partial, length % size)
    return full * size + partial


def add_outliers(graph: PoseGraph, kind: str, count: int, seed: int = 1, group_size: int = 10,
                 local_window: int = 20, reference: Optional[Dict[int, Pose]] = None,
                 alpha: float = 0.95) -> Tuple[PoseGraph, List[Tuple[int, int, int]]]:
    """Returns the corrupted graph and labels (from, to, 1 = original loop / 0 = outlier) for
    every loop edge in output order. With `reference`, no outlier's measurement lies inside the
    chi2(alpha, 3) gate of the reference relative pose. Raises ValueError for impossible requests,
    before drawing when the graph has no edge or no room for `count`, and as soon as the groups
    drawn leave no room for the next one."""
    if kind not in KINDS:
        raise ValueError(f"unknown outlier kind '{kind}' (expected one of {', '.join(KINDS)})")
    if count < 0 or group_size < 1 or local_window < 2:
        raise ValueError("count must be >= 0, group_size >= 1 and local_window >= 2")
    ids = sorted(graph.poses)
    n = len(ids)
    missing = missing_nodes(graph, reference) if reference is not None else ""
    if missing:
        raise ValueError(f"reference poses lack {missing}")
    grouped = _is_grouped(kind)
    size = group_size if grouped else 1
    if n < size + 3:
        raise ValueError(f"graph has {n} nodes, too few for outliers in groups of {size}")
    if count and not graph.edges:
        raise ValueError("graph has no edges, none whose information matrix the outliers could copy")
    room = outlier_room(graph, kind, group_size, local_window)
    if count > room:
        groups = f" in groups of {size}" if grouped else ""
        raise ValueError(f"room for at most {room} {kind} outliers{groups} "
                         f"(links between nodes that are no edge yet), not {count}")
    loops = graph.loops()
    info = (loops[0] if loops else graph.edges[0]).information if count else None
    if reference is not None and not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    threshold = gate(alpha) if reference is not None else math.inf
    rng = random.Random(seed)
    existing = {(e.source, e.target) for e in graph.edges} | {(e.target, e.source) for e in graph.edges}
    taken = _diagonals(graph, ids)

    added: List[Edge] = []
    attempts = failures = 0
    while len(added) < count:
        attempts += 1
        if attempts > 1000 * (count + 10):
            raise ValueError(f"could not place {count} outliers of kind {kind} in this graph "
                             f"(placed {len(added)} in {attempts - 1} draws)")
        failures += 1
        if failures % _DRAWS_BEFORE_ROOM_CHECK == 0:
            next_size = min(size, count - len(added))
            if not any(length >= next_size and first <= last_start
                       for first, length, last_start in _free_runs(n, kind, size, local_window, taken)):
                raise ValueError(f"no room left for a group of {next_size} after placing {len(added)} of "
                                 f"{count} {kind} outliers: groups drawn at random leave gaps (at most "
                                 f"{room} fit when packed tightly)")
        a = rng.randint(0, n - 1 - size)
        if not _is_local(kind):
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
        zs = (_aliased_measurements(reference or graph.poses, group, z) if kind == "aliased"
              else [z] * len(group))
        if reference is not None and any(
                chi2_against(reference, i, j, zk, info) < threshold for (i, j), zk in zip(group, zs)):
            continue
        failures = 0
        taken[b - a].update(range(a, a + len(group)))
        for p, zk in zip(group, zs):
            existing.add(p)
            existing.add((p[1], p[0]))
            added.append(Edge(p[0], p[1], zk, info))

    out = PoseGraph(dict(graph.poses), list(graph.edges) + added)
    labels = [(e.source, e.target, 1) for e in graph.loops()] + [(e.source, e.target, 0) for e in added]
    return out, labels
