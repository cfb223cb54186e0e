"""world_compare: a map against the true worlds of the sessions it was made in."""
import math

import numpy as np
import pytest

from rrr_graphslam.world_compare import (FREE, OCCUPIED, UNKNOWN, GridMap, align, compare,
                                         observed_cells, read_map_server, seen_as_now)


def room(box: bool) -> GridMap:
    """A 20 x 20 room of 0.1 m cells, walls around; with `box`, a 4 x 4 box in its middle."""
    cells = np.full((20, 20), FREE, dtype=int)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    if box:
        cells[8:12, 8:12] = OCCUPIED
    return GridMap(cells, 0.1, (0.0, 0.0))


def moved(world: GridMap, transform) -> GridMap:
    """The same cells seen from another frame: the map a SLAM run in `world` would make, its
    frame `transform` away (cells resampled at the map's centres)."""
    x, y = world.centres()
    tx, ty, th = transform
    c, s = math.cos(th), math.sin(th)
    wx, wy = tx + c * x - s * y, ty + s * x + c * y
    return GridMap(world.state_at(wx, wy), world.resolution, world.origin)


def test_align_recovers_a_rigid_transform():
    truth = (1.5, -2.0, 0.4)
    c, s = math.cos(truth[2]), math.sin(truth[2])
    poses = [(x, y, 0.0) for x, y in [(0, 0), (3, 1), (2, 5), (-1, 4)]]
    true = [(truth[0] + c * x - s * y, truth[1] + s * x + c * y, 0.0) for x, y, _ in poses]
    t = align(poses, true)
    assert t == pytest.approx(truth, abs=1e-9)


def test_a_map_of_the_world_now_agrees_and_a_stale_one_does_not():
    before, now = room(box=True), room(box=False)  # the box left
    up_to_date = compare(now, [before, now], (0.0, 0.0, 0.0))
    assert up_to_date.changed_cells == 16  # the box's cells, free now and in sight
    assert up_to_date.changed_agreement == 1.0
    assert up_to_date.static_f1 == pytest.approx(1.0)
    stale = compare(before, [before, now], (0.0, 0.0, 0.0))
    assert stale.changed_agree == 0 and stale.changed_unknown == 0
    # A box that appeared: only its faces can be seen (the inside is never observed).
    appeared = compare(before, [now, before], (0.0, 0.0, 0.0))
    assert appeared.changed_cells == 12 and appeared.changed_agreement == 1.0
    blank = GridMap(np.full((20, 20), UNKNOWN, dtype=int), 0.1, (0.0, 0.0))
    nothing = compare(blank, [before, now], (0.0, 0.0, 0.0))
    assert nothing.changed_unknown == nothing.changed_cells and nothing.changed_agree == 0


def test_the_map_frame_is_taken_into_account():
    now = room(box=False)
    transform = (0.5, 0.3, 0.0)  # whole cells: the resampled map is exact
    slam_map = moved(now, transform)
    assert compare(slam_map, [room(box=True), now], transform).changed_agreement == 1.0
    assert compare(slam_map, [room(box=True), now], (0.0, 0.0, 0.0)).static_f1 < 0.9


