"""The Python API: frames, masks, options and files; every bad input raises a clear error."""

import copy
import threading

import numpy as np
import pytest

import g6d
from conftest import bop_images


def small_frame(width=64, height=48):
    rgb = np.zeros((height, width, 3), np.uint8)
    depth = np.full((height, width), 800, np.uint16)
    K = np.array([[500.0, 0, 32], [0, 500.0, 24], [0, 0, 1]])
    return rgb, depth, K


# --- one package: messages and solver side by side ---------------------------------------

def test_package_holds_messages_and_solver():
    from g6d import pose_array_t, rgbd_frame_t  # noqa: F401
    message = g6d.pose_estimate_t()
    message.object_id = "obj_000001"
    assert g6d.pose_estimate_t.decode(message.encode()).object_id == "obj_000001"
    assert callable(g6d.estimate_pose) and callable(g6d.find_objects)


def test_docstrings_give_frames_and_units():
    for function in (g6d.estimate_pose, g6d.track_pose, g6d.find_objects, g6d.estimate_pose_of_unknown_object,
                     g6d.build_templates, g6d.load_cache, g6d.draw_overlay, g6d.Frame):
        assert function.__doc__ and len(function.__doc__) > 200, function
    assert "metres" in g6d.estimate_pose.__doc__ and "cam_from_object" in g6d.estimate_pose.__doc__
    assert "metres per unit" in g6d.Frame.__doc__ and "(u + 0.5, v + 0.5)" in g6d.Frame.__doc__


# --- Frame ---------------------------------------------------------------------------------

def test_frame_from_uint16_and_float32_depth():
    rgb, depth, K = small_frame()
    frame = g6d.Frame(rgb, depth, K, depth_scale=0.001)
    assert (frame.width, frame.height) == (64, 48)
    assert frame.depth.dtype == np.float32 and frame.depth[0, 0] == np.float32(0.8)
    assert np.array_equal(frame.K, K)
    with pytest.raises(ValueError):
        frame.rgb[0, 0, 0] = 1  # read-only views
    metres = g6d.Frame(rgb, np.full((48, 64), 0.8, np.float32), K)
    assert metres.depth[5, 5] == np.float32(0.8)


@pytest.mark.parametrize("change, message", [
    (dict(rgb=np.zeros((48, 64, 3), np.float32)), "rgb: expected a uint8 array of shape (H, W, 3)"),
    (dict(rgb=np.zeros((48, 64), np.uint8)), "rgb: expected a uint8 array of shape (H, W, 3)"),
    (dict(rgb="not an image"), "rgb: expected"),
    (dict(depth=np.zeros((48, 64), np.float64)), "astype(numpy.float32)"),
    (dict(depth=np.zeros((40, 64), np.uint16)), "depth: expected uint16 with depth_scale"),
    (dict(depth_scale=None), "depth: a uint16 depth image needs depth_scale"),
    (dict(depth_scale=-1.0), "depth_scale: expected a finite number > 0"),
    (dict(depth_scale=float("nan")), "depth_scale: expected a finite number > 0"),
    (dict(K=np.eye(4)), "K: expected a 3x3 intrinsics matrix"),
    (dict(K=[[500, 1, 32], [0, 500, 24], [0, 0, 1]]), "K: K[0, 1] (skew) must be 0"),
    (dict(K=[[-500, 0, 32], [0, 500, 24], [0, 0, 1]]), "K: "),
    (dict(K=[[500, 0, 32], [0, 500, 24], [0, 0, 2]]), "[0, 0, 1]"),
    (dict(K=[[np.nan, 0, 32], [0, 500, 24], [0, 0, 1]]), "K: K[0, 0] is not finite"),
])
def test_frame_refuses_bad_input(change, message):
    rgb, depth, K = small_frame()
    arguments = dict(rgb=rgb, depth=depth, K=K, depth_scale=0.001)
    arguments.update(change)
    with pytest.raises(ValueError) as error:
        g6d.Frame(**arguments)
    assert message in str(error.value)


