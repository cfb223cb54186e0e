"""evaluate and add_outliers on inputs and outputs they cannot use: one line on stderr naming the
file (and the line where one applies), exit 1 for a bad file, 2 for a usage error, never a
traceback, and no waiting for a request that cannot be met."""
import gzip
import itertools
import os
import random
import re
import subprocess
import sys

import pytest
from conftest import DATA, SCRIPTS

EVALUATE = os.path.join(SCRIPTS, "evaluate")
ADD_OUTLIERS = os.path.join(SCRIPTS, "add_outliers")
RING = os.path.join(DATA, "ring.g2o.gz")
DECISIONS = "from\tto\tcluster\tverdict\n5\t0\t0\taccepted\n10\t2\t0\trejected\n"
LABELS = "5 0 1\n10 2 0\n"


def run(script, *args, stdout=subprocess.PIPE, timeout=30):
    return subprocess.run([sys.executable, script, *map(str, args)], stdout=stdout, stderr=subprocess.PIPE,
                          text=True, timeout=timeout)


def assert_one_line_error(result, name, path, line=None, what=""):
    """`name: path[:line]: what...` as the only line on stderr, exit 1."""
    assert result.returncode == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1, result.stderr
    where = re.escape(f"{name}: {path}") + (f":{line}" if line is not None else r"(:\d+)?")
    assert re.match(where + ": " + re.escape(what), result.stderr), result.stderr


