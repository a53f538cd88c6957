#!/usr/bin/env python3
"""Tests for scripts/ncu_source_summary.py on a small page in Nsight Compute's CSV shape
(tests/data/ncu/source_page_sample.csv: two files, each line's SASS rows under it, one SASS row
listed under two lines (inlined code) that the totals count once, a barrier, "-" for counters a
line has none of, a thousands separator). Stdlib only."""
import contextlib
import importlib.util
import io
import pathlib
import sys
import unittest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "tests" / "data" / "ncu" / "source_page_sample.csv"
spec = importlib.util.spec_from_file_location("ncu_source_summary", ROOT / "scripts" / "ncu_source_summary.py")
summary = importlib.util.module_from_spec(spec)
spec.loader.exec_module(summary)


def run(*args):
    out = io.StringIO()
    sys.argv = ["ncu_source_summary.py", str(SAMPLE), *args]
    with contextlib.redirect_stdout(out):
        assert summary.main() == 0
    return out.getvalue().splitlines()


class NcuSourceSummary(unittest.TestCase):
    def test_reads_source_lines_and_each_sass_row_once(self):
        records, sass = summary.read_page(SAMPLE)
        self.assertEqual([(f, line) for f, line, _, _ in records],
                         [("a.hpp", 10), ("a.hpp", 11), ("b.hpp", 5), ("b.hpp", 6)])
        self.assertEqual(records[2][3][summary.INSTRUCTIONS], 1000.0)
        self.assertEqual(records[1][3][summary.WAVEFRONTS], 0.0)
        self.assertEqual(sorted(sass), [0x7F00, 0x7F10, 0x7F20, 0x7F30])
        # the first line that lists an instruction names it
        self.assertEqual(sass[0x7F00][2], "a.hpp:10")
        self.assertEqual(sass[0x7F30][1][summary.INSTRUCTIONS], 1000.0)

    def test_totals_per_state_and_order(self):
        lines = run("--states", "10", "--by", "stall")
        # the SASS rows' sums: b.hpp:6's inlined copy of 0x7f00 not counted again (the lines' sums
        # would say 150 instructions and 64 wavefronts)
        self.assertIn("4 source lines, 4 SASS instructions; per state: 130 warp instructions, "
                      "34 shared-memory wavefronts (ideal 24)", lines[0])
        self.assertTrue(lines[1].startswith("b.hpp:5  stall  60.0%"), lines[1])
        self.assertTrue(run("--by", "excess", "--top", "1")[1].startswith("a.hpp:10"))
        self.assertEqual(len(run("--top", "2")), 3)

    def test_passes_are_cut_after_each_barrier(self):
        lines = run("--states", "10", "--by", "pass")
        self.assertEqual(len(lines), 3)
        # 0x7f00..0x7f20, closed by the barrier (40 executions over 10 states), then 0x7f30
        self.assertTrue(lines[1].startswith("pass  0  stall  40.0%  instructions      30  wavefronts     30"), lines[1])
        self.assertIn("barrier x 4.0  a.hpp:10 20, a.hpp:11 10", lines[1])
        self.assertTrue(lines[2].startswith("pass  1  stall  60.0%  instructions     100"), lines[2])
        self.assertIn("barrier x 0.0  b.hpp:5 100", lines[2])

    def test_rejects_a_file_without_the_header(self):
        with self.assertRaises(SystemExit):
            summary.read_page(ROOT / "tests" / "tools" / "ncu_source_summary_test.py")


if __name__ == "__main__":
    unittest.main()
