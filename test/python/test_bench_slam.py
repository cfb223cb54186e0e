"""scripts/bench_slam's table: the ATE against a corrected log, the scan-consistency columns and the
candidates labelled by the corrected log, with a stand-in for rrr_slam_offline that maps the
synthetic two-lap room (test_evaluate_slam) with its second lap shifted by 0.6 m and proposes three
loops between the laps (two true, one 0.6 m off), and one for rrr_map_info. Needs rrr_align_scans
(RRR_ALIGN_SCANS)."""
import contextlib
import gzip
import io
import os
import re
import stat
import sys

import pytest
from rrr_graphslam.bench_slam import main
from rrr_graphslam.graph_io import between, compose
from test_evaluate_slam import ALIGN, cast, flaser, two_laps, write_tum

STAND_IN = """#!{python}
import shutil, sys
args = sys.argv
out = {{k: args[args.index(k) + 1] for k in ("--output", "--decisions", "--trajectory")}}
shutil.copy("{trajectory}", out["--trajectory"])
shutil.copy("{graph}", out["--output"])
shutil.copy("{decisions}", out["--decisions"])
if "--save-map" in args:
    open(args[args.index("--save-map") + 1], "w").write("a saved map")
print("log            x: {scans} scans, 290.0 s")
print("nodes          6 in 1 submaps")
print("loop search    10 node-submap pairs, 1.00 ms each (0.01 s on 2 threads)")
print("candidates     3 in 3 clusters")
print("accepted       2")
print("rejected       1")
print("time           2.00 s (local SLAM 1.00, loop search 0.50, RRR 0.50), 145.0x real time")
"""

# rrr_offline: every verifier accepts the first and the third loop (the true one and the one 0.6 m
# off), but pcm accepts the second as well.
OFFLINE = """#!{python}
import sys
args = sys.argv
rows = ["0\\t3\\t0\\taccepted", "1\\t5\\t1\\t" + ("accepted" if "pcm" in args else "rejected"),
        "2\\t5\\t2\\taccepted"]
assert args[args.index("--cluster-gap") + 1] == "10"
open(args[args.index("--decisions") + 1], "w").write(
    "from\\tto\\tcluster\\tverdict\\n" + "".join(r + "\\n" for r in rows))
print("time           0.25 s")
print("optimizations  3")
"""

MAP_INFO = """#!{python}
import shutil, sys
assert open(sys.argv[1]).read() == "a saved map"
shutil.copy("{nodes}", sys.argv[sys.argv.index("--trajectory") + 1])
"""


def executable(path, text):
    path.write_text(text)
    path.chmod(path.stat().st_mode | stat.S_IEXEC)
    return str(path)


def write_run(tmp_path, poses):
    """The stand-in's graph (nodes at six scans, three loops between the laps, the last 0.6 m
    off), decisions
    (accepted, rejected, accepted) and the nodes' scan timestamps."""
    half = len(poses) // 2
    # The second lap's scans: one at the first's place, one well past the first corner (a loop
    # across a 90-degree turn, which a wrong laser offset would bend).
    scans = [1, 4, 8, half + 1, half + 4, half + 30]
    graph = "".join(f"VERTEX_SE2 {k} {poses[i][0]} {poses[i][1]} {poses[i][2]}\n"
                    for k, i in enumerate(scans))
    info = "100 0 0 100 0 1000"
    for k in range(len(scans) - 1):
        m = between(poses[scans[k]], poses[scans[k + 1]])
        graph += f"EDGE_SE2 {k} {k + 1} {m[0]} {m[1]} {m[2]} {info}\n"
    for a, b, offset in ((0, 3, 0.0), (1, 5, 0.0), (2, 5, 0.6)):
        m = compose(between(poses[scans[a]], poses[scans[b]]), (offset, 0.0, 0.0))
        graph += f"EDGE_SE2 {a} {b} {m[0]} {m[1]} {m[2]} {info}\n"
    (tmp_path / "graph.g2o").write_text(graph)
    (tmp_path / "decisions.tsv").write_text(
        "from\tto\tcluster\tverdict\treason\n0\t3\t0\taccepted\tx\n"
        "1\t5\t1\trejected\tx\n2\t5\t2\taccepted\tx\n")
    write_tum(tmp_path / "all_nodes.txt", poses)
    lines = (tmp_path / "all_nodes.txt").read_text().splitlines()
    (tmp_path / "nodes.txt").write_text("".join(lines[i] + "\n" for i in scans))


def laser_line(pose, t, laser_ahead):
    """A FLASER line of the room seen from `pose`, the laser `laser_ahead` m ahead of the robot."""
    laser = compose(pose, (laser_ahead, 0.0, 0.0))
    ranges = cast(laser)
    return ("FLASER %d %s %.6f %.6f %.6f %.6f %.6f %.6f %.6f nohost %.6f\n"
            % (len(ranges), " ".join(f"{r:.3f}" for r in ranges), *laser, *pose, 100.0 + t, t))


