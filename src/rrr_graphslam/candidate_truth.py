"""The front end's loop candidates scored against a reference the product did not make
(scripts/bench_slam): the corrected poses of a ple_corrected log, associated with the raw log's
scans by identical range readings (bench_sessions.GroundTruth).

A candidate joins two nodes, each made from one scan of the log. It is true when its measured
relative pose agrees with the reference's relative pose between those two scans within the
chi-square gate chi2(0.99, 3): the error weighted by the candidate's own covariance plus the
reference's. The corrected logs are themselves a SLAM estimate, good to a few centimetres, and a
scan matcher's information alone would call a true loop false for the reference's own error:
REFERENCE_SIGMA per relative pose. Most logs correct only some of their scans (ACES, Intel and
MIT CSAIL about one per metre of travel); a scan between two corrected ones is placed from them
by the motion of a trajectory (GroundTruth's `local`: the map's own, a few centimetres over such
a span), so its reference rests on that trajectory over its `bridge`. A candidate is labelled
only when both its scans lie within MAX_BRIDGE_M of a corrected scan, and the reference's
uncertainty grows by BRIDGE_SIGMA_PER_M over the two bridges: with it, the labels hardly depend on
which trajectory bridges (the map's or the raw odometry: 5 of ACES's 194 labels differ, 15 of
Intel's 3166). RRR's verdicts on the labelled candidates give its precision and recall on real
candidates, which the map it built cannot tell."""

import bisect
import math
from dataclasses import dataclass, field
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .graph_io import Edge, Pose, between, compose, information_matrix, normalize_angle
from .outliers import gate

# Standard deviation of a reference relative pose between two corrected scans: x, y (m), heading
# (rad); and its growth per metre of bridge (both ends' summed).
REFERENCE_SIGMA = (0.05, 0.05, math.radians(1.0))
BRIDGE_SIGMA_PER_M = (0.05, 0.05, math.radians(2.0))
MAX_BRIDGE_M = 0.5
ALPHA = 0.99


@dataclass
class NodeReference:
    """A node's reference robot pose and the bridge it rests on (GroundTruth.bridge, m)."""
    pose: Pose
    bridge: float = 0.0


def reference_chi2(edge: Edge, reference: Mapping[int, Optional[NodeReference]],
                   sigma: Tuple[float, float, float] = REFERENCE_SIGMA,
                   per_m: Tuple[float, float, float] = BRIDGE_SIGMA_PER_M,
                   max_bridge: float = MAX_BRIDGE_M) -> Optional[float]:
    """Squared Mahalanobis distance of the candidate's measurement from the reference's relative
    pose of its two nodes (g2o's error), under the candidate's covariance plus the reference's
    (sigma + per_m x both bridges); None when a node has no reference pose or a bridge longer
    than max_bridge."""
    a, b = reference.get(edge.source), reference.get(edge.target)
    if a is None or b is None or max(a.bridge, b.bridge) > max_bridge:
        return None
    e = np.array(between(edge.measurement, between(a.pose, b.pose)))
    s = np.array(sigma) + np.array(per_m) * (a.bridge + b.bridge)
    covariance = np.linalg.inv(information_matrix(edge.information)) + np.diag(np.square(s))
    return float(e @ np.linalg.solve(covariance, e))


@dataclass
class CandidateScore:
    """RRR's verdicts on the candidates the reference labels (those it cannot are `unlabelled`)."""
    candidates: int = 0
    true: int = 0
    false: int = 0
    unlabelled: int = 0
    accepted_true: int = 0
    accepted_false: int = 0
    # (from, to, m, deg, chi2) of every accepted false candidate, the largest chi2 first.
    false_accepted: List[Tuple[int, int, float, float, float]] = field(default_factory=list)

    @property
    def precision(self) -> float:
        accepted = self.accepted_true + self.accepted_false
        return self.accepted_true / accepted if accepted else 1.0

    @property
    def recall(self) -> float:
        return self.accepted_true / self.true if self.true else 1.0


def candidate_labels(loops: Sequence[Edge], reference: Mapping[int, Optional[NodeReference]],
                     alpha: float = ALPHA) -> List[Optional[bool]]:
    """Per candidate: true (reference_chi2 below gate(alpha)), false, or None (unlabelled)."""
    threshold = gate(alpha)
    out = []
    for edge in loops:
        d2 = reference_chi2(edge, reference)
        out.append(None if d2 is None else d2 < threshold)
    return out


