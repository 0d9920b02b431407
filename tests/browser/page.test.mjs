// The page around the view, in headless Chromium: on a server with no dataset the form to add
// one comes first and a mesh file dropped onto the view is uploaded, preprocessed and opened;
// the panel's sections fold under their headings and stay folded after a reload; on a 390x844
// phone the stats box starts hidden, the drawer covers at most 62% of the width, its controls
// fitting it, and a tap on the view closes it, the help lists the touch gestures, the probe's
// popup stays on the screen, and moving frames keep a usable size when the frame time shrinks
// them.
//   node --test tests/browser/page.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';
import { sample, startServer, startViewer, settled } from './harness.mjs';

let browser;

before(async () => {
  browser = await chromium.launch({ executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium', args: ['--no-sandbox'] });
});

after(async () => {
  await browser?.close();
});

test('an empty server shows the form to add a dataset first, and a file dropped on the view opens', async () => {
  const data = mkdtempSync(join(tmpdir(), 'tetrascope-page-'));
  const { server, url } = await startServer(data);
  const page = await browser.newPage({ viewport: { width: 1100, height: 700 } });
  try {
    await page.goto(url);
    await page.waitForFunction(() => document.getElementById('view-status').dataset.state === 'empty', null, { timeout: 30000 });
    const form = await page.locator('#add-dataset').boundingBox();
    assert.ok(form.y < 120, `the form to add a dataset starts ${form.y.toFixed(0)} px down the panel`);
    assert.ok(await page.isVisible('#upload-file'));
    assert.match(await page.textContent('#view-status'), /drop a mesh file here/);
    // a file dragged over the view, then dropped: the same upload as the form's
    const base64 = readFileSync(sample).toString('base64');
    await page.evaluate((encoded) => {
      const bytes = Uint8Array.from(atob(encoded), (c) => c.charCodeAt(0));
      const transfer = new DataTransfer();
      transfer.items.add(new File([bytes], 'dropped-disk.vtk', { type: 'application/octet-stream' }));
      const view = document.getElementById('view');
      view.dispatchEvent(new DragEvent('dragenter', { dataTransfer: transfer, bubbles: true, cancelable: true }));
      window.dropShown = !document.getElementById('drop-target').hidden;
      view.dispatchEvent(new DragEvent('drop', { dataTransfer: transfer, bubbles: true, cancelable: true }));
    }, base64);
    assert.equal(await page.evaluate(() => window.dropShown), true, 'the view says where to drop while a file is over it');
    assert.equal(await page.isHidden('#drop-target'), true);
    await page
      .waitForFunction(() => window.tetrascope.dataset?.name === 'dropped-disk', null, { timeout: 240000 })
      .catch(async (error) => assert.fail(`${error.message}; the upload says: ${await page.textContent('#job-status')}`));
    await settled(page, 0);
    assert.equal(await page.evaluate(() => document.body.classList.contains('empty-server')), false, 'the form goes back to its place');
    const after = await page.locator('#add-dataset').boundingBox();
    assert.ok(after.y > form.y + 200, 'below the view\'s controls again');
  } finally {
    await page.close();
    server.kill('SIGTERM');
    rmSync(data, { recursive: true, force: true });
  }
});

test('panel sections fold under their headings and stay folded after a reload', async () => {
  const viewer = await startViewer({ prefix: 'tetrascope-page-' });
  try {
    const { page, url } = viewer;
    await page.goto(url);
    await settled(page, 0);
    const heading = page.locator('#panel > section', { has: page.locator('h2', { hasText: 'Detail' }) }).locator('h2');
    assert.equal(await page.isVisible('#budget'), true);
    await heading.click();
    assert.equal(await page.isVisible('#budget'), false, 'a click on the heading folds the section');
    assert.equal(await heading.getAttribute('aria-expanded'), 'false');
    await page.reload();
    await settled(page, 0);
    assert.equal(await page.isVisible('#budget'), false, 'folded after a reload');
    await heading.focus();
    await page.keyboard.press('Enter');
    assert.equal(await page.isVisible('#budget'), true, 'Enter on the heading unfolds it');
  } finally {
    await viewer.stop();
  }
});

test('on a 390x844 phone: the drawer, the touch help, the probe on the screen, moving frames of a usable size', async () => {
  // 5 ms frames: even the coarsest cut is over the frame time, so moving frames shrink
  const viewer = await startViewer({ prefix: 'tetrascope-phone-', serveArgs: ['--frame-ms', '5'], viewport: { width: 390, height: 844 } });
  const phone = await viewer.browser.newPage({ viewport: { width: 390, height: 844 }, isMobile: true, hasTouch: true, deviceScaleFactor: 3 });
  try {
    await phone.goto(viewer.url);
    await settled(phone, 0);
    assert.equal(await phone.isHidden('#stats'), true, 'a phone starts without the stats box over the top of the view');
    assert.equal(await phone.isVisible('#stats-toggle'), true, 'and with its toggle');
    await phone.click('#panel-toggle');
    await phone.waitForFunction(() => document.getElementById('panel').getBoundingClientRect().left >= 0);
    await phone.waitForTimeout(300);  // the drawer's slide
    const drawer = await phone.locator('#panel').boundingBox();
    assert.ok(drawer.width <= 0.62 * 390 + 1, `the drawer is ${drawer.width} px of 390: ${(390 - drawer.width).toFixed(0)} px of the view in sight`);
    const overflow = await phone.evaluate(() => {
      const panel = document.getElementById('panel');
      return { scroll: panel.scrollWidth, client: panel.clientWidth };
    });
    assert.ok(overflow.scroll <= overflow.client, `the controls fit the drawer: ${overflow.scroll} px wide in ${overflow.client}`);
    await phone.touchscreen.tap(370, 600);  // the view beside the drawer
    await phone.waitForFunction(() => !document.body.classList.contains('panel-open'));
    assert.equal(await phone.evaluate(() => window.tetrascope.sent.filter((m) => m.type === 'probe').length), 0, 'the tap that closed the drawer asked nothing');

    await phone.click('#help-button');
    const help = await phone.textContent('#help');
    assert.match(help, /pinch/);
    assert.match(help, /two-finger drag/);
    assert.match(help, /double-tap/);
    const helpBox = await phone.locator('#help').boundingBox();
    assert.ok(helpBox.x >= 0 && helpBox.x + helpBox.width <= 390, 'the help fits the width');
    await phone.click('#help-button');

    // a tap near the right edge and the bottom: the popup of the values stays on the screen
    const frame = await phone.locator('#frame').boundingBox();
    await phone.touchscreen.tap(frame.x + frame.width - 6, frame.y + frame.height * 0.5);
    await phone.waitForFunction(() => !document.getElementById('probe').hidden, null, { timeout: 30000 });
    const popup = await phone.locator('#probe').boundingBox();
    assert.ok(popup.x >= 0 && popup.x + popup.width <= 390 + 0.5, `the popup spans x ${popup.x.toFixed(0)} to ${(popup.x + popup.width).toFixed(0)} of 390`);
    assert.ok(popup.y >= 0 && popup.y + popup.height <= 844 + 0.5, 'and fits the height');

    // a drag: its moving frames
    await phone.evaluate(() => {
      window.moving = [];
      window.tetrascope.onFrame = (h) => !h.still && !h.refining && window.moving.push([h.width, h.height]);
    });
    const cx = frame.x + frame.width / 2, cy = frame.y + frame.height / 2;
    await phone.evaluate(async ([x, y]) => {
      const canvas = document.getElementById('frame');
      const at = (dx) => ({ pointerId: 1, pointerType: 'mouse', isPrimary: true, button: 0, buttons: 1, clientX: x + dx, clientY: y, bubbles: true });
      canvas.dispatchEvent(new PointerEvent('pointerdown', at(0)));
      for (let i = 1; i <= 12; ++i) {
        canvas.dispatchEvent(new PointerEvent('pointermove', at(8 * i)));
        await new Promise((resolve) => setTimeout(resolve, 40));
      }
      canvas.dispatchEvent(new PointerEvent('pointerup', at(96)));
    }, [cx, cy]);
    await phone.waitForFunction(() => window.moving.length > 0, null, { timeout: 60000 });
    const moving = await phone.evaluate(() => window.moving);
    assert.ok(moving.length > 0, 'the drag drew moving frames');
    const smallest = Math.min(...moving.map(([w, h]) => Math.min(w, h)));
    assert.ok(smallest >= 200, `moving frames' shorter side at least 200 px: ${JSON.stringify(moving)}`);
  } finally {
    await phone.close();
    await viewer.stop();
  }
});
