"""Checks a SLAM trajectory of a CARMEN log against the log's own scans (scripts/evaluate_slam,
issue 24), and against a reference trajectory where one exists.

Scan consistency (no ground truth needed): a revisit is a pair of scans far apart along the
trajectory (at least --min-travel metres of the estimate's path between them) whose estimated
poses are close (within --radius, headings within --max-turn). Every --every metres of path one
scan looks for the nearest earlier scan that makes such a pair. rrr_align_scans aligns the two raw
scans directly (no map): the best pose in a 2 m, 15 degree window (branch and bound on a grid of
one scan's points, then MRPT's ICP), and the local optimum nearest the estimate (ICP alone from
it); it scores each relative pose by its overlap: the fraction of one scan's points within
--overlap-distance (0.1 m) of the other's surfaces. The scans' own relative pose is the best one
unless the nearest overlaps within --min-gain as well (a corridor, a row of doors: several poses
fit, and the one the estimate is at stands). Each pair is aligned both ways (b onto a, a onto b);
the scans have a relative pose only when the two ways agree (within --agree-m and --agree-deg)
and overlap at least --min-overlap each: a pose found one way only is an alias of repeated
structure. Overlaps are the mean of the two ways. A revisit is inconsistent when the estimated
relative pose is more than --max-m or --max-deg from the scans' own and the scans overlap clearly
better (by --min-gain) at theirs: where both overlap alike the scans cannot tell, and the revisit
counts consistent.

With a reference (--corrected: a ple_corrected log, its scans associated with the log's by
identical range readings as in bench_sessions.GroundTruth): the ATE (RMSE of the positions at the
scans the reference corrected, after the SE(2) alignment of the estimate onto the reference), and
per revisit the estimate's disagreement with the reference's relative pose and which of the two
the scans side with (the one at which they overlap more)."""

import argparse
import math
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import numpy as np
from scipy.spatial import cKDTree

from .bench_sessions import GroundTruth, local_from_trajectory, read_corrected, read_raw_scans
from .carmen import read_carmen
from .evaluation import alignment_errors
from .graph_io import Pose, between, compose, inverse
from .relations import read_tum


@dataclass
class CheckParams:
    every_m: float = 1.0          # a scan looks for a revisit every this many metres of path
    min_travel_m: float = 10.0    # path between the two scans of a revisit, at least
    radius_m: float = 2.0         # estimated positions at most this far apart
    max_turn_deg: float = 45.0    # estimated headings at most this far apart
    max_m: float = 0.3            # inconsistent: estimate and aligned scans differ by more ...
    max_deg: float = 3.0          # ... or by more than this
    min_gain: float = 0.1         # ... and the scans overlap this much better at the aligned pose
    min_overlap: float = 0.3      # an alignment overlapping less is not trusted (not aligned)
    agree_m: float = 0.1          # the two ways of aligning a pair agree within this ...
    agree_deg: float = 1.0        # ... and this
    overlap_m: float = 0.1        # a point overlaps within this of the other scan


@dataclass
class Revisit:
    a: int                        # earlier scan, index in log order
    b: int                        # later scan
    estimate: Pose                # b's robot in a's robot frame, by the trajectory
    reference: Optional[Pose] = None
    aligned: Optional[Pose] = None  # the scans' own (None: they did not align)
    overlap_estimate: float = math.nan
    overlap_aligned: float = math.nan
    overlap_reference: float = math.nan

    def error(self, other: Optional[Pose]) -> Tuple[float, float]:
        """(m, deg) between the estimate and another relative pose of the pair."""
        if other is None:
            return math.nan, math.nan
        e = between(other, self.estimate)
        return math.hypot(e[0], e[1]), abs(math.degrees(e[2]))

    def inconsistent(self, p: CheckParams) -> bool:
        m, deg = self.error(self.aligned)
        return (self.aligned is not None and (m > p.max_m or deg > p.max_deg) and
                self.overlap_aligned >= self.overlap_estimate + p.min_gain)

    def off_reference(self, p: CheckParams) -> bool:
        """The estimate disagrees with the reference and the scans side with the reference."""
        m, deg = self.error(self.reference)
        return (self.reference is not None and (m > p.max_m or deg > p.max_deg) and
                self.overlap_reference > self.overlap_estimate)


@dataclass
class Ate:
    rmse_m: float
    max_m: float
    scans: int


@dataclass
class Evaluation:
    scans: int
    placed: int
    revisits: List[Revisit] = field(default_factory=list)
    ate: Optional[Ate] = None

    def aligned(self) -> List[Revisit]:
        return [r for r in self.revisits if r.aligned is not None]

    def inconsistent(self, p: CheckParams) -> List[Revisit]:
        return sorted((r for r in self.revisits if r.inconsistent(p)),
                      key=lambda r: -r.error(r.aligned)[0])

    def off_reference(self, p: CheckParams) -> List[Revisit]:
        return sorted((r for r in self.revisits if r.off_reference(p)),
                      key=lambda r: -r.error(r.reference)[0])


