"""The confidence fits of scripts/calibrate_confidence.py (the mask path) and
scripts/calibrate_detection.py (detection): the standardized, penalized logistic fit returns
weights of the raw features that predict what the standardized fit predicts, recovers the
weights that made the data, and shrinks towards the base rate as its penalty grows."""

import math
import random
import sys

import pytest

from conftest import SOURCE_DIR

sys.path.insert(0, str(SOURCE_DIR / "scripts"))
import calibrate_confidence as cc  # noqa: E402


def logistic_rows(weights, n, seed):
    """n rows of answer features (S_A, ambiguous, on_surface, contour, mask_iou; a mask that
    fits) with labels drawn from the logistic with `weights` (bias first)."""
    rng = random.Random(seed)
    rows = []
    for _ in range(n):
        r = {"s": rng.uniform(0.0, 0.6), "amb": int(rng.random() < 0.2), "on": rng.uniform(0.3, 1.0),
             "contour": rng.uniform(0.0, 1.0), "miou": rng.uniform(0.4, 1.0), "wide": False, "dup": False,
             "obj": rng.randrange(5), "had": 0.5}
        p = cc.sigmoid(sum(w * x for w, x in zip(weights, cc.answer_features(r))))
        r["y"] = int(rng.random() < p)
        rows.append(r)
    return rows


TRUE = [-2.0, -6.0, -1.5, 4.0, 1.0, 2.0]


def test_raw_weights_predict_what_the_standardized_fit_predicts():
    rows = logistic_rows(TRUE, 400, 1)
    # With a negligible penalty both fits reach the same likelihood optimum.
    standardized = cc.fit_standardized(rows, 1e-6, features=cc.answer_features)
    raw = cc.fit(rows, l2=1e-6, features=cc.answer_features)
    for r in rows[:50]:
        assert cc.predict(standardized, r, features=cc.answer_features) == pytest.approx(
            cc.predict(raw, r, features=cc.answer_features), abs=1e-4)


def test_the_weights_that_made_the_data_are_recovered():
    rows = logistic_rows(TRUE, 3000, 2)
    w = cc.fit_standardized(rows, 1e-3, features=cc.answer_features)
    for fitted, true in zip(w[1:], TRUE[1:]):
        assert fitted == pytest.approx(true, abs=1.2)
    assert w[1] < 0 and w[3] > 0  # the signs of S_A and on_surface


def test_a_larger_penalty_pulls_the_confidence_towards_the_base_rate():
    rows = logistic_rows(TRUE, 400, 3)
    base = sum(r["y"] for r in rows) / len(rows)
    spread = []
    for l2 in (0.01, 10.0, 1000.0):
        w = cc.fit_standardized(rows, l2, features=cc.answer_features)
        spread.append(sum(abs(cc.predict(w, r, features=cc.answer_features) - base) for r in rows) / len(rows))
    assert spread[0] > spread[1] > spread[2]
    assert spread[2] < 0.1 * spread[0]
    # The bias is not penalized: the mean confidence stays at the base rate.
    w = cc.fit_standardized(rows, 1000.0, features=cc.answer_features)
    mean = sum(cc.predict(w, r, features=cc.answer_features) for r in rows) / len(rows)
    assert mean == pytest.approx(base, abs=0.02)


def test_a_feature_the_wide_masks_never_vary_gets_no_weight():
    rows = logistic_rows(TRUE, 300, 4)
    for r in rows[:150]:
        r["wide"] = True
    split = cc.Split(rows, l2=10.0)
    assert split.wide[3] == 0.0 and split.wide[4] == 0.0  # the frame check is left out of wide masks
    assert split.fit[3] > 0.0
    assert all(math.isfinite(w) for w in split.fit + split.wide)
