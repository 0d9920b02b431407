// Uploads and preprocessing jobs over the REST API (protocol/openapi.yaml): the name is
// checked against the datasets and the running jobs before any byte is uploaded; the job
// this tab started is followed (and survives a reload: its id is kept in sessionStorage);
// the jobs panel lists GET /api/v1/jobs, with cancel (DELETE /api/v1/jobs/ID), the error of
// failed jobs (once: the log tail shows only the lines the error does not already hold) and
// Dismiss for ended jobs that did not make a dataset (the ids dismissed are kept in this
// browser's localStorage; the server keeps its list); the dataset list is refreshed when a job
// ends. The uploads panel lists GET /api/v1/uploads (size, time, the datasets made from each,
// the job reading it, which job failed on it) with Delete (DELETE /api/v1/uploads/NAME; the
// server refuses while a job reads it, and the answer is shown).
const $ = (id) => document.getElementById(id);
const kFollowKey = 'tetrascope.job';
const kPollMs = 500;
const kIdlePollMs = 10000;  // jobs started elsewhere show up within this
const kNamePattern = /^[A-Za-z0-9_][A-Za-z0-9._-]{0,127}$/;  // the server's valid_name
const kDismissedKey = 'tetrascope.dismissedJobs';
const kMaxDismissed = 200;  // ids kept; job ids hold their creation time, so old ones do not return

function loadDismissed() {
  try {
    const ids = JSON.parse(localStorage.getItem(kDismissedKey) ?? '[]');
    return Array.isArray(ids) ? ids.filter((id) => typeof id === 'string').slice(-kMaxDismissed) : [];
  } catch {
    return [];  // no storage, or not ours: nothing dismissed
  }
}

const sizeText = (bytes) => (bytes < 1024 ? `${bytes} B` : bytes < 1048576 ? `${Math.round(bytes / 1024)} KB` : `${(bytes / 1048576).toFixed(1)} MB`);

export class Jobs {
  // onDatasetsChanged(): reload the dataset list; onDone(name): a followed job made `name`
  constructor(authHeaders, { onDatasetsChanged, onDone }) {
    this.headers = authHeaders;
    this.onDatasetsChanged = onDatasetsChanged;
    this.onDone = onDone;
    this.known = new Map();  // id -> state, to see jobs end
    this.timer = null;
    this.following = null;
    this.dismissed = loadDismissed();
    this.last = [];  // the last list fetched
  }

  // Hides an ended job from the panel for good (in this browser).
  dismiss(id) {
    this.dismissed = [...this.dismissed.filter((x) => x !== id), id].slice(-kMaxDismissed);
    try {
      localStorage.setItem(kDismissedKey, JSON.stringify(this.dismissed));
    } catch {
      // no storage: dismissed for this page only
    }
    if ($('job-status').dataset.job === id) {
      $('job-status').textContent = '';
      $('job-progress').value = 0;
    }
    this.render(this.last);
  }

  async start() {
    await this.refresh();
    setInterval(() => this.timer || this.refresh(), kIdlePollMs);
    const id = sessionStorage.getItem(kFollowKey);
    if (id) this.follow(id);
  }

  async api(path, options = {}) {
    const response = await fetch(path, { ...options, headers: { ...this.headers, ...(options.headers ?? {}) } });
    const body = await response.json().catch(() => ({}));
    return { ok: response.ok, status: response.status, body };
  }

  // ---------- upload ----------

