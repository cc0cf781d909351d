#!/usr/bin/env python3
"""The irregular z-buffer's grid resolution against its list lengths and occluder fragments.

Runs `penumbra bench technique --technique izb --set size=N --json` on a few fixtures for
grid sides N = 128 ... 4096 and writes an SVG chart (two panels, log-log: max and mean list
length; occluder fragments and time) and a Markdown table of the numbers.

    python3 tools/izb_grid_chart.py [--bin target/release/penumbra] [--threads 2] \
        [--out docs/izb_grid.svg] [--table docs/izb_grid.md]

Only the standard library; penumbra must be built (`cargo build --release`).
"""
import argparse
import json
import math
import subprocess

SCENES = ["long_view", "grazing", "contact", "terrain"]
SIZES = [128, 256, 512, 1024, 2048, 4096]
COLORS = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd"]


def run(binary, scene, size, threads, reps):
    out = subprocess.run(
        [binary, "bench", "technique", "--technique", "izb", "--scene", f"fixtures/scenes/{scene}.toml",
         "--set", f"size={size}", "--threads", str(threads), "--reps", str(reps), "--json"],
        check=True, capture_output=True, text=True,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def panel(x0, y0, w, h, title, series, ylabel):
    """One log-log panel: series = [(name, colour, [(x, y)], dashed)]."""
    ys = [y for _, _, pts, _ in series for _, y in pts if y > 0]
    lo, hi = math.floor(math.log10(min(ys))), math.ceil(math.log10(max(ys)))
    hi = max(hi, lo + 1)
    lx0, lx1 = math.log2(SIZES[0]), math.log2(SIZES[-1])
    px = lambda x: x0 + (math.log2(x) - lx0) / (lx1 - lx0) * w
    py = lambda y: y0 + h - (math.log10(max(y, 10**lo)) - lo) / (hi - lo) * h
    s = [f'<text x="{x0 + w / 2}" y="{y0 - 10}" text-anchor="middle" font-size="13">{title}</text>',
         f'<rect x="{x0}" y="{y0}" width="{w}" height="{h}" fill="none" stroke="#888"/>']
    for e in range(lo, hi + 1):
        yy = py(10**e)
        s.append(f'<line x1="{x0}" y1="{yy}" x2="{x0 + w}" y2="{yy}" stroke="#ddd"/>')
        s.append(f'<text x="{x0 - 6}" y="{yy + 4}" text-anchor="end" font-size="10">1e{e}</text>')
    for n in SIZES:
        xx = px(n)
        s.append(f'<line x1="{xx}" y1="{y0}" x2="{xx}" y2="{y0 + h}" stroke="#eee"/>')
        s.append(f'<text x="{xx}" y="{y0 + h + 14}" text-anchor="middle" font-size="10">{n}</text>')
    s.append(f'<text x="{x0 + w / 2}" y="{y0 + h + 30}" text-anchor="middle" font-size="11">grid side (texels)</text>')
    s.append(f'<text x="{x0 - 40}" y="{y0 + h / 2}" text-anchor="middle" font-size="11" '
             f'transform="rotate(-90 {x0 - 40} {y0 + h / 2})">{ylabel}</text>')
    for name, colour, pts, dashed in series:
        d = " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y in pts)
        dash = ' stroke-dasharray="5,3"' if dashed else ""
        s.append(f'<polyline points="{d}" fill="none" stroke="{colour}" stroke-width="2"{dash}/>')
        for x, y in pts:
            s.append(f'<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="2.5" fill="{colour}"/>')
    return s


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default="target/release/penumbra")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--out", default="docs/izb_grid.svg")
    ap.add_argument("--table", default="docs/izb_grid.md")
    a = ap.parse_args()
    data = {s: [(n, run(a.bin, s, n, a.threads, a.reps)) for n in SIZES] for s in SCENES}
    left, right = [], []
    for (scene, rows), colour in zip(data.items(), COLORS):
        left.append((f"{scene} max", colour, [(n, r["max_list_length"]) for n, r in rows], False))
        left.append((f"{scene} mean", colour, [(n, r["mean_list_length"]) for n, r in rows], True))
        right.append((f"{scene} fragments", colour, [(n, r["occluder_fragments"]) for n, r in rows], False))
    W, H = 900, 400
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif">',
           f'<rect width="{W}" height="{H}" fill="white"/>']
    svg += panel(80, 40, 320, 280, "list length per texel (solid: max, dashed: mean)", left, "samples")
    svg += panel(530, 40, 320, 280, "occluder fragments (conservative)", right, "fragments")
    for i, (scene, colour) in enumerate(zip(SCENES, COLORS)):
        svg.append(f'<rect x="{80 + i * 150}" y="{H - 26}" width="12" height="12" fill="{colour}"/>')
        svg.append(f'<text x="{96 + i * 150}" y="{H - 16}" font-size="12">{scene}</text>')
    svg.append("</svg>")
    with open(a.out, "w") as f:
        f.write("\n".join(svg) + "\n")
    lines = ["| scene | grid | max list | mean list | occluder fragments | tests | ms |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for scene, rows in data.items():
        for n, r in rows:
            lines.append(f"| {scene} | {n}² | {r['max_list_length']:.0f} | {r['mean_list_length']:.1f} | "
                         f"{r['occluder_fragments']:.0f} | {r['triangle-sample_tests']:.0f} | {r['ms']:.1f} |")
    with open(a.table, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {a.out} and {a.table}")


if __name__ == "__main__":
    main()
