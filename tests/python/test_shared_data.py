"""Python answers equal g6d-solve's on real data (../shared/data/ycbv_clutter): every
target of the first image, and the detection run without masks. Skipped when the data is
absent. The caches (36 templates per object) are built with g6d.build_templates once and
kept in the build folder."""

import json
import os
from pathlib import Path

import pytest

import g6d
from conftest import BUILD_DIR, assert_same_answer, bop_images, solve_json

VIEWS = 36
# G6D_PYTHON_TEST_IMAGES=all compares every image (15 targets) instead of the first.
ALL_IMAGES = os.environ.get("G6D_PYTHON_TEST_IMAGES") == "all"


@pytest.fixture(scope="module")
def ycbv(shared_data):
    root = shared_data / "ycbv_clutter"
    if not (root / "test" / "000001").is_dir():
        pytest.skip(f"no {root}: skipped")
    info = json.loads((root / "models" / "models_info.json").read_text())
    cache_dir = BUILD_DIR / "python_test_caches" / "ycbv_clutter"
    cache_dir.mkdir(parents=True, exist_ok=True)
    banks = {}
    for key, entry in info.items():
        object_id = f"obj_{int(key):06d}"
        mesh = root / "models" / entry["mesh"]
        cache = cache_dir / f"{object_id}_{VIEWS}.g6dcache"
        try:
            banks[object_id] = g6d.load_cache(cache, mesh_path=mesh)
        except g6d.Error:
            bank = g6d.build_templates(mesh, object_id, entry.get("units", "mm"), views=VIEWS, threads=2)
            bank.save(cache)
            banks[object_id] = bank
    return root, banks, cache_dir


def test_masks_equal_g6d_solve(ycbv, tmp_path):
    root, banks, cache_dir = ycbv
    images = bop_images(root / "test" / "000001")
    compared = 0
    for image in images if ALL_IMAGES else images[:1]:
        frame = image.frame()
        for i, gt in enumerate(image.gt):
            object_id = f"obj_{gt['obj_id']:06d}"
            if not image.mask_path(i).exists():
                continue
            result = g6d.estimate_pose(frame, banks[object_id], mask=g6d.read_image(image.mask_path(i), "gray"),
                                       threads=2)
            answer = solve_json(tmp_path, ["--cache", cache_dir / f"{object_id}_{VIEWS}.g6dcache",
                                           *image.solve_args(), "--mask", image.mask_path(i)])
            assert_same_answer(result, answer)
            compared += 1
    assert compared >= 3


def test_find_objects_equals_g6d_solve(ycbv, tmp_path):
    root, banks, cache_dir = ycbv
    image = bop_images(root / "test" / "000001")[0]
    found = g6d.find_objects(image.frame(), [(banks[k], 1) for k in sorted(banks)], threads=2, num_hypotheses=4)
    arguments = []
    for k in sorted(banks):
        arguments += ["--cache", cache_dir / f"{k}_{VIEWS}.g6dcache"]
    answer = solve_json(tmp_path, [*arguments, "--find-all", "--hypotheses", "4", *image.solve_args()])
    assert [r.object_id for r in found] == [a["object_id"] for a in answer["answers"]]
    for result, expected in zip(found, answer["answers"]):
        assert_same_answer(result, expected)
