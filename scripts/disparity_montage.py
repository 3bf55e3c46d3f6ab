#!/usr/bin/env python3
"""Side by side: the disparities (and confidences) of several runs on one
frame of a sequence, e.g. two versions or two presets, from the 16-bit PNGs
bdis_match writes (disparity round(d * 256), confidence round(c * 65535),
0 = no estimate). One row per run: disparity | confidence; a first row with
the left image and, where the sequence has it, the ground truth. All
disparity panels share one colour range; the pictures are cropped to the
left image's non-black part, over which "estimated" is counted.

    scripts/disparity_montage.py SEQUENCE_DIR FRAME OUT.png LABEL=DISP_DIR[:CONF_DIR] ...

For example, before and after a change on one in-vivo frame:

    bdis_match --left-dir S/left --right-dir S/right --out-dir before/d --confidence-dir before/c
    ... (the same with the new build into after/)
    scripts/disparity_montage.py S 000010.png montage.png before=before/d:before/c after=after/d:after/c

Exits 1 with a message when an image is missing or unreadable, 2 on a usage error."""
import argparse
import os
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_common as common  # noqa: E402

PANEL_WIDTH = 360


def parse_run(text):
    label, sep, dirs = text.partition("=")
    if not sep or not label or not dirs:
        raise argparse.ArgumentTypeError("expected LABEL=DISP_DIR[:CONF_DIR], got %r" % text)
    disparity_dir, _, confidence_dir = dirs.partition(":")
    return label, disparity_dir, confidence_dir or None


def montage(sequence, frame, runs):
    left = cv2.imread(os.path.join(sequence, "left", frame), cv2.IMREAD_COLOR)
    if left is None:
        raise common.Failure("cannot read %s" % os.path.join(sequence, "left", frame))
    in_view = left.any(axis=2)
    if not in_view.any():
        raise common.Failure("the left image of %s is black" % frame)
    x, y, w, h = cv2.boundingRect(in_view.astype(np.uint8))
    crop = (slice(y, y + h), slice(x, x + w))
    full_shape = in_view.shape

    def read_cropped(path, scale):
        values, valid = common.read_png16(path, scale)
        if values.shape != full_shape:
            raise common.Failure("%s is %dx%d, the left image %dx%d" % (
                path, values.shape[1], values.shape[0], full_shape[1], full_shape[0]))
        return values[crop], valid[crop]

    left, in_view = left[crop], in_view[crop]
    height = round(PANEL_WIDTH * h / w)
    size = (PANEL_WIDTH, height)
    maps = [(label,) + read_cropped(os.path.join(d, frame), 256.0) + (c,) for label, d, c in runs]
    gt_path = os.path.join(sequence, "gt_disparity", frame)
    gt = read_cropped(gt_path, 256.0) if os.path.exists(gt_path) else None
    estimates = [d[valid] for _, d, valid, _ in maps if valid.any()]
    if gt is not None and gt[1].any():
        estimates.append(gt[0][gt[1]])
    lo, hi = np.percentile(np.concatenate(estimates), [1, 99]) if estimates else (0.0, 1.0)
    rows = [[common.labelled(left, "left image, " + frame, size),
             common.labelled(common.colour_map(gt[0], gt[1], lo, hi), "ground truth", size) if gt is not None
             else np.zeros((height, PANEL_WIDTH, 3), np.uint8)]]
    for label, disparity, valid, confidence_dir in maps:
        row = [common.labelled(common.colour_map(disparity, valid, lo, hi),
                               "%s: disparity %.0f-%.0f px, %.0f%% estimated" % (
                                   label, lo, hi, 100 * valid[in_view].mean()),
                               size)]
        if confidence_dir:
            confidence, _ = read_cropped(os.path.join(confidence_dir, frame), 65535.0)
            row.append(common.labelled(common.grey_panel(confidence), label + ": confidence 0-1", size))
        else:
            row.append(np.zeros((height, PANEL_WIDTH, 3), np.uint8))
        rows.append(row)
    return np.vstack([np.hstack(r) for r in rows])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sequence", help="sequence folder (left/, optionally gt_disparity/)")
    parser.add_argument("frame", help="file name of the frame, e.g. 000010.png")
    parser.add_argument("out", help="montage PNG to write")
    parser.add_argument("runs", nargs="+", type=parse_run, metavar="LABEL=DISP_DIR[:CONF_DIR]")
    args = parser.parse_args()
    try:
        picture = montage(args.sequence, args.frame, args.runs)
        if not cv2.imwrite(args.out, picture, [cv2.IMWRITE_PNG_COMPRESSION, 9]):
            raise common.Failure("cannot write %s" % args.out)
    except common.Failure as e:
        print("disparity_montage: %s" % e, file=sys.stderr)
        return 1
    print("wrote %s (%d runs)" % (args.out, len(args.runs)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
