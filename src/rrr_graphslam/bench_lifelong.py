"""Lifelong benchmark (scripts/bench_lifelong, issue 20): a CARMEN log replayed as N sessions,
each the whole log again with its odometry moved by a seeded random SE(2), each mapped by
`rrr_slam_offline --load-map` from the map the previous session saved. The same moved logs are
run in several configurations: `untrimmed` (no --lifelong), `clt` (--lifelong, Chow-Liu tree),
`delete` (--lifelong --sparsification delete) and `online` (--lifelong --trim-every-n-nodes 200:
the earlier sessions also trimmed while each maps); on request `fresh-area` (--lifelong
--trim-rule fresh-area: Cartographer's coverage rule instead of the overlap ratio) and `dense`
(--lifelong --sparsification dense: the exact marginals kept as dense factors).

Per session and configuration: the saved map's nodes, edges, marginal edges, submaps and file
size (rrr_map_info); the trim's time and KL divergences (the tool's `trim_*` lines); the time of
one re-optimization of the map's trusted graph (see below); the relation error of the session's
own trajectory (--session-trajectory) on ACES (Kümmerle et al. 2009); the inter-session loops RRR
accepted and how many are false against the corrected log (bench_sessions' ground truth); the
wall time of the run. Prints a Markdown table, the issue's targets as pass/fail lines, and writes
PNG plots.

Re-optimization: the saved map's graph (rrr_map_info --graph: nodes at their map poses,
odometry, marginal edges, every loop candidate) without the candidates RRR did not accept. The
map's g2o carries no verdicts; a candidate is recognised by its measurement and information,
written digit for digit as in the run's --output, whose last edges are the candidates in the
order of --decisions. The count is checked against the map's own odometry + marginal + accepted
counts. rrr_optimize then runs on it twice: from LAGO (a cold re-optimization: its work does not
depend on how good the stored poses are) and from the stored poses (what loading the map and
optimizing again costs). The time is the CPU time rrr_optimize states for its initialization and
optimization (its `cpu time` line), the least of `--repeats` runs: the wall time it prints is
stretched by whatever else runs on the machine, and a process's own CPU time holds its start and
its file I/O, whose noise swamps a few milliseconds. (Runs of a binary that states none: its
process CPU time less that of a run that only reads and writes the graph.)

Ground truth for loops: every session is the same log, so a node's true pose is that of its
scan (same stamp) in any session. Each run writes the stamp and the session of every node of its
--output (--node-stamps). For runs kept from before that flag, a node's stamp comes from the map
the run loaded (the first lines of run K's --trajectory are the loaded nodes, in id order), or,
for the session's own nodes, from the saved map's node with the same pose (digit for digit); a
node the save trimmed takes the stamp of the session's scan (--session-trajectory) nearest to
it in pose, between the stamps of its kept neighbours (not valid when the save trims and moves
the session's own nodes: --keep-current-session false)."""

import argparse
import bisect
import math
import os
import re
import resource
import subprocess
import sys
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

from .bench_sessions import (LOGS, Criteria, LoopCheck, MapInfo, RunSummary, check_loops,
                             decided_loops, log_data_or_skip, parse_map_info, parse_summary,
                             random_transforms)
from .carmen import write_moved_log
from .evaluation import read_decisions
from .graph_io import GraphFileError, Pose, write_text_atomically
from .lifelong_world import (SimulatedWorld, WorldScore, plot_final_maps, score_map, simulation_key,
                             trajectory_ate, world_from_map, world_name)
from .relations import RelationError, read_tum, relation_error

CONFIGS = {
    "untrimmed": [],
    "clt": ["--lifelong", "--trim-kl"],
    "delete": ["--lifelong", "--sparsification", "delete", "--trim-kl"],
    "online": ["--lifelong", "--trim-every-n-nodes", "200", "--trim-kl"],
    # Cartographer's coverage rule (OverlappingSubmapsTrimmer2D) in place of the overlap ratio;
    # not run unless asked (--configs ... fresh-area).
    "fresh-area": ["--lifelong", "--trim-rule", "fresh-area", "--trim-kl"],
    # The exact marginal kept as dense factors (the comparison the tree approximates); not run
    # unless asked (--configs ... dense).
    "dense": ["--lifelong", "--sparsification", "dense", "--trim-kl"],
}
DEFAULT_CONFIGS = ["untrimmed", "clt", "delete", "online"]


# ---------------------------------------------------------------------------------------------
# The tool's trim lines


@dataclass
class TrimRecord:
    """One marginalization: `trim_record submap S submaps K nodes N blanket B constraints C
    edges E kl X kl_clt Y kl_delete Z ms T [kl_ms U [dense_factors D]]`: T the trim's own work, U
    the KL figures' measurement (runs of older builds printed no kl_ms, and their T held both), D
    the dense factors that replaced the constraints (sparsification dense)."""
    submap: int
    submaps: int
    nodes: int
    blanket: int
    constraints: int
    edges: int
    kl: float
    kl_clt: float
    kl_delete: float
    ms: float
    kl_ms: float = 0.0
    dense_factors: int = 0


@dataclass
class Trim:
    values: Dict[str, float] = field(default_factory=dict)  # trim_X -> value, without "trim_"
    records: List[TrimRecord] = field(default_factory=list)

    def get(self, key: str) -> float:
        return self.values.get(key, math.nan)


RECORD = re.compile(r"^trim_record submap (\d+) submaps (\d+) nodes (\d+) blanket (\d+) constraints (\d+) "
                    r"edges (\d+) kl (\S+) kl_clt (\S+) kl_delete (\S+) ms (\S+)(?: kl_ms (\S+)(?: dense_factors (\d+))?)?\s*$")


# `online_trim scan S nodes B -> A ...` (--trim-every-n-nodes): B, the graph before the trim.
ONLINE_TRIM = re.compile(r"^online_trim scan \d+ nodes (\d+) -> ", re.M)


