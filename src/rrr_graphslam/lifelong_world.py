"""The simulated changing world as a source of sessions for the lifelong benchmark
(scripts/bench_lifelong --world, issue 20): rrr_simulate's sessions of one world whose furniture
and doors change between them, their true poses, and what a saved map is scored by there: the ATE
of the map's nodes against the true poses, and the map rendered (rrr_map_info --map) against the
true worlds of the sessions so far (world_compare: the changed cells, the static cells' F1).

Unlike the replayed logs, every session drives its own route in its own world; the sessions'
stamps are a day apart (rrr_simulate's --session-gap), so one stamp names one scan of one
session."""

import hashlib
import math
import os
import subprocess
import sys
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .bench_sessions import StampIndex
from .evaluation import alignment_errors
from .graph_io import Pose, write_text_atomically
from .relations import read_tum
from .world_compare import (FREE, OCCUPIED, UNKNOWN, GridMap, WorldComparison, agreement, align,
                            changed_cells, compare, map_in_world, observed_by_log, read_map_server,
                            seen_as_now)


class SimulatedTruth:
    """The true pose of every scan of every session, by stamp (within 1 ms)."""

    def __init__(self, truth_files: Sequence[str]):
        self.stamps: List[float] = []
        self.poses: List[Pose] = []
        for path in truth_files:
            stamps, poses = read_tum(path)
            self.stamps.extend(stamps)
            self.poses.extend(poses)
        self.index = StampIndex(self.stamps)

    def pose(self, t: float) -> Optional[Pose]:
        i = self.index.find(t)
        return None if i is None else self.poses[i]


def world_name(world: str) -> str:
    """sim_STEM for WORLD/STEM.yaml: the benchmark's name of a simulated world."""
    return "sim_" + os.path.splitext(os.path.basename(world))[0]


def simulation_key(world: str, changes: Sequence[str] = (), route: Optional[str] = None,
                   max_scans: Optional[int] = None) -> str:
    """8 hex digits that change with anything that changes the sessions (the files' contents, not
    only their names): runs of other sessions are kept apart, never reused for these."""
    digest = hashlib.sha1()
    for path in [world] + list(changes) + ([route] if route else []):
        digest.update(os.path.abspath(path).encode() + b"\0")
        with open(path, "rb") as f:
            digest.update(f.read())
    digest.update(f"max_scans={max_scans}".encode())
    return digest.hexdigest()[:8]


def session_stem(k: int, sessions: int) -> str:
    """rrr_simulate's name of session k of `sessions`: at least two digits, as many as the last."""
    return f"session_{k:0{max(2, len(str(sessions - 1)))}d}"


class SimulatedWorld:
    """rrr_simulate WORLD --sessions N [--changes ...] [--route R] [--max-scans M] --seed S --out DIR, run once
    (again when the command differs from the one DIR was made by); the sessions' logs, true poses
    and true worlds."""

    relations = None  # no relation file: scored by ATE against the true poses

    def __init__(self, simulate: str, world: str, out_dir: str, sessions: int, seed: int,
                 changes: Sequence[str] = (), route: Optional[str] = None, reuse: bool = False,
                 max_scans: Optional[int] = None):
        self.name = world_name(world)
        cmd = [simulate, os.path.abspath(world), "--sessions", str(sessions), "--seed", str(seed),
               "--out", os.path.abspath(out_dir)]
        for c in changes:
            cmd += ["--changes", os.path.abspath(c)]
        if route:
            cmd += ["--route", os.path.abspath(route)]
        if max_scans:
            cmd += ["--max-scans", str(max_scans)]
        os.makedirs(out_dir, exist_ok=True)
        stamp = os.path.join(out_dir, "simulate.cmd")
        made = ""
        if os.path.exists(stamp):
            with open(stamp) as f:
                made = f.read()
        wanted = " ".join(cmd[1:]) + "\n"  # the binary's path may move between builds
        if not (reuse and made == wanted):
            if os.path.exists(stamp):
                os.remove(stamp)  # a run that fails leaves no stamp to match
            print("  " + " ".join(os.path.basename(c) if k == 0 else c for k, c in enumerate(cmd)),
                  file=sys.stderr)
            result = subprocess.run(cmd, capture_output=True, text=True)
            if result.returncode != 0:
                raise RuntimeError(f"{' '.join(cmd)} failed:\n{result.stderr}")
            write_text_atomically(stamp, wanted)
        stems = [os.path.join(out_dir, session_stem(k, sessions)) for k in range(sessions)]
        self.logs = [s + ".clf" for s in stems]
        self.truth_files = [s + "_truth.txt" for s in stems]
        self.world_files = [s + "_world.yaml" for s in stems]
        for path in self.logs + self.truth_files + self.world_files:
            if not os.path.exists(path):
                raise RuntimeError(f"rrr_simulate wrote no {path}")
        self.truth = SimulatedTruth(self.truth_files)
        self._worlds: Dict[int, GridMap] = {}
        self._observed: Dict[int, np.ndarray] = {}
        self._knowable: Dict[int, np.ndarray] = {}

    def world(self, k: int) -> GridMap:
        """Session k's true world (read once)."""
        if k not in self._worlds:
            self._worlds[k] = read_map_server(self.world_files[k])
        return self._worlds[k]

    def observed(self, k: int) -> np.ndarray:
        """The cells of session k's world its laser swept at its true poses (computed once)."""
        if k not in self._observed:
            self._observed[k] = observed_by_log(self.world(k), self.logs[k], self.truth.pose)
        return self._observed[k]

    def knowable(self, k: int) -> np.ndarray:
        """The cells of session k's world whose newest observation up to session k saw them as
        they are in it (world_compare.seen_as_now; computed once)."""
        if k not in self._knowable:
            self._knowable[k] = seen_as_now([self.world(j) for j in range(k + 1)],
                                            [self.observed(j) for j in range(k + 1)])
        return self._knowable[k]

    def use_local_motion(self, trajectory: str) -> None:
        """The true poses need no help from a run (bench_sessions' corrected logs do)."""


