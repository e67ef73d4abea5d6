#!/usr/bin/env python3
"""Tests of scripts/hierarchy_edge_labels.py on a small hierarchy (run by
ctest)."""
import io
import json
import os
import sys
import tempfile
import unittest
from contextlib import redirect_stderr, redirect_stdout

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hierarchy_edge_labels as hel  # noqa: E402

PAIR_LABELS = """# Inliers of each verified pair by kind (hisfm synth).
# NAME1 NAME2 INLIERS TRUE DOPPELGANGER RANDOM
000000.png 000001.png 400 396 2 2
000001.png 000002.png 300 100 195 5
000000.png 000003.png 250 2 246 2
000002.png 000003.png 350 349 0 1
000003.png 000004.png 200 0 198 2
"""

VIEW_GRAPH = {
    "skeleton_bridges": [
        {"image_id1": 1, "image_id2": 2, "inliers": 400, "score": 0.99},
        {"image_id1": 4, "image_id2": 1, "inliers": 250, "score": 0.674},
    ],
    "skeleton_intra_edges": [{"image_id1": 3, "image_id2": 4,
                              "inliers": 350}],
    "support_edges": [],
    "leaf_edges": [{"image_id1": 2, "image_id2": 3, "inliers": 300},
                   {"image_id1": 7, "image_id2": 9, "inliers": 10}],
    "rejected_bridges": [
        {"image_id1": 3, "image_id2": 4, "inliers": 350, "score": 0.2},
        {"image_id1": 4, "image_id2": 5, "inliers": 200, "score": 0.1},
    ],
    "rejected_trusted_edges": [
        {"image_id1": 3, "image_id2": 4, "inliers": 350, "score": 0.08,
         "round": 0},
        {"image_id1": 1, "image_id2": 4, "inliers": 250, "score": 0.02,
         "round": 1},
    ],
}


class HierarchyEdgeLabelsTest(unittest.TestCase):
    def test_classify_by_share_of_true_matches(self):
        self.assertEqual(hel.classify(400, 396), hel.TRUE)
        self.assertEqual(hel.classify(400, 200), hel.TRUE)
        self.assertEqual(hel.classify(300, 100), hel.MIXED)
        self.assertEqual(hel.classify(250, 2), hel.FALSE)
        self.assertEqual(hel.classify(0, 0), hel.FALSE)
        self.assertEqual(hel.classify(300, 100, true_share=0.3), hel.TRUE)

    def test_edge_without_a_score_is_printed(self):
        # The mapper writes "score": null for a pair it did not score.
        edge = {"image_id1": 9, "image_id2": 12, "inliers": 189,
                "score": None, "label": (hel.FALSE, 189, 0, 189)}
        self.assertEqual(hel.format_edge(edge),
                         "9-12 inliers 189 doppelganger "
                         "(0 true, 189 doppelganger matches)")
        edge["score"] = 0.6764
        self.assertIn("score 0.676 ", hel.format_edge(edge))

    def test_image_ids_follow_synthetic_names(self):
        self.assertEqual(hel.image_id("000041.png"), 42)
        with self.assertRaises(ValueError):
            hel.image_id("IMG_0001.JPG")

    def test_summary_counts_and_suspects(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "pair_labels.txt")
            with open(path, "w") as f:
                f.write(PAIR_LABELS)
            labels = hel.read_pair_labels(path)
        self.assertEqual(labels[(1, 4)], (hel.FALSE, 250, 2, 246))
        summary = hel.summarize(labels, VIEW_GRAPH)
        bridges = summary["skeleton_bridges"]
        self.assertEqual(bridges["counts"]["true"], 1)
        self.assertEqual(bridges["counts"]["doppelganger"], 1)
        self.assertEqual([(e["image_id1"], e["image_id2"])
                          for e in bridges["suspects"]], [(4, 1)])
        leaves = summary["leaf_edges"]
        self.assertEqual(leaves["counts"]["mixed"], 1)
        self.assertEqual(leaves["counts"]["unlabelled"], 1)
        self.assertEqual(len(leaves["suspects"]), 2)
        self.assertEqual(summary["skeleton_intra_edges"]["suspects"], [])
        # A rejected bridge is a suspect when it is true.
        rejected = summary["rejected_bridges"]["suspects"]
        self.assertEqual([(e["image_id1"], e["image_id2"]) for e in rejected],
                         [(3, 4)])
        # So is a rejected trusted edge: 3-4 is true, 1-4 a doppelganger.
        trusted = summary["rejected_trusted_edges"]
        self.assertEqual(trusted["counts"]["true"], 1)
        self.assertEqual(trusted["counts"]["doppelganger"], 1)
        self.assertEqual([(e["image_id1"], e["image_id2"])
                          for e in trusted["suspects"]], [(3, 4)])

    def test_command_prints_and_writes_labels(self):
        with tempfile.TemporaryDirectory() as tmp:
            labels = os.path.join(tmp, "pair_labels.txt")
            graph = os.path.join(tmp, "view_graph.json")
            out = os.path.join(tmp, "labels3.txt")
            with open(labels, "w") as f:
                f.write(PAIR_LABELS)
            with open(graph, "w") as f:
                json.dump(VIEW_GRAPH, f)
            printed = io.StringIO()
            with redirect_stdout(printed):
                code = hel.main(["--labels", labels, "--view_graph", graph,
                                 "--write_labels", out])
            self.assertEqual(code, 0)
            text = printed.getvalue()
            self.assertIn("skeleton_bridges: 1 true, 1 doppelganger", text)
            self.assertIn("4-1 inliers 250 score 0.674 doppelganger", text)
            with open(out) as f:
                lines = f.read().split("\n")
            self.assertIn("1 4 0", lines)
            self.assertIn("2 3 2", lines)
            self.assertIn("3 4 1", lines)

    def test_bad_input_is_one_line_error(self):
        with tempfile.TemporaryDirectory() as tmp:
            labels = os.path.join(tmp, "pair_labels.txt")
            with open(labels, "w") as f:
                f.write("000000.png 000001.png 400\n")
            errors = io.StringIO()
            with redirect_stderr(errors):
                code = hel.main(["--labels", labels, "--view_graph",
                                 os.path.join(tmp, "missing.json")])
            self.assertEqual(code, 1)
            self.assertEqual(errors.getvalue().count("\n"), 1)
            self.assertIn("expected 6 fields", errors.getvalue())


if __name__ == "__main__":
    unittest.main()
