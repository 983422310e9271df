#!/usr/bin/env python3
"""Right answers per kind of scene, from the log of g6d-bench-dataset --masks none (stderr).

synth_dev's scenes 0-9 are bins (238 instances with visib_fract >= 0.1 among the BOP'19
targets), 10-19 tables (174). An answer counts as right when the log says it lies within
ADD(-S) 0.1 d of a GT instance of its object (no "WRONG"); answers to absent objects are
left out.

    python3 scripts/detect_kinds.py out/geometry/new/synth_dev_none.log
    python3 scripts/detect_kinds.py LOG --split 10 --totals 238 174
"""
import argparse
import re


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("log")
    parser.add_argument("--split", type=int, default=10, help="first scene id of the second kind (default 10)")
    parser.add_argument("--names", nargs=2, default=["bins", "tables"])
    parser.add_argument("--totals", nargs=2, type=int, default=[238, 174], help="instances of each kind")
    args = parser.parse_args()
    right = [0, 0]
    kind = None
    with open(args.log) as log:
        for line in log:
            header = re.match(r"\[\d+\] scene (\d+) im (\d+)", line)
            if header:
                kind = 0 if int(header.group(1)) < args.split else 1
                continue
            if kind is not None and re.match(r"\s+obj_\d+: S .*ADD", line) and "WRONG" not in line:
                right[kind] += 1
    for k in range(2):
        print(f"{args.names[k]}: {right[k]} of {args.totals[k]} right ({100.0 * right[k] / args.totals[k]:.1f}%)")


if __name__ == "__main__":
    main()
