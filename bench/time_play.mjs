// Steps a second while a time series plays in the viewer, measured in headless Chromium against
// a real `tetrascope serve`, for bench/time_play.sh. The viewer opens DATASET, its Time panel's
// rate is set to "as fast as frames come" and Play is pressed: each step is sent once the frame
// of the step before is on the screen (with the step after it prefetched), so the steps a
// second shown are what the service sustains. Each run plays for SECONDS after a warm-up of
// two steps, then pauses and waits for the still; RUNS runs, the median reported. The
// interaction budget and frame time are the server's defaults (the interaction budget), the
// view 900x700 CSS pixels at device pixel ratio 1. Beside it, in the same run, the anchor: frames
// a second while the camera is dragged round (RUNS drags of SECONDS each). Prints one JSON line.
//   node bench/time_play.mjs DATA DATASET [RUNS] [SECONDS]
import { chromium } from '../tests/browser/node_modules/playwright-core/index.mjs';
import { startServer } from '../tests/browser/harness.mjs';

// Waits for a frame answering the last message sent (the still of a 1M-tet view can take long
// on a loaded machine; the next run starts from any frame of the step shown).
const answered = (page) =>
  page.waitForFunction(() => window.tetrascope.lastFrame?.header.message_id >= window.tetrascope.lastSentId, null, { timeout: 300000 });

const [data, dataset, runsText = '3', secondsText = '10'] = process.argv.slice(2);
const runs = Number(runsText);
const seconds = Number(secondsText);
const median = (v) => [...v].sort((a, b) => a - b)[Math.floor(v.length / 2)];

const { server, url } = await startServer(data, []);
const browser = await chromium.launch({ executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium', args: ['--no-sandbox'] });
try {
  const page = await browser.newPage({ viewport: { width: 900, height: 700 } });
  await page.goto(`${url}#dataset=${encodeURIComponent(dataset)}`);
  await answered(page);
  const info = await page.evaluate(() => ({ steps: window.tetrascope.dataset.time_steps.length, tets: window.tetrascope.dataset.tets }));
  await page.selectOption('#time-rate', '0');
  const rows = [];
  for (let r = 0; r < runs; ++r) {
    await page.locator('#time-play').click();
    await page.waitForFunction(() => window.tetrascope.time.stats.shown >= 2, null, { timeout: 120000 });
    const start = await page.evaluate(() => ({ shown: window.tetrascope.time.stats.shown, frames: window.tetrascope.frames }));
    const t0 = Date.now();
    await page.waitForTimeout(seconds * 1000);
    const end = await page.evaluate(() => ({ shown: window.tetrascope.time.stats.shown, frames: window.tetrascope.frames, tets: window.tetrascope.lastFrame.header.tets, width: window.tetrascope.lastFrame.header.width, height: window.tetrascope.lastFrame.header.height, render_ms: window.tetrascope.lastFrame.header.render_ms }));
    const elapsed = (Date.now() - t0) / 1000;
    await page.locator('#time-play').click();
    await answered(page);
    rows.push({ steps_per_second: (end.shown - start.shown) / elapsed, steps: end.shown - start.shown, seconds: elapsed, last_frame_tets: end.tets, last_frame_size: `${end.width}x${end.height}`, last_frame_render_ms: end.render_ms });
  }
  // the anchor, in the same run: frames a second while the camera is dragged round (the
  // interaction frames a moving view gets), step 0 shown
  const orbit = [];
  const box = await page.locator('#frame').boundingBox();
  for (let r = 0; r < runs; ++r) {
    const cx = box.x + box.width / 2, cy = box.y + box.height / 2;
    await page.mouse.move(cx, cy);
    await page.mouse.down();
    const f0 = await page.evaluate(() => window.tetrascope.frames);
    const t0 = Date.now();
    for (let k = 0; Date.now() - t0 < seconds * 1000; ++k) {
      await page.mouse.move(cx + 150 * Math.sin(k / 20), cy + 40 * Math.cos(k / 20));
      await page.waitForTimeout(16);
    }
    const elapsed = (Date.now() - t0) / 1000;
    const f1 = await page.evaluate(() => window.tetrascope.frames);
    await page.mouse.up();
    await answered(page);
    orbit.push({ frames_per_second: (f1 - f0) / elapsed, frames: f1 - f0, seconds: elapsed });
  }
  const errors = await page.evaluate(() => window.tetrascope.errors);
  console.log(JSON.stringify({ dataset, tets: info.tets, steps: info.steps, runs, seconds_per_run: seconds, median_steps_per_second: median(rows.map((r) => r.steps_per_second)), rows,
                               orbit_median_frames_per_second: median(orbit.map((r) => r.frames_per_second)), orbit, client_errors: errors.length }));
} finally {
  await browser.close();
  server.kill('SIGTERM');
}
