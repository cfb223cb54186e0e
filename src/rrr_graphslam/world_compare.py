"""A map made by SLAM against the true world it was made in (rrr_simulate's worlds): does the map
show the world as it is now?

Both are map_server pairs (YAML + PGM, trinary: occupied, free, unknown). The map is in its own
frame (the first session's odometry frame); the transform into the world frame comes from a
trajectory in the map frame and the true poses at the same timestamps (least-squares rigid fit,
`align`). Every known cell of the world is looked up in the map at its centre.

- Changed cells: cells whose state differs between an earlier session's world and the last one,
  and that a laser can see in the last world: free cells (furniture that left, a door opened) and
  occupied cells next to a free one (the faces of a new box; its inside is never observed). The
  map *agrees* in a changed cell when it has the last world's state there within
  `tolerance_cells` (the face of a box, one cell off, agrees); an unknown map cell does not.
- Changed cells the last session observed (`--observed-by` its log, with `--truth` its true
  poses): among the changed cells, those its laser swept at its true poses (the free cells along
  each beam and the cell a beam ends in; a cell within `tolerance_cells` of a swept one counted
  too). A change no robot looked at cannot be in any map. *Stale*: changed cells where the map
  has the earlier state (not unknown, not the last world's).
- Changed cells a map could know (`--logs`, every session's log, with `--truth` holding every
  session's true poses): those whose newest observation, by any session, saw the state they
  have now, cell by cell (no tolerance). The others no session looked at, or they changed after
  the last look (the far side of a door that closed, seen open and never again from behind); a
  map can still agree on an occupied one through the tolerance (a face seen one cell over).
- Static cells: the known cells of the last world that never changed, where the map observed
  something within `tolerance_cells` (the map cannot be asked about rooms no session entered).
  Occupancy F1 over them with the same tolerance: an occupied map cell is a true positive when
  the world is occupied within that many cells, and a world wall is found when the map is
  occupied within that many cells (a one-cell shift of a one-cell wall is no error at 0.1 m).
"""

import math
import os
from dataclasses import dataclass
from typing import List, Sequence, Tuple

import numpy as np

from .graph_io import Pose, GraphFileError

OCCUPIED, FREE, UNKNOWN = 1, 0, -1


@dataclass
class GridMap:
    cells: np.ndarray        # rows from the top of the image, OCCUPIED / FREE / UNKNOWN
    resolution: float        # m per cell
    origin: Tuple[float, float]  # the lower-left cell's corner, m

    def state_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """States at the points (UNKNOWN outside)."""
        col = np.floor((x - self.origin[0]) / self.resolution).astype(int)
        row_from_bottom = np.floor((y - self.origin[1]) / self.resolution).astype(int)
        height, width = self.cells.shape
        row = height - 1 - row_from_bottom
        inside = (col >= 0) & (col < width) & (row >= 0) & (row < height)
        out = np.full(x.shape, UNKNOWN, dtype=int)
        out[inside] = self.cells[row[inside], col[inside]]
        return out

    def centres(self) -> Tuple[np.ndarray, np.ndarray]:
        height, width = self.cells.shape
        cols, rows = np.meshgrid(np.arange(width), np.arange(height))
        x = self.origin[0] + (cols + 0.5) * self.resolution
        y = self.origin[1] + (height - 1 - rows + 0.5) * self.resolution
        return x, y


