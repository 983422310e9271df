#!/usr/bin/env python3
"""The Python call's cost per solve, side by side with the C++ call, and 1 vs 2 Python threads.

    PYTHONPATH=build/python python3 bench/python_overhead.py [--sample DIR] [--repeats 5]

On one BOP image (the embedded sample by default, made with g6d-make-sample when --sample
is not given) every instance is solved alternately by
  * the Python call, g6d.estimate_pose(frame, bank, mask=mask, threads=1), and
  * the C++ call, EstimatePose in a C++ loop inside the same process
    (g6d._core._bench_estimate_pose: the frame, mask and options already in C++),
`--repeats` times each. Per call it records the wall time and the solver's own total_ms;
wall - total_ms is the cost outside the solver (argument checks, copies, the executor,
result conversion for Python). The Python call's overhead per solve is the difference of
the two medians of that cost (solver noise cancels), and also the difference of the wall
time medians.

Then the same solves (every instance, `--repeats` times) run once on one Python thread and
once split over two Python threads (threads=1 per call): with the GIL released while
solving, two threads take about half the time on two idle cores (on a busy machine the
CPU use column shows how many cores the process got). Last, a Python thread spins beside
one solve: its longest pause shows that the solve does not hold the GIL.

Prints a Markdown table (bench/RESULTS.md, "Python").
"""

import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

import g6d

ROOT = Path(__file__).resolve().parents[1]


def make_sample(build_dir, views):
    out = Path(tempfile.mkdtemp(prefix="g6d_python_bench_")) / "sample"
    subprocess.run([str(build_dir / "tools" / "g6d-make-sample"), "--out", str(out), "--frames", "1",
                    "--views", str(views), "--no-log"], check=True, stdout=subprocess.DEVNULL)
    return out


def load_image(sample):
    scene = sample / "test" / "000001"
    camera = json.loads((scene / "scene_camera.json").read_text())["0"]
    gt = json.loads((scene / "scene_gt.json").read_text())["0"]
    K = np.array(camera["cam_K"], dtype=np.float64).reshape(3, 3)
    frame = g6d.Frame(g6d.read_image(scene / "rgb" / "000000.png", "rgb"),
                      g6d.read_image(scene / "depth" / "000000.png"), K,
                      depth_scale=camera["depth_scale"] / 1000.0)
    jobs = []
    for i, instance in enumerate(gt):
        object_id = f"obj_{instance['obj_id']:06d}"
        bank = g6d.load_cache(sample / "caches" / f"{object_id}.g6dcache")
        mask = g6d.read_image(scene / "mask_visib" / f"000000_{i:06d}.png", "gray")
        jobs.append((object_id, bank, mask))
    return frame, jobs


def machine():
    model = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}, numpy {np.__version__}"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sample", type=Path, help="a g6d-make-sample folder (default: make one)")
    parser.add_argument("--build", type=Path, default=ROOT / "build", help="build folder (for g6d-make-sample)")
    parser.add_argument("--views", type=int, default=324, help="templates per cache of a sample made here")
    parser.add_argument("--repeats", type=int, default=5, help="solves per instance and call")
    arguments = parser.parse_args()

    sample = arguments.sample or make_sample(arguments.build, arguments.views)
    frame, jobs = load_image(sample)
    options = g6d.SolverOptions()
    rows = []
    all_python, all_cpp = [], []
    for object_id, bank, mask in jobs:
        g6d.estimate_pose(frame, bank, mask=mask)  # warm-up (first-touch allocations)
        python, cpp = [], []
        for _ in range(arguments.repeats):
            start = time.perf_counter()
            result = g6d.estimate_pose(frame, bank, mask=mask, threads=1)
            wall = (time.perf_counter() - start) * 1000.0
            python.append((wall, result.stages["time_ms"]["total"]))
            cpp.extend(g6d._core._bench_estimate_pose(frame, bank, mask, options, 1, 1))
        all_python += python
        all_cpp += cpp
        rows.append((object_id, python, cpp))

    def medians(calls):
        return (statistics.median(w for w, _ in calls), statistics.median(w - t for w, t in calls))

    print(f"command: PYTHONPATH=build/python python3 bench/python_overhead.py {' '.join(sys.argv[1:])}".rstrip())
    print(f"date: {datetime.date.today().isoformat()}; machine: {machine()}")
    print(f"data: {sample} (image 0, {len(jobs)} instances), K = {options.num_hypotheses}, threads=1 per call, "
          f"{arguments.repeats} solves per instance and call, alternating\n")
    print("| instance | C++ call wall p50 (ms) | Python call wall p50 (ms) | C++ outside the solver p50 (ms) "
          "| Python outside the solver p50 (ms) | Python overhead per solve (ms) | overhead / solve |")
    print("|---|---|---|---|---|---|---|")
    for object_id, python, cpp in rows + [("all", all_python, all_cpp)]:
        cpp_wall, cpp_outside = medians(cpp)
        python_wall, python_outside = medians(python)
        overhead = python_outside - cpp_outside
        print(f"| {object_id} | {cpp_wall:.1f} | {python_wall:.1f} | {cpp_outside:.3f} | {python_outside:.3f} "
              f"| {overhead:.3f} | {100.0 * overhead / cpp_wall:.2f}% |")

    # 1 vs 2 Python threads over the same solves.
    work = [(bank, mask) for _, bank, mask in jobs] * arguments.repeats

    def run(items):
        for bank, mask in items:
            g6d.estimate_pose(frame, bank, mask=mask, threads=1)

    cpu_start, start = time.process_time(), time.perf_counter()
    run(work)
    one, one_cpu = time.perf_counter() - start, time.process_time() - cpu_start
    halves = [work[0::2], work[1::2]]
    threads = [threading.Thread(target=run, args=(half,)) for half in halves]
    cpu_start, start = time.process_time(), time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    two, two_cpu = time.perf_counter() - start, time.process_time() - cpu_start
    # CPU use = process CPU time / wall: 2.0 = both cores busy with this process all along
    # (a busy machine shares them with other processes, and the speed-up falls short of it).
    print(f"\nload average before: {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} cores")
    print(f"\n| Python threads | solves | wall (s) | per solve (ms) | speed-up | CPU use (cores) |")
    print("|---|---|---|---|---|---|")
    print(f"| 1 | {len(work)} | {one:.2f} | {1000 * one / len(work):.1f} | 1.00 | {one_cpu / one:.2f} |")
    print(f"| 2 | {len(work)} | {two:.2f} | {1000 * two / len(work):.1f} | {one / two:.2f} | {two_cpu / two:.2f} |")

    # The GIL during a solve, whatever the machine's load: a Python thread spins, stamping
    # the time, while another thread solves; with the GIL held for the solve, the spinner
    # would stop for the whole call.
    bank, mask = work[0]
    stamps, call = [], []

    def solve_once():
        call.append(time.perf_counter())
        g6d.estimate_pose(frame, bank, mask=mask, threads=1)
        call.append(time.perf_counter())

    solver = threading.Thread(target=solve_once)
    solver.start()
    while solver.is_alive():
        stamps.append(time.perf_counter())
    solver.join()
    inside = [t for t in stamps if call[0] <= t <= call[1]]
    gaps = [b - a for a, b in zip(inside, inside[1:])]
    longest = 1000 * max(gaps) if gaps else 1000 * (call[1] - call[0])
    print(f"\nA Python thread spinning beside one solve ({1000 * (call[1] - call[0]):.0f} ms): "
          f"{len(inside)} time stamps during the call, longest pause {longest:.1f} ms "
          f"(the GIL held for the solve would pause it for the whole call)")


if __name__ == "__main__":
    main()