def test_frame_nan_depth():
    rgb, _, K = small_frame()
    depth = np.full((48, 64), 0.8, np.float32)
    depth[3, 7] = np.nan
    depth[4, 1] = -1.0
    with pytest.raises(ValueError) as error:
        g6d.Frame(rgb, depth, K)
    assert "depth: 2 pixels are NaN, infinite or negative (the first at row 3, column 7)" in str(error.value)
    frame = g6d.Frame(rgb, depth, K, nan_as_missing=True)  # the service's reading
    assert frame.depth[3, 7] == 0.0 and frame.depth[4, 1] == 0.0 and frame.depth[0, 0] == np.float32(0.8)
    with pytest.raises(ValueError, match="give depth_scale only with uint16"):
        g6d.Frame(rgb, np.full((48, 64), 0.8, np.float32), K, depth_scale=0.001)


# --- options -------------------------------------------------------------------------------

def test_options_defaults_are_the_services():
    options = g6d.SolverOptions()
    assert options.num_hypotheses == 18 and options.mask_trust == g6d.MaskTrust.DEPTH
    assert options.match.hamming_threshold == 64 and options.match.max_sets == 256
    assert options.score.omega_c == 0.70 and options.mhpo.lambda_d == 0.1 and options.icp.trim_fraction == 0.70
    assert options.budget_ms == 0.0 and not options.post_refine and options.run_mhpo
    assert options.check() == "" and g6d.DetectOptions().check() == ""
    assert g6d.DetectOptions().max_score == 0.35 and g6d.TrackSolveOptions().icp_iterations == 10


def test_options_keywords_nested_and_copies():
    options = g6d.SolverOptions(num_hypotheses=4, mask_trust="exact", mhpo={"max_rounds": 3})
    assert options.num_hypotheses == 4 and options.mask_trust == g6d.MaskTrust.EXACT
    assert options.mhpo.max_rounds == 3
    options.mhpo.max_rounds = 7  # nested fields change the parent
    assert options.mhpo.max_rounds == 7
    other = copy.copy(options)
    other.pnp.seed = 99
    assert options.pnp.seed == 7 and other != options and copy.deepcopy(options) == options
    assert repr(g6d.SolverOptions(num_hypotheses=4)) == "SolverOptions(num_hypotheses=4)"
    assert g6d.SolverOptions().as_dict()["icp"]["kappa_d"] == 0.35


@pytest.mark.parametrize("fields, message", [
    (dict(num_hypotheses=0), "SolverOptions.num_hypotheses must be >= 1 (got 0)"),
    (dict(mhpo={"lambda_d": -1.0}), "lambda_d"),
    (dict(no_such_option=1), "unknown option 'no_such_option'"),
    (dict(num_hypotheses=2.5), "options.num_hypotheses: expected int, got 2.5"),
    (dict(run_mhpo=1), "options.run_mhpo: expected True or False"),
    (dict(mask_trust="maybe"), "options.mask_trust: expected one of exact, depth"),
    (dict(mhpo=3), "options.mhpo: expected a MhpoOptions or a dict"),
])
def test_bad_options_name_the_field(sample_frame, sample_banks, fields, message):
    image, frame = sample_frame
    bank = sample_banks[f"obj_{image.gt[0]['obj_id']:06d}"]
    with pytest.raises(ValueError) as error:
        g6d.estimate_pose(frame, bank, mask=g6d.read_image(image.mask_path(0), "gray"), **fields)
    assert message in str(error.value)


def test_bad_detect_and_track_options(sample_frame, sample_banks):
    _, frame = sample_frame
    bank = next(iter(sample_banks.values()))
    with pytest.raises(ValueError, match="max_score"):
        g6d.find_objects(frame, [(bank, 1)], detect={"max_score": -1.0})
    with pytest.raises(ValueError, match="detect: unknown option 'bogus'"):
        g6d.find_objects(frame, [(bank, 1)], detect={"bogus": 1})
    with pytest.raises(ValueError, match="track"):
        g6d.track_pose(frame, bank, np.eye(4), box=(10, 10, 50, 50), track={"icp_iterations": -1})


# --- masks and boxes -----------------------------------------------------------------------

