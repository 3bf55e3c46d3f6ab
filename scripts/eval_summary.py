#!/usr/bin/env python3
"""One run of bdis_eval (its --json) condensed to the figures the accuracy and
confidence targets are stated in, over all its sequences with ground truth;
with a second run, both side by side and, per sequence, what changed.

    scripts/eval_generated.sh ... -- --methods bdis --set compute_variance=true --json A.json
    scripts/eval_summary.py A.json [B.json] [--method bdis]

Per run:
  - mean bad2, density and miss_or_bad2 over the sequences;
  - the confidence's sparsification ratio to the oracle: geometric mean, worst,
    and the sequences over 3;
  - the sequences whose most confident half is over 3 % bad2, and those whose
    bad2 does not fall across the confidence deciles;
  - with compute_variance: the sequences with 60-80 % of the errors within 1
    sigma and 90-98 % within 2, and the median over them of the median
    |error| / sigma;
  - with an instrument (labels): the share of the tissue within 12 px of it
    that is wrong at confidence >= 0.5, its mean over those sequences and the
    largest;
  - per sequence without ground truth (in vivo): the outliers along the
    rectification border.
Sequences are matched between the runs by name (bdis_eval's, the directory's).
Exits 1 with a message when a file cannot be read or holds no result of the
method, 2 on a usage error."""
import argparse
import json
import math
import statistics
import sys

RATIO_TARGET = 3.0       # sparsification area over the oracle's
TOP_HALF_TARGET = 0.03   # bad2 of the most confident half
WITHIN_1_SIGMA = (0.60, 0.80)
WITHIN_2_SIGMA = (0.90, 0.98)
# The tissue within 12 px of the instrument wrong at confidence >= 0.5, in a result.
BESIDE_INSTRUMENT = ("instrument_bands", "tissue_within_12px", "confident_bad2_share")


class Failure(Exception):
    """A message for the user, printed without a traceback."""


