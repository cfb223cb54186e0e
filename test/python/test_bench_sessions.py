"""The multi-session benchmark's pure parts (scripts/bench_sessions): splitting a log into moved
sessions, the ground truth from corrected scans, reading the tools' outputs, and scoring
inter-session loops, mapped space and scans carried by their nodes."""
import math

import pytest
from rrr_graphslam.bench_sessions import (GroundTruth, Loop, RawScan, accepted_loops, decided_loops,
                                          check_loops, known_false_loops,
                                          online_false_accepts, session_components,
                                          cross_relations, mapped_space_entry,
                                          mapped_space_nodes, parse_map_info,
                                          parse_summary, place_scans, random_transforms,
                                          session_of_node, split_lines, write_sessions)
from rrr_graphslam.decision_stream import StreamRow
from rrr_graphslam.graph_io import between, compose


def flaser(t, pose, odom=None, ranges=(1.0, 2.0, 3.0, 4.0)):
    odom = odom or pose
    return ("FLASER %d %s %.6f %.6f %.6f %.6f %.6f %.6f %.6f nohost %.6f\n"
            % (len(ranges), " ".join(f"{r:.2f}" for r in ranges), *pose, *odom, 100.0 + t, t))


def test_transforms_are_seeded_and_the_first_session_stays():
    a, b = random_transforms(1, 4), random_transforms(1, 4)
    assert a == b and len(a) == 4
    assert a[0] == (0.0, 0.0, 0.0)
    assert all(abs(x) <= 100 and abs(y) <= 100 and -math.pi < t <= math.pi for x, y, t in a[1:])
    assert random_transforms(2, 4)[1] != a[1]