def test_bad_masks_and_boxes(sample_frame, sample_banks):
    image, frame = sample_frame
    bank = sample_banks[f"obj_{image.gt[0]['obj_id']:06d}"]
    mask = g6d.read_image(image.mask_path(0), "gray")
    cases = [
        (dict(mask=np.zeros_like(mask)), "mask: no non-zero pixel"),
        (dict(mask=mask[:-1]), "mask: expected a bool or uint8 array of shape"),
        (dict(mask=mask.astype(np.float32)), "mask: expected a bool or uint8 array"),
        (dict(mask=mask, box=(1, 2, 3, 4)), "give mask or box, not both"),
        (dict(), "no mask and no box"),
        (dict(box=(10, 10, 0, 20)), "box: width and height must be > 0"),
        (dict(box=(5000, 10, 20, 20)), "lies outside the"),
        (dict(box=(1, 2, 3)), "box: expected (x, y, width, height)"),
        (dict(box=(1.5, 2, 3, 4)), "box: expected whole numbers"),
        (dict(mask=mask, threads=0), "threads: expected >= 1"),
        (dict(mask=mask, threads="2"), "threads: expected a whole number"),
    ]
    for arguments, message in cases:
        with pytest.raises(ValueError) as error:
            g6d.estimate_pose(frame, bank, **arguments)
        assert message in str(error.value), arguments
    # A bool mask is the same mask.
    as_bool = g6d.estimate_pose(frame, bank, mask=mask > 0, num_hypotheses=2, run_mhpo=False)
    as_uint8 = g6d.estimate_pose(frame, bank, mask=mask, num_hypotheses=2, run_mhpo=False)
    assert as_bool.score == as_uint8.score


def test_bad_calls(sample_frame, sample_banks):
    image, frame = sample_frame
    bank = next(iter(sample_banks.values()))
    mask = g6d.read_image(image.mask_path(0), "gray")
    with pytest.raises(ValueError, match=r"starts\[0\]: not a rigid transform"):
        g6d.track_pose(frame, bank, np.diag([2.0, 1, 1, 1]), mask=mask)
    with pytest.raises(ValueError, match="starts: expected at least one"):
        g6d.track_pose(frame, bank, [], mask=mask)
    with pytest.raises(ValueError, match=r"objects\[0\]: expected \(TemplateBank, count\)"):
        g6d.find_objects(frame, [("obj_000001", 1)])
    with pytest.raises(ValueError, match=r"objects\[0\]: the count must be >= 1"):
        g6d.find_objects(frame, [(bank, 0)])
    with pytest.raises(ValueError, match="asked for twice"):
        g6d.find_objects(frame, [(bank, 1), bank])
    with pytest.raises(ValueError, match="is given twice"):
        g6d.estimate_pose_of_unknown_object(frame, [bank, bank], mask=mask)
    with pytest.raises(ValueError, match="at least one TemplateBank"):
        g6d.estimate_pose_of_unknown_object(frame, [], mask=mask)
    with pytest.raises(TypeError):
        g6d.estimate_pose(frame, "obj_000001", mask=mask)


# --- caches and templates ------------------------------------------------------------------

