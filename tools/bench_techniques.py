#!/usr/bin/env python3
"""Every technique's default on a scene of its family, timed with `penumbra bench technique`,
as the Markdown table of docs/performance.md ("Every technique's default").

    python3 tools/bench_techniques.py [--threads 2] [--reps 5] [--rounds 3]

Each technique runs `--rounds` times, the rounds interleaved (technique after technique, then
again), and the table gives the fastest median, its passes, and the image hash (the same
hash for every round, or the run fails). Build first: cargo build --release.
"""
import argparse
import json
import subprocess
import sys

# (technique, settings, scene file or None for the spheres scene, resolution, why this scene)
RUNS = [
    ("reference", [], None, None),
    ("shadow-map", [], None, None),
    ("pcss", [], None, None),
    ("chs", [], None, None),
    ("shadow-volume", [], None, None),
    ("planar", [], None, None),
    ("cookie", [], None, None),
    ("izb", [], None, None),
    ("hybrid", [], "fixtures/scenes/pergola.toml", "1920x1080"),
    ("multi-sample", [], "fixtures/scenes/pergola.toml", "1920x1080"),
    ("pvm", [], "fixtures/scenes/pergola.toml", "1920x1080"),
    ("pvmf", [], "fixtures/scenes/pergola.toml", "1920x1080"),
    ("transparency-map", [], "fixtures/scenes/smoke.toml", "1920x1080"),
    ("opacity-maps", [], "fixtures/scenes/smoke.toml", "1920x1080"),
    ("deep-shadow-map", [], "fixtures/scenes/smoke.toml", "1920x1080"),
    ("avsm", [], "fixtures/scenes/smoke.toml", "1920x1080"),
]


def run(bin_path, technique, sets, scene, resolution, threads, reps):
    cmd = [bin_path, "bench", "technique", "--technique", technique, "--threads", str(threads),
           "--reps", str(reps), "--json"]
    for s in sets:
        cmd += ["--set", s]
    if scene:
        cmd += ["--scene", scene]
    if resolution:
        cmd += ["--resolution", resolution]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/penumbra")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    best = {}
    for _ in range(a.rounds):
        for (t, sets, scene, res) in RUNS:
            j = run(a.bin, t, sets, scene, res, a.threads, a.reps)
            key = t
            if key in best and best[key]["hash"] != j.get("hash"):
                sys.exit(f"{t}: the image hash changed between rounds")
            if key not in best or j["ms"] < best[key]["ms"]:
                best[key] = j
    print("| technique (defaults) | scene | ms | passes, ms | image hash |")
    print("| --- | --- | --- | --- | --- |")
    for (t, sets, scene, res) in RUNS:
        j = best[t]
        where = "spheres, 1920x1080" if scene is None else f"{scene.split('/')[-1][:-5]}, {res}"
        passes = ", ".join(f"{k[3:].replace('_', ' ')} {v:.1f}" for k, v in j.items() if k.startswith("ms_"))
        print(f"| `{t}` | {where} | {j['ms']:.1f} | {passes} | {j.get('hash', '')} |")


if __name__ == "__main__":
    main()