def test_sessions_are_written_split_and_moved(tmp_path):
    log = tmp_path / "log.clf"
    log.write_text("PARAM robot_frontlaser_offset 0.0 nohost 0\n" +
                   "".join(flaser(float(t), (0.5 * t, 0.0, 0.1 * t), (0.5 * t, 0.0, 0.1 * t)) for t in range(8)) +
                   "ODOM 3.5 0.0 0.7 0.1 0.0 0.0 107.5 nohost 7.5\n")
    parts, transforms = write_sessions(str(log), str(tmp_path), 2, 7)
    assert transforms == random_transforms(7, 2) and transforms[0] == (0.0, 0.0, 0.0)
    first = (tmp_path / "part_0.clf").read_text().splitlines()
    assert first == log.read_text().splitlines()[:5]  # the header, then t = 0..3 as logged
    second = [line.split() for line in (tmp_path / "part_1.clf").read_text().splitlines()]
    assert second[0] == ["PARAM", "robot_frontlaser_offset", "0.0", "nohost", "0"]
    assert [f[0] for f in second[1:]] == ["FLASER"] * 4 + ["ODOM"]
    T = transforms[1]
    for f, t in zip(second[1:5], range(4, 8)):
        laser, odom = tuple(map(float, f[6:9])), tuple(map(float, f[9:12]))
        expected = compose(T, (0.5 * t, 0.0, 0.1 * t))
        assert laser[:2] == pytest.approx(expected[:2]) and odom[:2] == pytest.approx(expected[:2])
        assert math.remainder(laser[2] - expected[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
        assert float(f[12]) == pytest.approx(100.0 + t)  # ipc timestamp as logged
    assert tuple(map(float, second[5][1:3])) == pytest.approx(compose(T, (3.5, 0.0, 0.7))[:2])
    assert not list(tmp_path.glob("*.tmp")) and not list(tmp_path.glob("*.moved"))


def test_split_by_logger_time_copies_the_header_and_never_goes_back():
    header = ["# message formats\n", "PARAM robot_frontlaser_offset 0.0 nohost 0\n"]
    body = [flaser(t, (t, 0.0, 0.0)) for t in (0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0)]
    body.insert(5, flaser(3.5, (9.0, 0.0, 0.0)))  # logger time back in part 1: stays there
    body.insert(7, "# a comment\n")
    parts = split_lines(header + body, 2)
    assert [p[:2] for p in parts] == [header, header]
    times = [[float(line.split()[-1]) for line in p[2:] if line.startswith("FLASER")] for p in parts]
    assert times == [[0.0, 1.0, 2.0, 3.0], [4.0, 3.5, 5.0, 6.0, 7.0, 8.0]]
    assert sum(len(p) - 2 for p in parts) == len(body)  # every line once
    four = split_lines(header + body, 4)
    assert [len([line for line in p if line.startswith("FLASER")]) for p in four] == [2, 2, 3, 3]


def raw_scans(odometry):
    return [RawScan(100.0 + k, float(k), pose, (float(k),)) for k, pose in enumerate(odometry)]


def test_ground_truth_from_corrected_scans_blends_between_them():
    # The robot drives along x, 1 m per scan; the odometry says 1.1 m. Corrected scans 0 and 4
    # (matched by their ranges, whatever their stamps) are in another frame.
    raw = raw_scans([(1.1 * k, 0.0, 0.0) for k in range(6)])
    frame = (5.0, 5.0, math.pi / 2)
    corrected = [(0.3, compose(frame, (0.0, 0.0, 0.0)), (0.0,)),
                 (4.2, compose(frame, (4.0, 0.0, 0.0)), (4.0,)),
                 (9.9, (0.0, 0.0, 0.0), (42.0,))]  # no raw scan has these ranges
    truth = GroundTruth(raw, corrected)
    assert truth.matched == 2
    assert truth.pose_of_scan(4) == pytest.approx(compose(frame, (4.0, 0.0, 0.0)))
    # Halfway: 2.2 m from scan 0, 2.2 m back from scan 4 -> 1.8; blended 0.5/0.5 -> 2.0.
    assert between(truth.pose_of_scan(0), truth.pose_of_scan(2)) == pytest.approx((2.0, 0.0, 0.0))
    # After the last corrected scan: the odometry from it.
    assert between(truth.pose_of_scan(4), truth.pose_of_scan(5)) == pytest.approx((1.1, 0.0, 0.0))
    assert truth.pose(102.0) == truth.pose_of_scan(2) and truth.pose(102.5) is None
    # A local trajectory's motion replaces the odometry where it has both scans.
    local = [(float(k), 0.0, 0.0) for k in range(6)]
    local[3] = None
    exact = GroundTruth(raw, corrected, local)
    assert between(exact.pose_of_scan(0), exact.pose_of_scan(1)) == pytest.approx((1.0, 0.0, 0.0))
    assert between(exact.pose_of_scan(4), exact.pose_of_scan(5)) == pytest.approx((1.0, 0.0, 0.0))


SUMMARY = """loaded map     /tmp/s0.rrrmap: 1 sessions, 1426 nodes, 12 submaps in 0.39 s
log            /tmp/part_1.clf: 3804 scans, 682.7 s
nodes          2896 in 25 submaps
loop search    899 node-submap pairs, 32.57 ms each (16.81 s on 2 threads)
candidates     120 in 75 clusters
accepted       42
rejected       78
session 0      s0: 1426 nodes, 1502 edges, 3 accepted loops to other sessions
session 1      s1: 1470 nodes, 1589 edges, 3 accepted loops to other sessions
relocalized    at node 1467 (the session's node 41, 20.3 s after its start)
time           26.53 s (local SLAM 6.93, loop search 16.81, RRR 2.30), 25.7x real time
saved map      /tmp/s1.rrrmap in 0.11 s
"""


def test_summary_and_map_info_are_read():
    s = parse_summary(SUMMARY)
    assert (s.scans, s.nodes, s.candidates, s.accepted) == (3804, 2896, 120, 42)
    assert (s.load_s, s.save_s, s.time_s) == (0.39, 0.11, 26.53)
    assert (s.relocalized, s.tied_node, s.tied_after_s, s.crossing_accepted) == ("at", 41, 20.3, 3)
    tied = "relocalized    at node 1467 (the session's node 41, 20.3 s after its start)"
    s = parse_summary(SUMMARY.replace(tied, "relocalized    no"))
    assert s.relocalized == "no" and s.tied_node is None
    s = parse_summary(SUMMARY.replace(
        tied, "relocalized    only by the final decision"))
    assert s.relocalized == "final" and s.tied_node is None
    s = parse_summary("log            a.clf: 10 scans, 1.0 s\nnodes          5 in 1 submaps\n")
    assert s.relocalized is None and math.isnan(s.load_s) and math.isnan(s.save_s)

    info = parse_map_info("format_version 1\nsessions 2\nnodes 30\nbytes 1234\n"
                          "session 0 nodes 10 start_time 70.0 name s0\n"
                          "session 1 nodes 20 start_time 90.0 name s1\nparam scan_max_range 30\n")
    assert (info.nodes, info.bytes, info.session_nodes, info.first_nodes()) == (30, 1234, [10, 20], [0, 10])
    of = session_of_node(info.first_nodes())
    assert [of(0), of(9), of(10), of(29)] == [0, 0, 1, 1]


def test_accepted_loops_take_the_candidate_not_the_odometry(tmp_path):
    # Sessions 0: nodes 0-2, 1: nodes 3-4; the candidate 2 -> 3 joins consecutive ids.
    (tmp_path / "g.g2o").write_text(
        "".join(f"VERTEX_SE2 {k} {k} 0 0\n" for k in range(5)) +
        "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
        "EDGE_SE2 3 4 1 0 0 1 0 0 1 0 1\n"
        "EDGE_SE2 2 3 0.9 0 0 1 0 0 1 0 1\nEDGE_SE2 0 4 4.2 0 0 1 0 0 1 0 1\n"
        "EDGE_SE2 0 4 9 0 0 1 0 0 1 0 1\n")
    (tmp_path / "d.tsv").write_text("from\tto\tcluster\tverdict\treason\n2\t3\t0\taccepted\tx\n"
                                    "0\t4\t1\taccepted\tx\n0\t4\t2\trejected\tx\n")
    loops = accepted_loops(str(tmp_path / "g.g2o"), str(tmp_path / "d.tsv"))
    assert [(l.source, l.target, l.measurement[0]) for l in loops] == [(2, 3, 0.9), (0, 4, 4.2)]
    every = decided_loops(str(tmp_path / "g.g2o"), str(tmp_path / "d.tsv"))
    assert [(l.source, l.target, l.measurement[0], v) for l, v in every] == [
        (2, 3, 0.9, "accepted"), (0, 4, 4.2, "accepted"), (0, 4, 9.0, "rejected")]


def test_inter_session_loops_are_scored_against_the_truth():
    stamps = [0.0, 1.0, 2.0, 3.0, 4.0]
    truth_poses = {t: (t, 0.0, 0.0) for t in stamps}
    of = session_of_node([0, 3])
    loops = [Loop(2, 3, (1.0, 0.0, 0.0)),                       # inter-session, right
             Loop(0, 4, (4.0, 0.6, 0.0)),                       # inter-session, 0.6 m off
             Loop(0, 3, (3.0, 0.0, math.radians(12))),          # inter-session, 12 degrees off
             Loop(0, 2, (2.0, 0.0, 0.0)),                       # in session 0
             Loop(1, 4, (3.0, 0.0, 0.0))]
    check = check_loops(loops, stamps, of, lambda t: truth_poses.get(t if t != 1.0 else -1), 0.5, 10.0)
    assert (check.inter_session, check.inter_session_false) == (4, 2)
    assert (check.checked, check.false, check.unknown) == (4, 2, 1)
    only = check_loops(loops, stamps, of, truth_poses.get, 0.5, 10.0, involving=0)
    assert only.inter_session == 4
    assert check_loops(loops, stamps, of, truth_poses.get, 0.5, 10.0, involving=2).inter_session == 0


def test_false_inter_session_loops_are_scored_as_the_run_decided_them():
    stamps = [0.0, 1.0, 2.0, 3.0, 4.0]
    truth_poses = {t: (t, 0.0, 0.0) for t in stamps}
    of = session_of_node([0, 3])
    loops = [Loop(2, 3, (1.0, 0.0, 0.0)),     # 0: inter-session, right
             Loop(0, 4, (4.0, 0.6, 0.0)),     # 1: inter-session, 0.6 m off
             None,                            # 2: not in the graph
             Loop(0, 2, (2.0, 3.0, 0.0)),     # 3: in session 0, off (not this session's)
             Loop(1, 3, (9.0, 0.0, 0.0))]     # 4: inter-session, off
    known = known_false_loops(loops, stamps, of, truth_poses.get, 0.5, 10.0, involving=1)
    assert known == [False, True, False, False, True]

    def row(nodes, candidate, previous, verdict, final=False):
        return StreamRow(final, nodes, float(nodes), candidate, previous, verdict)
    rows = [row(10, 1, "pending", "pending"), row(12, 1, "pending", "accepted"),
            row(13, 0, "pending", "accepted"), row(15, 4, "pending", "accepted"),
            row(20, 1, "accepted", "rejected"), row(22, 4, "accepted", "rejected"),  # one of them 12-22
            row(30, 4, "rejected", "accepted"),                                       # again from 30
            row(40, 4, "accepted", "rejected", final=True)]  # the final decision is not online
    assert online_false_accepts(rows, known, 45) == (2, 10 + 15)
    assert online_false_accepts(rows[:6], known, 45) == (2, 10)
    assert online_false_accepts([], known, 45) == (0, 0)


def test_mapped_space_is_the_first_node_near_an_earlier_session():
    positions = [(0.0, 0.0), (5.0, 0.0), (10.0, 0.0), None, (30.0, 0.0), (20.0, 0.5), (10.5, 0.5), (5.0, 0.0)]
    assert mapped_space_entry(positions, 3, 8, 1.0) == 3   # node 6, 0.71 m from node 2
    assert mapped_space_entry(positions, 3, 6, 1.0) is None
    assert mapped_space_entry(positions, 0, 3, 1.0) is None
    # A session leaves mapped space and enters it again: node 7 is back at node 1's place.
    assert mapped_space_nodes(positions, 3, 8, 1.0) == [3, 4]
    assert mapped_space_nodes(positions, 3, 8, 0.5) == [4]
    assert mapped_space_nodes(positions, 0, 3, 1.0) == []
    # In, out, in again: the count skips the nodes away from the map.
    away = [(0.0, 0.0), (5.0, 0.0), (0.3, 0.0), (40.0, 0.0), (50.0, 0.0), (5.2, 0.1)]
    assert mapped_space_nodes(away, 2, 6, 1.0) == [0, 3]


def test_scans_keep_their_offset_from_their_node():
    node_stamps = [1.0, 3.0]
    then = [(0.0, 0.0, 0.0), (2.0, 0.0, 0.0)]
    now = [(10.0, 0.0, math.pi / 2), (10.0, 2.0, math.pi / 2)]
    scans = [(1.0, (0.0, 0.0, 0.0)), (2.0, (1.0, 0.1, 0.0)), (3.0, (2.0, 0.0, 0.0)), (4.0, (2.5, 0.0, 0.1))]
    placed = place_scans([t for t, _ in scans], [p for _, p in scans], node_stamps, then, now)
    assert placed[0] == pytest.approx(now[0])
    assert placed[1] == pytest.approx((9.9, 1.0, math.pi / 2))
    assert placed[2] == pytest.approx(now[1])
    assert placed[3] == pytest.approx((10.0, 2.5, math.pi / 2 + 0.1))


def test_cross_relations_have_their_ends_in_different_sessions():
    sessions = {1.0: 0, 2.0: 0, 3.0: 1}
    relations = [(1.0, 2.0, (0, 0, 0)), (2.0, 3.0, (0, 0, 0)), (3.0, 9.0, (0, 0, 0))]
    assert cross_relations(relations, sessions.get) == [relations[1]]


def test_sessions_joined_by_accepted_loops():
    of = session_of_node([0, 10, 20, 30])
    loops = [Loop(1, 12, (0, 0, 0)), Loop(25, 35, (0, 0, 0)), Loop(3, 5, (0, 0, 0))]
    assert session_components(loops, of, 4) == [[0, 1], [2, 3]]
    assert session_components([], of, 3) == [[0], [1], [2]]
