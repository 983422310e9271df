#!/usr/bin/env python3
"""Prints the demo's per-instance table and summary (called by scripts/demo.sh).

    demo_report.py OUT_DIR DATASET_DIR

Reads, in OUT_DIR: replay/*.json (g6d-replay --summary-json, one per scene),
estimates.jsonl (g6d-replay --estimates-jsonl: S_A and confidence per estimate; optional),
results.csv (the BOP results the evaluation scored) and eval.json (g6d-eval --json); and
DATASET_DIR/models/models_info.json for the diameters. One line per estimate the service
sent: image, object, S_A, confidence, solver time, and the ADD(-S) error against the
ground truth (smallest over the image's estimates of that object, as g6d-eval reports
it). Then ADD(-S)@0.1d recall, BOP AR and the latency percentiles.
"""
import glob
import json
import os
import sys


def percentile(values, q):
    """Nearest rank, as g6d-replay reports its percentiles."""
    if not values:
        return 0.0
    values = sorted(values)
    return values[int(q * (len(values) - 1) + 0.5)]


def main():
    out, dataset = sys.argv[1], sys.argv[2]
    info = json.load(open(os.path.join(dataset, "models", "models_info.json")))
    diameter_mm = {f"obj_{int(k):06d}": v["diameter"] for k, v in info.items()}
    evaluation = json.load(open(os.path.join(out, "eval.json")))
    errors = {(t["scene_id"], t["im_id"], t["gt_idx"]): t for t in evaluation["targets"]}

    # S_A and confidence per estimate, when this g6d-replay writes them.
    scores = {}
    estimates_path = os.path.join(out, "estimates.jsonl")
    have_scores = os.path.exists(estimates_path)
    if have_scores:
        with open(estimates_path) as f:
            for line in f:
                if line.strip():
                    e = json.loads(line)
                    scores[(e["scene_id"], e["image_id"], e["gt_index"], e["object_id"])] = e
    # Else the confidence from the results CSV (its score column), per image and object.
    confidences = {}
    with open(os.path.join(out, "results.csv")) as f:
        for line in f:
            fields = line.strip().split(",")
            if len(fields) == 7 and fields[0] != "scene_id":
                confidences[(int(fields[0]), int(fields[1]), f"obj_{int(fields[2]):06d}")] = float(fields[3])

    frames = []
    for path in sorted(glob.glob(os.path.join(out, "replay", "*.json"))):
        frames += json.load(open(path))["frames"]
    frames.sort(key=lambda fr: (fr["scene_id"], fr["image_id"]))
    scenes = {fr["scene_id"] for fr in frames}

    print(f"{'image':>9}  {'object':<11} {'S_A':>6} {'conf':>5} {'ms':>5}  {'ADD(-S) mm':>10} {'/ d':>6}  correct")
    latencies, solve_times, ok_count, failed = [], [], 0, 0
    for fr in frames:
        image = f"{fr['scene_id']}/{fr['image_id']}" if len(scenes) > 1 else str(fr["image_id"])
        if not fr["answered"]:
            print(f"{image:>9}  (no answer from the service)")
            continue
        latencies.append(fr["latency_s"])
        for e in fr.get("estimates", []):
            obj = e["object_id"]
            if e["status"] != "ok":
                failed += 1
                print(f"{image:>9}  {obj:<11} {e['status']}: {e.get('message', '')}")
                continue
            ok_count += 1
            solve_times.append(e["solve_time_s"])
            scored = scores.get((fr["scene_id"], fr["image_id"], e["gt_index"], obj))
            s_a = f"{scored['score']:6.3f}" if scored else f"{'n/a':>6}"
            confidence = scored["confidence"] if scored else confidences.get((fr["scene_id"], fr["image_id"], obj))
            conf = f"{confidence:5.2f}" if confidence is not None else f"{'-':>5}"
            target = errors.get((fr["scene_id"], fr["image_id"], e["gt_index"]))
            if target is None or target["best_add_mm"] is None:
                error = f"{'-':>10} {'-':>6}  (not a target)"
            else:
                d = diameter_mm.get(obj, 0.0)
                ratio = target["best_add_mm"] / d if d > 0 else 0.0
                error = f"{target['best_add_mm']:10.1f} {ratio:6.3f}  {'yes' if target['add_correct'] else 'NO'}"
            print(f"{image:>9}  {obj:<11} {s_a} {conf} {1000 * e['solve_time_s']:5.0f}  {error}")

    overall = evaluation["overall"]
    print()
    print(f"ADD(-S)@0.1d recall: {100 * overall['add_recall']:.1f}% ({overall['add_correct']} of "
          f"{overall['targets']} targets)   BOP AR {overall['ar']:.3f} (VSD {overall['ar_vsd']:.3f}, "
          f"MSSD {overall['ar_mssd']:.3f}, MSPD {overall['ar_mspd']:.3f})")
    print(f"latency per image, send -> answer through LCM: p50 {percentile(latencies, 0.5):.2f} s, "
          f"p95 {percentile(latencies, 0.95):.2f} s;  solver per instance: p50 "
          f"{1000 * percentile(solve_times, 0.5):.0f} ms, p95 {1000 * percentile(solve_times, 0.95):.0f} ms")
    answered = sum(1 for fr in frames if fr["answered"])
    print(f"images: {len(frames)} sent, {answered} answered;  estimates: {ok_count} ok, {failed} failed")
    if not have_scores:
        print("note: this g6d-replay does not write per-estimate S_A (--estimates-jsonl); S_A shown as n/a")


if __name__ == "__main__":
    main()
