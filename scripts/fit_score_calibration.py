#!/usr/bin/env python3
"""Fits the builtin verifier's calibration tables (src/hisfm/verify/pair_score.cc).

Input: the TSV files `bench/cue_study --labels L --output F.tsv` writes for the
instances of the tuning half of the synthetic families (odd seeds), one row per
verified pair with its label (1 true, 0 false) and the edge test's counts.
Output: the two tables, P(true) in 20 equal bins of the raw score, for pairs
the test judged ("speaks") and for silent pairs, by isotonic regression (pool
adjacent violators). Each instance's true and false pairs are weighted so that
true pairs carry the share `--prior` of every instance (the share of true
pairs among the pairs the hierarchy verified on the tuning half, 0.58), so
that no family and no instance dominates by its size.

The raw score and the rule for when the test speaks must match
PairFeatures::RawScore and PairFeatures::Speaks.

Usage: fit_score_calibration.py [--prior 0.58] TSV...
"""
import argparse
import math

BINS = 20
MIN_UNIQUE = 5             # kMinUniquePoints
MIN_REPEAT_OVER_CHANCE = 2.0  # kMinRepeatabilityOverChance
MAX_SILENT_RAW = 0.75      # kMaxSilentRawScore


def raw_score(row):
    """(raw score, speaks) of one cue_study row."""
    unique = float(row["unique"])
    visible = float(row["visible"])
    chance = float(row["displaced"]) / (4 * visible) if visible > 0 else 0.0
    checked = float(row["models_checked"])
    repeat = float(row["models_found"]) / checked if checked > 0 else 0.0
    if (row["judged"] == "1" and unique >= MIN_UNIQUE
            and repeat >= MIN_REPEAT_OVER_CHANCE * chance):
        missing = max(0.0, visible - float(row["found"]))
        return min(1.0, max(0.0, 1.0 - missing / unique)), True
    return min(MAX_SILENT_RAW, float(row["rel_burst"])), False


def read_tsv(path):
    with open(path) as f:
        header = f.readline().rstrip("\n").split("\t")
        for line in f:
            values = line.rstrip("\n").split("\t")
            if len(values) == len(header):
                yield dict(zip(header, values))


def isotonic(values, weights):
    """Non-decreasing least-squares fit (pool adjacent violators)."""
    blocks = []  # [mean, weight, count]
    for v, w in zip(values, weights):
        blocks.append([v, w, 1])
        while len(blocks) > 1 and blocks[-2][0] > blocks[-1][0]:
            b = blocks.pop()
            a = blocks.pop()
            w_sum = a[1] + b[1]
            mean = (a[0] * a[1] + b[0] * b[1]) / w_sum if w_sum > 0 else 0.0
            blocks.append([mean, w_sum, a[2] + b[2]])
    out = []
    for mean, _, count in blocks:
        out += [mean] * count
    return out


def interpolate(x, xs, ys):
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    for k in range(1, len(xs)):
        if x <= xs[k]:
            f = (x - xs[k - 1]) / (xs[k] - xs[k - 1])
            return (1 - f) * ys[k - 1] + f * ys[k]
    return ys[-1]


def fit(paths, prior, speaks):
    num = [0.0] * BINS
    den = [0.0] * BINS
    for path in paths:
        rows = [r for r in read_tsv(path) if r["label"] in ("0", "1")]
        positives = sum(1 for r in rows if r["label"] == "1")
        negatives = len(rows) - positives
        for r in rows:
            score, s = raw_score(r)
            if s != speaks:
                continue
            b = min(BINS - 1, int(score * BINS))
            true = r["label"] == "1"
            w = prior / max(positives, 1) if true else (1 - prior) / max(negatives, 1)
            den[b] += w
            num[b] += w * true
    filled = [k for k in range(BINS) if den[k] > 0]
    if not filled:
        return [math.nan] * BINS
    iso = isotonic([num[k] / den[k] for k in filled], [den[k] for k in filled])
    return [interpolate(k, filled, iso) for k in range(BINS)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--prior", type=float, default=0.58)
    parser.add_argument("tsv", nargs="+")
    args = parser.parse_args()
    for speaks, name in ((True, "kJudged"), (False, "kSilent")):
        table = fit(args.tsv, args.prior, speaks)
        print("%s = {%s};" % (name, ", ".join("%.3f" % v for v in table)))


if __name__ == "__main__":
    main()
