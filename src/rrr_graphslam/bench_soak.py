"""Soak benchmark (scripts/bench_soak): a CARMEN log replayed through the nodelet in slam mode,
several passes in a row (~reset between them), faster than real time. Per pass: scans processed,
nodes, wall time, the worker's processing time per batch (the status message's last_update_sec,
one per drained queue: about one scan at a time when the node keeps up), the largest backlog, and
the nodelet manager's memory (VmRSS at the end of the pass, VmHWM so far). A map that is reset
between passes needs the same memory each pass: growth from pass to pass is a leak."""

import argparse
import os
import socket
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from typing import List, Optional


@dataclass
class Pass:
    number: int
    scans: int = 0
    nodes: int = 0
    malformed: int = 0
    seconds: float = 0.0
    batch_ms: List[float] = field(default_factory=list)
    max_backlog: int = 0
    rss_mb: float = 0.0
    hwm_mb: float = 0.0


def proc_memory_mb(pid: int):
    """(VmRSS, VmHWM) of a process in MB, from /proc."""
    values = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, rest = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                values[key] = int(rest.split()[0]) / 1024.0
    return values.get("VmRSS", 0.0), values.get("VmHWM", 0.0)


def find_pid(needle: str) -> Optional[int]:
    """The process whose command line contains `needle`."""
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/cmdline", "rb") as f:
                if needle.encode() in f.read():
                    return int(entry)
        except OSError:
            continue
    return None


def percentile(values: List[float], q: float) -> float:
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def table(passes: List[Pass]) -> str:
    rows = ["| pass | scans | nodes | malformed | wall s | batch p50 / p99 / max ms | max backlog | RSS MB (end) | peak RSS MB |",
            "|---|---|---|---|---|---|---|---|---|"]
    for p in passes:
        rows.append(f"| {p.number} | {p.scans} | {p.nodes} | {p.malformed} | {p.seconds:.1f} | "
                    f"{percentile(p.batch_ms, 0.5):.2f} / {percentile(p.batch_ms, 0.99):.2f} / "
                    f"{max(p.batch_ms) if p.batch_ms else float('nan'):.2f} | {p.max_backlog} | "
                    f"{p.rss_mb:.1f} | {p.hwm_mb:.1f} |")
    if len(passes) > 1:
        rows.append("")
        rows.append(f"RSS at the end of the last pass minus the first: {passes[-1].rss_mb - passes[0].rss_mb:+.1f} MB")
    return "\n".join(rows)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--log", required=True, help="CARMEN log (e.g. intel.clf.gz)")
    parser.add_argument("--passes", type=int, default=5)
    parser.add_argument("--rate", type=float, default=10.0, help="multiple of real time (default 10)")
    parser.add_argument("--duration", type=float, default=0.0, help="s of the log per pass (0: all)")
    parser.add_argument("--replay", required=True, help="the replay_carmen script")
    args = parser.parse_args(argv)
    if not os.path.exists(args.log):
        print(f"bench_soak: {args.log}: no such file", file=sys.stderr)
        return 1

    # A master of our own, so that nothing else on this machine talks to the node.
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{free_port()}",
               ROSCONSOLE_STDOUT_LINE_BUFFERED="1")
    os.environ.update(env)
    children = []

    def start(cmd):
        p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
        children.append(p)
        return p

    try:
        port = env["ROS_MASTER_URI"].rsplit(":", 1)[1]
        start(["roscore", "-p", port])
        import rospy
        from std_srvs.srv import Trigger
        from rrr_graphslam.msg import RrrStatus
        deadline = time.monotonic() + 30
        while True:
            try:
                rospy.get_master().getPid()
                break
            except Exception:  # noqa: BLE001 (the master is not up yet)
                if time.monotonic() > deadline:
                    raise RuntimeError("roscore did not start")
                time.sleep(0.2)
        subprocess.run(["rosparam", "set", "/use_sim_time", "true"], env=env, check=True)
        start(["roslaunch", "rrr_graphslam", "rrr_graphslam.launch", "input_mode:=scan", "output:=log"])
        rospy.init_node("bench_soak")
        samples = {"status": None}
        current: List[Pass] = []

        def on_status(msg):
            samples["status"] = msg
            if current:
                current[-1].batch_ms.append(1e3 * msg.last_update_sec)
                current[-1].max_backlog = max(current[-1].max_backlog, msg.backlog)

        rospy.Subscriber("/rrr_graphslam/status", RrrStatus, on_status, queue_size=100)
        rospy.wait_for_service("/rrr_graphslam/reset", timeout=60)
        reset = rospy.ServiceProxy("/rrr_graphslam/reset", Trigger)
        finish = rospy.ServiceProxy("/rrr_graphslam/finish", Trigger)
        manager = None
        deadline = time.monotonic() + 30
        while manager is None and time.monotonic() < deadline:
            manager = find_pid("__name:=rrr_graphslam_manager")
            time.sleep(0.2)
        if manager is None:
            raise RuntimeError("the nodelet manager's process was not found")

        passes: List[Pass] = []
        for number in range(1, args.passes + 1):
            reset()
            p = Pass(number)
            current[:] = [p]
            start_time = time.monotonic()
            replay = [sys.executable, args.replay, args.log, "--rate", str(args.rate),
                      f"__name:=soak_replay_{number}"]
            if args.duration > 0:
                replay += ["--duration", str(args.duration)]
            result = subprocess.run(replay, env=env, capture_output=True, text=True)
            if result.returncode != 0:
                raise RuntimeError(f"replay failed: {result.stderr[-500:]}")
            deadline = time.monotonic() + 600
            while time.monotonic() < deadline:
                s = samples["status"]
                if s is not None and s.backlog == 0 and s.messages_processed == s.messages_received:
                    break
                time.sleep(0.1)
            finish()
            p.seconds = time.monotonic() - start_time
            s = samples["status"]
            p.scans, p.nodes, p.malformed = s.messages_processed, s.nodes, s.messages_malformed
            p.rss_mb, p.hwm_mb = proc_memory_mb(manager)
            current.clear()
            passes.append(p)
            print(f"[soak] pass {number}: {p.scans} scans, {p.nodes} nodes, {p.seconds:.1f} s, "
                  f"RSS {p.rss_mb:.1f} MB", file=sys.stderr)
        print(f"Soak: {os.path.basename(args.log)} x {args.passes} at {args.rate:g}x real time"
              + (f", {args.duration:g} s of log per pass" if args.duration > 0 else ""))
        print()
        print(table(passes))
        return 0
    except (RuntimeError, OSError) as e:
        print(f"bench_soak: {e}", file=sys.stderr)
        return 1
    finally:
        for p in reversed(children):
            try:
                os.killpg(p.pid, 2)
                p.wait(timeout=20)
            except Exception:  # noqa: BLE001 (best effort at exit)
                p.kill()


if __name__ == "__main__":
    sys.exit(main())
