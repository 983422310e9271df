#!/usr/bin/env python3
"""Fits the confidence of an answer to a mask (SolverOptions::confidence and
wide_mask_confidence): P(pose within ADD(-S) 0.1 d) as a logistic in what the answer has,

    S_A, ambiguous, on_surface and contour_support (the answer against the whole frame,
    FrameCheck), mask_iou (the mask its pose implies against the caller's mask),

    confidence = 1 / (1 + exp(-(bias + score * S_A + ambiguous * [ambiguous] + on_surface * on
                                 + contour * contour + mask_iou * mask_iou)))

fitted apart for masks that fit the object and for masks wider than it or boxes (the records'
mask_wider and mask_is_box): there an answer that explains one object of the mask may be on
the wrong one, whatever its own evidence. On the per-instance records of g6d-bench-dataset
(--records FILE.csv) of several datasets, measured honestly: leave-one-object-out over all
datasets pooled (every answer predicted by a fit that saw no answer of its object) and
leave-one-dataset-out, with a reliability table, the expected calibration error (ECE), the
Brier score and the wrong answers with confidence >= 0.9, beside the confidence the answers
had. The fit from S_A and the ambiguity alone (confidence_bias, confidence_score_weight,
confidence_ambiguous_weight: tracking's answers, which have no frame check) is printed too.

    python3 scripts/calibrate_confidence.py synth_dev=out/c/synth_gt.rec.csv,out/c/synth_cut.rec.csv \
        lmo=out/c/lmo_gt.rec.csv ycbv_clutter=... ycbv_real=...

--measure=NAME=FILES reports a dataset the fit does not see (LM-O) with the fit on the others.
A dataset may have several record files, comma-separated (its GT masks and its degraded
masks); they are one dataset for the held-out splits, so an object held out is held out in
every file.

The features are standardized for the fit and one L2 penalty (--l2=X, default L2 below) holds
every weight but the bias back; the weights printed are those of the features as they are.
--l2=raw fits the raw features with a token penalty (1e-3), as before 2026-12-02.

No numpy needed: a small Newton's method.
"""
import csv
import math
import sys

WEIGHTS = ["bias", "score", "ambiguous", "on_surface", "contour", "mask_iou"]

# The L2 penalty on the weights of the standardized features (the bias free). Chosen on the
# answers of synth_dev and the real YCB-V sets with GT, cut, merged and box masks, left out
# one object at a time, over raw (1e-3), 0.3, 1, 3, 10, 30 and 100: wrong answers at >= 0.9
# 37, 37, 37, 32, 30, 26, 15 of 1,704; Brier 0.083, 0.083, 0.083, 0.083, 0.084, 0.085, 0.090;
# ECE 0.024, 0.024, 0.023, 0.022, 0.022, 0.025, 0.038. 10 is the strongest penalty that keeps
# the Brier score and the ECE, and the first whose S_A weight is negative (bench/RESULTS.md,
# "The mask path's confidence, held back the same way").
L2 = 10.0


def load(paths):
    rows = []
    for path in paths.split(","):
        with open(path) as f:
            for r in csv.DictReader(f):
                if r["success"] != "1":
                    continue
                number = lambda key: float(r[key]) if r.get(key) not in (None, "") else 0.0  # noqa: E731
                rows.append({"s": float(r["score"]), "amb": int(r.get("ambiguous", "0") or 0), "y": int(r["correct"]),
                             "obj": int(r["obj_id"]), "had": float(r["confidence"]), "file": path,
                             "on": number("on_surface"), "contour": number("contour_support"),
                             "miou": number("mask_iou"), "wide": number("mask_wider") > 0 or number("mask_is_box") > 0,
                             "dup": number("duplicate_answer") > 0})
    if not rows:
        sys.exit(f"{paths}: no successful estimates")
    return rows


def features(r):
    """S_A and the ambiguity alone (ConfidenceFromScore)."""
    return [1.0, r["s"], float(r["amb"])]


def answer_features(r):
    return [1.0, r["s"], float(r["amb"]), r["on"], r["contour"], r["miou"]]


def wide_features(r):
    """A wide mask or a box: the frame check is left out. It says that the pose lies well on
    an object of the mask, not that it is the one the caller meant."""
    return [1.0, r["s"], float(r["amb"]), 0.0, 0.0, r["miou"]]


class Split:
    """Two logistic fits: masks that fit the object, and wide masks or boxes. With `l2`, each
    is fitted on standardized features with that penalty on every weight but the bias
    (fit_standardized); without, as before 2026-12-02 (raw features, L2 1e-3)."""

    def __init__(self, rows, l2=None):
        # Answers on another answer's instance (duplicate_answer) are left out: their
        # confidence is bounded by that answer's (ExplainAwayNeighbours), not by this fit.
        fitting = [r for r in rows if not r["wide"] and not r["dup"]]
        wide = [r for r in rows if r["wide"] and not r["dup"]]

        def one(subset, feats):
            # Standardized, a feature the subset does not vary (the wide fit's zeroed frame
            # check) is 0 on every row, and its weight stays 0.
            return fit(subset, features=feats) if l2 is None else fit_standardized(subset, l2, features=feats)

        self.fit = one(fitting, answer_features) if fitting else [0.0] * len(WEIGHTS)
        self.wide = one(wide, wide_features) if wide else self.fit

    def __call__(self, r):
        if r["wide"]:
            return predict(self.wide, r, features=wide_features)
        return predict(self.fit, r, features=answer_features)


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


