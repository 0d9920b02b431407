// The web client in headless Chromium (Debian's chromium, driven by playwright-core):
// the page loads, a frame appears, a drag rotates the view (the image changes), the
// transfer-function editor changes the image, and an upload + preprocess job's progress bar
// reaches 100% and the new dataset opens.
//   node --test tests/browser/viewer.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawn, execFileSync } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const root = join(dirname(fileURLToPath(import.meta.url)), '..', '..');
const binary = process.env.TETRA_BINARY ?? join(root, 'build', 'release', 'apps', 'tetrascope');
const sample = join(root, 'data', 'samples', 'disk_out_ref.vtk');
const shots = process.env.TETRA_SCREENSHOTS;  // a folder: keep screenshots for inspection

let data, server, url, browser, page;

before(async () => {
  data = mkdtempSync(join(tmpdir(), 'tetrascope-browser-'));
  execFileSync(binary, ['preprocess', sample, '-o', join(data, 'disk'), '--segment-tets', '2000', '--base-tets', '3000', '--progress', 'none']);
  server = spawn(binary, ['serve', '--data', data, '--port', '0', '--workers', '1'], { stdio: ['ignore', 'pipe', 'inherit'] });
  url = await new Promise((resolve, reject) => {
    let out = '';
    server.stdout.on('data', (chunk) => {
      out += chunk;
      const m = out.match(/open (http:\/\/\S+)/);
      if (m) resolve(m[1]);
    });
    server.on('exit', (code) => reject(new Error(`server exited with ${code}`)));
  });
  browser = await chromium.launch({ executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium', args: ['--no-sandbox'] });
  page = await browser.newPage({ viewport: { width: 1000, height: 640 } });
  page.on('pageerror', (e) => console.error('page error:', e));
});

after(async () => {
  await browser?.close();
  server?.kill('SIGTERM');
  if (data) rmSync(data, { recursive: true, force: true });
});

// a digest of the canvas, so that a failed comparison prints two short strings
const frameImage = () =>
  page.evaluate(async () => {
    const url = document.getElementById('frame').toDataURL('image/png');
    const digest = await crypto.subtle.digest('SHA-256', new TextEncoder().encode(url));
    return [...new Uint8Array(digest)].map((b) => b.toString(16).padStart(2, '0')).join('');
  });

// until a still frame shows everything the page asked for
async function settled() {
  await page.waitForFunction(
    () => {
      const s = window.tetrascope;
      return s.lastFrame?.header.still && s.lastFrame.header.message_id === s.lastSentId;
    },
    null,
    { timeout: 60000 },
  );
  await page.waitForTimeout(200);  // the bitmap is drawn
}

async function shot(name) {
  if (shots) await page.screenshot({ path: join(shots, `${name}.png`) });
}

test('the page loads and a frame appears', async () => {
  await page.goto(url);
  await settled();
  const state = await page.evaluate(() => ({ frames: window.tetrascope.frames, dataset: window.tetrascope.dataset?.name, errors: window.tetrascope.errors }));
  assert.equal(state.dataset, 'disk');
  assert.ok(state.frames >= 1);
  assert.deepEqual(state.errors, []);
  assert.match(await page.textContent('#stats'), /tets/);
  await shot('loaded');
});

test('a drag rotates the view', async () => {
  const before = await frameImage();
  const box = await page.locator('#frame').boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  for (let i = 1; i <= 10; ++i) await page.mouse.move(box.x + box.width / 2 + i * 15, box.y + box.height / 2 + i * 10);
  await page.mouse.up();
  await settled();
  assert.notEqual(await frameImage(), before, 'the image did not change');
  assert.match(page.url(), /eye=/, 'the view is saved in the URL');
  await shot('rotated');
});

test('the transfer-function editor changes the image', async () => {
  const before = await frameImage();
  const box = await page.locator('#tf-editor').boundingBox();
  // drag the right end point (alpha 1) down to alpha ~0.1
  await page.mouse.move(box.x + box.width - 1, box.y + 1);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width - 1, box.y + box.height * 0.8, { steps: 5 });
  await page.mouse.up();
  await settled();
  assert.notEqual(await frameImage(), before, 'the image did not change');
  await shot('tf-edited');
});

test('upload and preprocess: the progress bar reaches 100% and the dataset opens', async () => {
  await page.setInputFiles('#upload-file', sample);
  await page.fill('#job-name', 'uploaded-disk');
  await page.click('#upload-submit');
  await page.waitForFunction(() => document.getElementById('job-progress').value === 100, null, { timeout: 120000 });
  assert.match(await page.textContent('#job-status'), /done/);
  await page.waitForFunction(() => window.tetrascope.dataset?.name === 'uploaded-disk', null, { timeout: 30000 });
  const options = await page.$$eval('#dataset option', (o) => o.map((x) => x.value));
  assert.ok(options.includes('uploaded-disk'));
  await shot('uploaded');
});

