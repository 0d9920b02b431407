// Boundary regions in the viewer: the "Boundary regions" panel lists the regions of the
// dataset's boundary (dataset.info's regions: its tags, or the pieces its sharp edges split it
// into) with a checkbox each, and "Bodies only" hides every region on the domain's bounding
// box (a far field, a symmetry plane) in one click, showing the boundary. The hidden ids live
// in the view (view.hiddenRegions), travel in the URL (hide=) and go to the server as
// regions.set.

// protocol/js/codec.js's MAX_HIDDEN_REGIONS (not imported: view-state.js, which imports this
// module, also runs under node, where /protocol/ does not resolve)
const MAX_HIDDEN_REGIONS = 1024;

// ---------- the URL ----------

export function regionsToHash(view) {
  return view.hiddenRegions?.length ? [`hide=${view.hiddenRegions.join(',')}`] : [];
}

// Untrusted (a pasted link): ids that are not whole numbers below the limit are dropped.
export function regionsFromHash(h) {
  const ids = (h.get('hide') ?? '').split(',').filter((s) => /^\d{1,4}$/.test(s)).map(Number).filter((id) => id < MAX_HIDDEN_REGIONS);
  return { hiddenRegions: [...new Set(ids)].sort((a, b) => a - b).slice(0, MAX_HIDDEN_REGIONS) };
}

export const regionName = (region) => region.name || `region ${region.id}`;

// The box of the regions shown when the view draws the boundary alone with some regions
// hidden (what Fit and the presets frame then); else the dataset's box.
export function shownBounds(info, view) {
  const regions = info?.regions ?? [];
  const hidden = new Set(view.hiddenRegions ?? []);
  const boundaryAlone = view.surface && !view.dvr && !view.iso && !view.lines?.on && !view.lines?.points && !view.slices?.length;
  if (!boundaryAlone || !hidden.size) return info?.bounds;
  const shown = regions.filter((r) => !hidden.has(r.id));
  if (!shown.length) return info?.bounds;
  return {
    min: [0, 1, 2].map((k) => Math.min(...shown.map((r) => r.bounds.min[k]))),
    max: [0, 1, 2].map((k) => Math.max(...shown.map((r) => r.bounds.max[k]))),
  };
}

// ---------- the panel ----------

export class RegionsPanel {
  // host: { send(type, body), view(), showBoundary() (turns the boundary on), saved() }
  constructor(root, host) {
    this.root = root;
    this.host = host;
    this.regions = [];
    this.list = root.querySelector('#regions');
    root.querySelector('#bodies-only').addEventListener('click', () => this.bodiesOnly());
    root.querySelector('#all-regions').addEventListener('click', () => this.setHidden([]));
  }

  // A dataset opened: its regions, and the view's hidden ids that it has.
  setDataset(info) {
    this.regions = info.regions ?? [];
    const view = this.host.view();
    view.hiddenRegions = (view.hiddenRegions ?? []).filter((id) => id < this.regions.length);
    this.root.hidden = !this.regions.length;
    this.show();
  }

  show() {
    const hidden = new Set(this.host.view().hiddenRegions);
    this.list.replaceChildren(
      ...this.regions.map((r) => {
        const row = document.createElement('label');
        row.className = 'region-row';
        row.title = `${r.triangles.toLocaleString()} triangles, area ${+r.area.toPrecision(3)}${r.touches_domain_box ? ', on the domain box' : ''}`;
        const box = document.createElement('input');
        box.type = 'checkbox';
        box.checked = !hidden.has(r.id);
        box.dataset.region = r.id;
        box.addEventListener('change', () => this.toggle(r.id, box.checked));
        const name = document.createElement('span');
        name.className = 'region-name';
        name.textContent = regionName(r);
        const count = document.createElement('span');
        count.className = 'region-count';
        count.textContent = r.triangles.toLocaleString();
        row.append(box, name, count);
        return row;
      }),
    );
  }

  toggle(id, shown) {
    const hidden = new Set(this.host.view().hiddenRegions);
    if (shown) hidden.delete(id);
    else hidden.add(id);
    this.setHidden([...hidden]);
  }

  // Hides every region on the domain's box and shows the boundary.
  bodiesOnly() {
    this.setHidden(this.regions.filter((r) => r.touches_domain_box).map((r) => r.id));
    if (!this.host.view().surface) this.host.showBoundary();
  }

  setHidden(ids) {
    this.host.view().hiddenRegions = [...new Set(ids)].sort((a, b) => a - b);
    this.show();
    this.send();
    this.host.saved();
  }

  send() {
    if (!this.regions.length) return;
    this.host.send('regions.set', { hidden: this.host.view().hiddenRegions ?? [] });
  }
}
