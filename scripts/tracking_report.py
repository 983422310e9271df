#!/usr/bin/env python3
"""Prints the tracking tables of scripts/tracking.sh as markdown.

    tracking_report.py OUT_DIR [calibration] [sequences] [service]

Reads OUT_DIR/runs/*.txt (g6d-bench-tracking reports) and OUT_DIR/service_{on,off}/
(g6d-replay summary and estimates, g6d-eval, the service's CPU seconds and wall time).
"""
import collections
import json
import os
import re
import sys


def read(path):
    return open(path).read() if os.path.exists(path) else None


def calibration(runs):
    names = [("lmo", "LM-O (rendered depth)"), ("ycbv_clutter", "YCB-V clutter (real)"),
             ("ycbv_real", "YCB-V foam brick (real)"), ("sequence", "sample sequence")]
    print("\n### Loss threshold: TrackPose from the ground truth moved at random (g6d-bench-tracking --perturb)\n")
    print("Start error: rotation up to 40 deg, translation up to 0.3 d. A tracked pose is kept when S_A <= loss_score"
          " (and J >= min_iou, which S_A <= 0.2 implies). Wrong = ADD(-S) >= 0.1 d.\n")
    rows = collections.OrderedDict()
    times = {}
    counts = {}
    for tag, label in names:
        text = read(os.path.join(runs, f"perturb_{tag}.txt"))
        if not text:
            continue
        for threshold, kept, refused in re.findall(
                r"^\| ([\d.]+) \| \d+ of \d+ \| (\d+ of \d+ \([\d.]+%\)) \| ([\d.]+%) \|$", text, re.M):
            rows.setdefault(threshold, {})[label] = (kept, refused)
        m = re.search(r"(\d+) solves", text)
        counts[label] = m.group(1) if m else "?"
        m = re.search(r"total p50 ([\d.]+) p95 ([\d.]+); prepare ([\d.]+) / [\d.]+, ICP ([\d.]+) / [\d.]+, MHPO ([\d.]+)", text)
        times[label] = m.groups() if m else None
    labels = [label for _, label in names if label in counts]
    print("| loss_score | " + " | ".join(f"{label} ({counts[label]} solves): wrong kept / correct refused" for label in labels) + " |")
    print("|---|" + "---|" * len(labels))
    for threshold, by_label in rows.items():
        cells = [f"{by_label[l][0]} / {by_label[l][1]}" if l in by_label else "-" for l in labels]
        print(f"| {threshold} | " + " | ".join(cells) + " |")
    print("\n| TrackPose time (ms) | total p50 | total p95 | prepare p50 | ICP p50 | MHPO p50 |\n|---|---|---|---|---|---|")
    for label in labels:
        if times[label]:
            print(f"| {label} | " + " | ".join(times[label]) + " |")


def sequence_row(text):
    r = {}
    m = re.search(r"^\| (\d+) \| ([\d.]+)% \| ([\d.]+%|-) \| (\d+) \| (\d+) \| (\d+) \((\d+) / (\d+)\) \|$", text, re.M)
    if m:
        r.update(n=m.group(1), tracking=m.group(2), baseline=m.group(3), detected=m.group(4), tracked=m.group(5),
                 redetected=m.group(6), lost=m.group(7), periodic=m.group(8))
    for key, pattern in [("track", r"tracked solve \(TrackPose\), per instance"), ("frame", r"frame, tracking"),
                         ("frame_baseline", r"frame, every frame solved"), ("background", r"background re-detection, per instance")]:
        m = re.search(r"^\| " + pattern + r"[^|]* \| ([\d.]+) \| ([\d.]+) \| (\d+) \|$", text, re.M)
        if m:
            r[key] = f"{m.group(1)} / {m.group(2)}"
    m = re.search(r"wrong poses published \(ADD\(-S\) >= 0.1 d\): (\d+) of (\d+) before", text)
    if m:
        r["wrong_before"] = f"{m.group(1)} / {m.group(2)}"
    m = re.search(r", (\d+) of (\d+) from the abrupt move at frame (\d+) on; longest run of wrong frames of one instance after it: (\d+)", text)
    r["wrong_after"] = f"{m.group(1)} / {m.group(2)} (longest run {m.group(4)})" if m else "-"
    m = re.search(r"tracks corrected by them: (\d+)", text)
    r["corrected"] = m.group(1) if m else "0"
    return r


