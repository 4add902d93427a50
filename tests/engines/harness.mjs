// The rendering harness of the engine tests: one headless Chromium (Debian's `chromium`, WebGL2 on
// SwiftShader) driven by puppeteer-core, and a localhost HTTP server for the engine pages
// (tests/engines/pages/), the engines' npm packages (tests/engines/node_modules/) and the files
// under to render (DATA_ROOT, the tests' temporary folder). Nothing leaves the machine.
//
// usage: node harness.mjs DATA_ROOT
//   stdin:  one JSON request a line, {"id": 1, "page": "three.html", "params": {...}}
//   stdout: one JSON answer a line, {"id": 1, "ok": true, "result": ..., "console": [...]}
//           (or "ok": false, "error": "..."); the first line is {"ready": true, "chromium": VERSION}.
// A page defines `window.shbakeRender(params)` (async, returns JSON) once its modules are loaded;
// the harness opens a fresh tab for each request, calls it and closes the tab. A request
// {"id", "screenshot": "/data/DIR/index.html", "selector": "canvas"} opens that page instead and
// returns its PNG (of the element `selector` alone, if given) and its layout (optional "width",
// "height" of the viewport; "measure": selectors whose boxes come back). Files are named
// to the page as "/data/<path relative to DATA_ROOT>". The page's console lines (warnings and
// errors included) come back with the answer so that a test can require there are none.
// Render-target conventions every page follows (tests/engine_browser.py reads them): float32
// RGBA, rows top first, a perspective camera with a vertical field of view `fov_deg`, square
// images of `size` pixels, looking from `eye` at `target` with `up`, in shbake's world frame.
import fs from "node:fs";
import http from "node:http";
import os from "node:os";
import path from "node:path";
import readline from "node:readline";
import { fileURLToPath } from "node:url";
import puppeteer from "puppeteer-core";

const HERE = path.dirname(fileURLToPath(import.meta.url));
const DATA_ROOT = path.resolve(process.argv[2] || os.tmpdir());
const CHROMIUM = process.env.SHBAKE_CHROMIUM || "/usr/bin/chromium";
// Flags: headless, no sandbox (root in CI), no network chatter (the network is closed), a fresh
// profile, WebGL2 through ANGLE on SwiftShader (the CPU Vulkan device; no GPU needed).
export const CHROMIUM_FLAGS = [
  "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync",
  "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
];
const TYPES = {
  ".html": "text/html", ".js": "text/javascript", ".mjs": "text/javascript", ".json": "application/json",
  ".wasm": "application/wasm", ".png": "image/png",
};

function resolveUnder(root, rel) {
  const p = path.resolve(root, "." + path.sep + decodeURIComponent(rel));
  return p === root || p.startsWith(root + path.sep) ? p : null;
}

function serve(req, res) {
  const url = new URL(req.url, "http://localhost");
  let file = null;
  if (url.pathname.startsWith("/data/")) file = resolveUnder(DATA_ROOT, url.pathname.slice(6));
  else if (url.pathname.startsWith("/engines/")) file = resolveUnder(HERE, url.pathname.slice(9));
  if (!file || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
    res.writeHead(404).end();
    return;
  }
  const type = TYPES[path.extname(file)] || "application/octet-stream";
  res.writeHead(200, { "Content-Type": type, "Cache-Control": "no-store" });
  fs.createReadStream(file).pipe(res);
}

const server = http.createServer(serve);
await new Promise((r) => server.listen(0, "127.0.0.1", r));
const origin = `http://127.0.0.1:${server.address().port}`;
const profile = fs.mkdtempSync(path.join(os.tmpdir(), "shbake-chromium-"));
const browser = await puppeteer.launch({
  executablePath: CHROMIUM,
  headless: true,
  userDataDir: profile,
  args: CHROMIUM_FLAGS,
  protocolTimeout: 600000,
});

async function handle(request) {
  const page = await browser.newPage();
  const lines = [];
  page.on("console", (m) => lines.push(`${m.type()}: ${m.text()}`));
  page.on("pageerror", (e) => lines.push(`pageerror: ${e.message}`));
  page.on("response", (r) => { if (r.status() >= 400) lines.push(`http ${r.status()}: ${new URL(r.url()).pathname}`); });
  try {
    if (request.screenshot) return { id: request.id, ok: true, result: await screenshot(page, { ...request, lines }), console: lines };
    await page.goto(`${origin}/engines/pages/${request.page}`, { waitUntil: "load" });
    await page.waitForFunction("typeof window.shbakeRender === 'function'", { timeout: 120000 });
    const result = await page.evaluate((p) => window.shbakeRender(p), request.params || {});
    return { id: request.id, ok: true, result, console: lines };
  } catch (e) {
    return { id: request.id, ok: false, error: String(e && e.stack ? e.stack : e), console: lines };
  } finally {
    await page.close();
  }
}

// A page of the data root (an export's own viewer): opened, given until its body's data-state
// leaves "loading", then captured as PNG (base64) with that state.
async function screenshot(page, request) {
  await page.setViewport({ width: request.width || 640, height: request.height || 720 });
  await page.goto(`${origin}${request.screenshot}`, { waitUntil: "load" });
  await page.waitForFunction("document.body && document.body.dataset.state !== 'loading'", { timeout: 120000 });
  await new Promise((r) => setTimeout(r, 200));  // a composited frame after the first draw
  const state = await page.evaluate(() => document.body.dataset.state);
  const before = request.lines.slice();  // the page's own lines: capturing reads pixels back
  const target = request.selector ? await page.$(request.selector) : page;  // an element alone
  const layout = await page.evaluate(measureLayout, request.measure || []);
  return { state, console: before, layout, png: await target.screenshot({ encoding: "base64" }) };
}

// The page's layout at its viewport: the document's scroll and client widths, the viewport's
// height, the box of each selector's first element, and the elements reaching past the right
// edge (tag.class, the first ten).
function measureLayout(selectors) {
  const doc = document.documentElement;
  const box = (e) => { const r = e.getBoundingClientRect(); return { top: r.top, bottom: r.bottom, left: r.left, right: r.right }; };
  const rects = {};
  for (const s of selectors) { const e = document.querySelector(s); rects[s] = e ? box(e) : null; }
  const past = [...document.body.querySelectorAll("*")].filter((e) => e.getBoundingClientRect().right > doc.clientWidth + 0.5);
  return { scrollWidth: doc.scrollWidth, clientWidth: doc.clientWidth, innerHeight: window.innerHeight, rects,
           overflowing: past.slice(0, 10).map((e) => `${e.tagName.toLowerCase()}.${e.className}`) };
}

async function shutdown() {
  await browser.close().catch(() => {});
  server.close();
  fs.rmSync(profile, { recursive: true, force: true });
}

process.stdout.write(JSON.stringify({ ready: true, chromium: await browser.version() }) + "\n");
const input = readline.createInterface({ input: process.stdin });
for await (const line of input) {
  if (!line.trim()) continue;
  const answer = await handle(JSON.parse(line));
  process.stdout.write(JSON.stringify(answer) + "\n");
}
await shutdown();
