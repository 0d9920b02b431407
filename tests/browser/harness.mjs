// What the browser tests share: a store of the bundled sample in a scratch folder, a real
// `tetrascope serve` on it, headless Chromium on one page, and helpers that read the page.
import { spawn, execFileSync } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

export const root = join(dirname(fileURLToPath(import.meta.url)), '..', '..');
export const binary = process.env.TETRA_BINARY ?? join(root, 'build', 'release', 'apps', 'tetrascope');
export const sample = join(root, 'data', 'samples', 'disk_out_ref.vtk');

// Starts `tetrascope serve --data DATA` (one worker, `serveArgs` added) on a free port;
// resolves to { server, url } once it prints its address. TETRA_WEB: serve that copy of the
// web client (e.g. another commit's, to see a test fail without a change).
export async function startServer(data, serveArgs = []) {
  const web = process.env.TETRA_WEB ? ['--web', process.env.TETRA_WEB] : [];
  const server = spawn(binary, ['serve', '--data', data, '--port', '0', '--workers', '1', ...web, ...serveArgs], { stdio: ['ignore', 'pipe', 'inherit'] });
  const url = await new Promise((resolve, reject) => {
    let out = '';
    server.stdout.on('data', (chunk) => {
      out += chunk;
      const m = out.match(/open (http:\/\/\S+)/);
      if (m) resolve(m[1]);
    });
    server.on('exit', (code) => reject(new Error(`server exited with ${code}`)));
  });
  return { server, url };
}

const kSampleBuild = ['--segment-tets', '2000', '--base-tets', '3000'];

// Preprocesses `mesh` (the sample unless given) as `name` ("disk") with `build` options,
// starts the server (one worker, `serveArgs` added) and a page of `viewport`; with `open`, the
// page goes to the viewer and waits for its first image. Returns { data, url, browser, page, stop }.
export async function startViewer({ prefix, serveArgs = [], viewport = { width: 900, height: 700 }, mesh = sample, name = 'disk', build = kSampleBuild, open = false }) {
  const data = mkdtempSync(join(tmpdir(), prefix));
  execFileSync(binary, ['preprocess', mesh, '-o', join(data, name), ...build, '--progress', 'none']);
  const { server, url } = await startServer(data, serveArgs);
  const browser = await chromium.launch({ executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium', args: ['--no-sandbox'] });
  const page = await browser.newPage({ viewport });
  page.on('pageerror', (e) => console.error('page error:', e));
  const stop = async () => {
    await browser.close();
    server.kill('SIGTERM');
    rmSync(data, { recursive: true, force: true });
  };
  if (open) {
    await page.goto(url);
    await settled(page, 0);
  }
  return { data, url, browser, page, stop };
}

// A digest of the image on the page's canvas.
export const frameImage = (page) =>
  page.evaluate(async () => {
    const url = document.getElementById('frame').toDataURL('image/png');
    const digest = await crypto.subtle.digest('SHA-256', new TextEncoder().encode(url));
    return [...new Uint8Array(digest)].map((b) => b.toString(16).padStart(2, '0')).join('');
  });

// Waits until the last frame is a still answering the last message sent, then `pause` ms for
// the canvas to paint.
export async function settled(page, pause = 200) {
  await page.waitForFunction(
    () => {
      const s = window.tetrascope;
      return s.lastFrame?.header.still && s.lastFrame.header.message_id === s.lastSentId;
    },
    null,
    { timeout: 60000 },
  );
  if (pause > 0) await page.waitForTimeout(pause);
}

// The body of the last message of `type` the page sent (undefined when none), and the errors
// the page's client recorded.
export const lastSent = (page, type) => page.evaluate((t) => window.tetrascope.sent.filter((m) => m.type === t).at(-1)?.body, type);
export const clientErrors = (page) => page.evaluate(() => window.tetrascope.errors);
