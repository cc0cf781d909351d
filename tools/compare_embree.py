#!/usr/bin/env python3
"""penumbra's reference tracer against Intel Embree on this machine, on the same rays.

`penumbra bench rays --export` writes the spheres scene's triangles and the rays (the camera's
shadow rays, or with --random incoherent ones); tools/embree_rays.c traces them with Embree,
one rtcOccluded1 call per ray and no packets, on the same number of threads. The two run
alternately (`--rounds` times each, so both see the same machine load); the script prints the
median rates, build times and their ratios, and checks that both found the same number of
occluded rays.

    python3 tools/compare_embree.py [--threads 1,2] [--rounds 3] [--bin target/release/penumbra]

Needs gcc and Embree's headers and library: installs Debian's libembree-dev with apt-get when
<embree3/rtcore.h> is missing (Embree 3.13 on Debian 12).
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def ensure_embree():
    if not os.path.exists("/usr/include/embree3/rtcore.h"):
        subprocess.run(["apt-get", "install", "-y", "libembree-dev"], check=True)


def run_json(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def embree(exe, d, threads, reps):
    out = subprocess.run([exe, d, str(threads), str(reps)], check=True, capture_output=True, text=True).stdout
    return {k: float(v) for k, v in (line.split() for line in out.strip().splitlines())}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--rays", type=int, default=4_000_000)
    ap.add_argument("--bin", default=os.path.join(HERE, "..", "target", "release", "penumbra"))
    a = ap.parse_args()
    ensure_embree()
    with tempfile.TemporaryDirectory() as tmp:
        exe = os.path.join(tmp, "embree_rays")
        subprocess.run(["gcc", "-O3", "-o", exe, os.path.join(HERE, "embree_rays.c"), "-lembree3", "-lpthread"],
                       check=True)
        print("| rays | threads | penumbra Mrays/s | Embree Mrays/s | ratio | penumbra build ms | Embree build ms |")
        print("| --- | --- | --- | --- | --- | --- | --- |")
        for kind, extra in (("shadow", []), ("random", ["--random"])):
            d = os.path.join(tmp, kind)
            for t in (int(x) for x in a.threads.split(",")):
                ours, theirs = [], []
                for r in range(a.rounds):
                    args = [a.bin, "bench", "rays", "--threads", str(t), "--reps", str(a.reps), "--rays", str(a.rays),
                            "--json", *extra]
                    if r == 0:
                        args += ["--export", d]
                    ours.append(run_json(args))
                    theirs.append(embree(exe, d, t, a.reps))
                with open(os.path.join(d, "rays.txt")) as f:
                    info = dict(line.split() for line in f)
                if int(theirs[0]["occluded"]) != int(info["occluded"]):
                    print(f"warning: {kind}: Embree found {int(theirs[0]['occluded'])} occluded rays, "
                          f"penumbra {info['occluded']}", file=sys.stderr)
                om = statistics.median(x["mrays_per_s"] for x in ours)
                em = statistics.median(x["mrays_per_s"] for x in theirs)
                ob = statistics.median(x["ms_build"] for x in ours)
                eb = statistics.median(x["build_ms"] for x in theirs)
                print(f"| {kind} | {t} | {om:.2f} | {em:.2f} | {om / em:.2f} | {ob:.1f} | {eb:.1f} |")


if __name__ == "__main__":
    main()
