#!/usr/bin/env python3
"""Prints the demo's tracking part (called by scripts/demo.sh): the moving-camera sequence
replayed through the service in real time.

    demo_tracking_report.py RUN_DIR SEQUENCE_DIR

Reads, in RUN_DIR: summary.json (g6d-replay --summary-json), estimates.jsonl (--estimates-jsonl,
with "mode"), eval.json (g6d-eval --json --per-instance --estimated-only); and
SEQUENCE_DIR/sample.json (frames, fps, the abrupt move). Prints a timeline per object, one
character per frame (D detected, . tracked, R re-detected, x a wrong answer (ADD(-S) >=
0.1 d), _ no answer: the frame was dropped while the service was busy), then the counts,
times and accuracy.
"""
import collections
import json
import os
import sys

from demo_report import percentile  # scripts/ is this script's folder: nearest rank, as g6d-replay


def main():
    run, sequence = sys.argv[1], sys.argv[2]
    manifest = json.load(open(os.path.join(sequence, "sample.json")))
    frames = manifest["frames"]
    fps = manifest["options"]["fps"]
    summary = json.load(open(os.path.join(run, "summary.json")))
    evaluation = json.load(open(os.path.join(run, "eval.json")))
    correct = {(t["im_id"], t["gt_idx"]): t["add_correct"] for t in evaluation["targets"] if t.get("estimates", 0) > 0}
    answers = collections.defaultdict(dict)  # object -> image -> estimate
    with open(os.path.join(run, "estimates.jsonl")) as f:
        for line in f:
            if line.strip():
                e = json.loads(line)
                answers[e["object_id"]][e["image_id"]] = e

    print(f"\nTracking: the moving-camera sequence ({frames} frames at {fps:g} Hz, {len(manifest['objects'])} objects; "
          f"obj_{manifest.get('abrupt_obj_id', 0):06d} jumps at frame {manifest.get('abrupt_frame', -1)}), "
          "replayed in real time through g6d-service:")
    print("  D detected  . tracked  R re-detected  x wrong (ADD(-S) >= 0.1 d)  _ no answer (frame dropped while busy)")
    ruler = "".join(str(i // 10 % 10) if i % 10 == 0 else " " for i in range(frames))
    print(f"  {'frame':<11}{ruler}")
    symbol = {"detected": "D", "tracked": ".", "redetected": "R"}
    modes = collections.Counter()
    times = collections.defaultdict(list)
    ok = total = 0
    for obj in sorted(answers):
        row = []
        for im in range(frames):
            e = answers[obj].get(im)
            if e is None or e["status"] != "ok":
                row.append("_")
                continue
            mode = e.get("mode", "detected")
            modes[mode] += 1
            times[mode].append(1000 * e["solve_time_s"])
            good = correct.get((im, e["gt_index"]))
            total += good is not None
            ok += bool(good)
            row.append("x" if good is False else symbol.get(mode, "?"))
        print(f"  {obj:<11}{''.join(row)}")
    duration_s = frames / fps
    latency = summary["latency_s"]
    print(f"  frames: {summary['sent']} sent, {summary['answered']} answered ({summary['answered'] / duration_s:.1f} per second); "
          f"latency send -> answer p50 {1000 * latency['p50']:.0f} ms, p95 {1000 * latency['p95']:.0f} ms")
    print("  answers: " + ", ".join(f"{modes[m]} {m}" for m in ("detected", "tracked", "redetected")) + ";  solve time p50: " +
          ", ".join(f"{m} {percentile(times[m], 0.5):.0f} ms" for m in ("tracked", "detected", "redetected") if times[m]))
    print(f"  ADD(-S)@0.1d of the answers: {100.0 * ok / max(1, total):.1f}% ({ok} of {total})")


if __name__ == "__main__":
    main()
