// Screenshots of the viewer for the README (docs/images/) and for choosing defaults:
//   node tests/browser/shoot.mjs DATA_DIR OUT_DIR 'name|#fragment' ...
// starts `tetrascope serve --data DATA_DIR`, opens each fragment (a view link) at 1000x640,
// waits for the still that shows it, and writes OUT_DIR/name.png: the page (SHOT_VIEW=1: the
// view alone), or with SHOT_SAVED=1 the image *Save image* writes (the still with its legends).
import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { chromium } from 'playwright-core';
import { startServer } from './harness.mjs';

const [data, out, ...shots] = process.argv.slice(2);
const { server, url } = await startServer(data);
try {
  const browser = await chromium.launch({ executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium', args: ['--no-sandbox'] });
  const width = Number(process.env.SHOT_WIDTH ?? 1000), height = Number(process.env.SHOT_HEIGHT ?? 640);
  for (const shot of shots) {
    const [name, fragment] = shot.split('|');
    const page = await browser.newPage({ viewport: { width, height } });
    await page.addInitScript(() => localStorage.setItem('tetrascope.stats', 'hidden'));  // images without the stats box
    await page.goto(`${url}${fragment}`);
    await page.waitForFunction(() => {
      const s = window.tetrascope;
      return s.dataset && s.lastFrame?.header.still && s.lastFrame.header.message_id === s.lastSentId;
    }, null, { timeout: 120000 });
    await page.waitForTimeout(300);
    if (process.env.SHOT_SAVED) {
      const bytes = await page.evaluate(async () => [...new Uint8Array(await (await window.tetrascope.composeStill()).arrayBuffer())]);
      writeFileSync(join(out, `${name}.png`), Buffer.from(bytes));
    } else await page.screenshot({ path: join(out, `${name}.png`), clip: process.env.SHOT_VIEW ? await page.locator('#view').boundingBox() : undefined });
    console.log(name, page.url().replace(/^[^#]*/, ''));
    await page.close();
  }
  await browser.close();
} finally {
  server.kill('SIGTERM');
}
