// Failed jobs in the viewer, in headless Chromium: a job that fails on a truncated mesh shows
// its error once on the page (the upload status points to the jobs panel; the log tail does
// not repeat it), Dismiss removes it from the panel, and it stays dismissed after a reload.
//   node --test tests/browser/jobs.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { startViewer, settled as settledOn } from './harness.mjs';

let viewer, page;

before(async () => {
  viewer = await startViewer({ prefix: 'tetrascope-jobs-', viewport: { width: 900, height: 700 } });
  page = viewer.page;
  await page.goto(viewer.url);
  await settledOn(page, 0);
});

after(async () => {
  await viewer?.stop();
});

// how many times `text` occurs in what the page shows (open <details> included)
const shown = (text) =>
  page.evaluate((t) => {
    for (const d of document.querySelectorAll('#jobs details')) d.open = true;
    return document.body.innerText.split(t).length - 1;
  }, text);

test('a failed job shows its error once and can be dismissed, for good', async () => {
  const broken = join(viewer.data, 'truncated.vtk');
  writeFileSync(broken, '# vtk DataFile Version 3.0\ntruncated\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 float\n0 0 0\n');
  await page.setInputFiles('#upload-file', broken);
  await page.fill('#job-name', 'truncated-mesh');
  await page.click('#upload-submit');
  await page.waitForFunction(() => /truncated-mesh: failed/.test(document.getElementById('job-status').textContent), null, { timeout: 60000 });
  const item = page.locator('#jobs li[data-state="failed"]', { hasText: 'truncated-mesh' });
  await item.waitFor({ timeout: 30000 });
  const { jobs } = await page.evaluate(() => fetch('/api/v1/jobs').then((r) => r.json()));
  const job = jobs.find((j) => j.name === 'truncated-mesh');
  assert.equal(job.state, 'failed');
  // the reader's message, as the error and the log tail both hold it
  const message = job.log_tail.at(-1).trim();
  assert.ok(job.error.includes(message), `the error holds the log's last line: ${job.error}`);
  assert.equal(await shown(message), 1, `"${message}" is on the page once`);
  assert.match(await page.textContent('#job-status'), /failed.*under Jobs/);

  await item.locator('button.job-dismiss').click();
  assert.equal(await item.count(), 0, 'Dismiss removes it from the panel');
  assert.equal(await shown(message), 0, 'and its error');
  assert.equal(await page.textContent('#job-status'), '', 'the upload status of that job goes too');
  await page.reload();
  await settledOn(page, 0);
  await page.waitForFunction(() => document.getElementById('jobs').children.length > 0, null, { timeout: 30000 });
  assert.equal(await item.count(), 0, 'still dismissed after a reload');
  const again = await page.evaluate(() => fetch('/api/v1/jobs').then((r) => r.json()));
  assert.ok(again.jobs.some((j) => j.id === job.id), "the server's list keeps it (the dismissal is the viewer's)");
});
