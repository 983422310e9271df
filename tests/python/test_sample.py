"""Python answers equal g6d-solve's, bit for bit, on the embedded sample: masks, a box, the
unknown-identity solve, detection without masks; plus tracking and the overlay."""

import numpy as np
import pytest

import g6d
from conftest import assert_same_answer, bop_images, solve_json


@pytest.fixture(scope="module")
def image(sample):
    return bop_images(sample / "test" / "000001")[0]


def test_masks_equal_g6d_solve(sample, sample_banks, image, tmp_path):
    frame = image.frame()
    for i, gt in enumerate(image.gt):
        object_id = f"obj_{gt['obj_id']:06d}"
        result = g6d.estimate_pose(frame, sample_banks[object_id], mask=g6d.read_image(image.mask_path(i), "gray"),
                                   threads=2)
        answer = solve_json(tmp_path, ["--cache", sample / "caches" / f"{object_id}.g6dcache", *image.solve_args(),
                                       "--mask", image.mask_path(i)])
        assert_same_answer(result, answer)
        assert result.success and result.object_id == object_id
        assert result.cam_from_object.shape == (4, 4) and result.cam_from_object[3].tolist() == [0, 0, 0, 1]
        assert result.corrected_mask.shape == (frame.height, frame.width) and result.corrected_mask.dtype == np.uint8
        assert result.stages["time_ms"]["total"] > 0 and result.stages["kept_hypotheses"] >= 1
        assert result.stages["query_features"] == answer["stages"]["query_features"]
        assert result.mask_iou == answer["mask"]["answer_mask_iou"]
        # The rendered sample's objects end at a sharp colour edge: most of a right answer's
        # outline has an edge along it (detection's confidence reads this share).
        assert 0.5 < result.oriented_edge <= 1.0 and 0.0 <= result.edge_support <= 1.0
        # A right answer sees past its outline by a pixel or two at most, not through a band.
        assert 0.0 <= result.free_space_band_px < 2.0


def test_options_reach_the_solver(sample, sample_banks, image, tmp_path):
    frame = image.frame()
    object_id = f"obj_{image.gt[0]['obj_id']:06d}"
    result = g6d.estimate_pose(frame, sample_banks[object_id], mask=g6d.read_image(image.mask_path(0), "gray"),
                               num_hypotheses=3, mask_trust="exact", run_mhpo=False)
    answer = solve_json(tmp_path, ["--cache", sample / "caches" / f"{object_id}.g6dcache", *image.solve_args(),
                                   "--mask", image.mask_path(0), "--hypotheses", "3", "--mask-trust", "exact",
                                   "--no-mhpo"])
    assert_same_answer(result, answer)
    # K = 3 PnP poses, and the point-pair-feature and outline poses refined beside them.
    defaults = g6d.SolverOptions()
    assert result.stages["kept_hypotheses"] <= 3 + defaults.ppf_hypotheses + defaults.silhouette_hypotheses


def test_box_is_solved(sample_banks, image):
    frame = image.frame()
    mask = g6d.read_image(image.mask_path(0), "gray")
    rows, columns = np.nonzero(mask)
    box = (int(columns.min()) - 3, int(rows.min()) - 3, int(np.ptp(columns)) + 7, int(np.ptp(rows)) + 7)
    result = g6d.estimate_pose(frame, sample_banks[f"obj_{image.gt[0]['obj_id']:06d}"], box=box)
    assert result.success and result.stages["mask_is_box"]


def test_unknown_identity_equals_g6d_solve(sample, sample_banks, image, tmp_path):
    frame = image.frame()
    banks = [sample_banks[k] for k in sorted(sample_banks)]
    result = g6d.estimate_pose_of_unknown_object(frame, banks, mask=g6d.read_image(image.mask_path(1), "gray"))
    answer = solve_json(tmp_path, ["--cache", sample / "caches", "--candidates", "all", *image.solve_args(),
                                   "--mask", image.mask_path(1)])
    assert_same_answer(result, answer)
    assert result.object_id == answer["object_id"] == f"obj_{image.gt[1]['obj_id']:06d}"
    assert result.identity["runner_up_object_id"] == answer["identity"]["runner_up"]
    assert [c["object_id"] for c in result.identity["candidates"]] == sorted(sample_banks)


def test_find_objects_equals_g6d_solve(sample, sample_banks, image, tmp_path):
    frame = image.frame()
    found = g6d.find_objects(frame, [(sample_banks[k], 1) for k in sorted(sample_banks)], num_hypotheses=4)
    answer = solve_json(tmp_path, ["--cache", sample / "caches", "--find-all", "--hypotheses", "4",
                                   *image.solve_args()])
    assert len(found) == len(answer["answers"]) >= 2
    for result, expected in zip(found, answer["answers"]):
        assert result.object_id == expected["object_id"]
        assert_same_answer(result, expected)
        assert result.region_box == tuple(expected["region"]["box"])
    assert found.report["solves"] == answer["detection"]["solves"]
    assert found.report["time_ms"]["total"] > 0


def test_track_from_the_answer(sample_banks, image):
    frame = image.frame()
    bank = sample_banks[f"obj_{image.gt[0]['obj_id']:06d}"]
    mask = g6d.read_image(image.mask_path(0), "gray")
    detected = g6d.estimate_pose(frame, bank, mask=mask)
    nudged = detected.cam_from_object.copy()
    nudged[:3, 3] += [0.004, -0.003, 0.005]
    tracked = g6d.track_pose(frame, bank, [nudged, detected.cam_from_object], mask=mask)
    assert tracked.success and tracked.score <= detected.score + 0.02
    assert np.linalg.norm(tracked.position_m - detected.position_m) < 0.005
    assert tracked.runner_up_cam_from_object is None


def test_overlay(sample_banks, image, tmp_path):
    frame = image.frame()
    results = [g6d.estimate_pose(frame, sample_banks[f"obj_{gt['obj_id']:06d}"],
                                 mask=g6d.read_image(image.mask_path(i), "gray"), num_hypotheses=4)
               for i, gt in enumerate(image.gt)]
    picture = g6d.draw_overlay(frame, results)
    assert picture.shape == frame.rgb.shape and picture.dtype == np.uint8
    changed = np.any(picture != frame.rgb, axis=2)
    assert changed.sum() > 200
    assert np.array_equal(g6d.draw_overlay(frame, []), frame.rgb)
    g6d.write_image(tmp_path / "overlay.png", picture)
    assert np.array_equal(g6d.read_image(tmp_path / "overlay.png"), picture)


def test_readme_python_lines_run_as_written(sample, tmp_path):
    """The README's Python section runs as written, in a folder holding out/sample."""
    import re
    import subprocess
    import sys
    from conftest import SOURCE_DIR
    readme = (SOURCE_DIR / "README.md").read_text()
    section = readme[readme.index("\n## Python\n"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "sample").symlink_to(sample)
    import os
    from pathlib import Path
    environment = dict(os.environ, PYTHONPATH=str(Path(g6d.__file__).resolve().parents[1]))
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                          env=environment)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "overlay.png").exists()
