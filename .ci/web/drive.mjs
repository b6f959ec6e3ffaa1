// Drives the web example in headless Chromium: waits for the app's first
// report, takes a screenshot, drags the cloth with the page's own pointer
// events, switches to a 128×128 cloth with the `N` key and records its step
// times, and fails on any panic or page error. Every wait is bounded.
//
//   node drive.mjs URL OUT_DIR
//
// Writes OUT_DIR/web.png (before the drag), OUT_DIR/web-dragged.png,
// OUT_DIR/web-128.png, OUT_DIR/console.log and OUT_DIR/timings.txt.
import { writeFileSync } from "node:fs";
import { chromium } from "playwright-core";

const [url, out] = process.argv.slice(2);
if (!url || !out) {
  console.error("usage: node drive.mjs URL OUT_DIR");
  process.exit(2);
}
const chromiumPath = process.env.CHROMIUM || "/usr/bin/chromium";
const lines = [];
const errors = [];

function fail(message) {
  console.error(`web check: ${message}`);
  writeFileSync(`${out}/console.log`, lines.join("\n") + "\n");
  process.exit(1);
}

// Waits until a console line from line `from` on matches `pattern`, for
// at most `seconds`.
async function waitFor(pattern, seconds, what, from = lines.length) {
  const until = Date.now() + seconds * 1000;
  for (;;) {
    const hit = lines.slice(from).find((l) => pattern.test(l));
    if (hit) return hit;
    if (errors.length) fail(`the page failed: ${errors.join(" | ")}`);
    if (Date.now() > until) fail(`no ${what} within ${seconds} s`);
    await new Promise((r) => setTimeout(r, 200));
  }
}

const browser = await chromium.launch({
  executablePath: chromiumPath,
  headless: true,
  timeout: 60_000,
  args: [
    "--no-sandbox",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-quic",
    // WebGL2 without a GPU: ANGLE on SwiftShader, Chromium's CPU renderer.
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--ignore-gpu-blocklist",
  ],
});
// Leave at once, whatever happens after this line, within the time limit.
const watchdog = setTimeout(() => fail("the check ran past its 300 s limit"), 300_000);
try {
  const page = await browser.newPage({ viewport: { width: 800, height: 600 } });
  page.on("console", (m) => {
    const text = m.text();
    lines.push(text);
    if (/panicked|RuntimeError|unreachable executed/.test(text)) errors.push(text);
  });
  page.on("pageerror", (e) => errors.push(String(e)));
  await page.goto(url, { timeout: 60_000 });
  const webgl2 = await page.evaluate(
    () => !!document.createElement("canvas").getContext("webgl2"),
  );
  if (!webgl2) fail("this Chromium has no WebGL2 (is SwiftShader missing?)");

  // The first report comes after 2 s of simulation.
  console.log(await waitFor(/web: \d+ particles, step/, 120, "report from the app"));
  await page.waitForTimeout(1500);
  await page.screenshot({ path: `${out}/web.png` });

  // Drag the hanging cloth sideways through the canvas's pointer events.
  const [x0, y0, x1, y1] = [420, 240, 560, 300];
  await page.mouse.move(x0, y0);
  await page.mouse.down();
  for (let k = 1; k <= 20; k++) {
    await page.mouse.move(x0 + ((x1 - x0) * k) / 20, y0 + ((y1 - y0) * k) / 20);
    await page.waitForTimeout(50);
  }
  const held = lines.some((l) => /pointer holds particle/.test(l));
  await page.screenshot({ path: `${out}/web-dragged.png` });
  await page.mouse.up();
  if (!held) fail("the drag did not pick the cloth");
  console.log("the drag picked the cloth");

  // 16² → 32² → 64² → 128²: N held down across a frame or more (a frame
  // takes about half a second under SwiftShader), each size seen in the log.
  await page.click("canvas");
  for (const n of [32, 64, 128]) {
    const mark = lines.length;
    await page.keyboard.down("KeyN");
    await page.waitForTimeout(1200);
    await page.keyboard.up("KeyN");
    await waitFor(new RegExp(`web: ${n}x${n} cloth`), 60, `${n}×${n} cloth`, mark);
  }
  const reports = [];
  for (let k = 0; k < 2; k++) {
    reports.push(await waitFor(/web: 16384 particles, step/, 120, "128×128 report"));
  }
  await page.screenshot({ path: `${out}/web-128.png` });
  const timings = lines.filter((l) => /web: \d+ particles, step/.test(l));
  writeFileSync(`${out}/timings.txt`, timings.join("\n") + "\n");
  console.log(reports.join("\n"));
  if (errors.length) fail(`the page failed: ${errors.join(" | ")}`);
} catch (e) {
  fail(String(e));
} finally {
  clearTimeout(watchdog);
  writeFileSync(`${out}/console.log`, lines.join("\n") + "\n");
  await browser.close();
}
