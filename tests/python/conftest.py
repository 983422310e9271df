"""Shared fixtures of the Python tests (ctest runs them: tests/CMakeLists.txt sets
G6D_BUILD_DIR, G6D_SOURCE_DIR, G6D_SHARED_DATA_DIR and PYTHONPATH=<build>/python)."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import g6d

BUILD_DIR = Path(os.environ.get("G6D_BUILD_DIR", Path(__file__).resolve().parents[2] / "build"))
SOURCE_DIR = Path(os.environ.get("G6D_SOURCE_DIR", Path(__file__).resolve().parents[2]))
SHARED_DATA_DIR = Path(os.environ.get("G6D_SHARED_DATA_DIR", SOURCE_DIR.parent / "shared" / "data"))
SOLVE = BUILD_DIR / "tools" / "g6d-solve"


def run(command):
    """Runs a command; returns its CompletedProcess (text output)."""
    return subprocess.run([str(c) for c in command], capture_output=True, text=True, check=False)


class BopImage:
    """One image of a BOP scene: file paths, K, depth scale (mm per unit), GT instances."""

    def __init__(self, scene_dir, im_id, camera, gt):
        self.scene_dir = Path(scene_dir)
        self.im_id = im_id
        self.rgb_path = self.scene_dir / "rgb" / f"{im_id:06d}.png"
        if not self.rgb_path.exists():
            self.rgb_path = self.scene_dir / "rgb" / f"{im_id:06d}.jpg"
        self.depth_path = self.scene_dir / "depth" / f"{im_id:06d}.png"
        self.K = np.array(camera["cam_K"], dtype=np.float64).reshape(3, 3)
        self.depth_scale_mm = float(camera["depth_scale"])
        self.gt = gt

    def mask_path(self, gt_index):
        return self.scene_dir / "mask_visib" / f"{self.im_id:06d}_{gt_index:06d}.png"

    def frame(self):
        """The frame as g6d-solve builds it from the same files."""
        rgb = g6d.read_image(self.rgb_path, "rgb")
        depth = g6d.read_image(self.depth_path)
        return g6d.Frame(rgb, depth, self.K, depth_scale=self.depth_scale_mm / 1000.0)

    def solve_args(self):
        k = self.K
        return ["--rgb", self.rgb_path, "--depth", self.depth_path, "--depth-scale", repr(self.depth_scale_mm),
                "--K", f"{k[0, 0]!r},{k[1, 1]!r},{k[0, 2]!r},{k[1, 2]!r}"]


def bop_images(scene_dir):
    scene_dir = Path(scene_dir)
    cameras = json.loads((scene_dir / "scene_camera.json").read_text())
    gts = json.loads((scene_dir / "scene_gt.json").read_text())
    return [BopImage(scene_dir, int(k), cameras[k], gts[k]) for k in sorted(cameras, key=int)]


def solve_json(tmp_path, arguments):
    """Runs g6d-solve with `arguments` and --json; returns the JSON (or fails the test)."""
    out = tmp_path / f"solve_{len(list(tmp_path.iterdir()))}.json"
    done = run([SOLVE, *arguments, "--json", out])
    assert done.returncode in (0, 3), done.stdout + done.stderr
    return json.loads(out.read_text())


def assert_same_answer(result, answer):
    """A PoseResult equals a g6d-solve JSON answer bit for bit (pose, S_A, confidence)."""
    assert result.success == answer["success"], (result, answer["message"])
    assert result.position_m.tolist() == answer["position_m"]
    assert result.orientation_wxyz.tolist() == answer["orientation_wxyz"]
    assert result.score == answer["score"]
    assert result.confidence == answer["confidence"]
    assert result.termination == answer["termination"]


@pytest.fixture(scope="session")
def sample(tmp_path_factory):
    """A 2-image embedded sample with 3 objects and 36-template caches (g6d-make-sample)."""
    root = tmp_path_factory.mktemp("sample") / "sample"
    made = run([BUILD_DIR / "tools" / "g6d-make-sample", "--out", root, "--frames", "2", "--views", "36",
                "--inplane", "1", "--no-log"])
    assert made.returncode == 0, made.stdout + made.stderr
    return root


@pytest.fixture(scope="session")
def sample_banks(sample):
    return {p.stem: g6d.load_cache(p) for p in sorted((sample / "caches").glob("*.g6dcache"))}


@pytest.fixture(scope="session")
def sample_frame(sample):
    image = bop_images(sample / "test" / "000001")[0]
    return image, image.frame()


@pytest.fixture(scope="session")
def shared_data():
    if not SHARED_DATA_DIR.is_dir():
        pytest.skip(f"no shared test data at {SHARED_DATA_DIR} (a fresh machine): skipped")
    return SHARED_DATA_DIR
