#!/usr/bin/env python3
"""Fits a table that turns the confidence's product of cues into the
probability that an estimate is within 2 px of the true disparity.

A table has one probability per power of two of the raw confidence, from
2^-KNOTS to 2^0; core/src/matcher/confidence_calibration.cpp holds one per
finest level the matcher picks by the width (1 at 640 px, 2 at 1280, 3 at
1920), each fitted on frames of that width. Each knot's
probability is the share of estimates within 2 px among those whose raw
confidence lies within half an octave of it, every sequence weighted alike,
with a prior that keeps a knot with few estimates near its neighbours; the
table is then made increasing (pool adjacent violators) and strictly so,
with room between the top knots for the most confident estimates to keep
their order.

Fit on generated scenes only, never on the evaluation sequences. Level 1:

  scripts/eval_generated.sh --no-shared -- --methods bdis \\
      --set calibrated_confidence=false --dump-dir /tmp/raw_confidence
  /usr/bin/python3 scripts/fit_confidence_calibration.py /tmp/raw_confidence _ws/generated/*_s7 _ws/generated/*_s11

Levels 2 and 3, with SIZE 1280x720 and 1920x1080 (4 frames a render):

  scripts/eval_generated.sh --size SIZE --frames 4 --no-shared -- --methods bdis \\
      --set calibrated_confidence=false --dump-dir /tmp/raw_SIZE
  /usr/bin/python3 scripts/fit_confidence_calibration.py /tmp/raw_SIZE _ws/generated/*_s7_SIZE _ws/generated/*_s11_SIZE

DUMP_DIR/<sequence>/bdis/ holds what bdis_eval --dump-dir writes (disparity
PNGs, conf_*.tiff); each SEQUENCE_DIR its left/ and gt_disparity/. Prints the
C++ table and, per sequence, the expected calibration error of the fit.
"""
import argparse
import glob
import os
import sys

import numpy as np

KNOTS = 40             # octaves below 1 that the table spans
BAD_PX = 2.0           # an estimate off by more than this is an outlier (bad2)
PRIOR_WEIGHT = 0.002   # pseudo-count, in units of one sequence's estimates, towards the pooled share
# Each knot lies below the next by at least MIN_STEP or, nearer 1, by
# MIN_WRONG_DROP of what the next leaves below 1 (see fit()).
MIN_STEP = 1e-4
MIN_WRONG_DROP = 0.1


def load(dump_dir, sequence_dir):
    import cv2  # only needed to read the frames
    name = os.path.basename(os.path.normpath(sequence_dir))
    raw, good = [], []
    for path in sorted(glob.glob(os.path.join(dump_dir, name, 'bdis', '*.png'))):
        stem = os.path.basename(path)[:-4]
        disparity = cv2.imread(path, cv2.IMREAD_UNCHANGED).astype(np.float32) / 256
        confidence = cv2.imread(os.path.join(dump_dir, name, 'bdis', f'conf_{stem}.tiff'), cv2.IMREAD_UNCHANGED)
        truth = cv2.imread(os.path.join(sequence_dir, 'gt_disparity', f'{stem}.png'),
                           cv2.IMREAD_UNCHANGED).astype(np.float32) / 256
        left = cv2.imread(os.path.join(sequence_dir, 'left', f'{stem}.png'), cv2.IMREAD_GRAYSCALE)
        if confidence is None or truth is None or left is None:
            sys.exit(f'{name}/{stem}: missing confidence, ground truth or left image')
        scored = (truth > 0) & (left > 0) & (disparity > 0)
        raw.append(confidence[scored])
        good.append(np.abs(disparity[scored] - truth[scored]) <= BAD_PX)
    if not raw:
        sys.exit(f'no frames for {name} in {dump_dir}')
    return name, np.concatenate(raw), np.concatenate(good)


def octave(raw):
    """log2 of the raw confidence, clamped to the table's span."""
    return np.clip(np.log2(np.maximum(raw, np.finfo(np.float32).tiny)), -KNOTS, 0)


def increasing(values, weights):
    """Weighted least-squares non-decreasing fit (pool adjacent violators)."""
    blocks = []  # [value, weight, count]
    for v, w in zip(values, weights):
        blocks.append([v, w, 1])
        while len(blocks) > 1 and blocks[-2][0] > blocks[-1][0]:
            v2, w2, n2 = blocks.pop()
            v1, w1, n1 = blocks.pop()
            blocks.append([(v1 * w1 + v2 * w2) / (w1 + w2), w1 + w2, n1 + n2])
    return np.concatenate([[v] * n for v, _, n in blocks])


def fit(samples):
    knots = np.arange(-KNOTS, 1)
    good_sum = np.zeros(len(knots))
    weight_sum = np.zeros(len(knots))
    for _, raw, good in samples:
        index = np.rint(octave(raw)).astype(int) + KNOTS
        w = 1.0 / len(raw)  # every sequence counts alike
        good_sum += w * np.bincount(index, weights=good.astype(float), minlength=len(knots))
        weight_sum += w * np.bincount(index, minlength=len(knots))
    pooled = good_sum.sum() / weight_sum.sum()
    share = (good_sum + PRIOR_WEIGHT * pooled) / (weight_sum + PRIOR_WEIGHT)
    table = increasing(share, weight_sum + PRIOR_WEIGHT)
    # Strictly increasing and below 1, so that the order of the raw
    # confidence survives: fixed from the top down. Near 1 the rise is a part
    # of what is left below 1 (a float has about 2^24 values in [0.5, 1),
    # evenly spaced, so a fixed small rise would leave the most confident
    # estimates a few dozen values to share).
    table = np.minimum(table, 1 - MIN_STEP)
    for i in range(len(table) - 2, -1, -1):
        table[i] = min(table[i], table[i + 1] - min(MIN_STEP, MIN_WRONG_DROP * (1 - table[i + 1])))
    return table


def calibrated(table, raw):
    """What the C++ stage computes: linear in the mantissa between knots."""
    exponent = np.floor(np.log2(np.maximum(raw, np.finfo(np.float32).tiny)))
    mantissa = raw / np.exp2(exponent) - 1
    i = np.clip(exponent.astype(int) + KNOTS, 0, KNOTS)
    j = np.minimum(i + 1, KNOTS)
    p = table[i] + (table[j] - table[i]) * mantissa
    return np.where(exponent < -KNOTS, table[0], np.where(exponent >= 0, table[-1], p))


def calibration_error(table, raw, good, bins=np.array([0, .5, .6, .7, .8, .9, .95, .98, 1.0001])):
    p = calibrated(table, raw)
    index = np.digitize(p, bins) - 1
    error = 0.0
    for b in range(len(bins) - 1):
        k = index == b
        if k.any():
            error += k.mean() * abs(p[k].mean() - good[k].mean())
    return error


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('dump_dir')
    parser.add_argument('sequences', nargs='+')
    args = parser.parse_args()
    samples = [load(args.dump_dir, s) for s in args.sequences]
    table = fit(samples)
    print(f'    // {len(samples)} sequences: ' + ' '.join(name for name, _, _ in samples))
    print('    calibrationOf({')
    for row in range(0, len(table), 6):
        print('        ' + ' '.join(f'{v:.6f}f,' for v in table[row:row + 6]))
    print('    }),')
    for name, raw, good in samples:
        print(f'# {name:28s} within 2 px {good.mean():.3f}, '
              f'mean calibrated {calibrated(table, raw).mean():.3f}, '
              f'expected calibration error {calibration_error(table, raw, good):.3f}')


if __name__ == '__main__':
    main()