def parse_trim(text: str) -> Optional[Trim]:
    """The `trim_*` lines of a --lifelong run; None if the run printed no `lifelong` line."""
    if not re.search(r"^lifelong\s", text, re.M):
        return None
    trim = Trim()
    for line in text.splitlines():
        if line.startswith("trim_record"):
            m = RECORD.match(line)
            if not m:
                raise ValueError(f"unreadable line: {line!r}")
            g = m.groups()
            trim.records.append(TrimRecord(*(int(v) for v in g[:6]),
                                           *(float(v) for v in g[6:11] if v is not None),
                                           *(int(v) for v in g[11:] if v is not None)))
        elif line.startswith("trim_"):
            f = line.split()
            if len(f) == 2:
                trim.values[f[0][len("trim_"):]] = float(f[1])
    return trim


def percentile(values: Sequence[float], q: float) -> float:
    """The q-th percentile (0-100), linear between order statistics; nan for none."""
    v = sorted(values)
    if not v:
        return math.nan
    pos = (len(v) - 1) * q / 100.0
    lo = math.floor(pos)
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (v[hi] - v[lo]) * (pos - lo)


# ---------------------------------------------------------------------------------------------
# The map's trusted graph


def _edge_lines(lines: Sequence[str]) -> List[int]:
    return [k for k, line in enumerate(lines) if line.startswith("EDGE_SE2 ")]


def edge_key(line: str) -> Tuple[str, ...]:
    """An edge's measurement and information as written (without its node ids)."""
    return tuple(line.split()[3:])


def untrusted_candidates(run_graph_lines: Sequence[str], decisions) -> Dict[Tuple[str, ...], int]:
    """The candidates of a run RRR did not accept, by edge_key (with multiplicity): the run's
    --output lists them as its last edges, in the order of its --decisions; each row's nodes
    must be the edge's."""
    edges = _edge_lines(run_graph_lines)
    if len(decisions) > len(edges):
        raise ValueError(f"{len(decisions)} decisions but {len(edges)} edges")
    first = len(edges) - len(decisions)
    out: Dict[Tuple[str, ...], int] = {}
    for d, k in zip(decisions, edges[first:]):
        f = run_graph_lines[k].split()
        if (int(f[1]), int(f[2])) != (d.source, d.target):
            raise ValueError(f"decision {d.source}-{d.target} is not the edge {f[1]}-{f[2]} of the graph")
        if d.verdict != "accepted":
            key = edge_key(run_graph_lines[k])
            out[key] = out.get(key, 0) + 1
    return out


def trusted_graph_lines(map_graph_lines: Sequence[str], untrusted: Dict[Tuple[str, ...], int]) -> Tuple[List[str], int]:
    """The map's graph without the edges that are candidates RRR did not accept; (lines, edges
    kept)."""
    left = dict(untrusted)
    out, kept = [], 0
    for line in map_graph_lines:
        if line.startswith("EDGE_SE2 "):
            key = edge_key(line)
            if left.get(key, 0) > 0:
                left[key] -= 1
                continue
            kept += 1
        out.append(line)
    return out, kept


def expected_trusted_edges(info: MapInfo) -> int:
    v = info.values
    return int(v["odometry_edges"]) + int(v.get("marginal_edges", 0)) + int(v["loop_edges_accepted"])


def read_lines(path: str) -> List[str]:
    with open(path) as f:
        return f.read().splitlines(keepends=True)


# ---------------------------------------------------------------------------------------------
# Node stamps for the loop check


def read_node_stamps(path: str) -> Tuple[List[Optional[float]], List[Optional[int]]]:
    """rrr_slam_offline --node-stamps: the stamp and the session index of every node id (None
    for an id the file does not name)."""
    rows = {}
    with open(path) as f:
        for number, line in enumerate(f, 1):
            if not line.strip() or line.startswith("#"):
                continue
            fields = line.split()
            try:
                rows[int(fields[0])] = (float(fields[1]), int(fields[2]))
            except (ValueError, IndexError):
                raise GraphFileError(path, number, f"expected 'id timestamp session', found '{line.strip()}'") from None
    n = max(rows) + 1 if rows else 0
    return ([rows[k][0] if k in rows else None for k in range(n)],
            [rows[k][1] if k in rows else None for k in range(n)])


def node_stamps(run_graph_lines: Sequence[str], loaded_stamps: Sequence[float], loaded: int,
                map_graph_lines: Sequence[str], map_stamps: Sequence[float],
                session_stamps: Sequence[float], session_poses: Sequence[Pose]) -> List[Optional[float]]:
    """The stamp of every node of a run's --output (ids 0..n-1): the loaded nodes' from the map
    the run loaded; the session's own from the saved map's node at the same pose, or, where the
    save trimmed it, from the session scan nearest in pose between its kept neighbours' stamps."""
    def vertices(lines):
        out = {}
        for line in lines:
            if line.startswith("VERTEX_SE2 "):
                f = line.split()
                out[int(f[1])] = tuple(f[2:5])
        return out
    run = vertices(run_graph_lines)
    by_pose = {pose: k for k, pose in vertices(map_graph_lines).items()}
    n = max(run) + 1 if run else 0
    stamps: List[Optional[float]] = [None] * n
    for k in range(min(loaded, n)):
        stamps[k] = loaded_stamps[k]
    for k in range(loaded, n):
        m = by_pose.get(run.get(k))
        if m is not None and m < len(map_stamps):
            stamps[k] = map_stamps[m]
    known = [k for k in range(loaded, n) if stamps[k] is not None]
    order = sorted(range(len(session_stamps)), key=lambda i: session_stamps[i])
    sorted_stamps = [session_stamps[i] for i in order]
    for k in range(loaded, n):
        if stamps[k] is not None or k not in run:
            continue
        j = bisect.bisect_left(known, k)
        lo = stamps[known[j - 1]] if j > 0 else -math.inf
        hi = stamps[known[j]] if j < len(known) else math.inf
        a, b = bisect.bisect_right(sorted_stamps, lo), bisect.bisect_left(sorted_stamps, hi)
        x, y, t = (float(v) for v in run[k])
        best, best_d = None, math.inf
        for i in order[a:b]:
            p = session_poses[i]
            d = math.hypot(p[0] - x, p[1] - y) + 0.5 * abs(math.remainder(p[2] - t, 2 * math.pi))
            if d < best_d:
                best, best_d = session_stamps[i], d
        stamps[k] = best
    return stamps


