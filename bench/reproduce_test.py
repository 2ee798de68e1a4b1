#!/usr/bin/env python3
"""Unit tests of bench/reproduce.py's computations: the QoE of each lambda recomputed from
jobs.csv, miss rates, spreads, the paper's 'lower/higher by' figures, the verdict rule, the
per-phase table of case study 1 and the page checker. Run: python3 bench/reproduce_test.py
(CTest: reproduce_py)."""
import json
import math
import os
import shutil
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import reproduce as rp  # noqa: E402

JOBS = """policy,operation,job,release_ms,finish_ms,deadline_ms,outcome,response_ms,qoe,frame_age_ms,reason
red,drive,1,1000.0,1040.0,1100.0,met,40.0,1.0,40.0,
red,drive,2,1100.0,1250.0,1200.0,missed,150.0,0.0,150.0,
red,drive,3,1200.0,,1300.0,dropped,,0,,deadline passed
red,drive,4,1300.0,,1400.0,unfinished,,0,,
edf,drive,1,1000.0,,1100.0,skipped,,0,,max_inflight
edf,drive,2,1600.0,1650.0,1700.0,met,50.0,1.0,50.0,
"""


class QoeTest(unittest.TestCase):
    def test_score_is_the_papers_equation(self):
        # 50 ms late at lambda 1: 1 / (1 + e * 0.05).
        self.assertAlmostEqual(rp.qoe_score(1250.0, 1200.0, 1.0), 1 / (1 + math.e * 0.05))
        self.assertEqual(rp.qoe_score(1040.0, 1100.0, 10.0), 1.0)  # on time: 1 at any lambda

    def test_mean_counts_drops_as_zero_and_leaves_unfinished_out(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "jobs.csv")
            open(path, "w").write(JOBS)
            jobs = rp.read_jobs(path)
        for lam in (0.001, 1.0, 10.0):
            want = (1.0 + 1 / (1 + math.exp(lam) * 0.05) + 0.0) / 3
            self.assertAlmostEqual(rp.qoe_at(jobs["red"], lam), want)
        self.assertAlmostEqual(rp.qoe_at(jobs["edf"], 1.0), 0.5)
        # Larger lambda, lower QoE when a job completes late.
        self.assertGreater(rp.qoe_at(jobs["red"], 0.001), rp.qoe_at(jobs["red"], 10.0))
        self.assertIsNone(rp.qoe_at([], 1.0))

    def test_miss_rate_and_bins(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "jobs.csv")
            open(path, "w").write(JOBS)
            jobs = rp.read_jobs(path)
        self.assertAlmostEqual(rp.miss_pct(jobs["red"]), 200 / 3)
        self.assertAlmostEqual(rp.miss_pct(jobs["edf"]), 50.0)
        # Releases at 1.0, 1.1, 1.2 s fall in the bin from 1.0 s: two of three missed.
        self.assertEqual(rp.bins_miss_pct(jobs["red"], 0.5), [(1.0, 200 / 3)])


class FiguresTest(unittest.TestCase):
    def test_spread_and_cell(self):
        self.assertEqual(rp.spread([3.0, None, 1.0, 2.0]), (2.0, 1.0, 3.0))
        self.assertIsNone(rp.spread([None]))
        self.assertEqual(rp.cell([3.0, 1.0, 2.0]), "2.00 [1.00–3.00]")
        self.assertEqual(rp.cell([5.0], "{:.1f}"), "5.0")
        self.assertEqual(rp.cell([]), "—")

    def test_relative_figures(self):
        self.assertAlmostEqual(rp.lower_pct(60.0, 80.0), 25.0)
        self.assertAlmostEqual(rp.higher_pct(0.9, 0.6), 50.0)
        self.assertIsNone(rp.lower_pct(1.0, 0.0))
        self.assertIsNone(rp.higher_pct(None, 1.0))

    def test_verdict_rule(self):
        self.assertEqual(rp.verdict(40.5, None), "not measured")
        self.assertEqual(rp.verdict(40.5, -3.0), "did not hold")
        self.assertEqual(rp.verdict(40.5, 0.0), "did not hold")
        self.assertEqual(rp.verdict(40.5, 20.0), "held, weaker")
        self.assertEqual(rp.verdict(40.5, 99.0), "held more strongly")

    def test_ordering(self):
        self.assertEqual(rp.ordering({"edf": 80.0, "red": 1.0, "red-fg": None, "red-ida": 1.0},
                                     ["red", "red-ida", "red-fg", "edf"]),
                         ["red", "red-ida", "edf"])


