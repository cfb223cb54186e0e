"""What a pose-graph replay sends, in which order, and how the node's answers map back to the file.

ROS-free so that pytest checks it without a master; replay_ros.py does the publishing.
Nodes go out in id order: for each node the odometry edge that creates it (PoseGraphEdge, always
from the previous node to this one; an edge stored the other way round is inverted), then the loop
candidates whose newer end it is (LoopCandidate). A node without odometry from the previous one
starts a new session: its first outgoing odometry edge introduces it.
"""

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .evaluation import Decision
from .graph_io import Edge, PoseGraph, information_matrix, inverse


def information_row_major(upper: Sequence[float]) -> List[float]:
    """The 3x3 information matrix of six upper-triangle values (g2o order), row-major."""
    return information_matrix(upper).ravel().tolist()


def inverted_edge(edge: Edge) -> Tuple[Tuple[float, float, float], List[float]]:
    """Measurement and row-major information of the same constraint stated from the other end:
    z' = z^-1 and, with noise on the right (g2o), Omega' = Ad(z)^-T Omega Ad(z)^-1."""
    x, y, t = edge.measurement
    c, s = math.cos(t), math.sin(t)
    # Ad(z) = [[R, (y, -x)^T], [0, 1]]; its inverse is [[R^T, -R^T (y, -x)^T], [0, 1]].
    ad_inv = np.array([[c, s, s * x - c * y], [-s, c, s * y + c * x], [0.0, 0.0, 1.0]])
    omega = ad_inv.T @ information_matrix(edge.information) @ ad_inv
    return inverse(edge.measurement), omega.ravel().tolist()


@dataclass
class Odometry:
    source: int
    target: int
    measurement: Tuple[float, float, float]
    information: List[float]  # row-major 3x3


@dataclass
class Candidate:
    index: int  # among the file's loop edges (the row of its DECISIONS.tsv)
    edge: Edge
    duplicate_of: Optional[int] = None  # an earlier candidate with the same ends and measurement


@dataclass
class Step:
    node: int
    odometry: Optional[Odometry] = None  # None: the node starts a session (or is introduced by it)
    candidates: List[Candidate] = field(default_factory=list)


@dataclass
class Plan:
    steps: List[Step]
    candidates: List[Candidate]  # every loop edge in file order
    skipped_parallel_odometry: int = 0


def plan_replay(graph: PoseGraph) -> Plan:
    ids = sorted(graph.poses)
    position = {n: k for k, n in enumerate(ids)}
    steps = [Step(n) for n in ids]
    skipped = 0
    candidates: List[Candidate] = []
    seen: Dict[tuple, int] = {}
    for edge in graph.edges:
        if edge.is_loop:
            key = (edge.source, edge.target, *edge.measurement)
            cand = Candidate(len(candidates), edge, seen.get(key))
            seen.setdefault(key, cand.index)
            candidates.append(cand)
            steps[max(position[edge.source], position[edge.target])].candidates.append(cand)
            continue
        newer = max(edge.source, edge.target)
        step = steps[position[newer]]
        if step.odometry is not None:
            skipped += 1
            continue
        if edge.source < edge.target:
            step.odometry = Odometry(edge.source, edge.target, edge.measurement,
                                     information_row_major(edge.information))
        else:
            z, info = inverted_edge(edge)
            step.odometry = Odometry(edge.target, edge.source, z, info)
    for k, step in enumerate(steps):
        if step.odometry is None and not (k + 1 < len(steps) and steps[k + 1].odometry is not None
                                          and steps[k + 1].odometry.source == step.node):
            raise ValueError(f"node {step.node} has no odometry edge to either neighbour; "
                             "a replay cannot introduce it")
    return Plan(steps, candidates, skipped)


def file_index_by_arrival(plan: Plan, final: Dict[Tuple[int, int], List[Tuple[int, str, int, str]]]
                          ) -> Dict[int, Tuple[int, Tuple[int, str, str]]]:
    """The node's arrival index of each sent candidate -> (its file index, its final (cluster,
    verdict, reason)). `final` maps (from, to) to the node's final (arrival index, verdict, cluster,
    reason) of each candidate on that pair; candidates of one pair arrive in file order, so the k-th
    sent one is the k-th by arrival index."""
    by_pair = {pair: sorted(items) for pair, items in final.items()}
    used: Dict[Tuple[int, int], int] = {}
    out: Dict[int, Tuple[int, Tuple[int, str, str]]] = {}
    for cand in plan.candidates:
        if cand.duplicate_of is not None:
            continue
        pair = (cand.edge.source, cand.edge.target)
        k = used.get(pair, 0)
        items = by_pair.get(pair, [])
        if k < len(items):
            arrival, verdict, cluster, reason = items[k]
            out[arrival] = (cand.index, (cluster, verdict, reason))
            used[pair] = k + 1
    return out


def decisions_in_file_order(plan: Plan,
                            final: Dict[Tuple[int, int], List[Tuple[int, str, int, str]]]) -> List[Decision]:
    """One Decision per file candidate, in file order (`final` as for file_index_by_arrival).
    Duplicates, which the node refuses, share their twin's decision; a candidate without an answer
    stays pending."""
    answer = {index: decided for index, decided in file_index_by_arrival(plan, final).values()}
    rows = []
    for cand in plan.candidates:
        twin = cand.index if cand.duplicate_of is None else cand.duplicate_of
        cluster, verdict, reason = answer.get(twin, (-1, "pending", "no decision received from the node"))
        if cand.duplicate_of is not None:
            reason = f"duplicate of file candidate {twin} (not sent): {reason}"
        rows.append(Decision(cand.edge.source, cand.edge.target, cluster, verdict, reason))
    return rows