def fit(rows, l2=1e-3, features=features, unpenalized=()):
    """Logistic regression of r["y"] on features(r) (Newton's method, L2 penalty on every weight
    but those whose indices are in `unpenalized`)."""
    k = len(features(rows[0]))
    w = [0.0] * k
    penalty = [0.0 if i in unpenalized else l2 for i in range(k)]
    for _ in range(100):
        g = [pi * wi for pi, wi in zip(penalty, w)]
        h = [[penalty[i] + 1e-9 if i == j else 0.0 for j in range(k)] for i in range(k)]
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


def fit_standardized(rows, l2, features=features):
    """fit() on each feature less its mean over `rows` and divided by its standard deviation
    there, with the L2 penalty `l2` on every weight but the bias (features(r)[0], a constant
    1), returned as the weights of the features as they are (what the C++ options take).
    Standardized, one penalty weighs every feature alike whatever its units; it keeps a
    weight from growing to fit a few answers of one kind of scene."""
    xs = [features(r) for r in rows]
    k, n = len(xs[0]), len(xs)
    mean = [sum(x[i] for x in xs) / n for i in range(k)]
    sd = [(sum((x[i] - mean[i]) ** 2 for x in xs) / n) ** 0.5 for i in range(k)]
    mean[0], sd[0] = 0.0, 1.0  # the bias column
    sd = [s if s > 1e-12 else 1.0 for s in sd]  # a feature constant over these rows

    def scaled(r):
        return [(x - m) / s for x, m, s in zip(features(r), mean, sd)]

    w = fit(rows, l2=l2, features=scaled, unpenalized=(0,))
    raw = [wi / si for wi, si in zip(w, sd)]
    raw[0] = w[0] - sum(wi * mi / si for wi, mi, si in zip(w[1:], mean[1:], sd[1:]))
    return raw


def predict(w, r, features=features):
    return sigmoid(sum(wi * xi for wi, xi in zip(w, features(r))))


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
    args = sys.argv[1:]
    given = next((a.split("=", 1)[1] for a in args if a.startswith("--l2=")), str(L2))
    l2 = None if given == "raw" else float(given)
    # --measure=NAME=FILES: a dataset the fit does not see, measured with the fit on the rest
    # (LM-O, whose rendered depth makes every frame check clean).
    measured = [a.split("=", 1)[1] for a in args if a.startswith("--measure=")]
    args = [a for a in args if not a.startswith(("--l2=", "--measure="))]
    if not args or any("=" not in a for a in args + measured):
        sys.exit(__doc__)
    datasets = {}
    for arg in args:
        name, path = arg.split("=", 1)
        datasets[name] = load(path)
    duplicates = sum(r["dup"] for rows in datasets.values() for r in rows)
    if duplicates:
        print(f"{duplicates} answers flagged duplicate_answer are left out (their confidence is at most 1 - "
              "their twin's); the tables below are of the rest")
        datasets = {name: [r for r in rows if not r["dup"]] for name, rows in datasets.items()}
    everything = [r for rows in datasets.values() for r in rows]
    model = Split(everything, l2)
    print(f"fit on all {len(everything)} answers of {', '.join(datasets)} "
          f"({sum(r['wide'] for r in everything)} to wide masks or boxes; "
          f"{'raw features, L2 1e-3' if l2 is None else f'standardized features, L2 {l2}'}):")
    for name, w in (("confidence", model.fit), ("wide_mask_confidence", model.wide)):
        print(f"  {name} = {{{', '.join(f'{x:.3f}' for x in w)}}};  // {', '.join(WEIGHTS)}")
    w = fit(everything)
    print(f"  S_A alone: confidence_bias = {w[0]:.3f}, confidence_score_weight = {w[1]:.3f}, "
          f"confidence_ambiguous_weight = {w[2]:.3f}")
    for name, rows in datasets.items():
        if len(datasets) > 1:
            held = Split([r for other, o in datasets.items() if other != name for r in o], l2)
            report(rows, held, f"{name}, held out (fit on the other datasets)")
        report(rows, lambda r: r["had"], f"{name}, the confidence the answers had")
    report(everything, model, "all datasets, in-sample fit")
    for arg in measured:
        name, path = arg.split("=", 1)
        rows = [r for r in load(path) if not r["dup"]]
        report(rows, model, f"{name}, not fitted (measured with the fit on all the others)")
        report(rows, lambda r: r["had"], f"{name}, the confidence the answers had")
        for file in sorted({r["file"] for r in rows}):
            part = [r for r in rows if r["file"] == file]
            wrong = sum(1 for r in part if model(r) >= 0.9 and r["y"] == 0)
            had = sum(1 for r in part if r["had"] >= 0.9 and r["y"] == 0)
            brier = sum((model(r) - r["y"]) ** 2 for r in part) / len(part)
            brier_had = sum((r["had"] - r["y"]) ** 2 for r in part) / len(part)
            print(f"  {file}: {len(part)} answers, wrong at >= 0.9 {had} -> {wrong}, Brier {brier_had:.3f} -> {brier:.3f}")
    # Leave one object out over all datasets pooled: every answer is predicted by a fit that
    # saw no answer of its object (objects are the finer honest split: a dataset held out
    # whole leaves the fit without the kind of scene it shows).
    groups = sorted({(name, r["obj"]) for name, rows in datasets.items() for r in rows})
    held_out = {}
    for group in groups:
        held = Split([r for name, rows in datasets.items() for r in rows if (name, r["obj"]) != group], l2)
        for r in datasets[group[0]]:
            if r["obj"] == group[1]:
                held_out[id(r)] = held(r)
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