  async uploadAndPreprocess() {
    const file = $('upload-file').files[0];
    const status = $('job-status');
    if (!file) {
      status.textContent = 'Choose a mesh file first (.vtk, .vtu, .msh, .node/.ele, .off, Exodus II .exo/.e, CGNS .cgns).';
      return;
    }
    const name = $('job-name').value.trim() || file.name.replace(/\.[^.]*$/, '').replace(/[^A-Za-z0-9._-]/g, '_').replace(/^[.-]+/, '');
    if (!kNamePattern.test(name)) {
      status.textContent = `'${name}' is not a usable name: letters, digits, '.', '_' and '-', up to 128, not starting with '.' or '-'.`;
      return;
    }
    // checked before uploading, so that a taken name leaves no orphaned upload behind
    const [datasets, jobs] = await Promise.all([this.api('/api/v1/datasets'), this.api('/api/v1/jobs')]);
    if (datasets.body.datasets?.some((d) => d.name === name)) {
      status.textContent = `A dataset named '${name}' exists: choose another name.`;
      return;
    }
    const busy = jobs.body.jobs?.find((j) => j.name === name && (j.state === 'queued' || j.state === 'running'));
    if (busy) {
      status.textContent = `Job ${busy.id} is already making '${name}'.`;
      return;
    }
    const safeFile = file.name.replace(/[^A-Za-z0-9._-]/g, '_').replace(/^[.-]+/, '') || 'mesh';
    $('job-progress').value = 0;
    status.textContent = `Uploading ${file.name} (${(file.size / 1048576).toFixed(1)} MB)...`;
    const upload = await this.api(`/api/v1/uploads?name=${encodeURIComponent(safeFile)}`, { method: 'POST', body: file });
    if (!upload.ok) {
      status.textContent = `Upload refused: ${upload.body.error?.message ?? upload.status}`;
      return;
    }
    const submit = await this.api('/api/v1/jobs', {
      method: 'POST',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify({ source: upload.body.path, name, options: {} }),
    });
    if (!submit.ok) {  // e.g. the name was taken meanwhile: the upload would be an orphan
      await this.api(`/api/v1/uploads/${encodeURIComponent(safeFile)}`, { method: 'DELETE' });
      status.textContent = `Job refused: ${submit.body.error?.message ?? submit.status}`;
      return;
    }
    this.follow(submit.body.id);
  }

  // ---------- the followed job ----------

  async follow(id) {
    sessionStorage.setItem(kFollowKey, id);
    this.following = id;
    const status = $('job-status');
    while (this.following === id) {
      const { ok, body: job } = await this.api(`/api/v1/jobs/${encodeURIComponent(id)}`);
      if (!ok) {  // the server restarted, or the job was pruned
        sessionStorage.removeItem(kFollowKey);
        return;
      }
      $('job-progress').value = job.percent;
      const eta = job.eta_s != null && job.state === 'running' ? `, ${Math.ceil(job.eta_s)} s left` : '';
      // a failed job's error is shown once, in the jobs panel below, where it can be dismissed
      status.dataset.job = id;
      status.textContent = `${job.name}: ${job.state}${job.stage ? ` (${job.stage})` : ''} ${job.percent.toFixed(0)}%${eta}${job.error ? ': the error is under Jobs' : ''}`;
      this.poll();
      if (job.state === 'done' || job.state === 'failed' || job.state === 'cancelled') {
        sessionStorage.removeItem(kFollowKey);
        this.following = null;
        if (job.state === 'done') {
          await this.onDatasetsChanged();
          this.onDone(job.dataset ?? job.name);
        }
        return;
      }
      await new Promise((resolve) => setTimeout(resolve, kPollMs));
    }
  }

  // ---------- the jobs panel ----------

  poll() {
    if (this.timer) return;
    this.timer = setTimeout(() => {
      this.timer = null;
      this.refresh();
    }, kPollMs * 2);
  }

  async refresh() {
    this.refreshUploads();
    const { ok, body } = await this.api('/api/v1/jobs').catch(() => ({ ok: false }));
    if (!ok) return;
    const jobs = body.jobs ?? [];
    let ended = false;
    for (const job of jobs) {
      const before = this.known.get(job.id);
      if (before && before !== job.state && (job.state === 'done' || job.state === 'failed' || job.state === 'cancelled')) ended = true;
      this.known.set(job.id, job.state);
    }
    this.render(jobs);
    if (ended) await this.onDatasetsChanged();
    if (jobs.some((j) => j.state === 'queued' || j.state === 'running')) this.poll();
  }

