#!/usr/bin/env python3
"""Prints the poses g6d-service answers with: object id, status, cam_from_object
(position in metres, quaternion w x y z), S_A (lower is better), confidence, the mask IoU,
how the answer was made (detected / tracked / redetected, the track id) and, for a request
without an object id, the identity search (candidates tried, the runner-up identity).

Two sources, one decoding (the pure-Python classes lcm-gen makes from lcmtypes/; they
decode without the lcm module):

    # An lcm-logger log file (read directly, no lcm module needed):
    python3 examples/print_poses.py --log answers.lcmlog
    # Live, where the lcm Python module is importable:
    python3 examples/print_poses.py --live --lcm-url udpm://239.255.76.67:7667?ttl=0

The classes are found in build/lcmtypes/python (made by the build) unless --types or
G6D_LCM_PYTHON says where.
"""

import argparse
import os
import struct
import sys

SYNC_WORD = 0xEDA1DA01
# sync word (uint32), event number (int64), utime (int64), channel length (int32),
# data length (int32): big-endian, then the channel and the data bytes.
EVENT_HEADER = struct.Struct(">IqqII")


def read_log_events(path):
    """Yields (event number, utime, channel, data) of every event of an LCM log file.

    Raises ValueError naming the byte offset when the file is not an LCM log or ends in
    the middle of an event.
    """
    with open(path, "rb") as log:
        offset = 0
        while True:
            header = log.read(EVENT_HEADER.size)
            if not header:
                return
            if len(header) < EVENT_HEADER.size:
                raise ValueError(f"{path}: truncated event header at byte {offset}")
            sync, number, utime, channel_length, data_length = EVENT_HEADER.unpack(header)
            if sync != SYNC_WORD:
                raise ValueError(
                    f"{path}: byte {offset}: sync word 0x{sync:08X}, expected 0x{SYNC_WORD:08X}"
                    " (not an LCM log?)")
            channel = log.read(channel_length)
            data = log.read(data_length)
            if len(channel) < channel_length or len(data) < data_length:
                raise ValueError(f"{path}: event {number} at byte {offset} is truncated")
            offset += EVENT_HEADER.size + channel_length + data_length
            yield number, utime, channel.decode("utf-8", "replace"), data


def import_pose_array(types_dir):
    """The generated g6d.pose_array_t class, from types_dir (or the default places)."""
    here = os.path.dirname(os.path.abspath(__file__))
    candidates = [types_dir, os.environ.get("G6D_LCM_PYTHON"),
                  os.path.join(here, "..", "build", "lcmtypes", "python")]
    for directory in candidates:
        if directory and os.path.isdir(os.path.join(directory, "g6d")):
            sys.path.insert(0, os.path.abspath(directory))
            break
    try:
        from g6d import pose_array_t  # pylint: disable=import-outside-toplevel
    except ImportError as error:
        sys.exit(f"print_poses: cannot import the generated g6d classes ({error}); build the "
                 "project (they are in build/lcmtypes/python) or pass --types DIR")
    return pose_array_t


STATUS_NAMES = {0: "ok", 1: "no_solution", 2: "bad_input", 3: "unknown_object",
                4: "internal_error"}
MODE_NAMES = {0: "detected", 1: "tracked", 2: "redetected"}


def format_track(estimate):
    """How the answer was made: "detected", or the mode and the service's track id."""
    mode = MODE_NAMES.get(estimate.mode, f"unknown({estimate.mode})")
    if estimate.track_id < 0:
        return mode
    since = (f", {estimate.frames_since_detection} since detection"
             if estimate.frames_since_detection > 0 else "")
    return f"{mode} track {estimate.track_id}{since}"


def format_identity(estimate):
    """The identity search of a request without an object id ("" for a request with one)."""
    if not estimate.identity_searched:
        return ""
    runner_up = (f", runner-up {estimate.runner_up_object_id} S {estimate.runner_up_object_score:.4f}"
                 if estimate.runner_up_object_id else ", no runner-up")
    return f"  identity chosen of {estimate.candidates_tried}{runner_up}"


def format_answer(answer):
    """The lines printed for one decoded g6d.pose_array_t."""
    lines = [f"frame seq {answer.seq} utime {answer.source_utime} camera '{answer.camera_id}'"
             f" scene {answer.scene_id} image {answer.image_id}: "
             + ("ok" if answer.status == 0 else f"REJECTED: {answer.message}")]
    for estimate in answer.estimates:
        status = STATUS_NAMES.get(estimate.status, f"unknown({estimate.status})")
        if estimate.status != 0:
            object_id = estimate.object_id or "(identity unknown)"
            lines.append(f"  {object_id} label {estimate.label}: {status}: {estimate.message}")
            continue
        x, y, z = estimate.position
        qw, qx, qy, qz = estimate.orientation
        lines.append(f"  {estimate.object_id} label {estimate.label}: ok "
                     f"t = [{x:.4f} {y:.4f} {z:.4f}] m  q = [{qw:.5f} {qx:.5f} {qy:.5f} {qz:.5f}]"
                     f"  S_A = {estimate.score:.4f}  confidence = {estimate.confidence:.3f}"
                     f"  ({format_track(estimate)})  mask IoU = {estimate.mask_iou:.3f}"
                     f"{format_identity(estimate)}")
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--log", help="an lcm-logger log file")
    source.add_argument("--live", action="store_true", help="subscribe on the bus (lcm module)")
    parser.add_argument("--channel", default="G6D_POSES", help="answer channel (G6D_POSES)")
    parser.add_argument("--lcm-url", default="", help="LCM URL for --live (LCM's default)")
    parser.add_argument("--types", help="folder holding the generated g6d/ Python package")
    args = parser.parse_args()
    pose_array_t = import_pose_array(args.types)

    if args.log:
        answers = 0
        try:
            for _, _, channel, data in read_log_events(args.log):
                if channel != args.channel:
                    continue
                try:
                    answer = pose_array_t.decode(data)
                except ValueError as error:  # wrong fingerprint: another type on the channel
                    print(f"skipping an undecodable message on {channel}: {error}")
                    continue
                print("\n".join(format_answer(answer)))
                answers += 1
        except (OSError, ValueError) as error:
            sys.exit(f"print_poses: {error}")
        print(f"{answers} answers on {args.channel}")
        return

    try:
        import lcm  # pylint: disable=import-outside-toplevel
    except ImportError:
        sys.exit("print_poses: --live needs the lcm Python module (pip install lcm, or "
                 "Debian's python3-lcm where packaged); --log works without it")
    bus = lcm.LCM(args.lcm_url) if args.lcm_url else lcm.LCM()

    def handle(channel, data):
        print("\n".join(format_answer(pose_array_t.decode(data))), flush=True)

    bus.subscribe(args.channel, handle)
    try:
        while True:
            bus.handle()
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
