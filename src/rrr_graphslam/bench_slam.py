"""SLAM benchmark (scripts/bench_slam): rrr_slam_offline on CARMEN logs, with the relation error of
Kümmerle et al. 2009 where a relations file exists (ACES), the ATE against the corrected poses of
ple_corrected where a corrected log of the run exists (ACES, Intel, FR079, MIT CSAIL), the
scan-consistency check of evaluate_slam on every log (inconsistent revisits; with a corrected log,
the revisits off the reference where the scans side with it), speed against real time, the
branch-and-bound time per node-submap pair, the front end's candidates labelled true or false by
the corrected poses and RRR's precision and recall on them (candidate_truth; with --map-info),
and MRPT's ICP-SLAM (CMetricMapBuilderICP, rrr_bench_icp_slam) on the same logs as the baseline.
Prints a Markdown table; maps go to --maps as PNG."""

import argparse
import math
import os
import re
import subprocess
import sys
import time

from .bench_sessions import GroundTruth, local_from_trajectory, read_corrected, read_raw_scans
from .candidate_truth import (BRIDGE_SIGMA_PER_M, MAX_BRIDGE_M, REFERENCE_SIGMA,
                              candidate_labels, node_references, score_candidates, turn_drift,
                              write_labels)
from .carmen import read_carmen
from .evaluate_slam import CheckParams, evaluate
from .evaluation import read_decisions
from .graph_io import inverse, read_graph
from .relations import read_relations, read_tum, relation_error

# name: (file, relations file or None, ple_corrected log or None)
LOGS = {
    "aces": ("aces.clf.gz", "aces.relations", "aces-corrected.log.gz"),
    "intel": ("intel.clf.gz", None, "intel-corrected.log.gz"),
    "fr079": ("fr079.clf.gz", None, "freiburg-079-corrected.log.gz"),
    "mit-csail": ("mit-csail.clf.gz", None, "csail-corrected.log.gz"),
    "fr-clinic": ("fr-clinic_robotlaser.clf.gz", None, None),
}


# rrr_slam_offline options under which the map's nodes are not the run's own, one per node.
SESSION_OPTIONS = {"--load-map", "--lifelong", "--trim-every-n-nodes"}
# rrr_slam_offline's default cluster gap (OnlineRrrParams): the verifiers table decides the same
# clusters again.
CLUSTER_GAP = 10


def find(name, dirs):
    for d in dirs:
        path = os.path.join(d, name)
        if os.path.exists(path):
            return path
    return None


