"""CARMEN reader: the three message types, the FLASER angle convention, misses, file:line errors,
and the ROS-independent timestamp repair."""
import gzip
import math
import os

import pytest

from conftest import DATA
from rrr_graphslam.carmen import flaser_increment, monotonic_stamps, odometry_stream, read_carmen
from rrr_graphslam.graph_io import GraphFileError, between

ROBOTLASER = ("ROBOTLASER1 0 -1.570796 3.141593 0.017453 81.900000 0.010000 0 3 1.0 81.91 2.0 0 "
              "0.1 0.0 0.0 0.0 0.0 0.0 0.2 0.0 1.0 1.0 0.5 12.5 host 0.0\n")


def write(tmp_path, text, name="log.clf"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_flaser_beams_fall_on_whole_or_half_degrees():
    assert math.degrees(flaser_increment(180)) == pytest.approx(1.0)
    assert math.degrees(flaser_increment(181)) == pytest.approx(1.0)
    assert math.degrees(flaser_increment(360)) == pytest.approx(0.5)
    assert math.degrees(flaser_increment(361)) == pytest.approx(0.5)


def test_reads_every_message_type_in_log_order(tmp_path):
    log = read_carmen(write(tmp_path, "# comment\nPARAM x 1 nohost 0\n"
                                      "ODOM 1 2 0.5 0.3 0.1 0 10.0 host 0\n"
                                      "FLASER 4 1 2 3 4 1 2 0.5 1 2 0.5 10.5 host 0\n" + ROBOTLASER))
    assert [type(r).__name__ for r in log.records] == ["OdomRecord", "LaserRecord", "LaserRecord"]
    flaser, robot = log.lasers
    assert flaser.timestamp == 10.5 and flaser.angle_min == pytest.approx(-math.pi / 2)
    assert flaser.max_range == 4.0  # FLASER: the log's largest reading
    assert robot.max_range == pytest.approx(81.9) and robot.ranges == [1.0, 81.91, 2.0]
    assert robot.timestamp == 12.5 and robot.laser_pose == (0.1, 0.0, 0.0)
    assert log.odometry[0].pose == (1.0, 2.0, 0.5) and log.odometry[0].tv == 0.3
    assert log.laser_offset() == pytest.approx((0.0, 0.0, 0.0))


@pytest.mark.parametrize("line, words", [
    ("FLASER 4 1 2 3\n", "4 readings need"),
    ("FLASER 2 1 nan 0 0 0 0 0 0 1 h 0\n", "not finite"),
    ("ODOM 1 2 x 0 0 0 1 h 0\n", "could not convert"),
    ("ODOM 1 2\n", "at least 8 fields"),
    # A reading count one off would shift every later field: refused, as the C++ reader does.
    ("FLASER 2 1 2 3 0 0 0 0 0 0 1 h 1\n", "2 readings need 13 fields, found 14"),
    ("FLASER 4 1 2 3 0 0 0 0 0 0 1 h 1\n", "4 readings need 15 fields, found 14"),
    ("ROBOTLASER1 0 -1.5 3.0 0.5 20.0 0.1 0 4 1 2 3 4 99999999999999999999 0 0 0 0 0 0 0 0 0 0 0 1 h 1\n",
     "expected"),
    ("ROBOTLASER1 0 -1.5 3.0 0.5 20.0 0.1 0 99999999999999999999 1 2\n", "does not fit"),
])
def test_malformed_lines_name_file_and_line(tmp_path, line, words):
    path = write(tmp_path, "ODOM 0 0 0 0 0 0 1 h 0\n" + line)
    with pytest.raises(GraphFileError) as e:
        read_carmen(path)
    assert str(e.value).startswith(f"{path}:2:") and words in str(e.value)


def test_log_without_scans_is_refused(tmp_path):
    with pytest.raises(GraphFileError, match="no FLASER"):
        read_carmen(write(tmp_path, "ODOM 0 0 0 0 0 0 1 h 0\n"))


def test_stamps_that_go_back_are_moved_just_past_the_previous():
    stamps, moved = monotonic_stamps([1.0, 2.0, 1.5, 1.7, 3.0])
    assert moved == 2 and stamps[2] > 2.0 and stamps[3] > stamps[2] and stamps[4] == 3.0


def test_bundled_aces_head():
    log = read_carmen(os.path.join(DATA, "carmen", "aces_head.clf.gz"))
    assert len(log.lasers) > 250 and all(len(r.ranges) == 180 for r in log.lasers)
    assert log.max_range == pytest.approx(50.0)
    assert len(odometry_stream(log)) == len(log.odometry) > 250


def test_a_moved_log_is_the_same_run_seen_from_another_frame(tmp_path):
    from rrr_graphslam.carmen import write_moved_log
    source = os.path.join(DATA, "carmen", "aces_head.clf.gz")
    target = tmp_path / "moved.clf"
    frame = (10.0, -5.0, 2.0)
    write_moved_log(source, str(target), frame, later=100.0)
    a, b = read_carmen(source), read_carmen(str(target))
    assert len(a.lasers) == len(b.lasers) and len(a.odometry) == len(b.odometry)
    c, s = math.cos(frame[2]), math.sin(frame[2])
    for r, m in zip(a.lasers, b.lasers):
        assert m.timestamp == pytest.approx(r.timestamp + 100.0)
        assert m.ranges == r.ranges
        x, y, t = r.odom_pose
        assert m.odom_pose[0] == pytest.approx(frame[0] + c * x - s * y)
        assert m.odom_pose[1] == pytest.approx(frame[1] + s * x + c * y)
        # The laser's pose on the robot is unchanged.
        assert between(m.odom_pose, m.laser_pose) == pytest.approx(between(r.odom_pose, r.laser_pose), abs=1e-9)
    assert b.odometry[0].timestamp == pytest.approx(a.odometry[0].timestamp + 100.0)


def test_the_way_back_alone_is_the_rest_of_a_there_and_back_drive(tmp_path):
    from rrr_graphslam.carmen import write_there_and_back_log
    source = os.path.join(DATA, "carmen", "aces_head.clf.gz")
    both, back = tmp_path / "both.clf", tmp_path / "back.clf"
    write_there_and_back_log(source, str(both))
    write_there_and_back_log(source, str(back), part="back")
    a, b, r = read_carmen(source), read_carmen(str(both)), read_carmen(str(back))
    assert len(b.lasers) == 2 * len(a.lasers) and len(r.lasers) == len(a.lasers)
    # The way back: the scans of the way there in reverse order, after its last stamp.
    assert [s.ranges for s in r.lasers] == [s.ranges for s in reversed(a.lasers)]
    assert [s.timestamp for s in r.lasers] == [s.timestamp for s in b.lasers[len(a.lasers):]]
    assert r.lasers[0].timestamp > a.lasers[-1].timestamp
    with pytest.raises(ValueError, match="part"):
        write_there_and_back_log(source, str(back), part="there")
