#!/usr/bin/env python3
"""Fits the solver's confidence: P(pose within ADD(-S) 0.1 d) as a logistic in S_A and the
ambiguity flag,

    confidence = 1 / (1 + exp(-(bias + score_weight * S_A + ambiguous_weight * ambiguous)))

on the per-instance records of g6d-bench-dataset (--records FILE.csv) of several datasets,
and measures it honestly: leave-one-dataset-out (fit on all other datasets, measure on the
held-out one), so no image of a measured dataset was seen by its fit. Per dataset it prints
a reliability table (confidence bin vs observed accuracy), the expected calibration error
(ECE), the Brier score, and the misses with confidence >= 0.9. The old one-feature LM-O fit
(slope 7.25, midpoint 0.673) is measured beside it.

    python3 scripts/calibrate_confidence.py lmo=out/cal/lmo.csv ycbv_clutter=out/cal/ycbv_clutter.csv \\
        ycbv_real=out/cal/ycbv_real.csv sample=out/cal/sample.csv

A dataset may have several record files, comma-separated (its GT masks and its degraded
masks: lmo=out/c/lmo_none.records.csv,out/c/lmo_cut.records.csv); they are one dataset for
the held-out splits, so an object held out is held out in every file.

No numpy needed: a small Newton's method with an L2 penalty (1e-3).
"""
import csv
import math
import sys

OLD_SLOPE, OLD_MIDPOINT = 7.25, 0.673


def load(paths):
    rows = []
    for path in paths.split(","):
        with open(path) as f:
            for r in csv.DictReader(f):
                if r["success"] != "1":
                    continue
                rows.append({"s": float(r["score"]), "amb": int(r.get("ambiguous", "0") or 0), "y": int(r["correct"]),
                             "obj": int(r["obj_id"]), "had": float(r["confidence"]), "file": path})
    if not rows:
        sys.exit(f"{paths}: no successful estimates")
    return rows


def features(r):
    return [1.0, r["s"], float(r["amb"])]


def sigmoid(x):
    if x < -500:
        return 0.0
    return 1.0 / (1.0 + math.exp(-x))


def solve(a, b):
    """Gaussian elimination for a small dense system a x = b."""
    n = len(b)
    m = [row[:] + [b[i]] for i, row in enumerate(a)]
    for c in range(n):
        p = max(range(c, n), key=lambda i: abs(m[i][c]))
        m[c], m[p] = m[p], m[c]
        for i in range(n):
            if i != c and m[c][c] != 0:
                f = m[i][c] / m[c][c]
                for j in range(c, n + 1):
                    m[i][j] -= f * m[c][j]
    return [m[i][n] / m[i][i] for i in range(n)]


def fit(rows, l2=1e-3, features=features):
    """Logistic regression of r["y"] on features(r) (Newton's method, L2 penalty)."""
    k = len(features(rows[0]))
    w = [0.0] * k
    for _ in range(100):
        g = [l2 * wi for wi in w]
        h = [[l2 if i == j else 0.0 for j in range(k)] for i in range(k)]
        for r in rows:
            x = features(r)
            p = sigmoid(sum(wi * xi for wi, xi in zip(w, x)))
            q = max(p * (1 - p), 1e-9)
            for i in range(k):
                g[i] += (p - r["y"]) * x[i]
                for j in range(k):
                    h[i][j] += q * x[i] * x[j]
        step = solve(h, g)
        w = [wi - si for wi, si in zip(w, step)]
        if sum(abs(si) for si in step) < 1e-10:
            break
    return w


def predict(w, r, features=features):
    return sigmoid(sum(wi * xi for wi, xi in zip(w, features(r))))


def predict_old(r):
    return sigmoid(-OLD_SLOPE * (r["s"] - OLD_MIDPOINT))


