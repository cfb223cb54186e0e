"""The soak benchmark's pure parts: percentiles, the table, reading a process's memory."""
import os

from rrr_graphslam.bench_soak import Pass, find_pid, percentile, proc_memory_mb, table


def test_percentiles_and_table_report_every_pass_and_the_growth():
    assert percentile([5, 1, 3, 2, 4], 0.5) == 3 and percentile([1, 2, 3], 0.99) == 3
    assert percentile([], 0.5) != percentile([], 0.5)  # NaN for no samples
    passes = [Pass(1, scans=100, nodes=40, batch_ms=[1.0, 2.0, 50.0], max_backlog=3, rss_mb=80.0, hwm_mb=90.0),
              Pass(2, scans=100, nodes=40, batch_ms=[1.0, 2.5], rss_mb=81.5, hwm_mb=91.0)]
    text = table(passes)
    lines = text.splitlines()
    assert lines[0].startswith("| pass | scans | nodes |") and len(lines) == 6
    assert "| 1 | 100 | 40 | 0 |" in lines[2] and "2.00 / 50.00 / 50.00" in lines[2]
    assert text.endswith("RSS at the end of the last pass minus the first: +1.5 MB")


def test_this_process_is_found_and_its_memory_read():
    rss, hwm = proc_memory_mb(os.getpid())
    assert 0 < rss <= hwm
    assert find_pid("test_bench_soak") is not None or find_pid("pytest") is not None
