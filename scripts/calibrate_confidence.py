#!/usr/bin/env python3
"""Fits the solver's confidence: P(pose within ADD(-S) 0.1 d) = 1 / (1 + exp(slope * (S_A - midpoint))).

Input: the per-instance records of g6d-bench-dataset (--records FILE.csv). The fit is a
two-parameter logistic regression of `correct` on S_A by Newton's method (no numpy needed).
It reports the fit on all records, a 2-fold cross-validation split by image id parity
(fit on one half, measure on the other), and a reliability table (predicted confidence vs
observed accuracy per bin) with the expected calibration error (ECE) and the Brier score.

  python3 scripts/calibrate_confidence.py out/exp/lmo_full_records.csv
"""
import csv
import math
import sys


def load(path):
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            if r["success"] != "1":
                continue
            rows.append((float(r["score"]), int(r["correct"]), int(r["im_id"])))
    if not rows:
        sys.exit(f"{path}: no successful estimates")
    return rows


def sigmoid(x):
    return 1.0 / (1.0 + math.exp(-x)) if x > -500 else 0.0


def fit(rows, l2=1e-3):
    """Logistic regression p = sigmoid(a + b * S); returns (slope, midpoint) of our form."""
    a, b = 0.0, 0.0
    for _ in range(100):
        ga = gb = 0.0
        haa = hab = hbb = l2
        for s, y, _ in rows:
            p = sigmoid(a + b * s)
            ga += p - y
            gb += (p - y) * s
            w = max(p * (1 - p), 1e-9)
            haa += w
            hab += w * s
            hbb += w * s * s
        gb += l2 * b
        ga += l2 * a
        det = haa * hbb - hab * hab
        da = (hbb * ga - hab * gb) / det
        db = (haa * gb - hab * ga) / det
        a, b = a - da, b - db
        if abs(da) + abs(db) < 1e-10:
            break
    slope = -b
    midpoint = a / slope if slope != 0 else float("nan")
    return slope, midpoint


def confidence(s, slope, midpoint):
    return sigmoid(-slope * (s - midpoint))


def report(rows, slope, midpoint, title):
    bins = [[] for _ in range(10)]
    brier = 0.0
    for s, y, _ in rows:
        c = confidence(s, slope, midpoint)
        brier += (c - y) ** 2
        bins[min(9, int(c * 10))].append((c, y))
    ece = 0.0
    print(f"\n{title}: n = {len(rows)}, accuracy {sum(y for _, y, _ in rows) / len(rows):.3f}")
    print("| confidence bin | n | mean confidence | observed accuracy |\n|---|---|---|---|")
    for i, b in enumerate(bins):
        if not b:
            continue
        mc = sum(c for c, _ in b) / len(b)
        acc = sum(y for _, y in b) / len(b)
        ece += len(b) / len(rows) * abs(mc - acc)
        print(f"| {i / 10:.1f}-{(i + 1) / 10:.1f} | {len(b)} | {mc:.3f} | {acc:.3f} |")
    print(f"ECE {ece:.3f}, Brier {brier / len(rows):.3f}")


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    rows = load(sys.argv[1])
    slope, midpoint = fit(rows)
    print(f"fit on all {len(rows)} estimates: confidence_slope = {slope:.2f}, confidence_midpoint = {midpoint:.4f}")
    report(rows, slope, midpoint, "all (in-sample)")
    even = [r for r in rows if r[2] % 2 == 0]
    odd = [r for r in rows if r[2] % 2 == 1]
    if even and odd:
        se, me = fit(even)
        so, mo = fit(odd)
        print(f"\n2-fold by image parity: even -> slope {se:.2f} midpoint {me:.4f}; odd -> slope {so:.2f} midpoint {mo:.4f}")
        report(odd, se, me, "fit on even images, measured on odd")
        report(even, so, mo, "fit on odd images, measured on even")
    for extra in sys.argv[2:]:
        report(load(extra), slope, midpoint, f"held-out file {extra}")


if __name__ == "__main__":
    main()
