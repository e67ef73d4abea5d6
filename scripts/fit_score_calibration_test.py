#!/usr/bin/env python3
"""Tests of scripts/fit_score_calibration.py on generated rows (ctest)."""
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


def row(label, raw, agreement, burstiness, judged=True, other=1.0):
    """A cue_study row whose test speaks (or not) with the given raw score;
    `agreement` is the smaller of the two sides' agreements, `other` the
    larger (on side i or j at random)."""
    unique = 100
    missing = round((1 - raw) * unique)
    sides = ["%.4f" % agreement, "%.4f" % max(agreement, other)]
    random.Random(missing + 1000 * int(agreement * 100)).shuffle(sides)
    return {"id1": "1", "id2": "2", "label": str(label),
            "judged": "1" if judged else "0",
            "agree_i": sides[0], "agree_j": sides[1],
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
            x = [rng.random() for _ in range(3)]
            z = truth[0] + sum(t * v for t, v in zip(truth[1:], x))
            label = 1 if rng.random() < 1 / (1 + math.exp(-z)) else 0
            rows.append(row(label, *x))
        path = os.path.join(self.dir.name, "a.tsv")
        write_tsv(path, rows)
        # With the prior equal to the sample's share of true rows the
        # weights are uniform and the fit is the plain maximum likelihood.
        share = sum(r["label"] == "1" for r in rows) / len(rows)
        beta = fit.fit_logistic([path], share, ridge=1e-6)
        for b, t in zip(beta, truth):
            self.assertAlmostEqual(b, t, delta=0.5)

    def test_judged_features_take_the_smaller_agreement(self):
        r = row(1, 0.5, 0.3, 0.8)
        for i, j in (("0.3", "0.9"), ("0.9", "0.3")):
            r["agree_i"], r["agree_j"] = i, j
            x = fit.judged_features(r)
            self.assertEqual(x[0], 1.0)
            self.assertAlmostEqual(x[1], 0.5)
            self.assertAlmostEqual(x[2], 0.3)
            self.assertAlmostEqual(x[3], 0.8)
        # Out-of-range inputs are clamped as in CalibratedPairScore.
        self.assertAlmostEqual(fit.judged_features(row(1, 0.5, 1, 1.6))[3],
                               1.0)

    def test_one_class_instances_are_left_out(self):
        rng = random.Random(5)
        rows = []
        for _ in range(1000):
            x = [rng.random() for _ in range(3)]
            rows.append(row(1 if rng.random() < x[0] else 0, *x))
        mixed = os.path.join(self.dir.name, "mixed.tsv")
        control = os.path.join(self.dir.name, "control.tsv")
        write_tsv(mixed, rows)
        write_tsv(control, [row(1, 0.1, 0.1, 0.1) for _ in range(500)])
        self.assertEqual(fit.fit_logistic([mixed], 0.58),
                         fit.fit_logistic([mixed, control], 0.58))
        with self.assertRaises(ValueError):
            fit.fit_logistic([control], 0.58)

    def test_silent_table_is_monotone_and_separates_the_classes(self):
        # Silent rows: the raw score is the (capped) relative burstiness.
        rng = random.Random(3)
        rows = []
        for _ in range(2000):
            burstiness = rng.random()
            label = 1 if rng.random() < burstiness else 0
            rows.append(row(label, 0.5, 1, burstiness, judged=False))
        path = os.path.join(self.dir.name, "b.tsv")
        write_tsv(path, rows)
        table = fit.fit_silent([path], 0.5)
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