# ---------------------------------------------------------------------------------------------
# Results, targets, table


@dataclass
class SessionResult:
    config: str
    session: int                     # 0-based
    info: MapInfo
    summary: RunSummary
    trim: Optional[Trim]
    wall_s: float
    reopt_lago_s: float = math.nan
    reopt_file_s: float = math.nan
    relation: Optional[RelationError] = None
    loops: Optional[LoopCheck] = None
    # The candidates with an end among the session's own nodes, and those of them RRR accepted,
    # against the ground truth: RRR's precision and recall on the run's own loops.
    own_candidates: Optional[LoopCheck] = None
    own_accepted: Optional[LoopCheck] = None
    peak_nodes: int = 0              # the most the run's graph held (before a save's or online trim)
    # The simulated world (--world): ATE (m) of the saved map's nodes and of the session's own
    # scans against the true poses, and the rendered map against the sessions' true worlds, as
    # every scan weighs alike and as the newest session saw each cell (rrr_map_info --map-layering).
    ate_map: float = math.nan
    ate_session: float = math.nan
    world: Dict[str, WorldScore] = field(default_factory=dict)

    def precision_recall(self) -> Tuple[float, float]:
        if self.own_candidates is None or self.own_accepted is None:
            return math.nan, math.nan
        accepted_true = self.own_accepted.checked - self.own_accepted.false
        true = self.own_candidates.checked - self.own_candidates.false
        return (accepted_true / self.own_accepted.checked if self.own_accepted.checked else math.nan,
                accepted_true / true if true else math.nan)

    def value(self, key: str) -> int:
        return int(self.info.values.get(key, 0))


@dataclass
class Target:
    config: str
    what: str
    measured: str
    passed: Optional[bool]           # None: not measurable

    def line(self) -> str:
        verdict = {True: "PASS", False: "FAIL", None: "n/a"}[self.passed]
        return f"{verdict}  {self.config}: {self.what}: {self.measured}"


def _ratio_target(config: str, what: str, first: float, last: float, limit: float, unit: str = "",
                  fmt: str = "{:.0f}") -> Target:
    # A CPU time of 0 is one below the timer's resolution (optimize_time), not a measurement.
    if not (first > 0 and last > 0):
        return Target(config, f"{what} <= {limit}x session 1",
                      "not measured" if math.isnan(first) or math.isnan(last) else
                      f"{fmt.format(first)}{unit} -> {fmt.format(last)}{unit}: below the timer's resolution", None)
    r = last / first
    return Target(config, f"{what} <= {limit}x session 1",
                  f"{fmt.format(first)}{unit} -> {fmt.format(last)}{unit} = {r:.2f}x", r <= limit)


def check_targets(config: str, rows: Sequence[SessionResult], max_trim_ms: float = 50.0) -> List[Target]:
    """Issue 20's targets for one configuration's sessions (in order)."""
    if not rows:
        return []
    first, last = rows[0], rows[-1]
    n = len(rows)
    out = [
        _ratio_target(config, f"nodes after {n} sessions", first.info.nodes, last.info.nodes, 1.3),
        _ratio_target(config, f"edges after {n} sessions", first.value("edges"), last.value("edges"), 1.5),
        _ratio_target(config, f"map file after {n} sessions", first.info.bytes / 1e6, last.info.bytes / 1e6, 1.5,
                      " MB", "{:.2f}"),
        _ratio_target(config, f"re-optimization from LAGO after {n} sessions", first.reopt_lago_s * 1e3,
                      last.reopt_lago_s * 1e3, 1.5, " ms", "{:.1f}"),
        _ratio_target(config, f"re-optimization from the map's poses after {n} sessions",
                      first.reopt_file_s * 1e3, last.reopt_file_s * 1e3, 1.5, " ms", "{:.1f}"),
    ]
    if first.relation is not None and last.relation is not None and first.relation.count and last.relation.count:
        a, b = first.relation.trans_mean, last.relation.trans_mean
        out.append(Target(config, f"ACES relation error of session {n} within 10% of session 1's",
                          f"{a:.4f} m -> {b:.4f} m ({(b / a - 1) * 100:+.1f}%)", b <= 1.1 * a))
    trims = [r.trim for r in rows if r.trim is not None]
    if trims:
        bad = [(r.session + 1, r.trim.get("kl_clt"), r.trim.get("kl_delete")) for r in rows if r.trim is not None
               and r.trim.records and not r.trim.get("kl_clt") <= 0.1 * r.trim.get("kl_delete")]
        ratios = [r.trim.get("kl_clt") / r.trim.get("kl_delete") for r in rows
                  if r.trim is not None and r.trim.records and r.trim.get("kl_delete") > 0]
        out.append(Target(config, "KL(clt) <= 0.1 KL(delete) on every run (the run's trims summed)",
                          (f"worst ratio {max(ratios):.3f}" if ratios else "no trims") +
                          ("; over in sessions " + ", ".join(f"{s} ({c:.3g} vs {d:.3g})" for s, c, d in bad)
                           if bad else ""), (not bad) if ratios else None))
        records = [t for tr in trims for t in tr.records]
        per_trim = [t.kl_clt / t.kl_delete for t in records if t.kl_delete > 0]
        over = sum(1 for x in per_trim if x > 0.1)
        out.append(Target(config, "KL(clt) <= 0.1 KL(delete) on every trim",
                          f"{over} of {len(per_trim)} trims over, worst {max(per_trim):.3f}" if per_trim
                          else "no trims", over == 0 if per_trim else None))
        ms = [t.ms for t in records]
        big = [t.ms for t in records if t.blanket <= 100]
        out.append(Target(config, f"trim p99 < {max_trim_ms:.0f} ms (every trim record, blanket <= 100)",
                          f"p99 {percentile(big, 99):.1f} ms, max {max(ms):.1f} ms over {len(ms)} trims "
                          f"({len(ms) - len(big)} with a blanket over 100)" if ms else "no trims",
                          percentile(big, 99) < max_trim_ms if big else None))
    untied = [r.session + 1 for r in rows[1:] if r.summary.relocalized not in (None, "at", "final")]
    out.append(Target(config, "every session after the first tied to the map",
                      "sessions never tied: " + ", ".join(map(str, untied)) if untied else
                      f"{n - 1} of {n - 1} tied", not untied))
    false_loops = sum(r.loops.inter_session_false for r in rows if r.loops is not None)
    inter = sum(r.loops.inter_session for r in rows if r.loops is not None)
    out.append(Target(config, "no false inter-session loop accepted",
                      f"{false_loops} of {inter} accepted inter-session loops false", false_loops == 0))
    return out


