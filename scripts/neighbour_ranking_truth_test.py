#!/usr/bin/env python3
"""Tests of scripts/neighbour_ranking_truth.py on a small generated database
(run by ctest)."""
import io
import os
import sqlite3
import sys
import tempfile
import unittest
from array import array
from contextlib import redirect_stderr, redirect_stdout

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import neighbour_ranking_truth as nrt  # noqa: E402

NUM_KEYPOINTS = 20


def scene_pairs():
    """Image 1 sees image 2 through six unique keypoints (a true pair) and
    images 3, 4, 5 through eight keypoints of a repeated pattern, which 3, 4
    and 5 also match among themselves (doppelgangers): by inlier count image
    1's strongest pair is a doppelganger, by the other two weights it is
    image 2."""
    pairs = {(1, 2): [(k, k) for k in range(6)]}
    pattern = {1: range(6, 14), 3: range(8), 4: range(8), 5: range(8)}
    group = sorted(pattern)
    for x in range(len(group)):
        for y in range(x + 1, len(group)):
            a, b = group[x], group[y]
            pairs[(a, b)] = list(zip(pattern[a], pattern[b]))
    return pairs


def write_scene(folder):
    """A COLMAP-like database (the tables the script reads) and the pair
    labels `hisfm synth` writes."""
    pairs = scene_pairs()
    db = sqlite3.connect(os.path.join(folder, "database.db"))
    db.execute("CREATE TABLE keypoints (image_id INTEGER, rows INTEGER)")
    db.execute("CREATE TABLE two_view_geometries "
               "(pair_id INTEGER, rows INTEGER, data BLOB)")
    for i in range(1, 6):
        db.execute("INSERT INTO keypoints VALUES (?, ?)", (i, NUM_KEYPOINTS))
    for (a, b), matches in pairs.items():
        flat = array("I", [k for m in matches for k in m])
        db.execute("INSERT INTO two_view_geometries VALUES (?, ?, ?)",
                   (a * nrt.MAX_NUM_IMAGES + b, len(matches),
                    flat.tobytes()))
    db.commit()
    db.close()
    with open(os.path.join(folder, "pair_labels.txt"), "w") as f:
        f.write("# NAME1 NAME2 INLIERS TRUE DOPPELGANGER RANDOM\n")
        for (a, b), matches in pairs.items():
            true = len(matches) if (a, b) == (1, 2) else 0
            f.write(f"{a - 1:06d}.png {b - 1:06d}.png {len(matches)} {true} "
                    f"{len(matches) - true} 0\n")


class NeighbourRankingTruthTest(unittest.TestCase):
    def test_degrees_and_weights(self):
        pairs = scene_pairs()
        degrees = nrt.keypoint_degrees(
            pairs, {i: NUM_KEYPOINTS for i in range(1, 6)})
        self.assertEqual(degrees[1][0], 1)   # unique, seen by image 2 only
        self.assertEqual(degrees[1][6], 3)   # pattern, seen by 3, 4 and 5
        self.assertEqual(degrees[1][19], 0)  # never matched
        weights = nrt.pair_weights(pairs, degrees, 0.5)
        self.assertEqual(weights["inliers"][(1, 2)], 6)
        self.assertEqual(weights["inliers"][(1, 3)], 8)
        self.assertAlmostEqual(weights["burst"][(1, 2)], 6.0)
        self.assertAlmostEqual(weights["burst"][(1, 3)], 8 / 3)
        # Image 1's limit: 0.5 of its median degree 3, at least 2.
        self.assertEqual(weights["distinct"][(1, 2)], 6)
        self.assertEqual(weights["distinct"][(1, 3)], 0)

    def test_top_neighbour_truth(self):
        # Images 1, 2 and 3; image 3's only pair is false.
        true_pairs = {(1, 2)}
        self.assertAlmostEqual(
            nrt.top_neighbour_truth({(1, 2): 6, (1, 3): 8}, true_pairs), 1 / 3)
        self.assertAlmostEqual(
            nrt.top_neighbour_truth({(1, 2): 9, (1, 3): 8}, true_pairs), 2 / 3)
        self.assertTrue(
            nrt.math.isnan(nrt.top_neighbour_truth({}, true_pairs)))

    def test_main_prints_each_weights_share(self):
        with tempfile.TemporaryDirectory() as tmp:
            write_scene(tmp)
            out = io.StringIO()
            with redirect_stdout(out):
                rc = nrt.main([tmp, "--min_num_inliers", "1"])
            self.assertEqual(rc, 0)
            lines = out.getvalue().splitlines()
            self.assertEqual(lines[0], "scene inliers burst distinct")
            # Image 2 is right under every weight; image 1 only when the
            # pattern's matches are discounted; 3, 4, 5 never.
            self.assertEqual(lines[1].split()[1:], ["0.20", "0.40", "0.40"])
            # The database is opened read-only: the script never writes it.
            with self.assertRaises(sqlite3.OperationalError):
                db = sqlite3.connect(
                    f"file:{tmp}/database.db?mode=ro", uri=True)
                db.execute("CREATE TABLE x (y INTEGER)")

    def test_missing_scene_is_an_error(self):
        err = io.StringIO()
        with redirect_stderr(err), redirect_stdout(io.StringIO()):
            rc = nrt.main(["/nonexistent/scene"])
        self.assertEqual(rc, 1)
        self.assertIn("error: /nonexistent/scene", err.getvalue())


if __name__ == "__main__":
    unittest.main()