def test_cache_errors(sample, tmp_path):
    cache = next((sample / "caches").glob("*.g6dcache"))
    data = cache.read_bytes()
    with pytest.raises(g6d.Error, match="missing"):
        g6d.load_cache(tmp_path / "missing.g6dcache")
    (tmp_path / "truncated.g6dcache").write_bytes(data[: len(data) // 2])
    with pytest.raises(RuntimeError, match="truncated.g6dcache"):
        g6d.load_cache(tmp_path / "truncated.g6dcache")
    corrupt = bytearray(data)
    corrupt[len(corrupt) // 2] ^= 0xFF
    (tmp_path / "corrupt.g6dcache").write_bytes(bytes(corrupt))
    with pytest.raises(g6d.Error, match="corrupt.g6dcache"):
        g6d.load_cache(tmp_path / "corrupt.g6dcache")
    (tmp_path / "text.g6dcache").write_text("not a cache")
    with pytest.raises(g6d.Error, match="text.g6dcache"):
        g6d.load_cache(tmp_path / "text.g6dcache")


def test_build_templates_equals_the_tool(sample, tmp_path):
    """build_templates + save writes the same bytes as g6d-build-templates."""
    from conftest import BUILD_DIR, run
    mesh = sample / "models" / "obj_000001.obj"
    calls = []
    bank = g6d.build_templates(mesh, "obj_000001", "m", views=12, inplane=1, threads=2,
                               progress=lambda done, total: calls.append((done, total)))
    assert bank.num_templates == 12 and bank.object_id == "obj_000001" and bank.mesh_units == "m"
    assert [c[0] for c in calls] == list(range(1, 13)) and all(c[1] == 12 for c in calls)
    bank.save(tmp_path / "python.g6dcache")
    made = run([BUILD_DIR / "tools" / "g6d-build-templates", "--mesh", mesh, "--units", "m", "--object-id",
                "obj_000001", "--out", tmp_path / "tool.g6dcache", "--views", "12", "--inplane", "1"])
    assert made.returncode == 0, made.stderr
    assert (tmp_path / "python.g6dcache").read_bytes() == (tmp_path / "tool.g6dcache").read_bytes()
    again = g6d.load_cache(tmp_path / "python.g6dcache", mesh_path=mesh)
    assert again.num_keypoints == bank.num_keypoints


def test_build_templates_errors(sample, tmp_path):
    mesh = sample / "models" / "obj_000001.obj"
    with pytest.raises(ValueError, match="units: expected 'mm' or 'm'"):
        g6d.build_templates(mesh, "obj_000001", "cm", views=3, inplane=1)
    with pytest.raises(ValueError, match="views: expected a positive multiple of inplane"):
        g6d.build_templates(mesh, "obj_000001", "m", views=10)
    with pytest.raises(g6d.Error):
        g6d.build_templates(tmp_path / "none.obj", "obj_000001", "m", views=3, inplane=1)

    def stop(done, total):
        raise KeyboardInterrupt("stop")
    with pytest.raises(KeyboardInterrupt, match="stop"):
        g6d.build_templates(mesh, "obj_000001", "m", views=3, inplane=1, progress=stop)


def test_images_round_trip(tmp_path):
    rgb = np.arange(48 * 64 * 3, dtype=np.uint8).reshape(48, 64, 3)
    depth = np.arange(48 * 64, dtype=np.uint16).reshape(48, 64)
    g6d.write_image(tmp_path / "rgb.png", rgb)
    g6d.write_image(tmp_path / "depth.png", depth)
    assert np.array_equal(g6d.read_image(tmp_path / "rgb.png"), rgb)
    assert np.array_equal(g6d.read_image(tmp_path / "depth.png"), depth)
    with pytest.raises(g6d.Error, match="cannot read"):
        g6d.read_image(tmp_path / "missing.png")
    with pytest.raises(ValueError, match="mode"):
        g6d.read_image(tmp_path / "rgb.png", "bgr")
    with pytest.raises(ValueError, match="image: expected a uint8 or uint16"):
        g6d.write_image(tmp_path / "x.png", rgb.astype(np.float32))


# --- threads -------------------------------------------------------------------------------

def test_threads_solve_at_once_with_the_same_answers(sample, sample_banks):
    image = bop_images(sample / "test" / "000001")[1]
    frame = image.frame()
    jobs = [(sample_banks[f"obj_{gt['obj_id']:06d}"], g6d.read_image(image.mask_path(i), "gray"))
            for i, gt in enumerate(image.gt)]
    alone = [g6d.estimate_pose(frame, bank, mask=mask, num_hypotheses=4) for bank, mask in jobs]
    together = [None] * len(jobs)

    def solve(i):
        together[i] = g6d.estimate_pose(frame, jobs[i][0], mask=jobs[i][1], num_hypotheses=4)
    threads = [threading.Thread(target=solve, args=(i,)) for i in range(len(jobs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for a, b in zip(alone, together):
        assert np.array_equal(a.cam_from_object, b.cam_from_object) and a.score == b.score
