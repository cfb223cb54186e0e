"""The relation metric (Kümmerle et al. 2009) on hand-made trajectories."""
import math

import pytest
from rrr_graphslam.relations import read_relations, read_tum, relation_error


def write_tum(path, rows):
    path.write_text("# t x y z qx qy qz qw\n" + "".join(
        f"{t} {x} {y} 0 0 0 {math.sin(a / 2)} {math.cos(a / 2)}\n" for t, x, y, a in rows))


def test_perfect_and_offset_trajectories(tmp_path):
    write_tum(tmp_path / "t.txt", [(1.0, 0, 0, 0), (2.0, 1, 0, math.pi / 2), (3.0, 1, 1, math.pi / 2)])
    (tmp_path / "r.txt").write_text("1.0 2.0 1 0 0 0 0 1.5707963\n2.0 3.0 1 0 0 0 0 0\n"
                                    "2.0 9.0 1 0 0 0 0 0\n")
    stamps, poses = read_tum(str(tmp_path / "t.txt"))
    assert poses[1] == pytest.approx((1, 0, math.pi / 2))
    err = relation_error(stamps, poses, read_relations(str(tmp_path / "r.txt")))
    assert err.count == 2 and err.missing == 1
    assert err.trans_mean == pytest.approx(0.0, abs=1e-6)
    # The relation says 1.1 m where the trajectory has 1 m: 0.1 m error on one of two relations.
    (tmp_path / "r2.txt").write_text("1.0 2.0 1 0 0 0 0 1.5707963\n2.0 3.0 1.1 0 0 0 0 0\n")
    err = relation_error(stamps, poses, read_relations(str(tmp_path / "r2.txt")))
    assert err.trans_mean == pytest.approx(0.05, abs=1e-6)
    assert err.trans_std == pytest.approx(0.05, abs=1e-6)


def test_malformed_files_name_the_line(tmp_path):
    from rrr_graphslam.graph_io import GraphFileError
    (tmp_path / "bad.txt").write_text("1 2 3\n")
    with pytest.raises(GraphFileError, match="bad.txt:1"):
        read_tum(str(tmp_path / "bad.txt"))
    with pytest.raises(GraphFileError, match="bad.txt:1"):
        read_relations(str(tmp_path / "bad.txt"))


def test_squares_and_no_match(tmp_path):
    write_tum(tmp_path / "t.txt", [(1.0, 0, 0, 0), (2.0, 1, 0, 0), (3.0, 2, 0, 0)])
    stamps, poses = read_tum(str(tmp_path / "t.txt"))
    # 0.1 m and 0.3 m off, 2 and 4 degrees off.
    relations = [(1.0, 2.0, (1.1, 0.0, math.radians(2.0))), (2.0, 3.0, (1.3, 0.0, math.radians(-4.0)))]
    err = relation_error(stamps, poses, relations)
    assert err.trans_sq_mean == pytest.approx((0.01 + 0.09) / 2)
    assert err.rot_mean_deg == pytest.approx(3.0) and err.rot_std_deg == pytest.approx(1.0)
    assert err.rot_sq_mean_deg2 == pytest.approx((4.0 + 16.0) / 2)
    none = relation_error(stamps, poses, [(7.0, 8.0, (0.0, 0.0, 0.0))])
    assert none.count == 0 and none.missing == 1 and math.isnan(none.trans_mean) and math.isnan(none.rot_std_deg)
