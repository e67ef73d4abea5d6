#!/usr/bin/env python3
"""Which edges of a mapper run's hierarchy are false, by the synthetic labels.

`hisfm synth` writes pair_labels.txt beside each scene's database: the inliers
of every verified pair split into true, doppelganger and random matches.
`hisfm mapper` writes the hierarchy it reconstructed from to
WORK/view_graph.json (WORK: --work_path, default OUTPUT_work). This script
joins the two and prints, per kind of edge (tree bridges, intra-community
edges of the skeleton, support edges, leaf edges, rejected bridges, rejected
trusted edges), how many are true, doppelganger and mixed pairs, and lists
every edge of the hierarchy that is not true and every true bridge or trusted
edge that the verifier rejected, with its score.
That is the first question about a folded model: which pair folded it.

A pair is labelled by the share of its inliers that are true matches:
true at --true_share (0.5) or more, doppelganger at --false_share (0.05) or
less, mixed in between (the two images overlap but most of their matches go
to another copy of the pattern). --write_labels also writes the labels as
`bench/cue_study --labels` reads them (id1 id2 label: 1 true, 0 doppelganger,
2 mixed, which cue_study skips); image ids are the synthetic scenes' (image
name NNNNNN.png has id NNNNNN + 1).

Usage:
  hierarchy_edge_labels.py --labels SCENE/pair_labels.txt \\
      --view_graph OUTPUT_work/view_graph.json [--write_labels FILE]
"""
import argparse
import json
import os
import sys

TRUE, FALSE, MIXED = 1, 0, 2
NAMES = {TRUE: "true", FALSE: "doppelganger", MIXED: "mixed"}

# Kinds of edge in view_graph.json, in the order they are reported.
EDGE_KINDS = ["skeleton_bridges", "skeleton_intra_edges", "support_edges",
              "leaf_edges"]
# Kinds of edge the verifier rejected: a suspect when it is true.
REJECTED_KINDS = ["rejected_bridges", "rejected_trusted_edges"]


def image_id(name):
    """The synthetic scenes' image id of an image name (000041.png -> 42)."""
    stem = os.path.splitext(os.path.basename(name))[0]
    if not stem.isdigit():
        raise ValueError("not a synthetic image name: %r" % name)
    return int(stem) + 1


def classify(inliers, true_matches, true_share=0.5, false_share=0.05):
    """TRUE, FALSE or MIXED for a pair with `true_matches` of `inliers`."""
    if inliers <= 0:
        return FALSE
    share = true_matches / inliers
    if share >= true_share:
        return TRUE
    if share <= false_share:
        return FALSE
    return MIXED


def read_pair_labels(path, true_share=0.5, false_share=0.05):
    """{(id1, id2) with id1 < id2: (label, inliers, true, doppelganger)}."""
    labels = {}
    with open(path) as f:
        for number, line in enumerate(f, 1):
            if not line.strip() or line.startswith("#"):
                continue
            fields = line.split()
            if len(fields) != 6:
                raise ValueError("%s:%d: expected 6 fields, got %d"
                                 % (path, number, len(fields)))
            a, b = image_id(fields[0]), image_id(fields[1])
            inliers, true, doppelganger = (int(v) for v in fields[2:5])
            labels[(min(a, b), max(a, b))] = (
                classify(inliers, true, true_share, false_share), inliers,
                true, doppelganger)
    return labels


def edge_label(labels, edge):
    """The label entry of a view_graph.json edge, None if unlabelled."""
    a, b = edge["image_id1"], edge["image_id2"]
    return labels.get((min(a, b), max(a, b)))


def summarize(labels, view_graph):
    """{kind: {"counts": {label name: n}, "suspects": [edge dicts]}}: per kind
    of edge, the counts by label and the edges to look at (hierarchy edges not
    true; rejected bridges and trusted edges that are true), each with its
    label entry."""
    out = {}
    for kind in EDGE_KINDS + REJECTED_KINDS:
        counts = {name: 0 for name in list(NAMES.values()) + ["unlabelled"]}
        suspects = []
        for edge in view_graph.get(kind, []):
            entry = edge_label(labels, edge)
            label = entry[0] if entry else None
            counts[NAMES.get(label, "unlabelled")] += 1
            rejected = kind in REJECTED_KINDS
            if (label == TRUE) == rejected:
                suspects.append(dict(edge, label=entry))
        out[kind] = {"counts": counts, "suspects": suspects}
    return out


def format_edge(edge):
    entry = edge["label"]
    text = "%d-%d inliers %s" % (edge["image_id1"], edge["image_id2"],
                                 edge.get("inliers", "?"))
    if edge.get("score") is not None:
        text += " score %.3f" % edge["score"]
    if entry is None:
        return text + " (unlabelled)"
    return text + " %s (%d true, %d doppelganger matches)" % (
        NAMES[entry[0]], entry[2], entry[3])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--labels", required=True)
    parser.add_argument("--view_graph", required=True)
    parser.add_argument("--write_labels")
    parser.add_argument("--true_share", type=float, default=0.5)
    parser.add_argument("--false_share", type=float, default=0.05)
    args = parser.parse_args(argv)
    if not 0 <= args.false_share < args.true_share <= 1:
        parser.error("need 0 <= --false_share < --true_share <= 1")
    try:
        labels = read_pair_labels(args.labels, args.true_share,
                                  args.false_share)
        with open(args.view_graph) as f:
            view_graph = json.load(f)
    except (OSError, ValueError) as error:
        print("error: %s" % error, file=sys.stderr)
        return 1
    if args.write_labels:
        tmp = args.write_labels + ".tmp"
        with open(tmp, "w") as f:
            for (a, b), entry in sorted(labels.items()):
                f.write("%d %d %d\n" % (a, b, entry[0]))
        os.replace(tmp, args.write_labels)
    for kind, result in summarize(labels, view_graph).items():
        counts = ", ".join("%d %s" % (n, name)
                           for name, n in result["counts"].items() if n)
        print("%s: %s" % (kind, counts or "none"))
        for edge in result["suspects"]:
            print("    " + format_edge(edge))
    return 0


if __name__ == "__main__":
    sys.exit(main())
