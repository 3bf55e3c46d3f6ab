#!/usr/bin/env python3
"""Where the wrong estimates of a run lie by the surface the ground truth
shows: per band of ground-truth disparity and of its slope (the Sobel
derivative, px per px), the share of the estimates, their bad2 and their
share of all wrong ones; the wrong ones by sign and by size of the error.
With confidences: how many of the wrong estimates in the most confident half
are dark (left grey < 30). Reads the 16-bit PNGs
bdis_match writes (disparity round(d * 256), confidence round(c * 65535),
0 = no estimate) for every frame that has ground truth; the scorable pixels
are those of ../shared/data/README.md (ground truth > 0, non-black left).

    bdis_match --left-dir S/left --right-dir S/right --out-dir D [--confidence-dir C]
    scripts/error_by_surface.py S D [--confidence C]

--warp-by first|gt measures a prototype instead of reading D: each frame is
matched again with the right image warped by D (first) or by the ground truth
(gt), both smoothed and hole-filled by a normalised Gaussian (sigma 3 px), and
the residual added back (two bdis_match runs a frame; --bdis-match PATH).
--set NAME=VALUE (repeatable) goes to the warped pair's bdis_match, e.g.
two_scales=true to bound what a slant model would gain with the larger
footprint (D from bdis_match with the same --set, to compare).

Exits 1 with a message when an image is missing or unreadable, 2 on a usage error."""
import argparse
import os
import subprocess
import sys
import tempfile

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bdis_common as common  # noqa: E402

DISPARITY_BANDS = ((0, 40), (40, 80), (80, None))
SLOPE_BANDS = ((0, 0.2), (0.2, None))
ERROR_BANDS = (("2-4 px", 2, 4), ("4-10 px", 4, 10), ("10 px and more", 10, np.inf))
DARK_GREY = 30
WARP_SHIFT = 16  # px added to the residual so that it stays >= 0 for bdis_match


def read_colour(path):
    image = cv2.imread(path, cv2.IMREAD_COLOR)
    if image is None:
        raise common.Failure("cannot read %s" % path)
    return image


def smooth_fill(disparity, sigma=3.0):
    """A normalised Gaussian over the estimates (> 0): smoothed, holes filled."""
    known = (disparity > 0).astype(np.float32)
    total = cv2.GaussianBlur(disparity * known, (0, 0), sigma)
    weight = cv2.GaussianBlur(known, (0, 0), sigma)
    filled = np.where(weight > 1e-3, total / np.maximum(weight, 1e-6), 0)
    wide = cv2.GaussianBlur(disparity * known, (0, 0), 5 * sigma) / np.maximum(
        cv2.GaussianBlur(known, (0, 0), 5 * sigma), 1e-6)
    return np.where(filled > 0, filled, wide).astype(np.float32)


