"""Scoring loop-closure decisions: precision, recall, F1 against a truth file, and the absolute
trajectory error (ATE) after the SE(2) alignment that minimizes it (Umeyama without scale).

Truth files, either
  labels:  one line 'from to label' per loop edge of the graph, in the graph's order
           (label 1 = true loop, 0 = false, -1 = unknown), as written by add_outliers and
           vertigo's sets;
  pairs:   one line 'i j' per true loop, any order (KITTI's *_GT_LC.txt); every candidate not
           listed is false.
A file is one or the other: rows of two and three columns together are an error.
Decisions: the TSV of rrr_offline / replay_posegraph with header 'from to cluster verdict' (+ 'reason', written by the C++ tools and the node).
"""

import math
import re
from dataclasses import dataclass
from typing import Dict, List, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from .graph_io import (GraphFileError, Pose, between, read_graph, tagged_lines, text_lines,
                       write_text_atomically)
from .outliers import chi2_against

DECISION_HEADER = ["from", "to", "cluster", "verdict"]
# The fifth column, the step of RRR that decided and its statistic; files written before it
# existed have four.
REASON_COLUMN = "reason"
VERDICTS = ("accepted", "rejected", "pending")


@dataclass
class Decision:
    source: int
    target: int
    cluster: int
    verdict: str
    reason: str = ""


@dataclass
class Score:
    tp: int
    fp: int
    fn: int
    tn: int

    @property
    def precision(self) -> float:
        return self.tp / (self.tp + self.fp) if self.tp + self.fp else 1.0

    @property
    def recall(self) -> float:
        return self.tp / (self.tp + self.fn) if self.tp + self.fn else 1.0

    @property
    def f1(self) -> float:
        p, r = self.precision, self.recall
        return 2 * p * r / (p + r) if p + r else 0.0


def read_decisions(path: str) -> List[Decision]:
    decisions = []
    lines = text_lines(path)
    header = next(lines, (1, ""))[1].split("\t")
    if header not in (DECISION_HEADER, DECISION_HEADER + [REASON_COLUMN]):
        raise GraphFileError(path, 1, f"header must be '{chr(9).join(DECISION_HEADER)}' "
                                      f"(+ '{chr(9)}{REASON_COLUMN}')")
    columns = len(header)
    for number, line in lines:
        fields = line.split("\t")
        if len(fields) != columns:
            raise GraphFileError(path, number,
                                 f"expected {columns} tab-separated fields, found {len(fields)}")
        try:
            d = Decision(int(fields[0]), int(fields[1]), int(fields[2]), fields[3],
                         fields[4] if columns == 5 else "")
        except ValueError:
            raise GraphFileError(path, number, "from, to and cluster must be integers") from None
        if d.verdict not in VERDICTS:
            raise GraphFileError(path, number, f"verdict must be one of {', '.join(VERDICTS)}")
        decisions.append(d)
    return decisions


def write_decisions(path: str, decisions: Sequence[Decision]) -> None:
    """DECISIONS.tsv as the C++ tools write it (header with the reason column), atomically."""
    rows = "".join(f"{d.source}\t{d.target}\t{d.cluster}\t{d.verdict}\t{d.reason}\n" for d in decisions)
    write_text_atomically(path, "\t".join(DECISION_HEADER + [REASON_COLUMN]) + "\n" + rows)


def read_truth(path: str, decisions: Sequence[Decision]) -> List[Optional[bool]]:
    """One truth value per decision (same order); None where a label is -1 (unknown). Every row
    of a file has the columns of its first: a 'from to label' file with an 'i j' row (or the
    reverse) is an error, not a list of true pairs."""
    rows = []
    for number, fields in tagged_lines(path):
        if len(fields) not in (2, 3) or not all(re.fullmatch("-?[0-9]+", x) for x in fields):
            raise GraphFileError(path, number, "expected 'from to label' (label 1, 0 or -1) or 'i j'")
        if rows and len(fields) != len(rows[0][1]):
            first = "'from to label'" if len(rows[0][1]) == 3 else "'i j'"
            raise GraphFileError(path, number, f"{len(fields)} columns, but line {rows[0][0]} has "
                                               f"{len(rows[0][1])}: every row must be {first}")
        if len(fields) == 3 and int(fields[2]) not in (1, 0, -1):
            raise GraphFileError(path, number, f"label must be 1, 0 or -1, found {fields[2]}")
        rows.append((number, [int(x) for x in fields]))
    if rows and len(rows[0][1]) == 3:
        if len(rows) != len(decisions):
            raise GraphFileError(path, 0, f"{len(rows)} labels for {len(decisions)} decisions")
        truth = []
        for (number, (i, j, label)), d in zip(rows, decisions):
            if (i, j) != (d.source, d.target):
                raise GraphFileError(path, number, f"label for {i}->{j} but decision {d.source}->{d.target}")
            truth.append(None if label < 0 else label == 1)
        return truth
    pairs = {(r[0], r[1]) for _, r in rows} | {(r[1], r[0]) for _, r in rows}
    return [(d.source, d.target) in pairs for d in decisions]