def run_ours(binary, log, out, extra):
    files = {k: os.path.join(out, v) for k, v in
             dict(graph="graph.g2o", decisions="decisions.tsv", trajectory="traj.txt", map="map").items()}
    cmd = [binary, log, "--quiet", "--output", files["graph"], "--decisions", files["decisions"],
           "--trajectory", files["trajectory"], "--map", files["map"]] + list(extra)
    result = subprocess.run(cmd, capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{result.stderr}")
    text = result.stdout

    def number(pattern):
        m = re.search(pattern, text)
        return float(m.group(1)) if m else math.nan
    return files, dict(
        duration=number(r"scans, ([0-9.]+) s"), time=number(r"time\s+([0-9.]+) s"),
        bnb_ms=number(r"pairs, ([0-9.]+) ms each"), candidates=number(r"candidates\s+([0-9]+)"),
        accepted=number(r"accepted\s+([0-9]+)"), rejected=number(r"rejected\s+([0-9]+)"),
        nodes=number(r"nodes\s+([0-9]+)"))


def label_candidates(map_info, log, corrected, files, saved_map):
    """score_candidates of the run's candidates and verdicts against the corrected log: the
    nodes' scans from the saved map (rrr_map_info --trajectory: each node's scan timestamp). The
    labels also go to candidates.labels beside the graph (the truth file format)."""
    out = os.path.dirname(saved_map)
    nodes_path = os.path.join(out, "nodes.txt")
    result = subprocess.run([map_info, saved_map, "--trajectory", nodes_path],
                            capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"{map_info} {saved_map} --trajectory failed:\n{result.stderr}")
    raw = read_raw_scans(log)
    truth = GroundTruth(raw, read_corrected(corrected),
                        local_from_trajectory(raw, *read_tum(files["trajectory"])))
    graph = read_graph(files["graph"])
    reference = node_references(sorted(graph.poses), read_tum(nodes_path)[0], truth,
                                inverse(read_carmen(log).laser_offset()))
    write_labels(os.path.join(out, "candidates.labels"), graph.loops(),
                 candidate_labels(graph.loops(), reference))
    decisions = read_decisions(files["decisions"])
    for k, (edge, d) in enumerate(zip(graph.loops(), decisions)):
        if (edge.source, edge.target) != (d.source, d.target):
            raise RuntimeError(f"{files['decisions']}: row {k + 1} decides {d.source}->{d.target}, "
                               f"but loop {k + 1} of {files['graph']} is {edge.source}->{edge.target}")
    return (score_candidates(graph.loops(), [d.verdict for d in decisions], reference),
            turn_drift(graph.edges, reference))


def verifiers_table(rrr_offline, rows, cache):
    """Every verifier of rrr_offline (bench_verifiers.VERIFIERS) decides each labelled log's
    candidates again, offline and in batch, with the cluster gap the online run used; scored
    against the same labels."""
    from .bench import scored_run
    from .bench_verifiers import VERIFIERS
    lines = ["| log | verifier | precision | recall | accepted false | rejected true | time s |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["truth"] is None:
            continue
        out = os.path.join(cache, r["name"])
        graph, labels = os.path.join(out, "graph.g2o"), os.path.join(out, "candidates.labels")
        for verifier, extra in VERIFIERS:
            slug = verifier.replace(" ", "-")
            s, run = scored_run(rrr_offline, graph, labels,
                                os.path.join(out, f"verifier-{slug}.tsv"),
                                [*extra, "--cluster-gap", str(CLUSTER_GAP)])
            lines.append(f"| {r['name']} | {verifier} | {s.precision:.3f} | {s.recall:.3f} | "
                         f"{s.fp} | {s.fn} | {run['time']:.2f} |")
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--slam-offline", required=True)
    parser.add_argument("--icp-slam", help="rrr_bench_icp_slam (MRPT baseline); omitted: not run")
    parser.add_argument("--align-scans", help="rrr_align_scans (scan-consistency check); omitted: "
                        "not run")
    parser.add_argument("--map-info", help="rrr_map_info (the nodes' scans, to label the "
                        "candidates by a corrected log); omitted: not labelled")
    parser.add_argument("--verifiers", metavar="RRR_OFFLINE",
                        help="rrr_offline: every verifier (rrr, pcm, scgp, gnc) decides the "
                        "labelled logs' candidates again, a second table; omitted: not run")
    parser.add_argument("--data", action="append", required=True, help="folders holding the logs")
    parser.add_argument("--cache", required=True, help="working folder")
    parser.add_argument("--maps", help="copy the map PNGs here")
    parser.add_argument("--logs", nargs="*", default=list(LOGS), choices=list(LOGS))
    parser.add_argument("extra", nargs=argparse.REMAINDER, help="-- then options for rrr_slam_offline")
    args = parser.parse_args(argv)
    extra = [a for a in args.extra if a != "--"]

    rows = []
    for name in args.logs:
        file, relations, corrected = LOGS[name]
        log = find(file, args.data)
        if log is None:
            print(f"{name}: {file} not found in {args.data}; skipped", file=sys.stderr)
            continue
        out = os.path.join(args.cache, name)
        os.makedirs(out, exist_ok=True)
        print(f"{name}: rrr_slam_offline ...", file=sys.stderr)
        corrected_path = find(corrected, args.data) if corrected else None
        # One session of the log, every node kept: node k is the k-th node of the saved map.
        label = bool(args.map_info and corrected_path) and not set(extra) & SESSION_OPTIONS
        saved_map = os.path.join(out, "map.rrrmap")
        files, r = run_ours(args.slam_offline, log, out,
                            extra + (["--save-map", saved_map] if label else []))
        row = dict(name=name, **r, ours=None, icp=None, icp_time=math.nan, check=None, truth=None,
                   drift=None)
        if label:
            row["truth"], row["drift"] = label_candidates(args.map_info, log, corrected_path, files,
                                                          saved_map)
        if args.align_scans:
            row["check"] = evaluate(log, files["trajectory"], args.align_scans, corrected_path)
        rel_path = find(relations, args.data) if relations else None
        if rel_path:
            rel = read_relations(rel_path)
            row["ours"] = relation_error(*read_tum(files["trajectory"]), rel)
        if args.icp_slam:
            print(f"{name}: MRPT ICP-SLAM ...", file=sys.stderr)
            traj = os.path.join(out, "icp_traj.txt")
            start = time.monotonic()
            subprocess.run([args.icp_slam, log, "--trajectory", traj], check=True, capture_output=True)
            row["icp_time"] = time.monotonic() - start
            if rel_path:
                row["icp"] = relation_error(*read_tum(traj), rel)
        if args.maps:
            os.makedirs(args.maps, exist_ok=True)
            # A README-sized copy (Debian's imagemagick); the full-size map stays in the cache.
            subprocess.run(["/usr/bin/convert", files["map"] + ".png", "-resize", "1000x1000>", "-strip",
                            os.path.join(args.maps, f"{name}.png")], check=True)
        rows.append(row)

    def rel(e):
        return "–" if e is None else f"{e.trans_mean:.4f} ± {e.trans_std:.4f} m / {e.rot_mean_deg:.2f}°"

    params = CheckParams()

    def ate(e):
        return "–" if e is None or e.ate is None else f"{e.ate.rmse_m:.3f} m (max {e.ate.max_m:.2f})"

    def inconsistent(e):
        if e is None:
            return "–"
        bad = e.inconsistent(params)
        worst = f", worst {bad[0].error(bad[0].aligned)[0]:.2f} m" if bad else ""
        return f"{len(bad)} of {len(e.aligned())}{worst}"

    def off_reference(e):
        if e is None or e.ate is None:
            return "–"
        off = e.off_reference(params)
        worst = f", worst {off[0].error(off[0].reference)[0]:.2f} m" if off else ""
        return f"{len(off)}{worst}"

    def by_reference(t):
        return "–" if t is None else f"{t.true} / {t.false}" + (
            f" ({t.unlabelled} not labelled)" if t.unlabelled else "")

    def precision_recall(t):
        if t is None:
            return "–"
        text = f"{t.precision:.3f} / {t.recall:.3f}"
        if not t.false_accepted:
            return text
        _, _, m, deg, _ = t.false_accepted[0]
        return f"{text}; worst false accepted {m:.2f} m / {deg:.1f}°"

    def drift(d):
        return "–" if d is None else f"{d.per_step_rad:.4f} ({d.pairs} pairs, worst {d.worst_deg:.1f}°)"

    print("| log | nodes | time (s) | × real time | B&B ms / pair | candidates | accepted | "
          "by the reference: true / false | RRR precision / recall (reference) | "
          "relation error, ours | ATE vs corrected | inconsistent revisits | "
          "off the reference | local SLAM's turn drift (rad per node step) | MRPT ICP-SLAM | "
          "ICP time (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['name']} | {r['nodes']:.0f} | {r['time']:.1f} | {r['duration'] / r['time']:.1f} | "
              f"{r['bnb_ms']:.2f} | {r['candidates']:.0f} | {r['accepted']:.0f} | "
              f"{by_reference(r['truth'])} | {precision_recall(r['truth'])} | {rel(r['ours'])} | "
              f"{ate(r['check'])} | {inconsistent(r['check'])} | {off_reference(r['check'])} | "
              f"{drift(r['drift'])} | {rel(r['icp'])} | {r['icp_time']:.1f} |")
    sx, _, st = REFERENCE_SIGMA
    bx, _, bt = BRIDGE_SIGMA_PER_M
    print("\nby the reference: a candidate is true when its measurement agrees with the corrected "
          "poses' relative pose of its two scans within chi2(0.99, 3), under its own covariance "
          f"plus the reference's ({sx:g} m and {math.degrees(st):g}°, plus {bx:g} m and "
          f"{math.degrees(bt):g}° per metre of bridge); not labelled when a scan lies more than "
          f"{MAX_BRIDGE_M:g} m from a corrected one; precision and recall of RRR's accepted "
          "candidates against those labels (worst: the accepted false candidate of the largest "
          "chi2).\n"
          "ATE: RMSE of the positions at the corrected scans after SE(2) alignment; inconsistent "
          "revisits: of the revisits whose scans aligned, those whose relative pose in the map is "
          f"more than {params.max_m} m or {params.max_deg}° from the scans' own and fits them worse "
          "(scripts/evaluate_slam); off the reference: revisits more than "
          f"{params.max_m} m or {params.max_deg}° from the corrected poses' relative pose where the "
          "scans overlap better at the reference's.\n"
          "Local SLAM's turn drift: over pairs of nodes at corrected scans 100 to 1000 node steps "
          "apart, the standard deviation per step of a random walk that explains how far the "
          "chain of local-SLAM steps turned from the corrected poses (the corrected poses' own "
          "error included); the third entry of scan_odometry_stddev states it.")
    if args.verifiers:
        print("\nThe labelled candidates decided again by each verifier of rrr_offline (batch, "
              f"cluster gap {CLUSTER_GAP}):\n")
        for line in verifiers_table(args.verifiers, rows, args.cache):
            print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