def warped_match(bdis_match, settings, left, right, base, work):
    """Disparity of `left` against `right` warped by `base`: base + residual."""
    h, w = base.shape
    xs, ys = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    shifted = np.empty_like(base)  # base at x + WARP_SHIFT, the warp's source column
    shifted[:, :w - WARP_SHIFT] = base[:, WARP_SHIFT:]
    shifted[:, w - WARP_SHIFT:] = base[:, w - 1:w]
    warped = cv2.remap(right, xs - shifted + WARP_SHIFT, ys, cv2.INTER_LINEAR,
                       borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    warped[base <= 0] = 0
    paths = [os.path.join(work, name) for name in ("left.png", "right.png", "residual.png")]
    cv2.imwrite(paths[0], left)
    cv2.imwrite(paths[1], warped)
    # The check's mirrored search has no meaning on a warped pair.
    command = [bdis_match, paths[0], paths[1], paths[2], "--set", "lr_check_tolerance=0"]
    for setting in settings:
        command += ["--set", setting]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    residual = common.read_png16(paths[2], 256.0)[0]
    return np.where(residual > 0, base + residual - WARP_SHIFT, 0).astype(np.float32)


def collect(args):
    names = sorted(n for n in os.listdir(os.path.join(args.sequence, "gt_disparity")) if n.endswith(".png"))
    if not names:
        raise common.Failure("no ground truth in %s/gt_disparity" % args.sequence)
    columns = {key: [] for key in ("signed", "gt", "slope", "grey", "confidence")}
    scorable = 0
    work = tempfile.mkdtemp(prefix="error_by_surface_")
    try:
        for name in names:
            gt = common.read_png16(os.path.join(args.sequence, "gt_disparity", name), 256.0)[0]
            left = read_colour(os.path.join(args.sequence, "left", name))
            disparity = common.read_png16(os.path.join(args.disparity_dir, name), 256.0)[0]
            if args.warp_by:
                right = read_colour(os.path.join(args.sequence, "right", name))
                base = smooth_fill(disparity if args.warp_by == "first" else gt)
                # The first run's check decides what is published, as before.
                disparity = np.where(disparity > 0, warped_match(args.bdis_match, args.set, left, right, base, work), 0)
            in_view = (gt > 0) & (left.max(axis=2) > 0)
            scorable += int(in_view.sum())
            estimated = in_view & (disparity > 0)
            slope = np.hypot(cv2.Sobel(gt, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(gt, cv2.CV_32F, 0, 1, ksize=3)) / 8
            grey = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY)
            columns["signed"].append((disparity - gt)[estimated])
            columns["gt"].append(gt[estimated])
            columns["slope"].append(slope[estimated])
            columns["grey"].append(grey[estimated])
            if args.confidence:
                confidence = common.read_png16(os.path.join(args.confidence, name), 65535.0)[0]
                columns["confidence"].append(confidence[estimated])
    finally:
        for entry in os.listdir(work):
            os.unlink(os.path.join(work, entry))
        os.rmdir(work)
    return len(names), scorable, {key: np.concatenate(v) if v else None for key, v in columns.items()}


def band_rows(label, values, bands, wrong):
    rows = []
    for low, high in bands:
        inside = (values >= low) & (values < high if high is not None else True)
        name = "%s %g-%s" % (label, low, "%g" % high if high is not None else "")
        share = inside.mean() if len(values) else 0.0
        bad2 = wrong[inside].mean() if inside.any() else 0.0
        of_wrong = (inside & wrong).sum() / max(1, wrong.sum())
        rows.append("  %-16s %5.1f %% of the estimates, bad2 %5.1f %%, %5.1f %% of the wrong ones"
                    % (name, 100 * share, 100 * bad2, 100 * of_wrong))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sequence", help="sequence folder (left/, right/, gt_disparity/)")
    parser.add_argument("disparity_dir", help="bdis_match --out-dir of the run")
    parser.add_argument("--confidence", metavar="DIR", help="bdis_match --confidence-dir of the run")
    parser.add_argument("--warp-by", choices=("first", "gt"), help="measure the warping prototype")
    parser.add_argument("--bdis-match", default=None, help="bdis_match to run for --warp-by")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                        help="with --warp-by: a matcher parameter for the warped pair (repeatable)")
    args = parser.parse_args()
    if args.set and not args.warp_by:
        parser.error("--set applies to --warp-by's matching only")
    bad = [s for s in args.set if "=" not in s]
    if bad:
        parser.error("--set needs NAME=VALUE, got %s" % bad[0])
    if args.warp_by and not args.bdis_match:
        args.bdis_match = common.find_program("bdis_match")
    try:
        frames, scorable, c = collect(args)
    except common.Failure as exc:
        print("error_by_surface: %s" % exc, file=sys.stderr)
        return 1
    wrong = np.abs(c["signed"]) > 2
    print("%s: %d frames, density %.3f, bad2 %.1f %%%s" % (
        os.path.basename(os.path.normpath(args.sequence)), frames, len(wrong) / max(1, scorable), 100 * wrong.mean(),
        " (warped by %s)" % args.warp_by if args.warp_by else ""))
    for line in band_rows("d_gt px", c["gt"], DISPARITY_BANDS, wrong) + band_rows("slope", c["slope"],
                                                                                    SLOPE_BANDS, wrong):
        print(line)
    print("  the wrong ones: %.0f %% too large a disparity (too near), %.0f %% too small"
          % (100 * (c["signed"][wrong] > 0).mean(), 100 * (c["signed"][wrong] < 0).mean()))
    size = np.abs(c["signed"][wrong])
    print("  the wrong ones by error: %s" % ", ".join(
        "%s %.0f %%" % (name, 100 * ((size >= low) & (size < high)).mean() if len(size) else 0.0)
        for name, low, high in ERROR_BANDS))
    if c["confidence"] is not None:
        top = np.argsort(-c["confidence"], kind="stable")[:len(wrong) // 2]
        top_wrong = wrong[top]
        dark = c["grey"][top] < DARK_GREY
        print("  most confident half: bad2 %.1f %%; dark (grey < %d): %.0f %% of it, %.0f %% of its wrong ones"
              % (100 * top_wrong.mean(), DARK_GREY, 100 * dark.mean(),
                 100 * (dark & top_wrong).sum() / max(1, top_wrong.sum())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