def bench(tmp_path, align=None, corrected_every=1, laser_ahead=0.0, extra=()):
    """bench_slam on the two-lap room as FR079 (with a corrected log holding every
    `corrected_every`-th scan at its true pose) and FR clinic (without); returns the main table's
    rows by log and the whole output."""
    poses = two_laps()
    half = len(poses) // 2
    lines = [laser_line(p, float(k), laser_ahead) for k, p in enumerate(poses)]
    data = tmp_path / "data"
    data.mkdir()
    for name, text in (("fr079.clf.gz", "".join(lines)),
                       ("freiburg-079-corrected.log.gz", "".join(lines[::corrected_every])),
                       ("fr-clinic_robotlaser.clf.gz", "".join(lines))):
        with gzip.open(data / name, "wt") as f:
            f.write(text)
    bent = tmp_path / "bent.txt"
    write_tum(bent, poses[:half] + [compose((0.6, 0.0, 0.0), p) for p in poses[half:]])
    write_run(tmp_path, poses)
    slam = executable(tmp_path / "slam_offline", STAND_IN.format(
        python=sys.executable, trajectory=bent, scans=len(poses), graph=tmp_path / "graph.g2o",
        decisions=tmp_path / "decisions.tsv"))
    map_info = executable(tmp_path / "map_info", MAP_INFO.format(python=sys.executable,
                                                                  nodes=tmp_path / "nodes.txt"))
    offline = executable(tmp_path / "offline", OFFLINE.format(python=sys.executable))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["--slam-offline", slam, *(["--align-scans", align] if align else []),
                     "--map-info", map_info, "--verifiers", offline, "--data", str(data),
                     "--cache", str(tmp_path / "cache"), "--logs", "fr079", "fr-clinic",
                     "--", *extra]) == 0
    main_table = out.getvalue().split("\n\n")[0]
    header = [c.strip() for c in main_table.splitlines()[0].split("|")[1:-1]]
    rows = {line.split("|")[1].strip(): dict(zip(header, [c.strip() for c in line.split("|")[1:-1]]))
            for line in main_table.splitlines() if line.startswith("| fr")}
    return rows, out.getvalue()


@pytest.mark.skipif(not ALIGN, reason="rrr_align_scans not given")
def test_the_table_reports_ate_and_inconsistent_revisits(tmp_path):
    rows, _ = bench(tmp_path, ALIGN)
    fr079, clinic = rows["fr079"], rows["fr-clinic"]
    assert float(fr079["ATE vs corrected"].split()[0]) == pytest.approx(0.3, abs=0.02)
    match = re.match(r"(\d+) of (\d+), worst 0\.(5|6)", fr079["inconsistent revisits"])
    count, aligned = int(match.group(1)), int(match.group(2))
    assert count >= 0.8 * aligned >= 4
    assert int(fr079["off the reference"].split(",")[0]) >= count
    assert fr079["× real time"] == "145.0"
    # Without a corrected log: the check still runs, the reference columns stay empty.
    assert clinic["ATE vs corrected"] == "–" and clinic["off the reference"] == "–"
    assert clinic["inconsistent revisits"].startswith(f"{count} of {aligned}")
    assert os.path.exists(tmp_path / "cache" / "fr079" / "traj.txt")


@pytest.mark.parametrize("corrected_every, laser_ahead", [(1, 0.0), (3, 0.2)])
def test_the_candidates_are_labelled_by_the_corrected_log_not_by_the_map(
        tmp_path, corrected_every, laser_ahead):
    # The map's second lap is 0.6 m off; the labels come from the corrected (true) poses, every
    # scan or every third one (the others bridged from them), of a laser 0.2 m ahead.
    rows, out = bench(tmp_path, corrected_every=corrected_every, laser_ahead=laser_ahead)
    fr079, clinic = rows["fr079"], rows["fr-clinic"]
    assert fr079["candidates"] == "3" and fr079["accepted"] == "2"
    assert fr079["by the reference: true / false"] == "2 / 1"
    assert fr079["RRR precision / recall (reference)"] == \
        "0.500 / 0.500; worst false accepted 0.60 m / 0.0°"
    assert clinic["by the reference: true / false"] == "–"
    assert fr079["ATE vs corrected"] == "–"  # no scan check without rrr_align_scans
    # Six nodes: no pair of nodes 100 steps apart to measure local SLAM's drift by.
    assert fr079["local SLAM's turn drift (rad per node step)"] == "–"
    # The verifiers table: the labelled log only, each verifier scored on the same labels.
    labels = (tmp_path / "cache" / "fr079" / "candidates.labels").read_text()
    assert labels == "0 3 1\n1 5 1\n2 5 0\n"
    verifiers = {line.split("|")[2].strip(): [c.strip() for c in line.split("|")[3:-1]]
                 for line in out.split("each verifier")[1].splitlines()
                 if line.startswith("| fr079 | ")}
    assert set(verifiers) == {"rrr", "pcm", "scgp", "gnc tls", "gnc gm"}
    assert verifiers["rrr"] == ["0.500", "0.500", "1", "1", "0.25"]
    assert verifiers["pcm"] == ["0.667", "1.000", "1", "0", "0.25"]
    assert "| fr-clinic | rrr" not in out


def test_a_map_that_is_not_the_runs_own_is_not_labelled(tmp_path):
    rows, out = bench(tmp_path, extra=["--lifelong"])
    assert rows["fr079"]["by the reference: true / false"] == "–"
    assert "| fr079 | rrr" not in out