def test_map_server_files_are_read_as_map_server_reads_them(tmp_path):
    pgm = tmp_path / "w.pgm"
    pgm.write_bytes(b"P5\n# comment\n3 2\n255\n" + bytes([0, 254, 205, 254, 0, 254]))
    (tmp_path / "w.yaml").write_text("image: w.pgm\nresolution: 0.5\norigin: [1.0, 2.0, 0.0]\n"
                                     "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    m = read_map_server(str(tmp_path / "w.yaml"))
    assert m.resolution == 0.5 and m.origin == (1.0, 2.0)
    assert m.cells.tolist() == [[OCCUPIED, FREE, UNKNOWN], [FREE, OCCUPIED, FREE]]
    # The top image row is the far side: (1.25, 2.75) is the top-left pixel.
    assert m.state_at(np.array([1.25, 1.25]), np.array([2.75, 2.25])).tolist() == [OCCUPIED, FREE]


def test_only_the_changes_the_last_session_observed_are_scored_apart():
    before, now = room(box=True), room(box=False)  # the box (x, y in 0.8-1.2 m) left
    # One beam from (0.35, 1.05) along +x, ending on the far wall: it sweeps the box's row y = 1.0-1.1.
    observed = observed_cells(now, [(0.0, 0.1, 5.0, [1.6])], [(0.35, 1.05, 0.0)])
    x, y = now.centres()
    assert observed[(np.abs(y - 1.05) < 1e-9) & (x > 0.3) & (x < 2.0)].all()
    assert observed.sum() == int(((np.abs(y - 1.05) < 1e-9) & (x > 0.3) & (x < 2.0)).sum())
    stale = compare(before, [before, now], (0.0, 0.0, 0.0), observed=observed)
    assert stale.changed_cells == 16 and stale.changed_stale == 16
    # With the one-cell tolerance, the box's rows 0.9-1.2 next to the swept row count as seen.
    assert stale.changed_observed == 12 and stale.changed_observed_agree == 0
    up_to_date = compare(now, [before, now], (0.0, 0.0, 0.0), observed=observed)
    assert up_to_date.changed_observed_agreement == 1.0 and up_to_date.changed_stale == 0
    assert compare(now, [before, now], (0.0, 0.0, 0.0)).changed_observed == -1


def test_a_change_is_knowable_only_where_the_newest_look_saw_it_as_it_is_now():
    # Session 1: an empty room; sessions 2 and 3: a box in it.
    empty, box = room(box=False), room(box=True)
    x, y = box.centres()
    row = (np.abs(y - 1.05) < 1e-9) & (x > 0.3) & (x < 1.9)  # the west wall to the east wall
    in_box = row & (box.cells == OCCUPIED)
    face = in_box & (x < 0.9)  # the box's west face in that row
    # Session 1 sweeps the whole row (empty then); session 2 sees the box's west face from the
    # west; session 3 looks elsewhere.
    whole = observed_cells(empty, [(0.0, 0.1, 5.0, [1.6])], [(0.35, 1.05, 0.0)])
    west = observed_cells(box, [(0.0, 0.1, 5.0, [0.5])], [(0.35, 1.05, 0.0)])
    nothing = np.zeros(box.cells.shape, dtype=bool)
    worlds = [empty, box, box]
    knowable = seen_as_now(worlds, [whole, west, nothing])
    assert in_box.sum() == 4 and face.sum() == 1
    assert knowable[face].all()  # session 2 saw the face as it is now
    assert not knowable[in_box & ~face].any()  # last seen by session 1, before the box came
    assert knowable[row & (box.cells == FREE)].all()  # free then and now, west and east of it
    assert not knowable[~(whole | west)].any()  # never looked at
    # Scored: the box cells are the changed ones; a map of the empty room agrees on none of
    # the knowable ones, a map of the room now on all.
    changed = box.cells != empty.cells
    stale = compare(empty, worlds, (0.0, 0.0, 0.0), knowable=knowable)
    assert stale.changed_knowable == int((knowable & changed).sum()) == 1
    assert stale.changed_knowable_agree == 0
    assert compare(box, worlds, (0.0, 0.0, 0.0), knowable=knowable).changed_knowable_agreement == 1.0
    assert compare(box, worlds, (0.0, 0.0, 0.0)).changed_knowable == -1
    with pytest.raises(ValueError, match="2 observed masks for 3 worlds"):
        seen_as_now(worlds, [whole, west])


def write_world(path, world: GridMap):
    """A map_server pair of a world (trinary pixels)."""
    pixels = np.where(world.cells == OCCUPIED, 0, np.where(world.cells == FREE, 254, 205)).astype(np.uint8)
    rows, cols = pixels.shape
    (path.parent / (path.name + ".pgm")).write_bytes(f"P5\n{cols} {rows}\n255\n".encode() + pixels.tobytes())
    (path.parent / (path.name + ".yaml")).write_text(
        f"image: {path.name}.pgm\nresolution: {world.resolution}\norigin: [{world.origin[0]}, {world.origin[1]}, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return str(path.parent / (path.name + ".yaml"))


def test_the_command_scores_the_knowable_changes_from_every_sessions_log(tmp_path, capsys):
    from rrr_graphslam.world_compare import main
    box, empty = room(box=True), room(box=False)
    worlds = [write_world(tmp_path / "w0", box), write_world(tmp_path / "w1", empty)]
    slam_map = write_world(tmp_path / "map", empty)
    # One scan per session from (0.35, 1.05) facing +x: readings south, east, north.
    logs = []
    for k, east in enumerate([0.5, 1.6]):
        log = tmp_path / f"s{k}.clf"
        log.write_text(f"FLASER 3 0.3 {east} 0.3 0.35 1.05 0 0.35 1.05 0 {k + 1}.0 host {k + 1}.0\n")
        logs.append(str(log))
    (tmp_path / "traj.txt").write_text("1.0 0.35 1.05 0 0 0 0 1\n2.0 0.5 1.05 0 0 0 0 1\n")
    # Each session's true poses in a file of its own, as rrr_simulate writes them.
    (tmp_path / "truth0.txt").write_text("1.0 0.35 1.05 0 0 0 0 1\n")
    (tmp_path / "truth1.txt").write_text("2.0 0.5 1.05 0 0 0 0 1\n")
    args = [slam_map, "--worlds", *worlds, "--trajectory", str(tmp_path / "traj.txt"),
            "--truth", str(tmp_path / "truth0.txt"), str(tmp_path / "truth1.txt")]
    assert main(args + ["--logs", *logs]) == 0
    out = dict(line.split(" ", 1) for line in capsys.readouterr().out.splitlines())
    # The box's row (4 cells) was swept empty by session 2: knowable, and the map has them free.
    assert out["changed_cells"] == "16" and out["changed_knowable"] == "4"
    assert out["changed_knowable_agree"] == "4" and out["changed_knowable_agreement"] == "1.0000"
    with pytest.raises(SystemExit):
        main(args + ["--logs", logs[0]])
    assert "--logs names 1 logs for 2 worlds" in capsys.readouterr().err


def test_the_final_maps_plot_marks_what_no_session_saw_as_it_is_now(tmp_path):
    pytest.importorskip("matplotlib")
    from rrr_graphslam.lifelong_world import plot_final_maps
    box, empty = room(box=True), room(box=False)
    worlds = [write_world(tmp_path / "w0", box), write_world(tmp_path / "w1", empty)]
    slam_map = write_world(tmp_path / "map", box)  # stale: the box is still in it
    knowable = np.zeros(box.cells.shape, dtype=bool)
    out = plot_final_maps([("stale", slam_map, (0.0, 0.0, 0.0), worlds)], str(tmp_path / "p.png"), "t",
                          [knowable])
    assert out == str(tmp_path / "p.png") and (tmp_path / "p.png").read_bytes().startswith(b"\x89PNG")