def check_world_targets(results: Dict[str, List[SessionResult]], ate_margin_m: float = 0.06,
                        changed_min: float = 0.95, f1_min: float = 0.95) -> List[Target]:
    """Issue 20's targets in the simulated changing world: after the last session the map shows
    the world as it is now in the changed cells and keeps the static ones; a trimmed map's ATE
    stays within `ate_margin_m` of the untrimmed one's, session by session."""
    out = []
    for config, rows in results.items():
        if not rows or not rows[-1].world:
            continue
        n = len(rows)
        w = rows[-1].world.get("newest-session")  # the lifelong map's layering; "all": in the table only
        if w is not None:
            layering, c = w.layering, w.comparison
            seen = "" if c.changed_observed < 0 else (
                f"; of the {c.changed_observed} the last session's laser swept "
                f"{c.changed_observed_agree} = {c.changed_observed_agreement:.3f}")
            if c.changed_knowable >= 0:
                seen += (f"; of the {c.changed_knowable} whose newest look saw them as they are now "
                         f"{c.changed_knowable_agree} = {c.changed_knowable_agreement:.3f}")
            out.append(Target(config, f"changed world after {n} sessions ({layering}): the map agrees with the "
                                      f"world now in >= {changed_min:.0%} of the changed cells",
                              f"{c.changed_agree} of {c.changed_cells} = {c.changed_agreement:.3f} (stale "
                              f"{c.changed_stale}, unknown {c.changed_unknown}{seen})",
                              c.changed_agreement >= changed_min if c.changed_cells else None))
            out.append(Target(config, f"static cells' occupancy F1 >= {f1_min} after {n} sessions ({layering})",
                              f"{c.static_f1:.3f} over {c.static_cells} cells", c.static_f1 >= f1_min))
    untrimmed = results.get("untrimmed", [])
    for config, rows in results.items():
        if config == "untrimmed":
            continue
        excess = [(b.ate_map - a.ate_map, a, b) for a, b in zip(untrimmed, rows)
                  if not (math.isnan(a.ate_map) or math.isnan(b.ate_map))]
        if not excess:
            continue
        worst, a, b = max(excess, key=lambda e: e[0])
        out.append(Target(config, f"ATE of the map within {100 * ate_margin_m:.0f} cm of the untrimmed one's in "
                                  f"every session ({len(excess)})",
                          f"worst session {b.session + 1}: {100 * b.ate_map:.2f} cm against {100 * a.ate_map:.2f} cm",
                          worst <= ate_margin_m))
    return out


def _f(x: float, fmt: str) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else fmt.format(x)


HEADER = ("| config | session | nodes | peak nodes in the run | edges | marginal edges | submaps | map file (MB) | trim p50 / p99 (ms) "
          "[slowest trim_record] | "
          "KL clt / delete (nats) | re-optimization CPU from LAGO / from the map's poses (ms) | relation error (m) | "
          "inter-session loops (false) | the session's loops: RRR precision / recall (candidates, false) | "
          "wall (s) |")


def fmt_row(r: SessionResult) -> str:
    t = r.trim
    trim_ms = "–" if t is None else (f"{_f(t.get('p50_ms'), '{:.1f}')} / {_f(t.get('p99_ms'), '{:.1f}')} "
                                     f"[{_f(max((x.ms for x in t.records), default=math.nan), '{:.1f}')}]")
    kl = "–" if t is None else f"{_f(t.get('kl_clt'), '{:.3g}')} / {_f(t.get('kl_delete'), '{:.3g}')}"
    rel = "–" if r.relation is None or not r.relation.count else \
        f"{r.relation.trans_mean:.4f} ± {r.relation.trans_std:.4f}"
    loops = "–" if r.loops is None or r.session == 0 else f"{r.loops.inter_session} ({r.loops.inter_session_false})"
    precision, recall = r.precision_recall()
    own = "–" if r.own_candidates is None else (f"{_f(precision, '{:.3f}')} / {_f(recall, '{:.3f}')} "
                                                f"({r.own_candidates.checked}, {r.own_candidates.false})")
    marginal = str(r.value("marginal_edges"))
    if r.value("dense_factors"):
        marginal += f" + {r.value('dense_factors')} dense factors over {r.value('dense_factor_nodes')} nodes"
    return (f"| {r.config} | {r.session + 1} | {r.info.nodes} | {r.peak_nodes or '–'} | {r.value('edges')} | {marginal} | "
            f"{r.value('submaps')} | {r.info.bytes / 1e6:.2f} | {trim_ms} | {kl} | "
            f"{_f(r.reopt_lago_s * 1e3, '{:.1f}')} / {_f(r.reopt_file_s * 1e3, '{:.1f}')} | {rel} | {loops} | "
            f"{own} | {_f(r.wall_s, '{:.1f}')} |")


def table(rows: Sequence[SessionResult]) -> str:
    lines = [HEADER, "|" + "---|" * (HEADER.count("|") - 1)]
    lines.extend(fmt_row(r) for r in rows)
    return "\n".join(lines)


WORLD_HEADER = ("| config | session | ATE of the map / of the session's scans (cm) | changed cells: agree / "
                "stale / unknown of N, every scan alike | the same, newest session per cell | changed cells the "
                "session's laser swept: agree of N (alike / newest) | changed cells whose newest look saw them as now: "
                "agree of N (alike / newest) | static cells' F1 (alike / newest) |")