def write_labels(path: str, loops: Sequence[Edge], labels: Sequence[Optional[bool]]) -> None:
    """A truth file of the labels format (evaluation.py: 'from to label' per loop edge, in the
    graph's order; -1 unknown), so that scripts/evaluate and rrr_offline's other verifiers are
    scored against the same labels."""
    with open(path, "w") as f:
        for edge, label in zip(loops, labels):
            f.write(f"{edge.source} {edge.target} {-1 if label is None else int(label)}\n")


def score_candidates(loops: Sequence[Edge], verdicts: Sequence[str],
                     reference: Mapping[int, Optional[NodeReference]],
                     alpha: float = ALPHA) -> CandidateScore:
    """Labels each candidate by the reference (reference_chi2 below gate(alpha)) and counts
    RRR's accepted ones among the true and the false. `loops` and `verdicts` in the same order
    (the graph's loop edges and the decisions' rows)."""
    if len(loops) != len(verdicts):
        raise ValueError(f"{len(loops)} loop candidates but {len(verdicts)} decisions")
    s = CandidateScore(candidates=len(loops))
    for edge, verdict, label in zip(loops, verdicts, candidate_labels(loops, reference, alpha)):
        if label is None:
            s.unlabelled += 1
            continue
        accepted = verdict == "accepted"
        if label:
            s.true += 1
            s.accepted_true += accepted
            continue
        s.false += 1
        if accepted:
            s.accepted_false += 1
            e = between(edge.measurement,
                        between(reference[edge.source].pose, reference[edge.target].pose))
            s.false_accepted.append((edge.source, edge.target, math.hypot(e[0], e[1]),
                                     abs(math.degrees(e[2])), reference_chi2(edge, reference)))
    s.false_accepted.sort(key=lambda f: -f[4])
    return s


def node_references(node_ids: Sequence[int], node_stamps: Sequence[float], truth,
                    to_robot: Pose) -> Dict[int, Optional[NodeReference]]:
    """The reference robot pose of each node and its bridge (None where its scan is not in the
    log), from its scan's ipc timestamp; ids and stamps in the same (node) order. `truth`: a
    bench_sessions.GroundTruth of the log, whose poses are the laser's; `to_robot`: the laser's
    pose in the robot frame, inverted."""
    if len(node_ids) != len(node_stamps):
        raise ValueError(f"{len(node_ids)} nodes but {len(node_stamps)} node timestamps")
    out = {}
    for node, t in zip(node_ids, node_stamps):
        i = truth.ipc.find(t)
        out[node] = None if i is None else NodeReference(
            compose(truth.pose_of_scan(i), to_robot), truth.bridge(i))
    return out


@dataclass
class TurnDrift:
    """How far the front end's own chain of nodes (local SLAM's steps, the odometry edges) turns
    away from the reference: over pairs of nodes at corrected scans (bridge 0) `min_steps` to
    `max_steps` node steps apart, the random-walk standard deviation per step that explains their
    heading errors, sqrt(mean(error^2 / steps)) (rad). The reference's own heading error is in it:
    an upper bound. It is what the third entry of scan_odometry_stddev states."""
    per_step_rad: float
    pairs: int
    worst_deg: float  # the largest heading error of a pair


def turn_drift(edges: Sequence[Edge], reference: Mapping[int, Optional[NodeReference]],
               min_steps: int = 100, max_steps: int = 1000) -> Optional[TurnDrift]:
    """TurnDrift of the chain of first edges between consecutive node ids (the odometry a g2o file
    lists before the loops); a node without one starts a new chain. None without a pair."""
    step: Dict[int, float] = {}
    for e in edges:
        if e.target == e.source + 1 and e.source not in step:
            step[e.source] = e.measurement[2]
    anchored = sorted(n for n, r in reference.items() if r is not None and r.bridge == 0.0)
    if not anchored:
        return None
    # Heading of the chain at each node (unwrapped), and the chain it belongs to.
    heading, chain = {}, {}
    first, last = anchored[0], anchored[-1]
    h, c = 0.0, 0
    for n in range(first, last + 1):
        heading[n], chain[n] = h, c
        if n in step:
            h += step[n]
        else:
            c += 1
    total, pairs, worst = 0.0, 0, 0.0
    for a in anchored:
        for b in anchored[bisect.bisect_left(anchored, a + min_steps):]:
            steps = b - a
            if steps >= max_steps or chain[a] != chain[b]:
                break
            turned = heading[b] - heading[a]
            truth = reference[b].pose[2] - reference[a].pose[2]
            error = normalize_angle(turned - truth)
            total += error * error / steps
            pairs += 1
            worst = max(worst, abs(error))
    if pairs == 0:
        return None
    return TurnDrift(math.sqrt(total / pairs), pairs, math.degrees(worst))
