#!/usr/bin/env python3
"""Renders a sweep's report page and charts in headless Chromium and saves screenshots, to
check what users see in a real browser (the page must open offline: Chromium runs with its
network features off, so any remote resource would show up missing).

Usage: python3 tools/report_screenshots.py [SWEEP_DIR] [OUT_DIR]
  SWEEP_DIR  a sweep's output folder (default out/sweep)
  OUT_DIR    where the PNGs go (default SWEEP_DIR/screenshots)

Needs Debian's chromium (apt-get install chromium); standard library otherwise.
"""
import pathlib
import shutil
import subprocess
import sys
import tempfile

FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--hide-scrollbars",
]


def shoot(browser, url, png, size):
    with tempfile.TemporaryDirectory() as profile:
        cmd = [browser, *FLAGS, f"--user-data-dir={profile}", f"--window-size={size}",
               f"--screenshot={png}", url]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=120)
    print(f"wrote {png}")


def main():
    sweep = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "out/sweep").resolve()
    out = pathlib.Path(sys.argv[2]).resolve() if len(sys.argv) > 2 else sweep / "screenshots"
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        sys.exit("chromium not found: apt-get install chromium")
    if not (sweep / "report.html").exists():
        sys.exit(f"{sweep}/report.html not found: run `penumbra sweep` first")
    out.mkdir(parents=True, exist_ok=True)
    shoot(browser, (sweep / "report.html").as_uri(), out / "report_top.png", "1300,2400")
    for chart in sorted(sweep.glob("chart_*.svg")):
        shoot(browser, chart.as_uri(), out / (chart.stem + ".png"), "880,540")


if __name__ == "__main__":
    main()
