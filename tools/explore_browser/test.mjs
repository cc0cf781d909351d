// The browser test of `penumbra explore`: starts the server on a scene with an area light,
// opens the page in headless Chromium (Debian's chromium, driven by playwright-core), clicks a
// pixel in a penumbra and checks that the steps panel shows the value the image has there;
// switches technique and checks again; opens the second technique side by side; stops the
// server with Ctrl-C (SIGINT) and checks that it exits cleanly. Writes screenshots.
//
// Usage: node tools/explore_browser/test.mjs PENUMBRA_BINARY [SCREENSHOT_DIR]
// (run from the repository's root; `npm ci --prefix tools/explore_browser` first).
import { chromium } from "playwright-core";
import { spawn } from "node:child_process";
import { mkdtempSync, mkdirSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

const binary = process.argv[2];
const shots = process.argv[3] || join(tmpdir(), "penumbra-explore-shots");
if (!binary) {
  console.error("usage: node tools/explore_browser/test.mjs PENUMBRA_BINARY [SCREENSHOT_DIR]");
  process.exit(2);
}
mkdirSync(shots, { recursive: true });
const browserPath = process.env.CHROMIUM || "/usr/bin/chromium";

function fail(message) {
  console.error(`explore browser test: FAILED: ${message}`);
  process.exitCode = 1;
  throw new Error(message);
}

// Starts the server and resolves with its URL (the line it prints).
function startServer() {
  const out = mkdtempSync(join(tmpdir(), "penumbra-explore-"));
  const child = spawn(binary, ["explore", "fixtures/scenes/contact.toml", "--technique", "pcss", "--port", "0", "--out", out], {
    stdio: ["ignore", "pipe", "inherit"],
  });
  let text = "";
  const url = new Promise((resolve, reject) => {
    child.stdout.on("data", (d) => {
      text += d;
      const m = text.match(/http:\/\/127\.0\.0\.1:\d+\//);
      if (m) resolve(m[0]);
    });
    child.on("exit", (code) => reject(new Error(`the server exited (${code}) before it printed its URL: ${text}`)));
    setTimeout(() => reject(new Error("no URL within 60 s")), 60000);
  });
  const exited = new Promise((resolve) => child.on("exit", (code, signal) => resolve({ code, signal, text: () => text })));
  return { child, url, exited };
}

async function idle(page) {
  await page.waitForFunction(() => document.body.dataset.busy === "" && window.slots[0].values, null, { timeout: 120000 });
}

// Clicks near the centre of pixel (x, y) of slot k's visibility image; returns the pixel the page
// picked (the page rounds the mouse position to CSS pixels: a pixel of a scaled picture can be
// off by one) once its steps are shown.
async function clickPixel(page, k, x, y, technique) {
  const img = page.locator(`#slot${k} img[data-name=visibility]`);
  // The picture's content box (inside the border), in page coordinates.
  const [left, top, w, h] = await img.evaluate((i) => {
    const b = i.getBoundingClientRect();
    return [b.left + i.clientLeft, b.top + i.clientTop, i.clientWidth / i.naturalWidth, i.clientHeight / i.naturalHeight];
  });
  await page.mouse.click(left + (x + 0.5) * w, top + (y + 0.5) * h);
  await page.waitForFunction(() => window.pixel, null, { timeout: 120000 });
  const [px, py] = await page.evaluate(() => window.pixel);
  if (Math.abs(px - x) > 1 || Math.abs(py - y) > 1) fail(`a click on (${x}, ${y}) picked (${px}, ${py})`);
  await page.waitForSelector(`#slot${k} .steps[data-pixel="${px},${py}"][data-technique="${technique}"] li[data-step=result]`, { state: "attached", timeout: 120000 });
  await idle(page);
  return [px, py];
}

// The steps panel's result against the image's value at the pixel.
async function checkResult(page, k, x, y, what) {
  const got = await page.evaluate(({ k, x, y }) => {
    const row = document.querySelector(`#slot${k} .steps li[data-step=result] tr[data-key=visibility]`);
    const v = window.slots[k].values;
    return { shown: row ? JSON.parse(row.dataset.value) : null, image: v.values[y * v.width + x], text: row ? row.textContent : "" };
  }, { k, x, y });
  if (got.shown === null || got.image === null || Math.abs(got.shown - got.image) > 1e-6) {
    fail(`${what}: the steps show ${JSON.stringify(got)} at (${x}, ${y})`);
  }
  console.log(`${what}: pixel (${x}, ${y}): steps ${got.shown}, image ${got.image}`);
  return got.shown;
}

const server = startServer();
let browser;
try {
  const url = await server.url;
  console.log(`server at ${url}`);
  browser = await chromium.launch({
    executablePath: browserPath,
    args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync"],
  });
  const page = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
  page.on("pageerror", (e) => console.error(`page error: ${e.message}`));
  page.on("console", (m) => { if (m.type() === "error") console.error(`page console: ${m.text()}`); });
  const offline = [];
  page.on("request", (r) => { if (!r.url().startsWith(url)) offline.push(r.url()); });
  await page.goto(url);
  await idle(page);

  // A penumbra pixel: the middle one (in scan order) of those strictly between 0.1 and 0.9
  // with their eight neighbours.
  const [cx, cy] = await page.evaluate(() => {
    const v = window.slots[0].values, soft = [];
    const inside = (i) => v.values[i] !== null && v.values[i] > 0.1 && v.values[i] < 0.9;
    v.values.forEach((a, i) => {
      const x = i % v.width, y = Math.floor(i / v.width);
      if (x < 1 || y < 1 || x + 1 >= v.width || y + 1 >= v.height) return;
      let all = true;
      for (let dy = -1; dy <= 1; dy++) for (let dx = -1; dx <= 1; dx++) all = all && inside(i + dy * v.width + dx);
      if (all) soft.push(i);
    });
    const i = soft[soft.length >> 1];
    return i === undefined ? [-1, -1] : [i % v.width, Math.floor(i / v.width)];
  });
  if (cx < 0) fail("no penumbra pixel in pcss's image of the contact scene");
  const [x, y] = await clickPixel(page, 0, cx, cy, "pcss");
  const a = await checkResult(page, 0, x, y, "pcss");
  if (!(a > 0.1 && a < 0.9)) fail(`the clicked pixel is not in a penumbra (${a})`);
  const marked = await page.locator("#slot0 figure.marked").count();
  if (marked < 1) fail("no light-space stage is marked with the pixel's texel");
  await page.screenshot({ path: join(shots, "explore.png") });
  await page.locator("#slot0 .stages").screenshot({ path: join(shots, "explore_stages.png") });

  // Another technique: the steps are asked again at the same pixel.
  await page.selectOption("#slot0 select[name=technique]", "vsm");
  await page.waitForSelector(`#slot0 .steps[data-technique="vsm"] li[data-step=result]`, { state: "attached", timeout: 120000 });
  await idle(page);
  await checkResult(page, 0, x, y, "vsm");

  // Side by side: the second slot runs its own technique; the same pixel in both.
  await page.check("#compare");
  await page.waitForSelector(`#slot1 .steps[data-pixel="${x},${y}"] li[data-step=result]`, { state: "attached", timeout: 120000 });
  await idle(page);
  await page.waitForFunction(() => window.slots[1].values, null, { timeout: 120000 });
  await checkResult(page, 1, x, y, "side by side");
  await page.screenshot({ path: join(shots, "explore_side_by_side.png") });
  if (offline.length) fail(`the page asked for resources elsewhere: ${offline.join(", ")}`);
  console.log(`screenshots in ${shots}`);
} catch (e) {
  process.exitCode = 1;
  console.error(`explore browser test: ${e.message}`);
} finally {
  if (browser) await browser.close();
  server.child.kill("SIGINT");
  const end = await server.exited;
  if (end.code !== 0 || !/stopped/.test(end.text())) {
    console.error(`explore browser test: the server did not stop cleanly on SIGINT (code ${end.code}, signal ${end.signal})`);
    process.exitCode = 1;
  }
}
if (process.exitCode) process.exit(process.exitCode);
console.log("explore browser test: passed");