  render(all) {
    this.last = all;
    const list = $('jobs');
    const jobs = all.filter((job) => !this.dismissed.includes(job.id));
    if (!jobs.length) {
      list.replaceChildren(Object.assign(document.createElement('li'), { textContent: 'No jobs yet.' }));
      return;
    }
    list.replaceChildren(
      ...jobs.slice(0, 20).map((job) => {
        const item = document.createElement('li');
        item.dataset.job = job.id;
        item.dataset.state = job.state;
        item.className = `job job-${job.state}`;
        const eta = job.eta_s != null && job.state === 'running' ? `, ${Math.ceil(job.eta_s)} s left` : '';
        const line = document.createElement('div');
        line.textContent = `${job.name}: ${job.state}${job.stage && job.state === 'running' ? ` (${job.stage})` : ''} ${job.percent.toFixed(0)}%${eta}`;
        item.append(line);
        if (job.state === 'queued' || job.state === 'running') {
          const progress = Object.assign(document.createElement('progress'), { max: 100, value: job.percent });
          const cancel = Object.assign(document.createElement('button'), { textContent: 'Cancel', className: 'job-cancel' });
          cancel.addEventListener('click', async () => {
            cancel.disabled = true;
            await this.api(`/api/v1/jobs/${encodeURIComponent(job.id)}`, { method: 'DELETE' });
            this.refresh();
          });
          item.append(progress, cancel);
        }
        if (job.state === 'failed') {
          const details = document.createElement('details');
          const error = job.error ?? 'failed';
          details.append(Object.assign(document.createElement('summary'), { textContent: error }));
          const more = (job.log_tail ?? []).filter((line) => line.trim() && !error.includes(line.trim())).slice(-8);
          if (more.length) details.append(Object.assign(document.createElement('pre'), { textContent: more.join('\n') }));
          item.append(details);
        }
        if (job.state === 'failed' || job.state === 'cancelled') {
          const dismiss = Object.assign(document.createElement('button'), { textContent: 'Dismiss', className: 'job-dismiss', title: 'remove this job from the list (in this browser)' });
          dismiss.addEventListener('click', () => this.dismiss(job.id));
          line.append(' ', dismiss);
        }
        return item;
      }),
    );
  }

  // ---------- the uploads panel ----------

  async refreshUploads() {
    const { ok, body } = await this.api('/api/v1/uploads').catch(() => ({ ok: false }));
    if (ok) this.renderUploads(body.uploads ?? []);
  }

  async deleteUpload(upload) {
    if (!window.confirm(`Delete ${upload.path} from the server?`)) return;
    const { ok, status, body } = await this.api(`/api/v1/uploads/${encodeURIComponent(upload.name)}`, { method: 'DELETE' });
    $('uploads-status').textContent = ok ? `Deleted ${upload.path}.` : `Not deleted: ${body.error?.message ?? status}`;
    await this.refreshUploads();
  }

  renderUploads(uploads) {
    const list = $('uploads');
    if (!uploads.length) {
      list.replaceChildren(Object.assign(document.createElement('li'), { textContent: 'No uploads.' }));
      return;
    }
    list.replaceChildren(...uploads.map((upload) => this.uploadItem(upload)));
  }

  uploadItem(upload) {
    const item = document.createElement('li');
    item.dataset.upload = upload.name;
    item.dataset.state = upload.state;
    item.className = `upload upload-${upload.state}`;
    const when = new Date(upload.modified * 1000).toLocaleString();
    const use = {
      reading: `read by job ${upload.job}`,
      used: `made ${upload.datasets.join(', ')}`,
      failed: `preprocessing failed (job ${upload.failed_job})`,  // the error itself once, under Jobs (here as the tooltip)
      unused: 'no dataset made from it',
    }[upload.state] ?? upload.state;
    const line = document.createElement('div');
    line.textContent = `${upload.name} (${sizeText(upload.bytes)}, ${when})`;
    const remove = Object.assign(document.createElement('button'), { textContent: 'Delete', className: 'upload-delete' });
    if (upload.state === 'reading') {
      remove.disabled = true;
      remove.title = `job ${upload.job} reads it: cancel the job or wait until it ends`;
    } else {
      remove.title = upload.state === 'used' ? 'the datasets made from it stay; deleting a dataset deletes its upload too' : `delete ${upload.path}`;
    }
    remove.addEventListener('click', () => this.deleteUpload(upload));
    line.append(' ', remove);
    item.append(line, Object.assign(document.createElement('div'), { className: 'upload-use', textContent: use, title: upload.error ?? '' }));
    return item;
  }
}
