#!/usr/bin/env python3
"""How often each image's strongest pair is true, under three pair weights.

The hierarchy starts from each image's strongest pair (paper Sec. III-A,
k = 1) and ego models from each image's strongest few; on a street of
identical facades the strongest pair can be a doppelganger, and every later
step inherits it. This script reads a synthetic scene's COLMAP database
(read-only) and its pair_labels.txt (`hisfm synth`) and prints, per weight,
the share of images whose strongest pair is true (at least half of its
inliers true matches, as scripts/hierarchy_edge_labels.py labels it):
  inliers   the number of inlier matches (the paper's weight);
  burst     the burstiness-weighted support, the sum over inliers of
            1 / sqrt(n1 n2), n1 and n2 the number of verified pairs each of
            its keypoints is an inlier of (match_burstiness.h; the
            hierarchy's default weight);
  distinct  the inliers whose two keypoints are both distinctive: of a
            degree at most --fraction (0.5) of the median degree of their
            image's matched keypoints, and at least 2 (local_model.h).
Pairs with fewer than --min_num_inliers (15, the mapper's default) inliers
are left out, as the mapper leaves them out.

Usage:
  neighbour_ranking_truth.py SCENE [SCENE ...] [--fraction 0.5]
      [--min_num_inliers 15]
"""
import argparse
import math
import os
import sqlite3
import sys
from array import array

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hierarchy_edge_labels as hel  # noqa: E402

# COLMAP's pair id: image_id1 * kMaxNumImages + image_id2, id1 < id2.
MAX_NUM_IMAGES = 2147483647
WEIGHTS = ["inliers", "burst", "distinct"]


def read_scene(folder, min_num_inliers):
    """(inlier matches by pair, keypoints per image)."""
    db = sqlite3.connect(f"file:{folder}/database.db?mode=ro", uri=True)
    try:
        num_keypoints = dict(db.execute("SELECT image_id, rows FROM keypoints"))
        pairs = {}
        for pair_id, rows, data in db.execute(
                "SELECT pair_id, rows, data FROM two_view_geometries "
                "WHERE rows >= ?", (min_num_inliers,)):
            id2 = pair_id % MAX_NUM_IMAGES
            id1 = (pair_id - id2) // MAX_NUM_IMAGES
            flat = array("I")
            flat.frombytes(data)
            pairs[(id1, id2)] = list(zip(flat[0::2], flat[1::2]))
    finally:
        db.close()
    return pairs, num_keypoints


def keypoint_degrees(pairs, num_keypoints):
    """Per image, per keypoint: the number of pairs it is an inlier of."""
    degrees = {i: [0] * n for i, n in num_keypoints.items()}
    for (a, b), matches in pairs.items():
        for k1, k2 in matches:
            degrees[a][k1] += 1
            degrees[b][k2] += 1
    return degrees


def pair_weights(pairs, degrees, fraction):
    """{weight name: {pair: weight}} for the three weights."""
    limit = {}
    for image_id, degree in degrees.items():
        matched = [d for d in degree if d > 0]
        # The upper median, as nth_element at size / 2 picks it.
        limit[image_id] = (
            max(2.0, fraction * sorted(matched)[len(matched) // 2])
            if matched else 0.0)
    weights = {name: {} for name in WEIGHTS}
    for (a, b), matches in pairs.items():
        burst = 0.0
        distinct = 0
        for k1, k2 in matches:
            d1 = degrees[a][k1]
            d2 = degrees[b][k2]
            burst += 1.0 / math.sqrt(max(1, d1) * max(1, d2))
            distinct += d1 <= limit[a] and d2 <= limit[b]
        weights["inliers"][(a, b)] = len(matches)
        weights["burst"][(a, b)] = burst
        weights["distinct"][(a, b)] = distinct
    return weights


def top_neighbour_truth(weights, true_pairs):
    """Share of images whose strongest pair by `weights` is in `true_pairs`
    (ties: the pair seen first)."""
    best = {}
    for pair, w in weights.items():
        for image_id in pair:
            if image_id not in best or w > best[image_id][0]:
                best[image_id] = (w, pair)
    if not best:
        return math.nan
    true = sum(pair in true_pairs for _, pair in best.values())
    return true / len(best)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="+")
    parser.add_argument("--fraction", type=float, default=0.5)
    parser.add_argument("--min_num_inliers", type=int, default=15)
    args = parser.parse_args(argv)
    print("scene " + " ".join(WEIGHTS))
    for folder in args.scenes:
        try:
            pairs, num_keypoints = read_scene(folder, args.min_num_inliers)
            labels = hel.read_pair_labels(f"{folder}/pair_labels.txt")
        except (OSError, sqlite3.Error, ValueError) as e:
            print(f"error: {folder}: {e}", file=sys.stderr)
            return 1
        true_pairs = {pair for pair, label in labels.items()
                      if label[0] == hel.TRUE}
        weights = pair_weights(pairs, keypoint_degrees(pairs, num_keypoints),
                               args.fraction)
        row = [f"{top_neighbour_truth(weights[name], true_pairs):.2f}"
               for name in WEIGHTS]
        print(folder.rstrip("/").split("/")[-1] + " " + " ".join(row))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
