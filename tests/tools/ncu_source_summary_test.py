#!/usr/bin/env python3
"""Tests for scripts/ncu_source_summary.py on a small page in Nsight Compute's CSV shape
(tests/data/ncu/source_page_sample.csv: two files, a SASS row that must not count twice, "-"
for counters a line has none of, a thousands separator). Stdlib only."""
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
    def test_reads_source_lines_only(self):
        records = summary.read_lines(SAMPLE)
        self.assertEqual([(f, line) for f, line, _, _ in records], [("a.hpp", 10), ("a.hpp", 11), ("b.hpp", 5)])
        self.assertEqual(records[2][3][summary.INSTRUCTIONS], 1000.0)
        self.assertEqual(records[1][3][summary.WAVEFRONTS], 0.0)

    def test_totals_per_state_and_order(self):
        lines = run("--states", "10", "--by", "stall")
        self.assertIn("130 warp instructions, 34 shared-memory wavefronts (ideal 24)", lines[0])
        self.assertTrue(lines[1].startswith("b.hpp:5  stall  60.0%"), lines[1])
        self.assertTrue(run("--by", "excess", "--top", "1")[1].startswith("a.hpp:10"))
        self.assertEqual(len(run("--top", "2")), 3)

    def test_rejects_a_file_without_the_header(self):
        with self.assertRaises(SystemExit):
            summary.read_lines(ROOT / "tests" / "tools" / "ncu_source_summary_test.py")


if __name__ == "__main__":
    unittest.main()
