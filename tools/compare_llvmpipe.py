#!/usr/bin/env python3
"""penumbra against Mesa's llvmpipe on this machine, on the issue-2 workloads.

For each workload it exports the triangles from penumbra (`--export`), then runs penumbra and
`tools/llvmpipe_bench.py` alternately (`--rounds` times each, so both see the same machine
load), and prints the minimum and median of each renderer's per-run medians, their ratio, and
the median (and range) of the ratios of neighbouring runs.

    python3 tools/compare_llvmpipe.py [--threads 2] [--rounds 3] [--only pcf2] [--bin target/release/penumbra]

Needs what tools/llvmpipe_bench.py needs (Mesa's EGL and moderngl).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))

# name, penumbra arguments, the JSON key compared (lower is better), how to report it
WORKLOADS = [
    ("frame pcf2 (T=100k)", ["bench", "frame", "--mode", "pcf2"], "ms_frame"),
    ("frame pcf5 (T=100k)", ["bench", "frame", "--mode", "pcf5"], "ms_frame"),
    ("frame pcss (T=100k)", ["bench", "frame", "--mode", "pcss"], "ms_frame"),
    ("frame vsm (T=100k)", ["bench", "frame", "--mode", "vsm"], "ms_frame"),
    ("colour+depth, 50-px tris", ["bench", "raster", "--mode", "color", "--area", "50"], "ms"),
    ("depth only, 50-px tris", ["bench", "raster", "--mode", "depth", "--area", "50"], "ms"),
    ("fill, 20000-px tris", ["bench", "raster", "--mode", "color", "--area", "20000", "--triangles", "2000"], "ms"),
]


def run_json(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--reps", type=int, default=10)
    ap.add_argument("--bin", default=os.path.join(HERE, "..", "target", "release", "penumbra"))
    ap.add_argument("--only", default="", help="run only the workloads whose name contains this")
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, args, key in WORKLOADS:
            if a.only not in name:
                continue
            d = os.path.join(tmp, str(len(rows)))
            common = ["--threads", str(a.threads), "--reps", str(a.reps), "--json"]
            first = run_json([a.bin, *args, *common, "--export", d])
            ours, theirs = [first[key]], []
            extra = {k: first[k] for k in ("mtri_per_s", "gpix_per_s") if k in first}
            for r in range(a.rounds):
                theirs.append(
                    run_json([sys.executable, os.path.join(HERE, "llvmpipe_bench.py"), d, "--threads", str(a.threads),
                              "--reps", str(a.reps)])[key if key != "ms" else "ms"]
                )
                if r + 1 < a.rounds:
                    ours.append(run_json([a.bin, *args, *common])[key])
            rows.append((name, ours, theirs, extra, first))
            o, t = statistics.median(ours), statistics.median(theirs)
            # Run i of each renderer are neighbours in time, so their ratio sees one machine
            # phase: the median of these ratios drifts less than the ratio of the medians.
            pairs = sorted(x / y for x, y in zip(ours, theirs))
            print(f"{name:28} penumbra {o:8.2f} ms (min {min(ours):.2f})   llvmpipe {t:8.2f} ms (min {min(theirs):.2f})"
                  f"   penumbra/llvmpipe {o / t:.2f}   paired {statistics.median(pairs):.2f}"
                  f" ({pairs[0]:.2f}-{pairs[-1]:.2f})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