def binary_files(folder):
    """Files that are no text: random bytes without and with NUL bytes, the start of a PNG, and
    a gzip stream cut in half (its name says .gz, and another's does not)."""
    rng = random.Random(5)
    noise = bytes(rng.randrange(256) for _ in range(3000))
    packed = gzip.compress((LABELS * 200).encode())
    files = {"noise.bin": noise.replace(b"\0", b"x"), "noise_nul.bin": noise,
             "image.png": b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR" + noise[:200],
             "cut.gz": packed[:len(packed) // 2], "cut_unnamed": packed[:len(packed) // 2]}
    for name, data in files.items():
        (folder / name).write_bytes(data)
    return sorted(files)


@pytest.fixture
def inputs(tmp_path):
    (tmp_path / "d.tsv").write_text(DECISIONS)
    (tmp_path / "labels").write_text(LABELS)
    return tmp_path


def test_evaluate_names_a_file_that_is_no_text(inputs):
    for name, role in itertools.product(binary_files(inputs), ["--decisions", "--truth"]):
        bad = inputs / name
        files = {"--decisions": inputs / "d.tsv", "--truth": inputs / "labels", role: bad}
        result = run(EVALUATE, *[x for flag, path in files.items() for x in (flag, path)])
        assert_one_line_error(result, "evaluate", bad)


def test_evaluate_names_a_ground_truth_line_that_is_not_finite(inputs):
    for values in ("-nan 1 2 0", "1e999 1 2 0", "0 1 2 0\n1 -inf 2 0"):
        poses = inputs / "poses.txt"
        poses.write_text(values + "\n")
        result = run(EVALUATE, "--truth", inputs / "labels", "--decisions", inputs / "d.tsv", "--graph", RING,
                     "--ground-truth", poses)
        assert_one_line_error(result, "evaluate", poses, values.count("\n") + 1, "expected finite numbers")


def test_evaluate_refuses_truth_rows_of_two_and_three_columns(inputs):
    truth = inputs / "truth"
    truth.write_text("5 0\n10 2 0\n")  # without the error: the label-0 row scored as a true loop
    result = run(EVALUATE, "--truth", truth, "--decisions", inputs / "d.tsv")
    assert_one_line_error(result, "evaluate", truth, 2, "3 columns, but line 1 has 2")
    truth.write_text("5 0 1\n10 2\n")
    result = run(EVALUATE, "--truth", truth, "--decisions", inputs / "d.tsv")
    assert_one_line_error(result, "evaluate", truth, 2, "2 columns, but line 1 has 3")


def test_evaluate_counts_only_label_1_as_true_and_leaves_unknown_labels_out(inputs):
    truth = inputs / "truth"
    truth.write_text("5 0 -1\n10 2 0\n")
    result = run(EVALUATE, "--truth", truth, "--decisions", inputs / "d.tsv")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("candidates 2  true 0  accepted 0\n")
    assert "(tp 0, fp 0, fn 0, tn 1)" in result.stdout


def test_evaluate_names_files_it_cannot_open(inputs):
    missing = inputs / "missing"
    result = run(EVALUATE, "--truth", missing, "--decisions", inputs / "d.tsv")
    assert_one_line_error(result, "evaluate", missing, None, "No such file or directory")
    result = run(EVALUATE, "--truth", inputs / "labels", "--decisions", inputs)
    assert_one_line_error(result, "evaluate", inputs, None, "Is a directory")


def test_evaluate_names_a_plot_it_cannot_write(inputs):
    common = ["--truth", inputs / "labels", "--decisions", inputs / "d.tsv", "--graph", RING]
    nowhere = inputs / "no" / "plot.png"
    assert_one_line_error(run(EVALUATE, *common, "--plot", nowhere), "evaluate", nowhere, None,
                          "No such file or directory")
    unknown = inputs / "plot.xyz"
    assert_one_line_error(run(EVALUATE, *common, "--plot", unknown), "evaluate", unknown, None,
                          "Format 'xyz' is not supported")
    usage = run(EVALUATE, *common[:4], "--plot", inputs / "plot.png")
    assert usage.returncode == 2 and "--plot needs --graph or --ground-truth" in usage.stderr


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize("script", ["evaluate", "add_outliers"])
def test_a_full_stdout_is_one_line_too(inputs, script):
    with open("/dev/full", "w") as full:
        if script == "evaluate":
            result = run(EVALUATE, "--truth", inputs / "labels", "--decisions", inputs / "d.tsv", stdout=full)
        else:
            result = run(ADD_OUTLIERS, RING, inputs / "out.g2o", "--count", 5, stdout=full)
    assert_one_line_error(result, script, "stdout", None, "No space left on device")


def test_add_outliers_refuses_a_graph_without_edges(tmp_path):
    graph = tmp_path / "vertices.g2o"
    graph.write_text("".join(f"VERTEX_SE2 {i} {i} 0 0\n" for i in range(10)))
    result = run(ADD_OUTLIERS, graph, tmp_path / "out.g2o", "--count", 3)
    assert_one_line_error(result, "add_outliers", graph, None, "graph has no edges")


@pytest.mark.parametrize("kind, room, fits", [("random", 6, 6), ("local", 6, 6), ("local-grouped", 5, 2)])
def test_add_outliers_says_at_once_how_many_fit(tmp_path, kind, room, fits):
    # Six nodes on a chain: single draws link two of nodes 0..4 at least two apart (6 pairs);
    # groups of 2 start at two of nodes 0..3: 0-2 1-3 2-4 (a group and a shorter one) and 0-3 1-4
    # (drawn at random, the groups may not leave room for all 5).
    graph = tmp_path / "chain.g2o"
    graph.write_text("".join(f"VERTEX_SE2 {i} {i} 0 0\n" for i in range(6))
                     + "".join(f"EDGE_SE2 {i} {i + 1} 1 0 0 1 0 0 1 0 1\n" for i in range(5)))
    out = tmp_path / "out.g2o"
    placed = run(ADD_OUTLIERS, graph, out, "--kind", kind, "--count", fits, "--group-size", 2)
    assert placed.returncode == 0, placed.stderr
    result = run(ADD_OUTLIERS, graph, out, "--kind", kind, "--count", 10 ** 9, "--group-size", 2, timeout=10)
    assert_one_line_error(result, "add_outliers", graph, None, f"room for at most {room} {kind} outliers")


def test_add_outliers_stops_when_random_groups_leave_only_gaps(tmp_path):
    # 7939 local-grouped outliers fit in ring.g2o packed end to end, but groups drawn at random
    # leave gaps shorter than a group long before 7500 (without the check: half a minute).
    result = run(ADD_OUTLIERS, RING, tmp_path / "out.g2o", "--kind", "local-grouped", "--count", 7500,
                 timeout=10)
    assert_one_line_error(result, "add_outliers", RING, None, "no room left for a group of 10 after placing")
    assert "at most 7939 fit when packed tightly" in result.stderr


def test_add_outliers_names_an_output_it_cannot_write(tmp_path):
    nowhere = tmp_path / "no" / "out.g2o"
    assert_one_line_error(run(ADD_OUTLIERS, RING, nowhere, "--count", 5), "add_outliers", nowhere, None,
                          "no directory")
    out = tmp_path / "out.g2o"
    truth = tmp_path / "no" / "truth"
    assert_one_line_error(run(ADD_OUTLIERS, RING, out, "--count", 5, "--truth", truth), "add_outliers", truth,
                          None, "no directory")
    assert not out.exists()  # nothing written when one of the two cannot be
    assert_one_line_error(run(ADD_OUTLIERS, RING, tmp_path, "--count", 5), "add_outliers", tmp_path, None,
                          "is a directory")
    if os.path.isdir("/proc/self"):  # a directory in which no file can be made
        proc = "/proc/self/out.g2o"
        assert_one_line_error(run(ADD_OUTLIERS, RING, proc, "--count", 5), "add_outliers", proc)


@pytest.mark.parametrize("flag, value", [("--count", -1), ("--group-size", 0), ("--local-window", 1),
                                         ("--alpha", 1.0)])
def test_add_outliers_out_of_range_flags_are_usage_errors(tmp_path, flag, value):
    args = [RING, tmp_path / "out.g2o", "--count", 5, flag, value]
    result = run(ADD_OUTLIERS, *args)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.splitlines()[-1].startswith(f"add_outliers: error: {flag} must be")