def truth_pairs(trajectory: str, truth: SimulatedTruth) -> List[Tuple[Pose, Pose]]:
    """(pose, true pose) for every pose of a TUM trajectory whose stamp has a true pose."""
    stamps, poses = read_tum(trajectory)
    pairs = [(p, truth.pose(t)) for t, p in zip(stamps, poses)]
    return [(p, q) for p, q in pairs if q is not None]


def trajectory_ate(trajectory: str, truth: SimulatedTruth) -> Tuple[float, int]:
    """RMSE (m) of a TUM trajectory's positions against the true poses at its stamps, after a
    rigid SE(2) alignment; and how many of its poses had a true pose."""
    pairs = truth_pairs(trajectory, truth)
    if len(pairs) < 2:
        return math.nan, len(pairs)
    errors = alignment_errors([p[:2] for p, _ in pairs], [q[:2] for _, q in pairs])
    return float(np.sqrt(np.mean(errors ** 2))), len(pairs)


@dataclass
class WorldScore:
    """A saved map against the worlds of the sessions that made it."""
    layering: str                   # rrr_map_info --map-layering
    comparison: WorldComparison
    world_from_map: Pose


def world_from_map(trajectory: str, truth: SimulatedTruth) -> Pose:
    """The rigid transform from a map's frame into the world's, fitted to a trajectory in the map
    frame (TUM) and the true poses at its stamps."""
    pairs = truth_pairs(trajectory, truth)
    if len(pairs) < 2:
        raise ValueError(f"{trajectory}: fewer than two poses with a true pose")
    return align([p for p, _ in pairs], [q for _, q in pairs])


def score_map(map_yaml: str, transform: Pose, worlds: Sequence[GridMap], observed: Optional[np.ndarray],
              layering: str, knowable: Optional[np.ndarray] = None) -> WorldScore:
    """The rendered map `map_yaml` against `worlds` (the sessions so far, the last being the world
    now), placed in the world by `transform` (world_from_map); with `observed` (the cells the last
    session's laser swept, SimulatedWorld.observed) and `knowable` (those whose newest observation
    saw them as now, SimulatedWorld.knowable), those changed cells are scored apart."""
    return WorldScore(layering, compare(read_map_server(map_yaml), worlds, transform, observed=observed,
                                        knowable=knowable), transform)


def plot_final_maps(maps: Sequence[Tuple[str, str, Pose, Sequence[str]]], path: str, title: str,
                    knowable: Optional[Sequence[np.ndarray]] = None) -> str:
    """PATH (PNG): the newest true world, then each (label, map YAML, world_from_map, the true
    worlds of the sessions that made it) resampled on the world's grid, the changed cells
    coloured by what the map shows there against its own last world (that world now: green; an
    earlier world's state: red; unknown: orange); with `knowable` (one mask per map,
    SimulatedWorld.knowable), the changed cells no session saw as they are now in purple."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    newest = max((m[3] for m in maps), key=len)
    worlds = [read_map_server(w) for w in newest]
    last = worlds[-1]

    def grey(cells):
        return np.where(cells == OCCUPIED, 0.0, np.where(cells == FREE, 1.0, 0.75))

    fig, axes = plt.subplots(1, 1 + len(maps), figsize=(4.6 * (1 + len(maps)), 4.9))
    axes = np.atleast_1d(axes)
    changed = changed_cells(worlds)
    axes[0].imshow(grey(last.cells), cmap="gray", vmin=0, vmax=1, interpolation="nearest")
    axes[0].imshow(np.ma.masked_where(~changed, np.zeros(changed.shape)), cmap=ListedColormap(["tab:blue"]),
                   alpha=0.8, interpolation="nearest")
    axes[0].set_title(f"true world of session {len(newest)}\n(blue: cells that changed)", fontsize=8)
    for m, (ax, (label, map_yaml, transform, world_files)) in enumerate(zip(axes[1:], maps)):
        own = [read_map_server(w) for w in world_files]
        last, changed = own[-1], changed_cells(own)
        seen = map_in_world(read_map_server(map_yaml), last, transform)
        ax.imshow(grey(seen), cmap="gray", vmin=0, vmax=1, interpolation="nearest")
        agrees = agreement(seen, last)
        marks = np.full(changed.shape, -1)
        marks[changed & agrees] = 0
        marks[changed & ~agrees & (seen != UNKNOWN)] = 1
        marks[changed & (seen == UNKNOWN)] = 2
        legend = "green now, red stale, orange unknown"
        if knowable is not None:
            marks[changed & ~knowable[m]] = 3
            legend += ",\npurple: no session saw them as they are now"
        ax.imshow(np.ma.masked_where(marks < 0, marks),
                  cmap=ListedColormap(["tab:green", "tab:red", "tab:orange", "tab:purple"]),
                  vmin=0, vmax=3, alpha=0.9, interpolation="nearest")
        ax.set_title(f"{label}\n(changed cells: {legend})", fontsize=8)
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title, fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.94))  # the panels' titles below the figure's
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
