#!/usr/bin/env python3
"""Tests of scripts/fit_score_calibration.py on generated TSV rows (run by ctest)."""
import math
import os
import random
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fit_score_calibration as fit  # noqa: E402

HEADER = ["id1", "id2", "label", "judged", "agree_i", "agree_j", "unique",
          "visible", "found", "displaced", "models_checked", "models_found",
          "rel_burst"]


def row(label, raw, agreement, burstiness, judged=True):
    """A cue_study row whose test speaks (or not) with the given raw score."""
    unique = 100
    missing = round((1 - raw) * unique)
    return {"id1": "1", "id2": "2", "label": str(label),
            "judged": "1" if judged else "0",
            "agree_i": "%.4f" % agreement, "agree_j": "1",
            "unique": str(unique), "visible": str(missing), "found": "0",
            "displaced": "0", "models_checked": "100", "models_found": "50",
            "rel_burst": "%.4f" % burstiness}


def write_tsv(path, rows):
    with open(path, "w") as f:
        f.write("\t".join(HEADER) + "\n")
        for r in rows:
            f.write("\t".join(r[k] for k in HEADER) + "\n")


class FitScoreCalibrationTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()

    def tearDown(self):
        self.dir.cleanup()

    def test_raw_score_and_speaking_follow_the_cpp_rule(self):
        raw, speaks = fit.raw_score(row(1, 0.7, 1, 1))
        self.assertAlmostEqual(raw, 0.7)
        self.assertTrue(speaks)
        raw, speaks = fit.raw_score(row(1, 0.7, 1, 0.9, judged=False))
        self.assertFalse(speaks)
        self.assertAlmostEqual(raw, fit.MAX_SILENT_RAW)

    def test_logistic_fit_recovers_the_generating_model(self):
        # Labels drawn from a known logistic model of the three inputs.
        truth = [-4.0, 3.0, 2.0, 2.5]
        rng = random.Random(7)
        rows = []
        for _ in range(6000):
            raw, agreement, burstiness = rng.random(), rng.random(), rng.random()
            z = truth[0] + truth[1] * raw + truth[2] * agreement + truth[3] * burstiness
            label = 1 if rng.random() < 1 / (1 + math.exp(-z)) else 0
            rows.append(row(label, raw, agreement, burstiness))
        path = os.path.join(self.dir.name, "a.tsv")
        write_tsv(path, rows)
        # With the prior equal to the sample's share of true rows the
        # weights are uniform and the fit is the plain maximum likelihood.
        share = sum(r["label"] == "1" for r in rows) / len(rows)
        beta = fit.fit_logistic([path], share, ridge=1e-6)
        for b, t in zip(beta, truth):
            self.assertAlmostEqual(b, t, delta=0.5)

    def test_tables_are_monotone_and_separate_the_classes(self):
        rng = random.Random(3)
        rows = []
        for _ in range(2000):
            raw = rng.random()
            rows.append(row(1 if rng.random() < raw else 0, raw, 1, 1))
            rows.append(row(1 if rng.random() < raw else 0, raw * 0.75, 1, raw,
                            judged=False))
        path = os.path.join(self.dir.name, "b.tsv")
        write_tsv(path, rows)
        for judged in (True, False):
            table = fit.fit_table([path], 0.5, judged)
            self.assertEqual(len(table), fit.BINS)
            for a, b in zip(table, table[1:]):
                self.assertLessEqual(a, b + 1e-12)
            self.assertLess(table[0], 0.3)
            self.assertGreater(max(table), 0.7)

    def test_isotonic_pools_violators(self):
        self.assertEqual(fit.isotonic([0.2, 0.6, 0.4, 0.9], [1, 1, 1, 1]),
                         [0.2, 0.5, 0.5, 0.9])


if __name__ == "__main__":
    unittest.main()
