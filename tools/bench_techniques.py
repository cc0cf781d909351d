#!/usr/bin/env python3
"""Every technique's defaults on a scene of its family, timed with `penumbra bench technique`:
the table of docs/performance.md ("Every technique's default"), or, with `--against`, two
builds side by side (the check that a change made no technique slower).

    cargo build --release
    python3 tools/bench_techniques.py [--threads 2] [--reps 5] [--rounds 3]
    python3 tools/bench_techniques.py --against /tmp/penumbra-before

Runs are interleaved (technique after technique, build after build, then the next round), and
each cell is the fastest median of the rounds: the machines drift by 10-30 % within minutes.
The image hash of every run of a technique must be the same (for both builds), or it fails;
`--images-may-differ` keeps the check within each build only (two builds of which one changed
what a technique computes on purpose).
"""
import argparse
import json
import subprocess
import sys

SPHERES = (None, None)
PERGOLA = ("fixtures/scenes/pergola.toml", "1920x1080")
SMOKE = ("fixtures/scenes/smoke.toml", "1920x1080")
TERRAIN = ("fixtures/scenes/terrain.toml", "1920x1080")
# (technique, settings, (scene file or None for the spheres scene, resolution))
RUNS = [
    ("reference", [], SPHERES),
    ("shadow-map", [], SPHERES),
    ("csm", [], SPHERES),
    ("sdsm", [], SPHERES),
    ("lispsm", [], SPHERES),
    ("logpsm", [], SPHERES),
    ("tsm", [], SPHERES),
    ("psm", [], SPHERES),
    ("pcss", [], SPHERES),
    ("chs", [], SPHERES),
    ("vsm", [], SPHERES),
    ("convolution", [], SPHERES),
    ("esm", [], SPHERES),
    ("evsm", [], SPHERES),
    ("msm", [], SPHERES),
    ("shadow-volume", [], SPHERES),
    ("planar", [], SPHERES),
    ("cookie", [], SPHERES),
    ("izb", [], SPHERES),
    ("hybrid", [], PERGOLA),
    ("multi-sample", [], PERGOLA),
    ("multi-sample", ["method=volumes"], PERGOLA),
    ("pvm", [], PERGOLA),
    ("pvmf", [], PERGOLA),
    ("transparency-map", [], SMOKE),
    ("opacity-maps", [], SMOKE),
    ("deep-shadow-map", [], SMOKE),
    ("avsm", [], SMOKE),
    ("screen-space", [], SPHERES),
    ("contact-map", [], SPHERES),
    ("terrain-height", [], TERRAIN),
]


def run(bin_path, technique, sets, scene, threads, reps):
    cmd = [bin_path, "bench", "technique", "--technique", technique, "--threads", str(threads),
           "--reps", str(reps), "--json"]
    for s in sets:
        cmd += ["--set", s]
    if scene[0]:
        cmd += ["--scene", scene[0], "--resolution", scene[1]]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def label(technique, sets):
    return f"`{technique}" + (f" [{' '.join(sets)}]`" if sets else "`")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/penumbra")
    ap.add_argument("--against", help="another build's binary, run alternately")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--images-may-differ", action="store_true",
                    help="the two builds' images may differ (each build's runs must still agree)")
    ap.add_argument("--only", nargs="*", help="only these techniques")
    a = ap.parse_args()
    bins = [a.bin] + ([a.against] if a.against else [])
    best = {}
    for _ in range(a.rounds):
        for (t, sets, scene) in RUNS:
            if a.only and t not in a.only:
                continue
            for b in bins:
                j = run(b, t, sets, scene, a.threads, a.reps)
                key = (t, tuple(sets))
                hashes = {v["hash"] for (k, bb), v in best.items()
                          if k == key and (bb == b or not a.images_may_differ)}
                if hashes and j["hash"] not in hashes:
                    sys.exit(f"{t} {sets}: the image hash differs between runs or builds")
                if (key, b) not in best or j["ms"] < best[(key, b)]["ms"]:
                    best[(key, b)] = j
    where = lambda s: "spheres, 1920x1080" if s[0] is None else f"{s[0].split('/')[-1][:-5]}, {s[1]}"
    if a.against:
        print("| technique | scene | this build, ms | the other, ms | this / other |")
        print("| --- | --- | --- | --- | --- |")
        for (t, sets, scene) in RUNS:
            if ((t, tuple(sets)), a.bin) not in best:
                continue
            new, old = best[((t, tuple(sets)), a.bin)]["ms"], best[((t, tuple(sets)), a.against)]["ms"]
            print(f"| {label(t, sets)} | {where(scene)} | {new:.1f} | {old:.1f} | {new / old:.2f} |")
        return
    print("| technique | scene | ms | passes, ms |")
    print("| --- | --- | --- | --- |")
    for (t, sets, scene) in RUNS:
        if ((t, tuple(sets)), a.bin) not in best:
            continue
        j = best[((t, tuple(sets)), a.bin)]
        passes = ", ".join(f"{k[3:].replace('_', ' ')} {v:.1f}" for k, v in j.items() if k.startswith("ms_"))
        print(f"| {label(t, sets)} | {where(scene)} | {j['ms']:.1f} | {passes} |")


if __name__ == "__main__":
    main()
