#!/usr/bin/env python3
"""Solves one BOP image from Python: reads the frame, builds (or loads) the template caches,
estimates every ground-truth instance's pose from its mask, prints the poses with S_A, and
saves the overlay. With --find the objects are found without masks instead.

    PYTHONPATH=build/python python3 examples/solve.py --dataset out/demo/sample
    PYTHONPATH=build/python python3 examples/solve.py --dataset ../shared/data/ycbv_clutter --image 1 --find

--dataset is a BOP folder (models/models_info.json, test/<scene>/...). Caches are read from
--caches (default <dataset>/caches): <obj_id>.g6dcache; a missing one is built from the
mesh models_info.json names (the `mesh` and `units` keys), or models/obj_<id>.ply in mm,
and saved there.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

import g6d


def bank_for(object_number, dataset, caches, views):
    """The object's TemplateBank: its cache, or built from its mesh and saved."""
    object_id = f"obj_{object_number:06d}"
    cache = caches / f"{object_id}.g6dcache"
    if cache.exists():
        return g6d.load_cache(cache)
    info = json.loads((dataset / "models" / "models_info.json").read_text()).get(str(object_number), {})
    mesh = dataset / "models" / info.get("mesh", f"{object_id}.ply")
    units = info.get("units", "mm")
    print(f"building {cache} from {mesh} ({views} templates)", file=sys.stderr)
    bank = g6d.build_templates(mesh, object_id, units, views=views, threads=2, progress=True)
    caches.mkdir(parents=True, exist_ok=True)
    bank.save(cache)
    return bank


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--dataset", type=Path, required=True, help="BOP dataset folder")
    parser.add_argument("--scene", type=int, default=1)
    parser.add_argument("--image", type=int, help="image id (default: the scene's first)")
    parser.add_argument("--caches", type=Path, help="cache folder (default: <dataset>/caches)")
    parser.add_argument("--views", type=int, default=324, help="templates of a cache built here")
    parser.add_argument("--find", action="store_true", help="find the objects without masks")
    parser.add_argument("--hypotheses", type=int, default=18, help="K, hypotheses refined by ICP and MHPO")
    parser.add_argument("--overlay", type=Path, default=Path("overlay.png"), help="the picture written")
    arguments = parser.parse_args()

    scene = arguments.dataset / "test" / f"{arguments.scene:06d}"
    cameras = json.loads((scene / "scene_camera.json").read_text())
    ground_truth = json.loads((scene / "scene_gt.json").read_text())
    key = str(arguments.image) if arguments.image is not None else min(cameras, key=int)
    camera, instances = cameras[key], ground_truth[key]
    image_id = int(key)

    # The frame: RGB, uint16 depth with BOP's depth_scale (mm per unit) as metres per unit, K.
    rgb_path = scene / "rgb" / f"{image_id:06d}.png"
    if not rgb_path.exists():
        rgb_path = rgb_path.with_suffix(".jpg")
    frame = g6d.Frame(g6d.read_image(rgb_path, "rgb"), g6d.read_image(scene / "depth" / f"{image_id:06d}.png"),
                      np.array(camera["cam_K"]).reshape(3, 3), depth_scale=camera["depth_scale"] / 1000.0)
    caches = arguments.caches or arguments.dataset / "caches"
    banks = {}
    for instance in instances:
        if instance["obj_id"] not in banks:
            banks[instance["obj_id"]] = bank_for(instance["obj_id"], arguments.dataset, caches, arguments.views)

    if arguments.find:
        counts = {}
        for instance in instances:
            counts[instance["obj_id"]] = counts.get(instance["obj_id"], 0) + 1
        results = g6d.find_objects(frame, [(banks[n], c) for n, c in counts.items()], threads=2,
                                   num_hypotheses=arguments.hypotheses)
        print(f"found {len(results)} of {len(instances)} objects in {results.report['time_ms']['total']:.0f} ms")
    else:
        results = []
        for index, instance in enumerate(instances):
            mask = g6d.read_image(scene / "mask_visib" / f"{image_id:06d}_{index:06d}.png", "gray")
            if not mask.any():
                continue  # not visible
            results.append(g6d.estimate_pose(frame, banks[instance["obj_id"]], mask=mask, threads=2,
                                             num_hypotheses=arguments.hypotheses))

    for result in results:
        if not result.success:
            print(f"{result.object_id}: no pose ({result.message})")
            continue
        t, q = result.position_m, result.orientation_wxyz
        print(f"{result.object_id}: t = ({t[0]:+.4f}, {t[1]:+.4f}, {t[2]:+.4f}) m, "
              f"q = ({q[0]:+.4f}, {q[1]:+.4f}, {q[2]:+.4f}, {q[3]:+.4f}), S_A {result.score:.4f}, "
              f"confidence {result.confidence:.3f}, {result.stages['time_ms']['total']:.0f} ms")
    g6d.write_image(arguments.overlay, g6d.draw_overlay(frame, results))
    print(f"overlay: {arguments.overlay}")


if __name__ == "__main__":
    main()