def score(decisions: Sequence[Decision], truth: Sequence[Optional[bool]]) -> Score:
    """Counts over the decisions whose truth is known."""
    tp = fp = fn = tn = 0
    for d, t in zip(decisions, truth):
        if t is None:
            continue
        accepted = d.verdict == "accepted"
        tp += accepted and t
        fp += accepted and not t
        fn += (not accepted) and t
        tn += (not accepted) and not t
    return Score(tp, fp, fn, tn)


def label_by_ground_truth(graph, node_times: Sequence[float], samples, true_within_m: float = 2.0,
                          false_beyond_m: float = 5.0, max_dt: float = 0.5) -> List[Tuple[int, int, int]]:
    """Labels for every loop edge of `graph` from a ground-truth trajectory sampled at other times
    (`samples`: sorted (t, x, y, theta)): 1 if the measured translation agrees with the
    ground-truth relative pose within `true_within_m`, 0 beyond `false_beyond_m`, -1 (unknown)
    in between or when a node has no sample within `max_dt` seconds."""
    import bisect

    from .graph_io import between

    times = [s[0] for s in samples]

    def pose_at(t):
        k = bisect.bisect_left(times, t)
        near = min((c for c in (k - 1, k) if 0 <= c < len(samples)), key=lambda c: abs(times[c] - t))
        return samples[near][1:] if abs(times[near] - t) <= max_dt else None

    labels = []
    for e in graph.loops():
        a, b = pose_at(node_times[e.source]), pose_at(node_times[e.target])
        if a is None or b is None:
            labels.append((e.source, e.target, -1))
            continue
        truth = between(a, b)
        error = math.hypot(truth[0] - e.measurement[0], truth[1] - e.measurement[1])
        label = 1 if error <= true_within_m else (0 if error > false_beyond_m else -1)
        labels.append((e.source, e.target, label))
    return labels


def read_ground_truth_poses(path: str) -> Dict[int, Pose]:
    """g2o/TORO (vertices, or edges chained), 'id x y theta' or 'x y theta' lines."""
    _, first = next(tagged_lines(path), (0, [""]))
    if first[0][:1].isalpha():
        return read_graph(path).poses
    poses = {}
    for k, (number, fields) in enumerate(tagged_lines(path)):
        try:
            values = [float(x) for x in fields]
        except ValueError:
            raise GraphFileError(path, number, "expected numbers") from None
        if not all(math.isfinite(v) for v in values):
            raise GraphFileError(path, number, "expected finite numbers")
        if len(values) == 4:
            poses[int(values[0])] = tuple(values[1:4])
        elif len(values) == 3:
            poses[k] = tuple(values)
        else:
            raise GraphFileError(path, number, "expected 'x y theta' or 'id x y theta'")
    return poses


def align_se2(estimate, truth) -> Tuple[float, Tuple[float, float]]:
    """Rotation angle and translation that map estimate points onto truth in the least-squares
    sense (Umeyama 1991 without scale; in 2D the angle is that of the cross-covariance)."""
    p, q = np.asarray(estimate, dtype=float), np.asarray(truth, dtype=float)
    p_mean, q_mean = p.mean(axis=0), q.mean(axis=0)
    a, b = p - p_mean, q - q_mean
    angle = math.atan2(float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])), float(np.sum(a * b)))
    t = q_mean - _rotation(angle) @ p_mean
    return angle, (float(t[0]), float(t[1]))