def world_table(rows: Sequence[SessionResult]) -> str:
    """The simulated world's columns, one row per session and configuration."""
    def changed(w: Optional[WorldScore]) -> str:
        if w is None:
            return "–"
        c = w.comparison
        return f"{c.changed_agree} / {c.changed_stale} / {c.changed_unknown} of {c.changed_cells}"

    lines = [WORLD_HEADER, "|" + "---|" * (WORLD_HEADER.count("|") - 1)]
    for r in rows:
        alike, newest = r.world.get("all"), r.world.get("newest-session")
        swept = " / ".join("–" if w is None or w.comparison.changed_observed < 0 else
                           f"{w.comparison.changed_observed_agree}" for w in (alike, newest))
        n_swept = max((w.comparison.changed_observed for w in (alike, newest) if w is not None), default=-1)
        knowable = " / ".join("–" if w is None or w.comparison.changed_knowable < 0 else
                              f"{w.comparison.changed_knowable_agree}" for w in (alike, newest))
        n_knowable = max((w.comparison.changed_knowable for w in (alike, newest) if w is not None), default=-1)
        f1 = " / ".join("–" if w is None else f"{w.comparison.static_f1:.3f}" for w in (alike, newest))
        lines.append(f"| {r.config} | {r.session + 1} | {_f(r.ate_map * 100, '{:.2f}')} / "
                     f"{_f(r.ate_session * 100, '{:.2f}')} | {changed(alike)} | {changed(newest)} | "
                     f"{swept} of {n_swept if n_swept >= 0 else '–'} | "
                     f"{knowable} of {n_knowable if n_knowable >= 0 else '–'} | {f1} |")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# Plots


