#!/usr/bin/env python3
"""bench/fidelity_table.py's table of each run against its two predictions: the gaps are the
simulated figures minus the real ones, read from prediction.json's "gap" where the run wrote
it and computed the same way where it did not, each held to the target (5 points, 10 %) and
counted in the summary line."""
import json
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))


def summary(policies):
    return {"policies": [{"name": n, "miss_rate": m / 100, "latency_ms": {"mean": l, "p99": l},
                          "qoe": 1.0, "sync_round_trips": 1, "dispatches": 1}
                         for n, m, l in policies]}


class FidelityTable(unittest.TestCase):
    def test_each_run_against_both_predictions(self):
        with tempfile.TemporaryDirectory() as out:
            d = os.path.join(out, "s")
            for k, (real_edf, with_gap) in enumerate([(40.0, True), (20.0, False)], start=1):
                run = os.path.join(d, f"run{k}")
                os.makedirs(run)
                json.dump(summary([("edf", real_edf, 100.0), ("red", 0.0, 30.0)]),
                          open(os.path.join(run, "summary.json"), "w"))
                pols = []
                for name, miss, mean, sim_miss, sim_mean, own_miss, own_mean in [
                        ("edf", real_edf, 100.0, 60.0, 104.0, real_edf + 1.0, 101.0),
                        ("red", 0.0, 30.0, 0.0, 34.0, 0.0, 30.3)]:
                    p = {"policy": name, "real": {"miss_pct": miss, "mean_ms": mean, "qoe": 1},
                         "sim": {"miss_pct": sim_miss, "miss_pct_min": sim_miss,
                                 "miss_pct_max": sim_miss, "mean_ms": sim_mean,
                                 "mean_ms_min": sim_mean, "mean_ms_max": sim_mean, "qoe": 1},
                         "sim_run_costs": {"miss_pct": own_miss, "miss_pct_min": own_miss,
                                           "miss_pct_max": own_miss, "mean_ms": own_mean,
                                           "mean_ms_min": own_mean, "mean_ms_max": own_mean,
                                           "qoe": 1}}
                    if with_gap:
                        # What the run's own check writes (the same arithmetic).
                        p["gap"] = {"ahead": {"miss_pts": sim_miss - miss,
                                              "mean_pct": (sim_mean - mean) / mean * 100,
                                              "within_target": abs(sim_miss - miss) <= 5
                                              and abs((sim_mean - mean) / mean * 100) <= 10},
                                    "own": {"miss_pts": own_miss - miss,
                                            "mean_pct": (own_mean - mean) / mean * 100,
                                            "within_target": True}}
                        if name == "red":
                            p["gap"]["unit_cost_ratio"] = 0.9  # the policy's own units
                    pols.append(p)
                doc = {"policies": pols}
                if with_gap:
                    doc["check"] = {"unit_cost_ratio": 0.8}
                json.dump(doc, open(os.path.join(run, "prediction.json"), "w"))
            text = subprocess.run([sys.executable, os.path.join(HERE, "fidelity_table.py"), out,
                                   "s.yaml"], check=True, capture_output=True, text=True).stdout
            rows = json.load(open(os.path.join(out, "fidelity-gaps.json")))
            own_rows = json.load(open(os.path.join(out, "fidelity-own.json")))
        self.assertEqual(len(rows), 4)
        by = {(r["run"], r["policy"]): r for r in rows}
        # edf: 60 predicted ahead against 40 and 20 real: +20 and +40 points, outside.
        self.assertAlmostEqual(by[("run1", "edf")]["ahead"]["miss_pts"], 20.0)
        self.assertAlmostEqual(by[("run2", "edf")]["ahead"]["miss_pts"], 40.0)
        self.assertFalse(by[("run2", "edf")]["ahead"]["within_target"])
        # red: 34 against 30 ms, +13.3 %: outside on latency alone.
        self.assertAlmostEqual(by[("run2", "red")]["ahead"]["mean_pct"], 40 / 3)
        self.assertFalse(by[("run2", "red")]["ahead"]["within_target"])
        # From the own costs every row is within.
        self.assertTrue(all(r["own"]["within_target"] for r in rows))
        self.assertIn("| s | run1 | edf | +20.0 * | +4.0 | +1.0 | +1.0 | 0.80x |", text)
        self.assertIn("| s | run2 | red | +0.0 | +13.3 * | +0.0 | +1.0 | — |", text)
        # A policy's own units' ratio where the check wrote it, else the run's over all.
        self.assertIn("| s | run1 | red | +0.0 | +13.3 * | +0.0 | +1.0 | 0.90x |", text)
        self.assertIn("fidelity: ahead 0 of 4 within the target, from the run's own costs 4 of 4",
                      text)
        # The older table from each run's own costs says what the side-by-side one says of them:
        # one arithmetic (gap()), rounded as the table shows it.
        self.assertEqual(len(own_rows), len(rows))
        for r in own_rows:
            g = by[(r["run"], r["policy"])]["own"]
            self.assertAlmostEqual(r["d_miss_points"], round(g["miss_pts"], 2))
            self.assertAlmostEqual(r["d_mean_pct"], round(g["mean_pct"], 1))
            self.assertEqual(r["within_target"], g["within_target"])
        self.assertIn("4 of 4 (scenario, policy, run) within the target from the run's own costs.",
                      text)


if __name__ == "__main__":
    unittest.main()