def _rotation(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def alignment_errors(estimate, truth) -> np.ndarray:
    """Distance of each estimate position (x, y rows) from its truth after align_se2."""
    est, gt = np.asarray(estimate, dtype=float), np.asarray(truth, dtype=float)
    angle, t = align_se2(est, gt)
    return np.linalg.norm(est @ _rotation(angle).T + np.array(t) - gt, axis=1)


def absolute_trajectory_error(estimate: Dict[int, Pose], truth: Dict[int, Pose]) -> Optional[float]:
    """RMSE of positions after SE(2) alignment over the common node ids (ids are matched in
    sorted order when the files number their nodes differently but have equal counts)."""
    common = sorted(set(estimate) & set(truth))
    if len(common) < 2 and len(estimate) == len(truth):
        pairs = list(zip(sorted(estimate), sorted(truth)))
    else:
        pairs = [(i, i) for i in common]
    if len(pairs) < 2:
        return None
    errors = alignment_errors([estimate[a][:2] for a, _ in pairs], [truth[b][:2] for _, b in pairs])
    return float(np.sqrt(np.mean(errors ** 2)))


class MapHarm(NamedTuple):
    """What the accepted loops did to the map, against a reference the verifier did not make."""
    ate: float        # of the map, m: against the ground truth, or against the clean optimum
    clean_ate: float  # of the outlier-free optimum against the ground truth; 0 without one
    limit: float      # the most `ate` may be: clean_ate + max(1 cm, 2% of it)

    @property
    def harmed(self) -> bool:
        return self.ate > self.limit


def map_harm(estimate: Dict[int, Pose], clean_optimum: Dict[int, Pose],
             ground_truth: Optional[Dict[int, Pose]] = None) -> Optional[MapHarm]:
    """The map optimized with the accepted loops (`estimate`) against the outlier-free graph's own
    optimum: with ground truth, its ATE may exceed the optimum's by max(1 cm, 2% of it); without,
    its ATE against the optimum itself may be 1 cm. None when they share fewer than two nodes."""
    if ground_truth is None:
        ate = absolute_trajectory_error(estimate, clean_optimum)
        return None if ate is None else MapHarm(ate, 0.0, 0.01)
    ate = absolute_trajectory_error(estimate, ground_truth)
    clean = absolute_trajectory_error(clean_optimum, ground_truth)
    if ate is None or clean is None:
        return None
    return MapHarm(ate, clean, clean + max(0.01, 0.02 * clean))


class AcceptedFalseLink(NamedTuple):
    source: int
    target: int
    # Each None when `optimized` lacks the link (it was not the graph the decisions made):
    chi2: Optional[float]     # of its measurement against the reference's relative pose
    off_m: Optional[float]    # the map's relative pose between its ends against the reference's
    off_deg: Optional[float]  # in metres and degrees


def accepted_false_links(optimized, decisions: Sequence[Decision], truth: Sequence[Optional[bool]],
                         reference: Dict[int, Pose]) -> List[AcceptedFalseLink]:
    """Every accepted link the truth calls false, with the chi2 of its measurement against the
    reference (how far from statistically indistinguishable it is) and how far the map
    (`optimized`, rrr_offline --output, which holds the accepted links) puts its ends from the
    reference's relative pose (what it did to the map there)."""
    edges = {(e.source, e.target): e for e in optimized.edges}
    out = []
    for d, t in zip(decisions, truth):
        if d.verdict != "accepted" or t is not False:
            continue
        edge = edges.get((d.source, d.target))
        if edge is None or d.source not in reference or d.target not in reference:
            out.append(AcceptedFalseLink(d.source, d.target, None, None, None))
            continue
        chi2 = chi2_against(reference, d.source, d.target, edge.measurement, edge.information)
        e = between(between(optimized.poses[d.source], optimized.poses[d.target]),
                    between(reference[d.source], reference[d.target]))
        out.append(AcceptedFalseLink(d.source, d.target, chi2, math.hypot(e[0], e[1]),
                                     abs(math.degrees(e[2]))))
    return out


def plot_decisions(path: str, poses, decisions: Sequence[Decision], truth: Optional[Sequence[bool]],
                   title: str = "") -> None:
    """PNG of the trajectory with accepted loops green, rejected red, missed true loops dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 8), dpi=110)
    ids = sorted(poses)
    ax.plot([poses[i][0] for i in ids], [poses[i][1] for i in ids], color="0.35", lw=0.8,
            label="trajectory", zorder=2)

    def segments(selected):
        xs, ys = [], []
        for d in selected:
            if d.source in poses and d.target in poses:
                a, b = poses[d.source], poses[d.target]
                xs += [a[0], b[0], None]
                ys += [a[1], b[1], None]
        return xs, ys

    truth = truth if truth is not None else [None] * len(decisions)
    rejected = [d for d, t in zip(decisions, truth) if d.verdict != "accepted" and t is not True]
    accepted = [d for d in decisions if d.verdict == "accepted"]
    missed = [d for d, t in zip(decisions, truth) if d.verdict != "accepted" and t is True]
    xs, ys = segments(rejected)
    ax.plot(xs, ys, color="tab:red", lw=0.4, alpha=0.5, label=f"rejected ({len(rejected)})", zorder=1)
    xs, ys = segments(accepted)
    ax.plot(xs, ys, color="tab:green", lw=0.8, label=f"accepted ({len(accepted)})", zorder=3)
    if missed:
        xs, ys = segments(missed)
        ax.plot(xs, ys, color="tab:blue", lw=0.8, ls="--", label=f"missed true loops ({len(missed)})",
                zorder=4)
    ax.set_aspect("equal")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