def path_length(poses: Sequence[Optional[Pose]]) -> List[float]:
    """Cumulative distance along the placed poses (a scan without a pose adds nothing)."""
    out, last, total = [], None, 0.0
    for p in poses:
        if p is not None:
            if last is not None:
                total += math.hypot(p[0] - last[0], p[1] - last[1])
            last = p
        out.append(total)
    return out


def select_revisits(poses: Sequence[Optional[Pose]], p: CheckParams) -> List[Tuple[int, int]]:
    """(a, b) scan pairs, a < b: every p.every_m of path, the scan b there and the earlier scan a
    nearest to it in the estimate among those p.min_travel_m of path or more before it, within
    p.radius_m and p.max_turn_deg."""
    placed = [k for k, q in enumerate(poses) if q is not None]
    if not placed:
        return []
    s = path_length(poses)
    tree = cKDTree(np.array([poses[k][:2] for k in placed]))
    pairs, next_s = [], 0.0
    for b in placed:
        if s[b] < next_s:
            continue
        best = None
        for n in tree.query_ball_point(poses[b][:2], p.radius_m):
            a = placed[n]
            if a >= b or s[b] - s[a] < p.min_travel_m:
                continue
            turn = abs(math.degrees(between(poses[a], poses[b])[2]))
            d = math.hypot(poses[a][0] - poses[b][0], poses[a][1] - poses[b][1])
            if turn <= p.max_turn_deg and (best is None or d < best[0]):
                best = (d, a)
        if best is not None:
            pairs.append((best[1], b))
            next_s = s[b] + p.every_m
    return pairs


def _scans_pose(fields: List[str], p: CheckParams) -> Tuple[Optional[Pose], float]:
    """The scans' own relative pose of one line of rrr_align_scans and its overlap: the best in
    the window unless the nearest optimum overlaps within p.min_gain as well."""
    best = (float(fields[3]), float(fields[4]), float(fields[5])) if fields[2] == "1" else None
    best_overlap = float(fields[7]) if best is not None else -math.inf
    nearest = (float(fields[8]), float(fields[9]), float(fields[10]))
    nearest_overlap = float(fields[11])
    if nearest_overlap >= best_overlap - p.min_gain:
        return nearest, nearest_overlap
    return best, best_overlap


def align(binary: str, log: str, revisits: Sequence[Revisit], p: CheckParams) -> None:
    """Runs rrr_align_scans on the revisits, both ways, and fills their aligned pose and
    overlaps."""
    if not revisits:
        return
    with tempfile.NamedTemporaryFile("w", suffix=".tsv", delete=False) as f:
        for r in revisits:
            back = [inverse(q) for q in (r.estimate, r.reference) if q is not None]
            for a, b, given in ((r.a, r.b, [q for q in (r.estimate, r.reference) if q is not None]),
                                (r.b, r.a, back)):
                f.write(f"{a} {b} " + " ".join("%.6f %.6f %.8f" % q for q in given) + "\n")
        path = f.name
    try:
        result = subprocess.run([binary, log, path, "--overlap-distance", str(p.overlap_m)],
                                capture_output=True, text=True)
    finally:
        os.unlink(path)
    if result.returncode != 0:
        raise RuntimeError(f"{binary} failed:\n{result.stderr}")
    lines = [line.split() for line in result.stdout.split("\n") if line.strip()]
    if len(lines) != 2 * len(revisits):
        raise RuntimeError(f"{binary}: {len(lines)} lines for {2 * len(revisits)} pairs")
    for r, f, g in zip(revisits, lines[0::2], lines[1::2]):
        if (int(f[0]), int(f[1]), int(g[0]), int(g[1])) != (r.a, r.b, r.b, r.a):
            raise RuntimeError(f"{binary}: pairs {f[:2]} {g[:2]} where {r.a} {r.b} was asked")
        r.overlap_estimate = 0.5 * (float(f[12]) + float(g[12]))
        if r.reference is not None:
            r.overlap_reference = 0.5 * (float(f[13]) + float(g[13]))
        forward, forward_overlap = _scans_pose(f, p)
        backward, backward_overlap = _scans_pose(g, p)
        if min(forward_overlap, backward_overlap) < p.min_overlap:
            continue
        d = between(forward, inverse(backward))
        if math.hypot(d[0], d[1]) <= p.agree_m and abs(math.degrees(d[2])) <= p.agree_deg:
            r.aligned, r.overlap_aligned = forward, 0.5 * (forward_overlap + backward_overlap)