def sequences(runs):
    variants = ["default", "no constant velocity", "periodic re-detection in the frame", "no periodic re-detection"]
    datasets = [("sample", "sample sequence (90 frames, 3 objects, rendered)"), ("ycbv_real", "ycbv_real (5 real frames)"),
                ("ycbv_clutter", "ycbv_clutter (5 real frames, 3 objects)")]
    print("\n### Tracking vs solving every frame (g6d-bench-tracking, GT visible masks, K = 18, 2 threads)\n")
    print("| sequence | variant | instances | ADD(-S) tracking | ADD(-S) every frame | detected / tracked / re-detected (lost, periodic) |"
          " tracked solve p50 / p95 ms | frame p50 / p95 ms, tracking | every frame | wrong published before | after the abrupt move |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for tag, label in datasets:
        for variant in variants:
            text = read(os.path.join(runs, f"seq_{variant.replace(' ', '_')}_{tag}.txt"))
            if not text:
                continue
            r = sequence_row(text)
            if "n" not in r:
                continue
            print(f"| {label} | {variant} | {r['n']} | {r['tracking']}% | {r['baseline']} | {r['detected']} / {r['tracked']} / "
                  f"{r['redetected']} ({r['lost']}, {r['periodic']}) | {r.get('track', '-')} | {r.get('frame', '-')} | "
                  f"{r.get('frame_baseline', '-')} | {r.get('wrong_before', '-')} | {r['wrong_after']} |")


def service(out):
    print("\n### The service at 30 Hz: g6d-replay --mode realtime on the sample sequence (2 workers)\n")
    print("The service is idle before and after the 3-s sequence: its CPU seconds over the replay, divided by the"
          " sequence's duration, are the cores it used while the frames came in.\n")
    print("| tracking | frames sent | answered | answered per second | latency p50 / p95 ms | service CPU s (cores) |"
          " answers detected / tracked / re-detected | ADD(-S) of the answers |")
    print("|---|---|---|---|---|---|---|---|")
    for tracking in ("on", "off"):
        d = os.path.join(out, f"service_{tracking}")
        summary_text = read(os.path.join(d, "summary.json"))
        if not summary_text:
            continue
        summary = json.loads(summary_text)
        cpu_s, wall_s = (float(x) for x in read(os.path.join(d, "cpu.txt")).split())
        modes = collections.Counter()
        for line in open(os.path.join(d, "estimates.jsonl")):
            modes[json.loads(line).get("mode", "?")] += 1
        evaluation = json.loads(read(os.path.join(d, "eval.json")) or "{}").get("overall", {})
        # The sequence lasts frames / fps; answered per second over that span.
        frames = summary["log"]["frames"]
        duration_s = frames / 30.0
        latency = summary["latency_s"]
        print(f"| {tracking} | {summary['sent']} | {summary['answered']} | {summary['answered'] / duration_s:.1f} | "
              f"{1000 * latency['p50']:.0f} / {1000 * latency['p95']:.0f} | {cpu_s:.2f} ({cpu_s / duration_s:.2f}) | "
              f"{modes['detected']} / {modes['tracked']} / {modes['redetected']} | "
              f"{100 * evaluation.get('add_recall', 0):.1f}% of {evaluation.get('targets_with_estimate', 0)} |")


def main():
    out = sys.argv[1]
    sections = sys.argv[2:] or ["calibration", "sequences", "service"]
    runs = os.path.join(out, "runs")
    if "calibration" in sections:
        calibration(runs)
    if "sequences" in sections:
        sequences(runs)
    if "service" in sections:
        service(out)


if __name__ == "__main__":
    main()