def _yaml_fields(path: str) -> dict:
    fields = {}
    with open(path) as f:
        for number, line in enumerate(f, 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            if ":" not in line:
                raise GraphFileError(path, number, f"expected 'key: value', found '{line}'")
            key, value = line.split(":", 1)
            fields[key.strip()] = value.strip()
    return fields


def _read_pgm(path: str) -> np.ndarray:
    with open(path, "rb") as f:
        data = f.read()
    tokens, pos = [], 0
    while len(tokens) < 4:
        while pos < len(data) and data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            while pos < len(data) and data[pos:pos + 1] != b"\n":
                pos += 1
            continue
        start = pos
        while pos < len(data) and not data[pos:pos + 1].isspace():
            pos += 1
        tokens.append(data[start:pos])
    if tokens[0] != b"P5":
        raise GraphFileError(path, 1, f"not a binary PGM (P5): {tokens[0]!r}")
    width, height, maxval = int(tokens[1]), int(tokens[2]), int(tokens[3])
    pos += 1
    dtype = np.uint8 if maxval < 256 else np.dtype(">u2")
    pixels = np.frombuffer(data, dtype=dtype, count=width * height, offset=pos)
    return pixels.reshape(height, width).astype(float) / maxval


def read_map_server(yaml_path: str) -> GridMap:
    """A map_server pair, its cells classified as map_server does (trinary)."""
    f = _yaml_fields(yaml_path)
    try:
        image = f["image"]
        resolution = float(f["resolution"])
        origin = [float(v) for v in f["origin"].strip("[]").split(",")]
        negate = int(f.get("negate", "0"))
        occupied = float(f.get("occupied_thresh", "0.65"))
        free = float(f.get("free_thresh", "0.196"))
    except (KeyError, ValueError) as e:
        raise GraphFileError(yaml_path, 0, f"missing or malformed field: {e}") from None
    if not os.path.isabs(image):
        image = os.path.join(os.path.dirname(yaml_path), image)
    v = _read_pgm(image)
    p = v if negate else 1.0 - v
    cells = np.full(p.shape, UNKNOWN, dtype=int)
    cells[p > occupied] = OCCUPIED
    cells[p < free] = FREE
    return GridMap(cells, resolution, (origin[0], origin[1]))


def align(map_poses: Sequence[Pose], true_poses: Sequence[Pose]) -> Pose:
    """The rigid transform T (x, y, theta) with T * map_pose ~ true_pose, least squares over the
    positions (Umeyama without scale)."""
    a = np.array([[p[0], p[1]] for p in map_poses])
    b = np.array([[p[0], p[1]] for p in true_poses])
    if len(a) < 2:
        raise ValueError("align needs at least two poses")
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    h = (a - ca).T @ (b - cb)
    theta = math.atan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    c, s = math.cos(theta), math.sin(theta)
    t = cb - np.array([[c, -s], [s, c]]) @ ca
    return (float(t[0]), float(t[1]), theta)


def _dilate(mask: np.ndarray, cells: int) -> np.ndarray:
    out = mask.copy()
    for dr in range(-cells, cells + 1):
        for dc in range(-cells, cells + 1):
            shifted = np.zeros_like(mask)
            rs = slice(max(dr, 0), mask.shape[0] + min(dr, 0))
            rd = slice(max(-dr, 0), mask.shape[0] + min(-dr, 0))
            cs = slice(max(dc, 0), mask.shape[1] + min(dc, 0))
            cd = slice(max(-dc, 0), mask.shape[1] + min(-dc, 0))
            shifted[rs, cs] = mask[rd, cd]
            out |= shifted
    return out


@dataclass
class WorldComparison:
    changed_cells: int
    changed_agree: int        # the map has the last world's state there
    changed_unknown: int      # the map has not observed them
    static_precision: float
    static_recall: float
    static_f1: float
    static_cells: int
    changed_stale: int = 0    # the map has an earlier world's state there
    changed_observed: int = -1        # changed cells the last session observed (-1: not asked)
    changed_observed_agree: int = -1  # ... where the map agrees
    changed_knowable: int = -1        # changed cells whose newest observation saw them as now (-1: not asked)
    changed_knowable_agree: int = -1  # ... where the map agrees

    @property
    def changed_agreement(self) -> float:
        return self.changed_agree / self.changed_cells if self.changed_cells else math.nan

    @property
    def changed_observed_agreement(self) -> float:
        return (self.changed_observed_agree / self.changed_observed if self.changed_observed > 0
                else math.nan)

    @property
    def changed_knowable_agreement(self) -> float:
        return (self.changed_knowable_agree / self.changed_knowable if self.changed_knowable > 0
                else math.nan)


def observed_cells(world: GridMap, scans, poses, laser_offset: Pose = (0.0, 0.0, 0.0),
                   step_m: float = 0.02) -> np.ndarray:
    """The cells of `world`'s grid that scans swept at the given robot poses (world frame): the
    cells along each beam up to its reading (a miss: up to its maximum range) and the cell it ends
    in. `scans`: (angle_min, angle_increment, max_range, ranges) per pose."""
    seen = np.zeros(world.cells.shape, dtype=bool)
    rows, cols = world.cells.shape
    ox, oy = world.origin
    for (angle_min, increment, max_range, ranges), (x, y, th) in zip(scans, poses):
        c, s = math.cos(th), math.sin(th)
        lx, ly = x + c * laser_offset[0] - s * laser_offset[1], y + s * laser_offset[0] + c * laser_offset[1]
        r = np.minimum(np.asarray(ranges, dtype=float), max_range)
        a = th + laser_offset[2] + angle_min + increment * np.arange(r.size)
        steps = np.arange(0.0, 1.0 + 1e-9, step_m / max(float(r.max(initial=0.0)), step_m))
        px = lx + np.outer(r * np.cos(a), steps)
        py = ly + np.outer(r * np.sin(a), steps)
        col = np.floor((px - ox) / world.resolution).astype(int)
        row = rows - 1 - np.floor((py - oy) / world.resolution).astype(int)
        ok = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
        seen[row[ok], col[ok]] = True
    return seen


def observed_by_log(world: GridMap, log_path: str, true_pose) -> np.ndarray:
    """observed_cells of a CARMEN log's scans placed at their true poses (`true_pose(stamp)`:
    the pose, or None for a scan without one)."""
    from .carmen import read_carmen
    log = read_carmen(log_path)
    placed = [(r, true_pose(r.timestamp)) for r in log.lasers]
    placed = [(r, p) for r, p in placed if p is not None]
    if not placed:
        raise ValueError(f"no scan of {log_path} has a true pose")
    return observed_cells(world, [(r.angle_min, r.angle_increment, r.max_range, r.ranges) for r, _ in placed],
                          [p for _, p in placed], log.laser_offset())


def map_in_world(slam_map: GridMap, world: GridMap, world_from_map: Pose) -> np.ndarray:
    """The map's state at the centre of every cell of `world`'s grid (`world_from_map` from
    align())."""
    x, y = world.centres()
    tx, ty, th = world_from_map
    c, s = math.cos(th), math.sin(th)
    dx, dy = x - tx, y - ty
    return slam_map.state_at(c * dx + s * dy, -s * dx + c * dy)


def changed_cells(worlds: Sequence[GridMap]) -> np.ndarray:
    """The cells of the last world whose state an earlier world had otherwise and that a laser can
    see now: free ones, and occupied ones next to a free one."""
    last = worlds[-1]
    for w in worlds:
        if w.cells.shape != last.cells.shape or w.resolution != last.resolution or w.origin != last.origin:
            raise ValueError("the worlds of the sessions must share one grid")
    changed = np.zeros(last.cells.shape, dtype=bool)
    for w in worlds[:-1]:
        changed |= (w.cells != last.cells) & (w.cells != UNKNOWN) & (last.cells != UNKNOWN)
    free_now = last.cells == FREE
    return changed & (free_now | ((last.cells == OCCUPIED) & _dilate(free_now, 1)))


def seen_as_now(worlds: Sequence[GridMap], observed: Sequence[np.ndarray]) -> np.ndarray:
    """The cells whose newest observation saw them as they are now: the last session whose laser
    swept a cell (`observed[k]`, observed_cells of session k in its world `worlds[k]`) saw the
    last world's state there. Elsewhere no map made of the sessions' scans can know a cell's state
    now: no session looked at it, or it changed after the last look (the far side of a door that
    closed, seen open and never again from that side)."""
    if len(observed) != len(worlds):
        raise ValueError(f"{len(observed)} observed masks for {len(worlds)} worlds")
    last = worlds[-1].cells
    knowable = np.zeros(last.shape, dtype=bool)
    looked = np.zeros(last.shape, dtype=bool)
    for world, seen in zip(reversed(worlds), reversed(observed)):
        newest_look = seen & ~looked
        knowable |= newest_look & (world.cells == last)
        looked |= newest_look
    return knowable


def agreement(seen: np.ndarray, world: GridMap, tolerance_cells: int = 1,
              near_seen_occupied: np.ndarray = None) -> np.ndarray:
    """Where the map (`seen`, on the world's grid) has the world's state: a free cell seen free, an
    occupied one seen occupied within `tolerance_cells` (`near_seen_occupied`: that dilation, if
    the caller has it)."""
    if near_seen_occupied is None:
        near_seen_occupied = _dilate(seen == OCCUPIED, tolerance_cells)
    return np.where(world.cells == OCCUPIED, near_seen_occupied, seen == FREE)


def compare(slam_map: GridMap, worlds: Sequence[GridMap], world_from_map: Pose,
            tolerance_cells: int = 1, observed: np.ndarray = None,
            knowable: np.ndarray = None) -> WorldComparison:
    """The map (in its frame) against the worlds of the sessions (all the same grid), the last
    being the world now; `world_from_map` from align(); `observed`, the cells the last session
    observed (observed_cells), if known; `knowable`, the cells whose newest observation saw them
    as they are now (seen_as_now), if known."""
    last = worlds[-1]
    changed = changed_cells(worlds)
    seen = map_in_world(slam_map, last, world_from_map)
    near_seen_occ = _dilate(seen == OCCUPIED, tolerance_cells)
    near_seen_free = _dilate(seen == FREE, tolerance_cells)
    agrees = agreement(seen, last, tolerance_cells, near_seen_occ)
    n_changed = int(changed.sum())
    agree = int((agrees & changed).sum())
    unknown = int(((seen == UNKNOWN) & changed).sum())
    stale = int((changed & ~agrees & (seen != UNKNOWN)).sum())
    n_observed = observed_agree = -1
    if observed is not None:
        in_sight = changed & _dilate(observed, tolerance_cells)
        n_observed, observed_agree = int(in_sight.sum()), int((agrees & in_sight).sum())
    n_knowable = knowable_agree = -1
    if knowable is not None:
        n_knowable, knowable_agree = int((changed & knowable).sum()), int((agrees & changed & knowable).sum())

    observed = near_seen_occ | near_seen_free
    static = (~changed) & (last.cells != UNKNOWN) & observed
    truth_occ = (last.cells == OCCUPIED) & static
    seen_occ = (seen == OCCUPIED) & static
    near_truth = _dilate(last.cells == OCCUPIED, tolerance_cells)
    tp_precision = int((seen_occ & near_truth).sum())
    tp_recall = int((truth_occ & near_seen_occ).sum())
    precision = tp_precision / int(seen_occ.sum()) if seen_occ.any() else math.nan
    recall = tp_recall / int(truth_occ.sum()) if truth_occ.any() else math.nan
    f1 = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
    return WorldComparison(n_changed, agree, unknown, precision, recall, f1, int(static.sum()),
                           stale, n_observed, observed_agree, n_knowable, knowable_agree)


def main(argv=None) -> int:
    import argparse
    from .relations import read_tum
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("map", help="the map's YAML (rrr_map_info --map, rrr_slam_offline --map)")
    parser.add_argument("--worlds", nargs="+", required=True,
                        help="the true worlds' YAMLs, one per session in order (rrr_simulate's session_K_world.yaml)")
    parser.add_argument("--trajectory", required=True, help="a trajectory in the map frame (TUM)")
    parser.add_argument("--truth", nargs="+", required=True,
                        help="the true poses at its timestamps (TUM, world frame); several files (one per "
                             "session, rrr_simulate's session_K_truth.txt) are read as one")
    parser.add_argument("--tolerance-cells", type=int, default=1)
    parser.add_argument("--observed-by", metavar="LOG",
                        help="the last session's CARMEN log (its scans placed at --truth's poses): "
                             "also score the changed cells it observed")
    parser.add_argument("--logs", nargs="+", metavar="LOG",
                        help="every session's CARMEN log, one per --worlds entry (their scans placed at "
                             "--truth's poses: give every session's): also score the changed cells whose newest observation "
                             "saw them as they are now (the cells a map could know)")
    args = parser.parse_args(argv)
    stamps, poses = read_tum(args.trajectory)
    truth = {}
    for path in args.truth:
        truth.update(zip(*read_tum(path)))
    pairs = [(p, truth[t]) for t, p in zip(stamps, poses) if t in truth]
    if len(pairs) < 2:
        parser.error("fewer than two timestamps of --trajectory are in --truth")
    transform = align([a for a, _ in pairs], [b for _, b in pairs])
    worlds = [read_map_server(w) for w in args.worlds]
    observed = None
    if args.observed_by:
        try:
            observed = observed_by_log(worlds[-1], args.observed_by, truth.get)
        except ValueError as e:
            parser.error(str(e))
    knowable = None
    if args.logs:
        if len(args.logs) != len(worlds):
            parser.error(f"--logs names {len(args.logs)} logs for {len(worlds)} worlds")
        try:
            # The last session's sweep is --observed-by's when that names the same log.
            swept = [observed if observed is not None and k == len(worlds) - 1 and log == args.observed_by
                     else observed_by_log(w, log, truth.get)
                     for k, (w, log) in enumerate(zip(worlds, args.logs))]
            knowable = seen_as_now(worlds, swept)
        except ValueError as e:
            parser.error(str(e))
    result = compare(read_map_server(args.map), worlds, transform, args.tolerance_cells, observed, knowable)
    print(f"changed_cells {result.changed_cells}")
    print(f"changed_agree {result.changed_agree}")
    print(f"changed_unknown {result.changed_unknown}")
    print(f"changed_agreement {result.changed_agreement:.4f}")
    print(f"changed_stale {result.changed_stale}")
    if observed is not None:
        print(f"changed_observed {result.changed_observed}")
        print(f"changed_observed_agree {result.changed_observed_agree}")
        print(f"changed_observed_agreement {result.changed_observed_agreement:.4f}")
    if knowable is not None:
        print(f"changed_knowable {result.changed_knowable}")
        print(f"changed_knowable_agree {result.changed_knowable_agree}")
        print(f"changed_knowable_agreement {result.changed_knowable_agreement:.4f}")
    print(f"static_cells {result.static_cells}")
    print(f"static_precision {result.static_precision:.4f}")
    print(f"static_recall {result.static_recall:.4f}")
    print(f"static_f1 {result.static_f1:.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