def absolute_trajectory_error(estimate: Sequence[Pose], reference: Sequence[Pose]) -> Ate:
    """RMSE and maximum of the position error after aligning the estimate onto the reference."""
    err = alignment_errors([q[:2] for q in estimate], [q[:2] for q in reference])
    return Ate(float(np.sqrt(np.mean(err ** 2))), float(err.max()), len(err))


def evaluate(log: str, trajectory: str, align_binary: str, corrected: Optional[str] = None,
             p: CheckParams = CheckParams()) -> Evaluation:
    raw = read_raw_scans(log)
    stamps, poses = read_tum(trajectory)
    scan_poses = local_from_trajectory(raw, stamps, poses)
    result = Evaluation(len(raw), sum(q is not None for q in scan_poses))
    reference = None
    if corrected:
        # The corrected poses are the laser's; revisits and the ATE compare robot poses.
        to_robot = inverse(read_carmen(log).laser_offset())
        truth = GroundTruth(raw, read_corrected(corrected), scan_poses)
        reference = [compose(truth.pose_of_scan(k), to_robot) for k in range(len(raw))]
        anchors = [k for k in truth.anchor_index if scan_poses[k] is not None]
        if anchors:
            result.ate = absolute_trajectory_error([scan_poses[k] for k in anchors],
                                                   [reference[k] for k in anchors])
    for a, b in select_revisits(scan_poses, p):
        result.revisits.append(Revisit(
            a, b, between(scan_poses[a], scan_poses[b]),
            between(reference[a], reference[b]) if reference else None))
    align(align_binary, log, result.revisits, p)
    return result


def revisit_line(r: Revisit, raw_stamps: Sequence[float]) -> str:
    m, deg = r.error(r.aligned)
    line = (f"{r.a} {r.b} {raw_stamps[r.a]:.3f} {raw_stamps[r.b]:.3f} {m:.3f} {deg:.2f} "
            f"{r.overlap_estimate:.2f} {r.overlap_aligned:.2f}")
    if r.reference is not None:
        rm, rdeg = r.error(r.reference)
        line += f" {rm:.3f} {rdeg:.2f} {r.overlap_reference:.2f}"
    return line


def summary(e: Evaluation, p: CheckParams) -> List[str]:
    bad = e.inconsistent(p)
    worst = bad[0].error(bad[0].aligned)[0] if bad else 0.0
    lines = [f"scans {e.scans}  placed {e.placed}",
             f"revisits {len(e.revisits)}  aligned {len(e.aligned())}",
             f"inconsistent {len(bad)}  worst {worst:.3f} m"]
    if e.ate is not None:
        off = e.off_reference(p)
        off_worst = off[0].error(off[0].reference)[0] if off else 0.0
        lines += [f"ATE {e.ate.rmse_m:.4f} m  max {e.ate.max_m:.3f} m  ({e.ate.scans} scans)",
                  f"off_reference {len(off)}  worst {off_worst:.3f} m"]
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("log", help="the CARMEN log (.clf, .gz allowed)")
    parser.add_argument("trajectory", help="a pose per scan, TUM format with the scans' "
                        "ipc_timestamp (rrr_slam_offline --trajectory)")
    parser.add_argument("--corrected", help="reference: a ple_corrected log of the same run")
    parser.add_argument("--align-scans", default="rrr_align_scans",
                        help="the rrr_align_scans binary (default: found on PATH)")
    parser.add_argument("--list", action="store_true", help="list every inconsistent revisit")
    d = CheckParams()
    for name in vars(d):
        parser.add_argument("--" + name.replace("_", "-"), type=float, default=getattr(d, name))
    args = parser.parse_args(argv)
    p = CheckParams(**{k: getattr(args, k) for k in vars(d)})
    try:
        e = evaluate(args.log, args.trajectory, args.align_scans, args.corrected, p)
    except (OSError, ValueError, RuntimeError) as error:
        print(f"evaluate_slam: {error}", file=sys.stderr)
        return 1
    print("\n".join(summary(e, p)))
    if args.list:
        stamps = [s.ipc for s in read_raw_scans(args.log)]
        print("# inconsistent: a b t_a t_b error_m error_deg overlap_estimate overlap_aligned"
              + (" ref_error_m ref_error_deg overlap_reference" if args.corrected else ""))
        for r in e.inconsistent(p):
            print(revisit_line(r, stamps))
        if args.corrected:
            print("# off the reference, the scans siding with it: same columns")
            for r in e.off_reference(p):
                print(revisit_line(r, stamps))
    return 0


if __name__ == "__main__":
    sys.exit(main())
