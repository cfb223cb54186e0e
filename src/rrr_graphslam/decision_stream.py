"""The decisions as a run made them (rrr_offline --mode incremental --decision-stream,
rrr_slam_offline --decision-stream): read the stream and score what a robot saw on the way, not
only the final verdicts. A false link accepted for a while bent the map the robot used for that
while, even if the final decision from scratch rejects it."""

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

import numpy as np

from .graph_io import GraphFileError, text_lines

STREAM_HEADER = ["when", "scan", "nodes", "stamp", "candidate", "from", "to", "cluster",
                 "previous", "verdict", "reason"]
VERDICTS = ("accepted", "rejected", "pending")


@dataclass
class StreamRow:
    final: bool  # the end of the run's decision, not an online one
    nodes: int
    stamp: float
    candidate: int
    previous: str
    verdict: str
    cluster: int = -1  # the candidate's cluster, -1 while it is open
    reason: str = ""


def read_decision_stream(path: str) -> List[StreamRow]:
    """Rows in file order; GraphFileError naming file and line for a malformed one."""
    lines = text_lines(path)
    header = next(lines, (1, ""))[1].split("\t")
    if header != STREAM_HEADER:
        raise GraphFileError(path, 1, f"header must be '{chr(9).join(STREAM_HEADER)}'")
    rows = []
    for number, line in lines:
        f = line.split("\t")
        if len(f) != len(STREAM_HEADER):
            raise GraphFileError(path, number, f"expected {len(STREAM_HEADER)} tab-separated "
                                               f"fields, found {len(f)}")
        if f[0] not in ("online", "final") or f[8] not in VERDICTS or f[9] not in VERDICTS:
            raise GraphFileError(path, number, "when must be online or final, verdicts one of "
                                               + ", ".join(VERDICTS))
        try:
            rows.append(StreamRow(f[0] == "final", int(f[2]), float(f[3]), int(f[4]), f[8], f[9],
                                  int(f[7]), f[10]))
        except ValueError:
            raise GraphFileError(path, number, "nodes, candidate and cluster must be integers, "
                                               "stamp a number") from None
    return rows


def percentile(values: Sequence[float], q: float) -> float:
    """Nearest-rank percentile (NumPy's inverted CDF); nan for no values."""
    if not len(values):
        return math.nan
    return float(np.percentile(values, q, method="inverted_cdf"))


@dataclass
class OnlineScore:
    outliers: int = 0               # candidates known false
    transient_false_accepts: int = 0  # false candidates accepted at any moment of the run
    final_false_accepts: int = 0    # ... still accepted at its end
    false_accept_nodes: Dict[int, int] = field(default_factory=dict)  # candidate -> nodes accepted
    true_reversals: int = 0         # online changes accepted -> rejected of true candidates
    first_verdict_nodes: List[int] = field(default_factory=list)  # arrival -> first verdict
    first_verdict_seconds: List[float] = field(default_factory=list)
    undecided_online: int = 0       # candidates whose first verdict came only at the end

    def longest_false_accept(self) -> int:
        return max(self.false_accept_nodes.values(), default=0)

    def false_accepts_longer_than(self, nodes: int) -> int:
        return sum(n > nodes for n in self.false_accept_nodes.values())


def score_stream(rows: Sequence[StreamRow], truth: Sequence[Optional[bool]]) -> OnlineScore:
    """What the stream's decisions were worth as they were made, against `truth` (per candidate
    index, None where unknown). A false candidate's accepted time is counted in nodes, from the
    change that accepted it to the change that rejected it (or the last node of the run)."""
    s = OnlineScore(outliers=sum(t is False for t in truth))
    last_nodes = max((r.nodes for r in rows), default=0)
    arrived: Dict[int, StreamRow] = {}
    accepted_since: Dict[int, int] = {}
    ever_false: set = set()
    for r in rows:
        if r.candidate >= len(truth):
            raise ValueError(f"stream candidate {r.candidate} but {len(truth)} truth labels")
        t = truth[r.candidate]
        if r.previous == r.verdict:  # an arrival
            arrived.setdefault(r.candidate, r)
            continue
        if r.previous == "pending" and r.candidate in arrived:
            a = arrived.pop(r.candidate)
            if r.final:
                s.undecided_online += 1
            else:
                s.first_verdict_nodes.append(r.nodes - a.nodes)
                s.first_verdict_seconds.append(r.stamp - a.stamp)
        if t is False:
            if r.verdict == "accepted":
                ever_false.add(r.candidate)
                accepted_since[r.candidate] = r.nodes
            elif r.previous == "accepted" and r.candidate in accepted_since:
                start = accepted_since.pop(r.candidate)
                s.false_accept_nodes[r.candidate] = (s.false_accept_nodes.get(r.candidate, 0)
                                                     + r.nodes - start)
        elif t is True and not r.final and r.previous == "accepted" and r.verdict == "rejected":
            s.true_reversals += 1
    for candidate, start in accepted_since.items():  # still accepted at the end
        s.final_false_accepts += 1
        s.false_accept_nodes[candidate] = s.false_accept_nodes.get(candidate, 0) + last_nodes - start
    for candidate in ever_false:
        s.false_accept_nodes.setdefault(candidate, 0)
    s.transient_false_accepts = len(ever_false)
    s.undecided_online += len(arrived)
    return s