def plot(results: Dict[str, List[SessionResult]], out_prefix: str, title: str) -> List[str]:
    """Writes PREFIX_size.png, PREFIX_reopt.png, PREFIX_kl.png; returns their paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    colors = {"untrimmed": "tab:gray", "clt": "tab:blue", "delete": "tab:orange", "online": "tab:green",
              "fresh-area": "tab:purple", "dense": "tab:red"}
    paths = []

    from matplotlib.ticker import MaxNLocator
    reference = next((rows for c, rows in results.items() if c != "untrimmed" and rows), None)
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.3))
    for ax, (label, get, limit) in zip(axes, [("nodes", lambda r: r.info.nodes, 1.3),
                                              ("edges", lambda r: r.value("edges"), 1.5),
                                              ("map file (MB)", lambda r: r.info.bytes / 1e6, 1.5)]):
        for config, rows in results.items():
            ax.plot([r.session + 1 for r in rows], [get(r) for r in rows], "o-", ms=3,
                    color=colors.get(config), label=config)
        if reference:
            ax.axhline(limit * get(reference[0]), color="tab:red", lw=0.8, ls=":",
                       label=f"target: {limit}x session 1 ({reference[0].config})")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_xlabel("session")
        ax.set_title(label, fontsize=10)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{title}: the saved map after each session", fontsize=10)
    fig.tight_layout()
    paths.append(out_prefix + "_size.png")
    fig.savefig(paths[-1], dpi=80)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(5.5, 3.3))
    for config, rows in results.items():
        x = [r.session + 1 for r in rows]
        ax.plot(x, [r.reopt_lago_s * 1e3 for r in rows], "o-", ms=3, color=colors.get(config),
                label=f"{config}, from LAGO")
        ax.plot(x, [r.reopt_file_s * 1e3 for r in rows], "s--", ms=3, color=colors.get(config),
                label=f"{config}, from the map's poses")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("session")
    ax.set_ylabel("rrr_optimize CPU time (ms)")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(f"{title}\none re-optimization of the saved map's trusted graph", fontsize=9)
    fig.tight_layout()
    paths.append(out_prefix + "_reopt.png")
    fig.savefig(paths[-1], dpi=80)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 3.6))
    styles = {"clt": dict(fillstyle="full"), "delete": dict(fillstyle="none")}
    for config, rows in results.items():
        records = [(r.session, t) for r in rows if r.trim is not None for t in r.trim.records]
        if not records:
            continue
        # Both divergences are computed for every trim, whichever replacement the run kept.
        x = [r.session + 1 + 0.3 * (k / max(1, len(r.trim.records))) for r in rows if r.trim is not None
             for k in range(len(r.trim.records))]
        style = styles.get(config, {})
        ax.semilogy(x, [max(t.kl_clt, 1e-6) for _, t in records], "o", ms=4, color="tab:blue",
                    label=f"KL(clt), {config} run", **style)
        ax.semilogy(x, [max(t.kl_delete, 1e-6) for _, t in records], "s", ms=4, color="tab:orange",
                    label=f"KL(delete), {config} run", **style)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("session whose save made the trim")
    ax.set_ylabel("KL from the exact marginal (nats)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    ax.set_title(f"{title}\nKL divergence of each trim (marginalization)", fontsize=9)
    fig.tight_layout()
    paths.append(out_prefix + "_kl.png")
    fig.savefig(paths[-1], dpi=80)
    plt.close(fig)
    return paths


# ---------------------------------------------------------------------------------------------
# Running the tools


class Tools:
    def __init__(self, slam: str, map_info: str, optimize: str, extra: Sequence[str], reuse: bool,
                 repeats: int = 3):
        self.slam, self.map_info, self.optimize = slam, map_info, optimize
        self.extra, self.reuse, self.repeats = list(extra), reuse, repeats
        self.no_run = False  # only the runs kept: a configuration stops at its first missing session

    def run_slam(self, log: str, stem: str, args: Sequence[str]) -> Tuple[RunSummary, str, float]:
        """rrr_slam_offline LOG ARGS; stdout kept as STEM.out, wall time as STEM.wall (both reused
        with --reuse)."""
        out, wall = stem + ".out", stem + ".wall"
        if self.reuse and os.path.exists(out):
            with open(out) as f:
                text = f.read()
            seconds = math.nan
            if os.path.exists(wall):
                with open(wall) as f:
                    seconds = float(f.read().strip() or "nan")
            return parse_summary(text), text, seconds
        cmd = [self.slam, log, "--quiet"] + list(args) + self.extra
        print("  " + " ".join(os.path.basename(c) if k < 2 else c for k, c in enumerate(cmd)), file=sys.stderr)
        start = time.monotonic()
        result = subprocess.run(cmd, capture_output=True, text=True)
        # As kept, so that a table of these runs and one of the kept runs (--reuse) print alike.
        seconds = round(time.monotonic() - start, 3)
        if result.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{result.stderr}")
        write_text_atomically(wall, f"{seconds:.3f}\n")
        write_text_atomically(out, result.stdout)
        return parse_summary(result.stdout), result.stdout, seconds

    def info(self, path: str, graph: str, trajectory: str) -> MapInfo:
        result = subprocess.run([self.map_info, path, "--graph", graph, "--trajectory", trajectory],
                                capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"rrr_map_info {path} failed:\n{result.stderr}")
        return parse_map_info(result.stdout)

    def render_map(self, path: str, out: str, resolution: float, layering: str) -> str:
        """rrr_map_info PATH --map OUT (map_server pair; reused with --reuse while newer than the
        map); returns OUT.yaml."""
        yaml, stamp = out + ".yaml", out + ".args"
        args = ["--map-resolution", str(resolution), "--map-layering", layering] + self.render_flags()
        made = ""
        if os.path.exists(stamp):
            with open(stamp) as f:
                made = f.read()
        if self.reuse and made == " ".join(args) + "\n" and os.path.exists(yaml) and \
                os.path.getmtime(yaml) >= os.path.getmtime(path):
            return yaml
        result = subprocess.run([self.map_info, path, "--map", out] + args, capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"rrr_map_info {path} --map {out} failed:\n{result.stderr}")
        write_text_atomically(stamp, " ".join(args) + "\n")
        return yaml

    def render_flags(self) -> List[str]:
        """The map evidence flags given to rrr_slam_offline (after --), for the maps scored too."""
        out = []
        for k, a in enumerate(self.extra[:-1]):
            if a in ("--map-hit-probability", "--map-miss-probability"):
                out += [a, self.extra[k + 1]]
        return out

    def _optimize_cpu(self, graph: str, args: Sequence[str]) -> Tuple[float, bool]:
        """CPU seconds of one rrr_optimize process, the least of `repeats` runs, and whether they
        are the ones it states for its initialization and optimization (its `cpu time` line; a
        binary that prints none: the process's user + system time)."""
        best, stated_all = math.inf, True
        for _ in range(self.repeats):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            result = subprocess.run([self.optimize, graph, "--output", graph + ".opt.g2o"] + list(args),
                                    capture_output=True, text=True)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            if result.returncode != 0 and "graph is disconnected" in result.stderr:
                # A session that never tied to the map stays its own component: no one graph to time.
                print(f"  {graph}: {result.stderr.strip().splitlines()[-1]}; not timed", file=sys.stderr)
                return math.nan, False
            if result.returncode != 0:
                raise RuntimeError(f"rrr_optimize {graph} failed:\n{result.stderr}")
            stated = re.search(r"^cpu time +([0-9.eE+-]+) s", result.stdout, re.M)
            stated_all = stated_all and stated is not None
            best = min(best, float(stated.group(1)) if stated else
                       (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime))
        return best, stated_all

    def optimize_time(self, graph: str, init: str) -> float:
        """CPU seconds of rrr_optimize --init INIT's initialization and optimization: the CPU time
        it states (`cpu time`: process start and file I/O left out, whose noise swamps a few
        milliseconds), or, from a binary that states none, its process CPU time beyond that of
        reading and writing the graph (--max-iterations 0 --init file). CPU time rather than the
        wall time it prints, which other processes on a loaded machine stretch."""
        work, stated = self._optimize_cpu(graph, ["--init", init])
        if math.isnan(work):  # not timed (a disconnected graph): not 0
            return math.nan
        if stated:
            return work
        return max(0.0, work - self._optimize_cpu(graph, ["--init", "file", "--max-iterations", "0"])[0])


def write_moved_logs(log: str, out_dir: str, count: int, seed: int, reuse: bool) -> List[str]:
    """session_K.clf: the whole log seen from odometry frame K (random_transforms; the first
    is the identity)."""
    paths = []
    for k, transform in enumerate(random_transforms(seed, count)):
        path = os.path.join(out_dir, f"session_{k}.clf")
        if not (reuse and os.path.exists(path)):
            write_moved_log(log, path + ".tmp", transform)
            os.replace(path + ".tmp", path)
        paths.append(path)
    return paths


def run_config(tools: Tools, logs: Sequence[str], out_dir: str, config: str) -> List[Tuple[str, RunSummary, str, float]]:
    """The sessions of one configuration; (stem, summary, stdout, wall s) per session."""
    os.makedirs(out_dir, exist_ok=True)
    out = []
    for k, log in enumerate(logs):
        stem = os.path.join(out_dir, f"s{k}")
        args = ["--output", stem + ".g2o", "--decisions", stem + ".tsv", "--trajectory", stem + ".traj.txt",
                "--session-trajectory", stem + ".session.txt", "--save-map", stem + ".rrrmap",
                "--session-name", f"s{k}", "--node-stamps", stem + ".stamps.txt"]
        if k > 0:
            args += ["--load-map", os.path.join(out_dir, f"s{k - 1}.rrrmap")]
        if tools.no_run and not os.path.exists(stem + ".out"):
            break
        summary, text, wall = tools.run_slam(log, stem, args + CONFIGS[config])
        out.append((stem, summary, text, wall))
    return out


LAYERINGS = ("all", "newest-session")


def score_world(tools: Tools, world: SimulatedWorld, row: SessionResult, stem: str, resolution: float) -> None:
    """The simulated world's figures of session `row.session`'s saved map: its nodes' ATE, the
    session's own ATE, and the map rendered both ways against the true worlds of the sessions so
    far, the changed cells this session's laser swept apart."""
    k = row.session
    row.ate_map = trajectory_ate(stem + ".map.traj.txt", world.truth)[0]
    row.ate_session = trajectory_ate(stem + ".session.txt", world.truth)[0]
    transform = world_from_map(stem + ".map.traj.txt", world.truth)
    worlds = [world.world(j) for j in range(k + 1)]
    for layering in LAYERINGS:
        rendered = tools.render_map(stem + ".rrrmap", f"{stem}.map_{layering}", resolution, layering)
        row.world[layering] = score_map(rendered, transform, worlds, world.observed(k), layering,
                                        world.knowable(k))


def evaluate_config(tools: Tools, data, runs, config: str, criteria: Criteria,
                    map_resolution: float = 0.1) -> List[SessionResult]:
    """Per session of one configuration's runs; `data`: the log's LogData or the SimulatedWorld
    (None: no ground truth)."""
    rows: List[SessionResult] = []
    prev_info: Optional[MapInfo] = None
    for k, (stem, summary, text, wall) in enumerate(runs):
        info = tools.info(stem + ".rrrmap", stem + ".map.g2o", stem + ".map.traj.txt")
        row = SessionResult(config, k, info, summary, parse_trim(text), wall)
        row.peak_nodes = max([summary.nodes] + [int(m) for m in ONLINE_TRIM.findall(text)])
        run_lines, map_lines = read_lines(stem + ".g2o"), read_lines(stem + ".map.g2o")
        decisions = read_decisions(stem + ".tsv")
        trusted, kept = trusted_graph_lines(map_lines, untrusted_candidates(run_lines, decisions))
        if kept != expected_trusted_edges(info):
            raise RuntimeError(f"{stem}: the map's trusted graph has {kept} edges, the map counts "
                               f"{expected_trusted_edges(info)} (odometry + marginal + accepted)")
        with open(stem + ".trusted.g2o", "w") as f:
            f.writelines(trusted)
        kept_times = stem + ".reopt"  # reused with --reuse while newer than the map
        if tools.reuse and os.path.exists(kept_times) and \
                os.path.getmtime(kept_times) >= os.path.getmtime(stem + ".rrrmap"):
            with open(kept_times) as f:
                row.reopt_lago_s, row.reopt_file_s = (float(v) for v in f.read().split())
        else:
            row.reopt_lago_s = tools.optimize_time(stem + ".trusted.g2o", "lago")
            row.reopt_file_s = tools.optimize_time(stem + ".trusted.g2o", "file")
            write_text_atomically(kept_times, f"{row.reopt_lago_s!r} {row.reopt_file_s!r}\n")
        if data is not None:
            s_stamps, s_poses = read_tum(stem + ".session.txt")
            if data.relations:
                row.relation = relation_error(s_stamps, s_poses, data.relations)
            if os.path.exists(stem + ".stamps.txt"):  # the run's own record (--node-stamps)
                stamps, sessions = read_node_stamps(stem + ".stamps.txt")
                own_session = max((x for x in sessions if x is not None), default=0)

                def session_of(node: int, sessions=sessions, own_session=own_session, k=k) -> int:
                    return k if sessions[node] == own_session else sessions[node]
            else:  # runs made before --node-stamps: reconstructed (node_stamps)
                # The loaded nodes still in the run's graph: all of the map it loaded, unless
                # online trims removed some (the session's own nodes are never trimmed: the saved
                # map's last session holds them all). Their ids keep their order, so --trajectory's
                # first lines are theirs; session_of() tells them from the session's, not their
                # own sessions apart.
                run_nodes = sum(1 for line in run_lines if line.startswith("VERTEX_SE2 "))
                loaded = run_nodes - (info.nodes - info.first_nodes()[-1])
                loaded_stamps = read_tum(stem + ".traj.txt")[0][:loaded]
                stamps = node_stamps(run_lines, loaded_stamps, loaded, map_lines,
                                     read_tum(stem + ".map.traj.txt")[0], s_stamps, s_poses)
                prev_first = [] if prev_info is None else prev_info.first_nodes()

                def session_of(node: int, loaded=loaded, prev_first=prev_first, k=k) -> int:
                    if node >= loaded:
                        return k
                    return bisect.bisect_right(prev_first, node) - 1

            def truth(t):
                return None if t is None else data.truth.pose(t)
            decided = decided_loops(stem + ".g2o", stem + ".tsv")
            accepted = [loop for loop, verdict in decided if verdict == "accepted"]
            row.loops = check_loops(accepted, stamps, session_of, truth, criteria.false_m, criteria.false_deg,
                                    involving=k)
            own = [(loop, verdict) for loop, verdict in decided
                   if k in (session_of(loop.source), session_of(loop.target))]
            row.own_candidates = check_loops([loop for loop, _ in own], stamps, session_of, truth,
                                             criteria.false_m, criteria.false_deg)
            row.own_accepted = check_loops([loop for loop, verdict in own if verdict == "accepted"], stamps,
                                           session_of, truth, criteria.false_m, criteria.false_deg)
        if isinstance(data, SimulatedWorld):
            score_world(tools, data, row, stem, map_resolution)
        rows.append(row)
        prev_info = info
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--slam-offline", required=True)
    parser.add_argument("--map-info", required=True)
    parser.add_argument("--optimize", required=True)
    parser.add_argument("--data", action="append", required=True,
                        help="folders holding the logs, relations and corrected logs")
    parser.add_argument("--cache", required=True, help="working folder (moved logs, runs, graphs)")
    parser.add_argument("--logs", nargs="*", default=["aces"], choices=list(LOGS))
    parser.add_argument("--sessions", type=int, default=10)
    parser.add_argument("--seeds", nargs="*", type=int, default=[1])
    parser.add_argument("--untrimmed-sessions", type=int, default=None,
                        help="sessions of the untrimmed run (default --sessions): its loop search grows "
                             "with every session, so the whole run grows with their square")
    parser.add_argument("--configs", nargs="*", default=DEFAULT_CONFIGS, choices=list(CONFIGS))
    parser.add_argument("--plots", default=None, help="PNG prefix (default: CACHE/LOG/seedS/lifelong)")
    parser.add_argument("--repeats", type=int, default=7, help="rrr_optimize runs per graph (least time)")
    parser.add_argument("--false-m", type=float, default=0.5, help="a loop is false beyond this (m)")
    parser.add_argument("--false-deg", type=float, default=10.0, help="... or this (degrees)")
    parser.add_argument("--max-trim-ms", type=float, default=50.0)
    parser.add_argument("--reuse", action="store_true", help="reuse the moved logs and runs kept in --cache")
    parser.add_argument("--no-run", action="store_true",
                        help="score only the runs kept in --cache (implies --reuse); a configuration "
                             "stops at its first session not run")
    parser.add_argument("--world", metavar="WORLD.yaml",
                        help="also run the simulated changing world: rrr_simulate's sessions of this world "
                             "(needs --simulate); scored by ATE against the true poses and the final map "
                             "against the true worlds")
    parser.add_argument("--changes", action="append", default=[], metavar="CHANGES.yaml",
                        help="with --world: rrr_simulate's change sets (repeatable)")
    parser.add_argument("--route", metavar="ROUTE.yaml", help="with --world: rrr_simulate's route")
    parser.add_argument("--simulate", help="path of the rrr_simulate binary (for --world)")
    parser.add_argument("--sim-max-scans", type=int, default=None,
                        help="with --world: rrr_simulate's --max-scans (shorter sessions)")
    parser.add_argument("--map-resolution", type=float, default=0.1,
                        help="with --world: m per cell of the rendered maps (default 0.1, the bundled world's)")
    parser.add_argument("extra", nargs=argparse.REMAINDER, help="-- then options for rrr_slam_offline")
    args = parser.parse_args(argv)
    if args.sessions < 1:
        parser.error("--sessions must be at least 1")
    if args.world and not args.simulate:
        parser.error("--world needs --simulate (the rrr_simulate binary)")
    if (args.changes or args.route or args.sim_max_scans) and not args.world:
        parser.error("--changes, --route and --sim-max-scans need --world")
    if args.map_resolution <= 0:
        parser.error("--map-resolution must be positive")
    criteria = Criteria(args.false_m, args.false_deg)
    tools = Tools(args.slam_offline, args.map_info, args.optimize, [a for a in args.extra if a != "--"],
                  args.reuse or args.no_run, args.repeats)
    tools.no_run = args.no_run
    count = max(args.sessions, args.untrimmed_sessions or 0)

    def sessions():
        """(name, data, seed, output folder, the sessions' logs) of every log and seed asked for."""
        for name in args.logs:
            data = log_data_or_skip(name, args.data)
            if data is None:
                continue
            for seed in args.seeds:
                out = os.path.join(args.cache, name, f"seed{seed}")
                os.makedirs(out, exist_ok=True)
                yield name, data, seed, out, write_moved_logs(data.log, out, count, seed, tools.reuse)
        if args.world:
            name = world_name(args.world)
            key = simulation_key(args.world, args.changes, args.route, args.sim_max_scans)
            for seed in args.seeds:
                out = os.path.join(args.cache, name, f"seed{seed}_{key}")
                world = SimulatedWorld(args.simulate, args.world, os.path.join(out, "sim"), count, seed,
                                       args.changes, args.route, tools.reuse, args.sim_max_scans)
                yield name, world, seed, out, world.logs

    failed = 0
    for name, data, seed, out, logs in sessions():
        runs = {}
        for config in args.configs:
            print(f"{name}, seed {seed}: {config}, {args.sessions} sessions ...", file=sys.stderr)
            n = args.untrimmed_sessions if config == "untrimmed" and args.untrimmed_sessions else args.sessions
            runs[config] = run_config(tools, logs[:n], os.path.join(out, config), config)
        # Ground truth between corrected scans moved by the first session's motion (one run).
        if runs[args.configs[0]]:
            data.use_local_motion(runs[args.configs[0]][0][0] + ".traj.txt")
        results = {c: evaluate_config(tools, data, runs[c], c, criteria, args.map_resolution) for c in args.configs}
        title = f"{name}, seed {seed}, " + ", ".join(f"{c} {len(runs[c])}" for c in args.configs) + " sessions"
        print(f"### {title}\n")
        print(table([r for c in args.configs for r in results[c]]))
        print()
        if isinstance(data, SimulatedWorld):
            print(world_table([r for c in args.configs for r in results[c]]))
            print()
        for c in args.configs:
            for r in results[c]:
                if r.loops is not None and r.loops.worst:
                    print(f"- {c}, session {r.session + 1}: accepted loops beyond {args.false_m} m / "
                          f"{args.false_deg}°: " + ", ".join(f"{m:.2f} m {d:.1f}° (nodes {a}-{b})"
                                                             for m, d, a, b in r.loops.worst[:6]))
        targets = [t for c in args.configs for t in check_targets(c, results[c], args.max_trim_ms)]
        targets += check_world_targets(results)
        for t in targets:
            print("- " + t.line())
            failed += t.passed is False
        prefix = args.plots.replace("{log}", name).replace("{seed}", str(seed)) if args.plots \
            else os.path.join(out, "lifelong")
        paths = plot(results, prefix, title)
        if isinstance(data, SimulatedWorld) and any(results.values()):
            finals = [(f"{c}, session {r.session + 1}", os.path.join(out, c, f"s{r.session}.map_newest-session.yaml"),
                       r.world["newest-session"].world_from_map, data.world_files[:r.session + 1])
                      for c in args.configs if results[c] for r in results[c][-1:]]
            knowable = [data.knowable(r.session) for c in args.configs if results[c] for r in results[c][-1:]]
            paths.append(plot_final_maps(finals, prefix + "_world.png",
                                         f"{title}: the final maps (newest session per cell)", knowable))
        for p in paths:
            print(f"- plot: {p}")
        print()
    print(f"{failed} target checks failed", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
