#!/usr/bin/env python3
"""Renders a sweep's report page and charts in headless Chromium and saves screenshots, to
check what users see in a real browser (the page must open offline: Chromium runs with its
network features off, so any remote resource would show up missing). Then clicks in the page
as a user would: a column header twice (the rows must sort ascending, then descending) and a
thumbnail (the enlarged view must open); exits non-zero if either fails.

Usage: python3 tools/report_screenshots.py [SWEEP_DIR] [OUT_DIR]
  SWEEP_DIR  a sweep's output folder (default out/sweep)
  OUT_DIR    where the PNGs go (default SWEEP_DIR/screenshots)

Needs Debian's chromium (apt-get install chromium); standard library otherwise.
"""
import html
import json
import pathlib
import re
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


HARNESS = """<!doctype html><html><body>
<iframe id="f" src="%s" width="1300" height="900"></iframe>
<script>
document.getElementById('f').onload = function () {
  var d = this.contentDocument, out = {};
  try {
    var table = d.querySelector('table'), th = table.tHead.rows[0].cells[2];
    var col = function () {
      return Array.prototype.map.call(table.tBodies[0].rows, function (r) { return parseFloat(r.cells[2].getAttribute('data-v')); });
    };
    th.click(); var a = col(); th.click(); var b = col();
    out.rows = a.length;
    out.ascending = a.every(function (x, i) { return i === 0 || a[i - 1] <= x; });
    out.descending = b.every(function (x, i) { return i === 0 || b[i - 1] >= x; });
    var img = d.querySelector('td img');
    if (img) { img.click(); out.enlarged = d.getElementById('box').style.display === 'flex'; }
  } catch (e) { out.error = String(e); }
  document.body.setAttribute('data-result', JSON.stringify(out));
};
</script></body></html>"""


def click_check(browser, report):
    """Sorts a table and enlarges an image in the page; returns what happened."""
    with tempfile.TemporaryDirectory() as tmp:
        harness = pathlib.Path(tmp) / "harness.html"
        harness.write_text(HARNESS % report.as_uri())
        profile = pathlib.Path(tmp) / "profile"
        cmd = [browser, *FLAGS, f"--user-data-dir={profile}", "--allow-file-access-from-files",
               "--virtual-time-budget=20000", "--dump-dom", harness.as_uri()]
        dom = subprocess.run(cmd, check=True, capture_output=True, text=True, timeout=180).stdout
    m = re.search(r"data-result=\"([^\"]*)\"", dom)
    if not m:
        return {"error": "the page did not load in the harness"}
    return json.loads(html.unescape(m.group(1)))


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
    # The first scene's section on its own (its table and images), from a page beside the
    # report so that the images' relative paths hold.
    page = (sweep / "report.html").read_text()
    head = page[: page.index("<body>") + len("<body>")]
    start = page.find('<h2 id="scene-')
    if start >= 0:
        end = page.find('<h2 id="scene-', start + 1)
        end = end if end >= 0 else page.index('<div id="box">')
        part = sweep / "_screenshot_scene.html"
        part.write_text(head + page[start:end] + "</body></html>")
        try:
            shoot(browser, part.as_uri(), out / "report_scene.png", "1300,1600")
        finally:
            part.unlink()
    result = click_check(browser, sweep / "report.html")
    print(f"clicks: {result}")
    if result.get("error") or not (result.get("ascending") and result.get("descending")) \
            or result.get("enlarged") is False:
        sys.exit("the report page did not sort or enlarge as it should")


if __name__ == "__main__":
    main()