@dataclass
class HeldGroup:
    """False links one online change accepted together (one cluster at one node)."""
    cluster: int
    candidates: List[int]
    accepted_at: int  # nodes arrived when they were accepted
    held: int         # nodes the longest-held of them stayed accepted from then


def held_false_groups(rows: Sequence[StreamRow], truth: Sequence[Optional[bool]],
                      longer_than: int = 100) -> List[HeldGroup]:
    """The groups of false links an online change accepted together and the run then held
    accepted for more than `longer_than` nodes (until rejected, or to the last node), in order of
    acceptance."""
    last_nodes = max((r.nodes for r in rows), default=0)
    groups: Dict[tuple, HeldGroup] = {}
    open_group: Dict[int, tuple] = {}  # false candidate -> its group while accepted
    for r in rows:
        if r.previous == r.verdict or truth[r.candidate] is not False or r.final:
            continue
        if r.verdict == "accepted":
            key = (r.nodes, r.cluster)
            groups.setdefault(key, HeldGroup(r.cluster, [], r.nodes, 0)).candidates.append(
                r.candidate)
            open_group[r.candidate] = key
        elif r.previous == "accepted" and r.candidate in open_group:
            g = groups[open_group.pop(r.candidate)]
            g.held = max(g.held, r.nodes - g.accepted_at)
    for key in open_group.values():  # held to the end of the run
        groups[key].held = max(groups[key].held, last_nodes - groups[key].accepted_at)
    return [g for _, g in sorted(groups.items()) if g.held > longer_than]


def online_summary(s: OnlineScore) -> str:
    """One line of what a robot saw on the way (the columns of bench_rrr's online table)."""
    nodes, seconds = s.first_verdict_nodes, s.first_verdict_seconds
    return (f"online: false links ever accepted {s.transient_false_accepts} (of {s.outliers}), "
            f"still accepted at the end {s.final_false_accepts}, longest accepted "
            f"{s.longest_false_accept()} nodes, accepted > 100 nodes {s.false_accepts_longer_than(100)}; "
            f"true links reversed {s.true_reversals}; first verdict p50 / p99 / max "
            f"{percentile(nodes, 50):.0f} / {percentile(nodes, 99):.0f} / {max(nodes, default=0)} "
            f"nodes, {percentile(seconds, 50):.2f} / {percentile(seconds, 99):.2f} / "
            f"{max(seconds, default=0.0):.2f} s; undecided until the end {s.undecided_online}")


@dataclass
class VerdictChange:
    verdict: str
    nodes: int      # nodes arrived since the candidate's arrival
    seconds: float  # time since its arrival (the stream's stamps)
    final: bool     # the end of the run's decision


def candidate_histories(rows: Sequence[StreamRow]) -> Dict[int, List[VerdictChange]]:
    """Per candidate, the verdicts it went through and when, counted from its arrival: its
    arrival verdict first (at 0 nodes, 0 s), then every change, the end of the run's included.
    ValueError for a stream that changes a candidate's verdict before it arrived (a row whose
    previous verdict differs from its verdict) or from another verdict than it last had."""
    histories: Dict[int, List[VerdictChange]] = {}
    arrival: Dict[int, StreamRow] = {}
    for r in rows:
        a = arrival.get(r.candidate)
        if a is None:
            if r.previous != r.verdict:
                raise ValueError(f"candidate {r.candidate} changes {r.previous} -> {r.verdict} "
                                 f"before its arrival")
            arrival[r.candidate] = r
            histories[r.candidate] = [VerdictChange(r.verdict, 0, 0.0, r.final)]
        elif r.previous != r.verdict:
            if r.previous != histories[r.candidate][-1].verdict:
                raise ValueError(f"candidate {r.candidate} changes from {r.previous}, but its "
                                 f"verdict was {histories[r.candidate][-1].verdict}")
            histories[r.candidate].append(
                VerdictChange(r.verdict, r.nodes - a.nodes, r.stamp - a.stamp, r.final))
    return histories


def write_histories(path: str, histories: Dict[int, List[VerdictChange]],
                    truth: Optional[Sequence[Optional[bool]]] = None) -> None:
    """TSV 'candidate truth history', one row per candidate in index order; history is
    'VERDICT@NODES/SECONDSs' per change, space-separated ('final:' marks the run's end decision);
    truth is true, false or - (unknown)."""
    lines = ["candidate\ttruth\thistory"]
    for candidate in sorted(histories):
        t = None if truth is None or candidate >= len(truth) else truth[candidate]
        label = "-" if t is None else ("true" if t else "false")
        steps = " ".join(f"{'final:' if c.final else ''}{c.verdict}@{c.nodes}/{c.seconds:.3f}s"
                         for c in histories[candidate])
        lines.append(f"{candidate}\t{label}\t{steps}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
