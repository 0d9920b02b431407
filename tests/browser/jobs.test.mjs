// Failed jobs in the viewer, in headless Chromium: a job that fails on a truncated mesh shows
// its error once on the page (the upload status points to the jobs panel; the log tail does
// not repeat it), Dismiss removes it from the panel, and it stays dismissed after a reload; the
// uploads panel lists that upload as failed and deletes it, a text file uploaded as a mesh
// fails the same way, and a dataset deleted in the viewer takes its upload with it.
//   node --test tests/browser/jobs.test.mjs   (TETRA_BINARY: the tetrascope executable)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { existsSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { sample, startViewer, settled as settledOn } from './harness.mjs';

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

const listedUploads = () => page.evaluate(() => fetch('/api/v1/uploads').then((r) => r.json()).then((b) => b.uploads.map((u) => u.name)));

test('the uploads panel marks a failed upload and deletes it', async () => {
  const item = page.locator('#uploads li[data-upload="truncated.vtk"]');
  await item.waitFor({ timeout: 30000 });
  assert.equal(await item.getAttribute('data-state'), 'failed');
  assert.match(await item.textContent(), /truncated\.vtk \(\d+ B, .+\).*preprocessing failed/);
  const { jobs } = await page.evaluate(() => fetch('/api/v1/jobs').then((r) => r.json()));
  const error = jobs.find((j) => j.name === 'truncated-mesh').error;
  assert.equal(await item.locator('.upload-use').getAttribute('title'), error, "the job's error is the tooltip, not shown twice");
  assert.ok(existsSync(join(viewer.data, 'uploads', 'truncated.vtk')));
  page.once('dialog', (dialog) => dialog.accept());
  await item.locator('button.upload-delete').click();
  await page.waitForFunction(() => !document.querySelector('#uploads li[data-upload="truncated.vtk"]'), null, { timeout: 10000 });
  assert.match(await page.textContent('#uploads-status'), /Deleted uploads\/truncated\.vtk/);
  assert.equal(existsSync(join(viewer.data, 'uploads', 'truncated.vtk')), false, 'gone from the server');
  assert.ok(!(await listedUploads()).includes('truncated.vtk'));
});

test('a text file that is no mesh: its job fails, its upload is listed as failed and deleted', async () => {
  const notes = join(viewer.data, 'notes.txt');
  writeFileSync(notes, 'pressure readings, not a mesh\n');
  await page.setInputFiles('#upload-file', notes);
  await page.fill('#job-name', 'notes-text');
  await page.click('#upload-submit');
  await page.waitForFunction(() => /notes-text: failed/.test(document.getElementById('job-status').textContent), null, { timeout: 60000 });
  const { jobs } = await page.evaluate(() => fetch('/api/v1/jobs').then((r) => r.json()));
  const error = jobs.find((j) => j.name === 'notes-text').error;
  assert.match(error, /unknown mesh format '\.txt'/);
  await page.locator('#jobs li[data-state="failed"]', { hasText: 'notes-text' }).waitFor({ timeout: 30000 });
  assert.equal(await shown(error.split(': ').at(-1)), 1, 'the reason is on the page once');
  const item = page.locator('#uploads li[data-upload="notes.txt"]');
  await item.waitFor({ timeout: 30000 });
  assert.equal(await item.getAttribute('data-state'), 'failed');
  page.once('dialog', (dialog) => dialog.accept());
  await item.locator('button.upload-delete').click();
  await page.waitForFunction(() => !document.querySelector('#uploads li[data-upload="notes.txt"]'), null, { timeout: 10000 });
  assert.equal(existsSync(join(viewer.data, 'uploads', 'notes.txt')), false, 'gone from the server');
});

test('a dataset deleted in the viewer takes its upload with it', async () => {
  await page.setInputFiles('#upload-file', sample);
  await page.fill('#job-name', 'sample-copy');
  await page.click('#upload-submit');
  await page.waitForFunction(() => /sample-copy: done/.test(document.getElementById('job-status').textContent), null, { timeout: 120000 });
  const item = page.locator('#uploads li[data-upload="disk_out_ref.vtk"]');
  await page.waitForFunction(() => document.querySelector('#uploads li[data-upload="disk_out_ref.vtk"]')?.dataset.state === 'used', null, { timeout: 30000 });
  assert.match(await item.textContent(), /made sample-copy/);
  await page.waitForFunction(() => document.getElementById('dataset').value === 'sample-copy', null, { timeout: 30000 });
  page.once('dialog', (dialog) => dialog.accept());
  await page.click('#dataset-delete');
  await page.waitForFunction(() => !document.querySelector('#uploads li[data-upload="disk_out_ref.vtk"]'), null, { timeout: 30000 });
  assert.match(await page.textContent('#uploads-status'), /Deleted uploads\/disk_out_ref\.vtk with sample-copy/);
  assert.equal(existsSync(join(viewer.data, 'uploads', 'disk_out_ref.vtk')), false);
  assert.ok(existsSync(join(viewer.data, 'disk', 'manifest.json')), 'the other dataset stays');
});
