#!/usr/bin/env python3
"""penumbra's reference tracer against Intel Embree on this machine, on the same rays.

`penumbra bench rays --export` writes the spheres scene's triangles and the rays (the camera's
shadow rays, or with --random incoherent ones); penumbra traces them one at a time and, with
`--packets`, in packets of 8 consecutive rays. tools/embree_rays.c traces them with Embree 4,
on the same number of threads: single rays (one rtcOccluded1 call per ray), packets of 8
and 16 consecutive rays (rtcOccluded8/16; the shadow rays are in pixel order, so a packet is
neighbouring pixels of a row), and single rays in a scene built with RTC_SCENE_FLAG_ROBUST
(Embree's robust mode, the closest to the reference's robust traversal and watertight test). With --embree3, the same program built against Debian's Embree
3.13 (-DEMBREE3) traces the single rays as a further column. The runs alternate (`--rounds` times each, so
all see the same machine load); the script prints the median rates, build times and ratios,
and checks that every tracer found the same number of occluded rays.

    python3 tools/compare_embree.py [--threads 1,2] [--rounds 3] [--embree3] [--bin target/release/penumbra]

Embree 4 comes from PyPI: the `embreex` wheel ships its shared library (and TBB's) in
`embreex.libs/`, without C headers, so embree_rays.c declares the few entry points it calls.
The wheel is downloaded with pip into --cache (default target/embree4) and unpacked there.
Needs gcc; with --embree3, Debian's libembree-dev (installed with apt-get when missing).
"""
import argparse
import glob
import json
import os
import statistics
import subprocess
import sys
import tempfile
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def embree4_library(cache):
    """The path of libembree4 from the embreex wheel, downloaded and unpacked into `cache`."""
    libs = glob.glob(os.path.join(cache, "embreex.libs", "libembree4*.so*"))
    if not libs:
        os.makedirs(cache, exist_ok=True)
        subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:", "-q", "-d",
                        cache, "embreex"], check=True)
        wheels = sorted(glob.glob(os.path.join(cache, "embreex-*.whl")))
        if not wheels:
            sys.exit("pip found no embreex wheel for this platform")
        with zipfile.ZipFile(wheels[-1]) as z:
            for n in z.namelist():
                if n.startswith("embreex.libs/"):
                    z.extract(n, cache)
        libs = glob.glob(os.path.join(cache, "embreex.libs", "libembree4*.so*"))
    if not libs:
        sys.exit(f"no libembree4 in the embreex wheel under {cache}")
    return libs[0]


def ensure_embree3():
    if not os.path.exists("/usr/include/embree3/rtcore.h"):
        subprocess.run(["apt-get", "install", "-y", "libembree-dev"], check=True)


def run_json(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def embree(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return {k: float(v) for k, v in (line.split() for line in out.strip().splitlines())}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--rays", type=int, default=4_000_000)
    ap.add_argument("--embree3", action="store_true", help="also Debian's Embree 3.13 (single rays)")
    ap.add_argument("--cache", default=os.path.join(ROOT, "target", "embree4"))
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "penumbra"))
    a = ap.parse_args()
    lib = embree4_library(os.path.abspath(a.cache))
    with tempfile.TemporaryDirectory() as tmp:
        exe4 = os.path.join(tmp, "embree4_rays")
        subprocess.run(["gcc", "-O3", "-o", exe4, os.path.join(HERE, "embree_rays.c"), lib,
                        f"-Wl,-rpath,{os.path.dirname(lib)}", "-lpthread"], check=True)
        # The robust scene (RTC_SCENE_FLAG_ROBUST) is the Embree mode closest to the reference,
        # whose traversal is always robust and whose triangle test is watertight.
        tracers = [("Embree 4 rtcOccluded1", [exe4], ["1"]), ("Embree 4 rtcOccluded8", [exe4], ["8"]),
                   ("Embree 4 rtcOccluded16", [exe4], ["16"]), ("Embree 4 robust rtcOccluded1", [exe4], ["1", "robust"])]
        if a.embree3:
            ensure_embree3()
            exe3 = os.path.join(tmp, "embree_rays")
            subprocess.run(["gcc", "-O3", "-DEMBREE3", "-o", exe3, os.path.join(HERE, "embree_rays.c"), "-lembree3",
                            "-lpthread"], check=True)
            tracers.append(("Embree 3.13 rtcOccluded1", [exe3], []))
        names = [t[0] for t in tracers]
        print("| rays | threads | penumbra Mrays/s | penumbra packets of 8 | "
              + " | ".join(f"{n} Mrays/s" for n in names)
              + " | penumbra / rtcOccluded1 | penumbra / robust rtcOccluded1 | penumbra packets / rtcOccluded8"
              " | penumbra build ms | Embree 4 build ms | build ratio |")
        print("| --- " * (10 + len(names)) + "|")
        for kind, extra in (("shadow", []), ("random", ["--random"])):
            d = os.path.join(tmp, kind)
            for t in (int(x) for x in a.threads.split(",")):
                ours, packets, theirs = [], [], {n: [] for n in names}
                for r in range(a.rounds):
                    args = [a.bin, "bench", "rays", "--threads", str(t), "--reps", str(a.reps), "--rays", str(a.rays),
                            "--json", *extra]
                    if r == 0:
                        args += ["--export", d]
                    ours.append(run_json(args))
                    packets.append(run_json(args[:-2] + ["--packets"] if r == 0 else args + ["--packets"]))
                    for name, exe, tail in tracers:
                        theirs[name].append(embree([*exe, d, str(t), str(a.reps), *tail]))
                with open(os.path.join(d, "rays.txt")) as f:
                    info = dict(line.split() for line in f)
                for name in names:
                    if int(theirs[name][0]["occluded"]) != int(info["occluded"]):
                        print(f"warning: {kind}: {name} found {int(theirs[name][0]['occluded'])} occluded rays, "
                              f"penumbra {info['occluded']}", file=sys.stderr)
                om = statistics.median(x["mrays_per_s"] for x in ours)
                pm = statistics.median(x["mrays_per_s"] for x in packets)
                rates = [statistics.median(x["mrays_per_s"] for x in theirs[n]) for n in names]
                ob = statistics.median(x["ms_build"] for x in ours)
                eb = statistics.median(x["build_ms"] for x in theirs[names[0]])
                print(f"| {kind} | {t} | {om:.2f} | {pm:.2f} | " + " | ".join(f"{e:.2f}" for e in rates)
                      + f" | **{om / rates[0]:.2f}** | **{om / rates[3]:.2f}** | **{pm / rates[1]:.2f}** | {ob:.1f}"
                      f" | {eb:.1f} | {ob / eb:.2f} |")


if __name__ == "__main__":
    main()