def report(rows, confidence, title):
    bins = [[] for _ in range(10)]
    brier = 0.0
    confident_misses = 0
    for r in rows:
        c = confidence(r)
        brier += (c - r["y"]) ** 2
        bins[min(9, int(c * 10))].append((c, r["y"]))
        confident_misses += c >= 0.9 and r["y"] == 0
    ece = 0.0
    accuracy = sum(r["y"] for r in rows) / len(rows)
    lines = []
    for i, b in enumerate(bins):
        if not b:
            continue
        mc = sum(c for c, _ in b) / len(b)
        acc = sum(y for _, y in b) / len(b)
        ece += len(b) / len(rows) * abs(mc - acc)
        lines.append(f"| {i / 10:.1f}-{(i + 1) / 10:.1f} | {len(b)} | {mc:.3f} | {acc:.3f} |")
    print(f"\n**{title}**: n = {len(rows)}, accuracy {accuracy:.3f}, ECE {ece:.3f}, Brier {brier / len(rows):.3f}, "
          f"misses with confidence >= 0.9: {confident_misses}")
    print("| confidence bin | n | mean confidence | observed accuracy |\n|---|---|---|---|")
    print("\n".join(lines))
    return ece


def main():
    if len(sys.argv) < 2 or any("=" not in a for a in sys.argv[1:]):
        sys.exit(__doc__)
    datasets = {}
    for arg in sys.argv[1:]:
        name, path = arg.split("=", 1)
        datasets[name] = load(path)
    everything = [r for rows in datasets.values() for r in rows]
    w = fit(everything)
    print(f"fit on all {len(everything)} estimates of {', '.join(datasets)}:")
    print(f"  confidence_bias = {w[0]:.3f}, confidence_score_weight = {w[1]:.3f}, "
          f"confidence_ambiguous_weight = {w[2]:.3f}")
    for name, rows in datasets.items():
        if len(datasets) > 1:
            others = [r for other, o in datasets.items() if other != name for r in o]
            held = fit(others)
            report(rows, lambda r, held=held: predict(held, r),
                   f"{name}, held out (fit on the other datasets: bias {held[0]:.2f}, S {held[1]:.2f}, "
                   f"ambiguous {held[2]:.2f})")
        report(rows, predict_old, f"{name}, old LM-O fit (slope {OLD_SLOPE}, midpoint {OLD_MIDPOINT})")
    report(everything, lambda r: predict(w, r), "all datasets, in-sample fit")
    # Leave one object out over all datasets pooled: every answer is predicted by a fit that
    # saw no answer of its object (LM-O is one scene, and only it has misses, so holding out
    # whole datasets leaves fits without a single miss; objects are the finer honest split).
    groups = sorted({(name, r["obj"]) for name, rows in datasets.items() for r in rows})
    held_out = {}
    for group in groups:
        train = [r for name, rows in datasets.items() for r in rows if (name, r["obj"]) != group]
        weights = fit(train)
        for r in datasets[group[0]]:
            if r["obj"] == group[1]:
                held_out[id(r)] = predict(weights, r)
    print(f"\nleave-one-object-out ({len(groups)} objects over {len(datasets)} datasets):")
    for name, rows in datasets.items():
        report(rows, lambda r: held_out[id(r)], f"{name}, leave-one-object-out")
    report(everything, lambda r: held_out[id(r)], "all datasets, leave-one-object-out")
    # One line per record file: the confidence the answers had against the held-out refit.
    print("\n| records | answers | right | had: ECE | had: wrong, conf >= 0.9 | refit, left out: ECE | refit: wrong, conf >= 0.9 |")
    print("|---|---|---|---|---|---|---|")
    for path in sorted({r["file"] for r in everything}):
        rows = [r for r in everything if r["file"] == path]
        line = [path, str(len(rows)), f"{100 * sum(r['y'] for r in rows) / len(rows):.1f}%"]
        for confidence in (lambda r: r["had"], lambda r: held_out[id(r)]):
            wrong = sum(1 for r in rows if confidence(r) >= 0.9 and r["y"] == 0)
            line += [f"{calibration_error(rows, confidence):.3f}", f"{wrong} ({100 * wrong / len(rows):.1f}%)"]
        print("| " + " | ".join(line) + " |")


def calibration_error(rows, confidence):
    """Expected calibration error over ten equal confidence bins."""
    bins = [[] for _ in range(10)]
    for r in rows:
        c = confidence(r)
        bins[min(9, int(c * 10))].append((c, r["y"]))
    return sum(len(b) / len(rows) * abs(sum(c for c, _ in b) / len(b) - sum(y for _, y in b) / len(b)) for b in bins if b)


if __name__ == "__main__":
    main()
