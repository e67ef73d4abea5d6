#!/usr/bin/env python3
"""Fits the builtin verifier's score (src/hisfm/verify/pair_score.cc).

Input: the TSV files `bench/cue_study --labels L --output F.tsv` writes for the
instances of the tuning half of the synthetic scenes (odd seeds), one row per
verified pair with its label (1 true, 0 false) and the edge test's counts.
Output, as the C++ constants of pair_score.cc:
- for the pairs the test judged ("speaks"): the coefficients of a logistic
  model of P(true) on the raw score, the join's depth agreement (the smaller
  of the two models') and the relative burstiness-weighted support, fitted by
  iteratively reweighted least squares;
- for silent pairs: P(true) in 20 equal bins of the raw score, by isotonic
  regression (pool adjacent violators).
Both fits weight each instance's true and false pairs so that true pairs
carry the share `--prior` of every instance (the share of true pairs among
the pairs the hierarchy verified on the tuning half, 0.58), so that no family
and no instance dominates by its size. Instances with only one class (the
control scenes without doppelgangers) are left out.

The raw score, the features and the rule for when the test speaks must match
PairFeatures and CalibratedPairScore (pair_score.h).

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


def clamp01(x):
    return min(1.0, max(0.0, x))


def judged_features(row):
    """The logistic model's inputs of a judged row (1 for the intercept, then
    as CalibratedPairScore uses them)."""
    raw, _ = raw_score(row)
    agreement = min(float(row["agree_i"]), float(row["agree_j"]))
    return [1.0, raw, clamp01(agreement), clamp01(float(row["rel_burst"]))]


def weighted_rows(paths, prior):
    """(row, is_true, weight) over the labelled rows of every file, weighted as
    the module docstring says."""
    for path in paths:
        rows = [r for r in read_tsv(path) if r["label"] in ("0", "1")]
        positives = sum(1 for r in rows if r["label"] == "1")
        negatives = len(rows) - positives
        if positives == 0 or negatives == 0:
            # A control scene without doppelgangers (or without true pairs):
            # the per-class weighting is undefined for it.
            continue
        for r in rows:
            true = r["label"] == "1"
            w = prior / positives if true else (1 - prior) / negatives
            yield r, true, w


def solve(a, b):
    """Solves the small dense system a x = b (Gauss-Jordan, pivoting)."""
    n = len(b)
    m = [list(a[i]) + [b[i]] for i in range(n)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        for r in range(n):
            if r != c and m[c][c] != 0:
                f = m[r][c] / m[c][c]
                m[r] = [x - f * y for x, y in zip(m[r], m[c])]
    return [m[i][n] / m[i][i] for i in range(n)]


def fit_logistic(paths, prior, ridge=1e-3, iterations=50):
    """Weighted logistic regression of the label on judged_features."""
    data = [(judged_features(r), t, w)
            for r, t, w in weighted_rows(paths, prior) if raw_score(r)[1]]
    if not data:
        raise ValueError("no judged pair in an instance with both classes")
    n = len(data[0][0])
    beta = [0.0] * n
    for _ in range(iterations):
        hessian = [[ridge * (i == j) for j in range(n)] for i in range(n)]
        gradient = [-ridge * b for b in beta]
        for x, t, w in data:
            z = sum(b * v for b, v in zip(beta, x))
            p = 1 / (1 + math.exp(-max(-30.0, min(30.0, z))))
            for i in range(n):
                gradient[i] += w * (t - p) * x[i]
                for j in range(n):
                    hessian[i][j] += w * p * (1 - p) * x[i] * x[j]
        step = solve(hessian, gradient)
        beta = [b + s for b, s in zip(beta, step)]
        if max(abs(s) for s in step) < 1e-9:
            break
    return beta


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


def fit_silent(paths, prior):
    """The silent pairs' table: isotonic P(true) per bin of the raw score."""
    num = [0.0] * BINS
    den = [0.0] * BINS
    for r, true, w in weighted_rows(paths, prior):
        score, speaks = raw_score(r)
        if speaks:
            continue
        b = min(BINS - 1, int(score * BINS))
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
    beta = fit_logistic(args.tsv, args.prior)
    print("kJudgedModel = {%s};  // intercept, raw, agreement, burstiness"
          % ", ".join("%.3f" % b for b in beta))
    table = fit_silent(args.tsv, args.prior)
    print("kSilent = {%s};" % ", ".join("%.3f" % v for v in table))


if __name__ == "__main__":
    main()
