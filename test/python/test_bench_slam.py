"""scripts/bench_slam's table: the ATE against a corrected log and the scan-consistency columns,
with a stand-in for rrr_slam_offline that maps the synthetic two-lap room (test_evaluate_slam)
with its second lap shifted by 0.6 m. Needs rrr_align_scans (RRR_ALIGN_SCANS)."""
import contextlib
import gzip
import io
import os
import re
import stat
import sys

import pytest
from rrr_graphslam.bench_slam import main
from rrr_graphslam.graph_io import compose
from test_evaluate_slam import ALIGN, cast, flaser, two_laps, write_tum

STAND_IN = """#!{python}
import shutil, sys
args = sys.argv
out = {{k: args[args.index(k) + 1] for k in ("--output", "--decisions", "--trajectory")}}
shutil.copy("{trajectory}", out["--trajectory"])
open(out["--output"], "w").write("VERTEX_SE2 0 0 0 0\\nVERTEX_SE2 1 1 0 0\\n"
                                 "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\\n")
open(out["--decisions"], "w").write("from\\tto\\tcluster\\tverdict\\treason\\n")
print("log            x: {scans} scans, 290.0 s")
print("nodes          {scans} in 1 submaps")
print("loop search    10 node-submap pairs, 1.00 ms each (0.01 s on 2 threads)")
print("candidates     0 in 0 clusters")
print("accepted       0")
print("rejected       0")
print("time           2.00 s (local SLAM 1.00, loop search 0.50, RRR 0.50), 145.0x real time")
"""


@pytest.mark.skipif(not ALIGN, reason="rrr_align_scans not given")
def test_the_table_reports_ate_and_inconsistent_revisits(tmp_path):
    poses = two_laps()
    half = len(poses) // 2
    text = "".join(flaser(cast(p), p, float(k)) for k, p in enumerate(poses))
    data = tmp_path / "data"
    data.mkdir()
    for name in ("fr079.clf.gz", "freiburg-079-corrected.log.gz", "fr-clinic_robotlaser.clf.gz"):
        with gzip.open(data / name, "wt") as f:
            f.write(text)
    bent = tmp_path / "bent.txt"
    write_tum(bent, poses[:half] + [compose((0.6, 0.0, 0.0), p) for p in poses[half:]])
    slam = tmp_path / "slam_offline"
    slam.write_text(STAND_IN.format(python=sys.executable, trajectory=bent, scans=len(poses)))
    slam.chmod(slam.stat().st_mode | stat.S_IEXEC)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["--slam-offline", str(slam), "--align-scans", ALIGN, "--data", str(data),
                     "--cache", str(tmp_path / "cache"), "--logs", "fr079", "fr-clinic"]) == 0
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[1:-1]]
            for line in out.getvalue().splitlines() if line.startswith("| fr")}
    header = [c.strip() for c in out.getvalue().splitlines()[0].split("|")[1:-1]]
    fr079 = dict(zip(header, rows["fr079"]))
    clinic = dict(zip(header, rows["fr-clinic"]))
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