def policy(name, miss, mean, qoe, phases=None):
    p = {"name": name, "jobs": 100, "completed": 100, "miss_rate": miss, "qoe": qoe,
         "latency_ms": {"mean": mean, "p99": 2 * mean}, "encoder_runs": 100,
         "sync_round_trips": 10, "dispatches": 20}
    if phases is not None:
        p["phases"] = [{"miss_rate": m} for m in phases]
    return p


class PageTest(unittest.TestCase):
    def setUp(self):
        self.out = tempfile.mkdtemp()

    def tearDown(self):
        shutil.rmtree(self.out)

    def write_run(self, scenario, k, policies, jobs=JOBS):
        d = os.path.join(self.out, "runs", scenario, f"run{k}")
        os.makedirs(d)
        json.dump({"schema": 1, "scenario": scenario, "backend": "sim", "policies": policies},
                  open(os.path.join(d, "summary.json"), "w"))
        open(os.path.join(d, "jobs.csv"), "w").write(jobs)

    def test_case_study_1_phases(self):
        for k, edf in enumerate(([0.0, 0.9, 0.1], [0.1, 0.8, 0.0], [0.0, 1.0, 0.2]), 1):
            self.write_run("case-dynamic", k, [policy("edf", 0.5, 30, 0.5, edf),
                                               policy("red", 0.0, 20, 1.0, [0, 0, 0])])
        page = rp.Page(self.out, "quick")
        rp.section_case1(page)
        d = page.data["case1"]
        self.assertEqual(d["miss_pct_median"]["edf"], [0.0, 90.0, 10.0])
        self.assertEqual(d["rise"], ["edf"])
        self.assertIn("| edf | 0.0 [0.0–10.0] | 90.0 [80.0–100.0] | 10.0 [0.0–20.0] |", page.md)

    def test_fig6_relative_to_edf(self):
        for k in (1, 2, 3):
            self.write_run("minibench-tight", k, [policy("edf", 0.8, 100.0, 0.2),
                                                  policy("red", 0.2, 50.0, 0.8)])
        page = rp.Page(self.out, "quick")
        rp.section_fig6(page, "fig6_tight", "minibench-tight", "tight")
        rel = page.data["fig6_tight"]["red_vs"]["edf"]
        self.assertAlmostEqual(rel["miss_lower_pct"], 75.0)
        self.assertAlmostEqual(rel["latency_lower_pct"], 50.0)
        self.assertAlmostEqual(rel["qoe_higher_pct"], 300.0)

    def test_table5_lambda_1_matches_the_runs_own_qoe(self):
        qoe_red = (1.0 + 1 / (1 + math.e * 0.05)) / 3
        self.write_run("minibench-tight", 1, [policy("edf", 0.5, 50, 0.5), policy("red", 0.6, 40, qoe_red)])
        page = rp.Page(self.out, "quick")
        rp.section_table5(page)
        d = page.data["table5"]
        self.assertLess(d["lambda1_max_abs_diff"], 1e-9)
        self.assertAlmostEqual(d["qoe_median"]["red"][3], qoe_red)

    def test_check_finds_a_missing_section_and_accepts_a_whole_page(self):
        for scen in ("minibench-tight", "minibench-loose", "case-dynamic", "case-async",
                     "case-async-dep", "interference-none"):
            for k in (1, 2):
                self.write_run(scen, k, [policy(p, 0.1 * i, 10.0 + i, 1 - 0.1 * i, [0.1, 0.2, 0.1])
                                         for i, p in enumerate(rp.POLICIES)])
        # A prediction of run 1 (fidelity's leave-one-out layout).
        loo = os.path.join(self.out, "runs", "minibench-tight", "loo1-seed1")
        shutil.copytree(os.path.join(self.out, "runs", "minibench-tight", "run1"), loo)
        scen_dir = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenarios")
        rp.build_page(self.out, "quick", "test", [], scen_dir)
        # No profile in this fixture: Table 1 is unmeasured, and the checker says so.
        self.assertEqual(rp.check(self.out, ["table1_overheads"]), [])
        self.assertTrue(any("table1_overheads not measured" in p for p in rp.check(self.out)))
        md = open(os.path.join(self.out, "reproduction.md")).read()
        self.assertIn("SMOKE RUN", md)
        for header in rp.HEADERS.values():
            self.assertIn(header, md)
        open(os.path.join(self.out, "reproduction.md"), "w").write(md.replace("## Case study 1", "## x"))
        self.assertTrue(any("Case study 1" in p for p in rp.check(self.out)))


if __name__ == "__main__":
    unittest.main()