def load(path, method):
    try:
        with open(path) as f:
            results = json.load(f)["results"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise Failure("cannot read %s as bdis_eval's --json: %s" % (path, exc))
    runs = {}
    for r in results:
        if r.get("method") == method:
            runs[r["sequence"]] = r
    if not runs:
        raise Failure("%s holds no result of method '%s'" % (path, method))
    return runs


def figure(result, *keys):
    """result[k0][k1]..., or None where a key is missing."""
    for k in keys:
        if not isinstance(result, dict) or k not in result:
            return None
        result = result[k]
    return result


def variance_in_bands(result):
    w1, w2 = figure(result, "variance", "within_1_sigma"), figure(result, "variance", "within_2_sigma")
    if w1 is None or w2 is None:
        return None
    return WITHIN_1_SIGMA[0] <= w1 <= WITHIN_1_SIGMA[1] and WITHIN_2_SIGMA[0] <= w2 <= WITHIN_2_SIGMA[1]


def names(items):
    return " (%s)" % ", ".join(items) if items else ""


def summary(runs):
    """The summary lines of one run, as (label, text) pairs."""
    scored = {k: r for k, r in runs.items() if r.get("ground_truth")}
    lines = []
    n = len(scored)
    if n:
        def mean(key):
            return sum(r[key] for r in scored.values()) / n
        lines.append(("sequences with ground truth", "%d" % n))
        lines.append(("mean bad2 / density / miss_or_bad2", "%.2f %% / %.3f / %.2f %%" % (
            100 * mean("bad2"), mean("density"), 100 * mean("miss_or_bad2"))))
        ratios = {k: figure(r, "confidence", "ratio") for k, r in scored.items()}
        ratios = {k: v for k, v in ratios.items() if v is not None and v > 0}
        if ratios:
            gmean = math.exp(sum(math.log(v) for v in ratios.values()) / len(ratios))
            worst = max(ratios, key=ratios.get)
            over = sorted(k for k, v in ratios.items() if v > RATIO_TARGET)
            lines.append(("ranking ratio: geometric mean, worst", "%.3f, %.2f (%s)" % (gmean, ratios[worst], worst)))
            lines.append(("ranking ratio over 3", "%d of %d%s" % (len(over), len(ratios), names(over))))
            top = sorted(k for k, r in scored.items()
                         if (figure(r, "confidence", "bad2_top50") or 0.0) > TOP_HALF_TARGET)
            lines.append(("most confident half over 3 % bad2", "%d of %d%s" % (len(top), len(ratios), names(top))))
            not_falling = sorted(k for k in ratios if not figure(scored[k], "confidence", "monotone"))
            lines.append(("bad2 falling across the deciles", "%d of %d%s" % (
                len(ratios) - len(not_falling), len(ratios), names(["not: " + ", ".join(not_falling)]
                                                                   if not_falling else []))))
        bands = {k: variance_in_bands(r) for k, r in scored.items()}
        bands = {k: v for k, v in bands.items() if v is not None}
        if bands:
            lines.append(("variance within 1 and 2 sigma in their bands", "%d of %d" % (
                sum(bands.values()), len(bands))))
            medians = [v for v in (figure(r, "variance", "median_error_over_sigma") for r in scored.values())
                       if v is not None]
            if medians:
                lines.append(("variance: median over the sequences of median |error| / sigma (a Gaussian: 0.674)",
                              "%.2f" % statistics.median(medians)))
        beside = {k: figure(r, *BESIDE_INSTRUMENT) for k, r in scored.items()}
        beside = {k: v for k, v in beside.items() if v is not None}
        if beside:
            worst = max(beside, key=beside.get)
            lines.append(("beside the instrument, wrong at >= 0.5: mean, largest", "%.2f %%, %.2f %% (%s)" % (
                100 * statistics.mean(beside.values()), 100 * beside[worst], worst)))
    for k, r in sorted(runs.items()):
        if not r.get("ground_truth") and r.get("border_outliers") is not None:
            lines.append(("%s: border outliers / density" % k, "%.2f %% / %.3f" % (
                100 * r["border_outliers"], r.get("valid_pixel_density", float("nan")))))
    return lines


def per_sequence(a, b):
    """Per sequence scored in both runs: density, bad2, ratio, most confident
    half, and with an instrument the tissue beside it wrong at >= 0.5."""
    rows = []
    for k in sorted(set(a) & set(b)):
        ra, rb = a[k], b[k]
        if not (ra.get("ground_truth") and rb.get("ground_truth")):
            continue

        def pair(fmt, scale, *keys):
            va, vb = figure(ra, *keys), figure(rb, *keys)
            text = lambda v: "-" if v is None else fmt % (scale * v)  # noqa: E731
            return "%s -> %s" % (text(va), text(vb))
        row = "%-28s density %s  bad2 %s %%  ratio %s  top half %s %%" % (
            k, pair("%.3f", 1, "density"), pair("%.2f", 100, "bad2"), pair("%.2f", 1, "confidence", "ratio"),
            pair("%.1f", 100, "confidence", "bad2_top50"))
        if figure(ra, *BESIDE_INSTRUMENT) is not None or figure(rb, *BESIDE_INSTRUMENT) is not None:
            row += "  beside %s %%" % pair("%.2f", 100, *BESIDE_INSTRUMENT)
        rows.append(row)
    return rows


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", metavar="RUN.json", help="bdis_eval --json output (one or two)")
    parser.add_argument("--method", default="bdis", help="the method to summarise (default: bdis)")
    args = parser.parse_args(argv)
    if len(args.runs) > 2:
        parser.error("one run, or two to compare")
    try:
        runs = [load(path, args.method) for path in args.runs]
    except Failure as exc:
        print("eval_summary.py: %s" % exc, file=sys.stderr)
        return 1
    if len(runs) == 1:
        for label, text in summary(runs[0]):
            print("%s: %s" % (label, text))
        return 0
    a, b = (dict(summary(r)) for r in runs)
    for label in list(a) + [k for k in b if k not in a]:
        print("%s: %s -> %s" % (label, a.get(label, "-"), b.get(label, "-")))
    print()
    for row in per_sequence(*runs):
        print(row)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
