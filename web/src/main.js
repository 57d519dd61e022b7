// qjulia explore: the page. Every edit asks for a quick preview at low resolution at once (the
// server cancels the stale one), and a refined one when the user pauses.
import { api, ApiError } from './api.js';
import { Panel } from './panel.js';
import { Viewer, kBackground } from './viewer.js';

const $ = (id) => document.getElementById(id);
const kQuickResolution = 64;
const kRefineDelayMs = 600;
const kCompareSamples = 200000;
const kRegionStep = 0.1;  // of the box's side, per arrow
const kRetries = 3;  // of a preview that something else cancelled (see runCycle)

// What the browser test reads (tests/explore/browser_test.js).
const explore = {
  ready: false,
  generation: 0,   // of the newest edit
  shown: null,     // the newest preview on screen: {generation, resolution, latencyMs, figures}
  latencies: [],   // ms from an edit to its first preview on screen
  compare: null,   // the newest comparison
  retries: 0,      // previews asked for again after something else cancelled them
  running: null,   // the preview being made: {generation, resolution}
  exportState: null,
  errors: [],
};
window.explore = explore;

const viewer = new Viewer($('canvas'));
const panel = new Panel({ onEdit: () => edited(), onView: () => viewChanged() });
let presets = [];
let name = 'qjulia';  // of the downloads
let controller = null;
let refineTimer = null;
let editTime = 0;

function setStatus(text, error = false) {
  $('status').textContent = text;
  $('status').classList.toggle('error', error);
}

function setBusy(on) { $('busy').hidden = !on; }

// A preview skips what only the final mesh needs: decimation and the printing aids.
function previewParams(p, resolution) {
  const q = JSON.parse(JSON.stringify(p));
  q.resolution = resolution;
  delete q.print;
  if (q.mesh) {
    delete q.mesh.faces;
    delete q.mesh.max_error;
  }
  return q;
}

function methodLabel(method, bailout) {
  return method === 'escape' ? `Standard (escape), R = ${bailout}` : `Extended (cut-off), r = ${bailout}`;
}

function figuresText(f) {
  return `${f.faces.toLocaleString('en')} faces, ${f.components} component${f.components === 1 ? '' : 's'}` +
    `, volume ${f.volume.toPrecision(4)}, ${f.resolution}³ in ${f.seconds.toFixed(2)} s`;
}

function showError(error) {
  // A message about the formula goes under it, with a caret at the parser's column.
  const body = error instanceof ApiError ? error.body : error;
  const message = body.error || String(error.message || error);
  if (body.key === 'formula') {
    panel.showFormulaError(message, body.column);
  } else {
    panel.showFormulaError(null);
  }
  setStatus(message, true);
}

function edited() {
  $('preset').value = '';
  startCycle();
}

function startCycle() {
  const generation = ++explore.generation;
  editTime = performance.now();
  clearTimeout(refineTimer);
  if (controller) controller.abort();
  controller = new AbortController();
  const detail = panel.detail();
  const quick = Math.min(kQuickResolution, detail);
  runCycle(generation, quick, controller.signal).then((outcome) => {
    // An empty solid at the quick resolution may have parts that a finer grid sees.
    if (!outcome || generation !== explore.generation || quick >= detail) return;
    refineTimer = setTimeout(() => {
      if (generation !== explore.generation) return;
      controller = new AbortController();
      runCycle(generation, detail, controller.signal);
    }, kRefineDelayMs);
  });
}

// One preview (or two and their comparison, side by side): 'shown' when it reached the screen,
// 'empty' when the solid is empty, false otherwise (cancelled, an error).
async function runCycle(generation, resolution, signal, attempt = 0) {
  const current = () => generation === explore.generation && !signal.aborted;
  const params = panel.params();
  const running = { generation, resolution };
  explore.running = running;
  setBusy(true);
  try {
    const check = await api.check(params, signal);
    if (!current()) return false;
    if (!check.ok) {
      showError(check);
      return false;
    }
    panel.showFormulaError(null);
    let figures;
    if (panel.sideBySide()) {
      const a = previewParams({ ...params, method: 'escape', bailout: panel.bailout('escape') }, resolution);
      const b = previewParams({ ...params, method: 'cutoff', bailout: panel.bailout('cutoff') }, resolution);
      $('label-a').textContent = methodLabel('escape', a.bailout);
      $('label-b').textContent = methodLabel('cutoff', b.bailout);
      const results = [];
      for (const [index, p] of [[0, a], [1, b]]) {
        try {
          const r = await api.mesh(p, signal);
          if (!current()) return false;
          await viewer.setMesh(index, r.glb, p.bounds);
          results.push(r.figures);
        } catch (e) {
          if (!(e instanceof ApiError) || e.status !== 400) throw e;
          viewer.clearMesh(index);  // an empty solid: nothing to show on this side
          results.push(null);
          $(index ? 'label-b' : 'label-a').textContent += ` — ${e.message}`;
        }
      }
      figures = results[0] || results[1];
      if (results[0] && results[1]) {
        const cmp = await api.compare(a, b, kCompareSamples, signal);
        if (!current()) return false;
        explore.compare = { generation, resolution, hausdorff: cmp.hausdorff, a: cmp.a_figures, b: cmp.b_figures };
        setStatus(`Hausdorff distance standard ↔ extended: ${cmp.hausdorff.toPrecision(4)} ` +
          `(${resolution}³, ${cmp.samples.toLocaleString('en')} samples) · standard ` +
          `${cmp.a_figures.faces.toLocaleString('en')} faces, extended ${cmp.b_figures.faces.toLocaleString('en')} faces`);
      } else {
        explore.compare = { generation, resolution, hausdorff: null };
        setStatus('one of the solids is empty: no Hausdorff distance', true);
      }
    } else {
      const p = previewParams(params, resolution);
      $('label-a').textContent = methodLabel(p.method, p.bailout);
      let r;
      try {
        r = await api.mesh(p, signal);
      } catch (e) {
        if (e instanceof ApiError && e.status === 400 && current()) viewer.clearMesh(0);
        throw e;
      }
      if (!current()) return false;
      await viewer.setMesh(0, r.glb, p.bounds);
      figures = r.figures;
      setStatus(figuresText(figures));
    }
    // On screen: the frame that draws the new mesh has been presented.
    await new Promise((resolve) => requestAnimationFrame(() => resolve()));
    if (!current()) return false;
    const latencyMs = performance.now() - editTime;
    const first = !explore.shown || explore.shown.generation !== generation;
    explore.shown = { generation, resolution, latencyMs, figures, sideBySide: panel.sideBySide() };
    if (first) explore.latencies.push({ generation, resolution, ms: latencyMs });
    return 'shown';
  } catch (e) {
    // The server runs the preview it received last. Requests travel on separate connections, so
    // one of an older edit, sent just before its edit was superseded, can reach the server after
    // this one and cancel it; so can another page, or Stop pressed in another page. This page's
    // own newer edits and Stop abort `signal` first: a cancelled preview that is still current
    // was cancelled by something else, and is asked for again (a few times, so that two pages
    // cannot cancel each other forever).
    if (e instanceof ApiError && e.cancelled && current() && attempt < kRetries) {
      ++explore.retries;
      return await runCycle(generation, resolution, signal, attempt + 1);
    }
    if (e.name === 'AbortError' || (e instanceof ApiError && e.cancelled)) return false;
    if (current()) showError(e);
    return e instanceof ApiError && e.body.empty === true ? 'empty' : false;
  } finally {
    if (explore.running === running) explore.running = null;
    if (generation === explore.generation) setBusy(false);
  }
}

function viewChanged() {
  const v = panel.view();
  viewer.setRotation(v.rotation);
  if (v.shading !== viewer.shading) viewer.setShading(v.shading);
  viewer.setLights(v.lights);
}

// Moves the box by kRegionStep of its side along each axis d = -1, 0, 1.
function moveRegion(d) {
  const b = panel.bounds();
  for (let a = 0; a < 3; ++a) {
    const step = (b.max[a] - b.min[a]) * kRegionStep * d[a];
    b.min[a] += step;
    b.max[a] += step;
  }
  panel.setBounds(b);
  edited();
}

// Scales the box about its centre by `factor` (< 1 magnifies).
function zoomRegion(factor) {
  const b = panel.bounds();
  for (let a = 0; a < 3; ++a) {
    const c = (b.min[a] + b.max[a]) / 2, h = (b.max[a] - b.min[a]) / 2 * factor;
    b.min[a] = c - h;
    b.max[a] = c + h;
  }
  panel.setBounds(b);
  edited();
}

function download(href, filename) {
  const a = document.createElement('a');
  a.href = href;
  a.download = filename;
  document.body.append(a);
  a.click();
  a.remove();
}

function downloadBlob(blob, filename) {
  const url = URL.createObjectURL(blob);
  download(url, filename);
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

function applyParams(p, newName) {
  if (newName) name = newName;
  panel.setParams(p);
  startCycle();
}

// Exports: start, poll the progress, download when done.
let exportId = null;
async function startExport() {
  const format = $('format').value;
  $('export-status').textContent = 'starting';
  try {
    const s = await api.startExport(panel.params(), format);
    exportId = s.id;
  } catch (e) {
    $('export-status').textContent = e.message;
    return;
  }
  $('export').disabled = true;
  $('export-cancel').disabled = false;
  const id = exportId;
  for (;;) {
    let s;
    try {
      s = await api.exportStatus(id);
    } catch (e) {
      $('export-status').textContent = e.message;
      break;
    }
    explore.exportState = s;
    $('export-progress').value = s.progress;
    if (s.state === 'running') {
      $('export-status').textContent = `${s.stage || 'starting'} ${Math.round(s.progress * 100)}%`;
      await new Promise((resolve) => setTimeout(resolve, 200));
      continue;
    }
    if (s.state === 'done') {
      $('export-status').textContent = `done: ${s.faces.toLocaleString('en')} faces, ` +
        `${(s.bytes / 1048576).toFixed(1)} MB in ${s.seconds.toFixed(1)} s`;
      download(s.file, `${name}.${s.format}`);
    } else {
      $('export-status').textContent = s.state === 'failed' ? s.error : 'cancelled';
    }
    break;
  }
  $('export').disabled = false;
  $('export-cancel').disabled = true;
}

function wire() {
  $('preset').addEventListener('change', () => {
    const p = presets.find((x) => x.name === $('preset').value);
    if (p) {
      applyParams(p.params, p.name);
      $('preset').value = p.name;
    }
  });
  $('side-by-side').addEventListener('change', () => {
    viewer.setSideBySide(panel.sideBySide());
    $('label-b').hidden = !panel.sideBySide();
    if (!panel.sideBySide()) viewer.clearMesh(1);
    startCycle();
  });
  for (const button of document.querySelectorAll('[data-move]')) {
    button.addEventListener('click', () => moveRegion(button.dataset.move.split(',').map(Number)));
  }
  for (const button of document.querySelectorAll('[data-zoom]')) {
    button.addEventListener('click', () => zoomRegion(Number(button.dataset.zoom)));
  }
  $('reset-region').addEventListener('click', () => {
    panel.setBounds(panel.initialBounds);
    edited();
  });
  const keys = {
    ArrowLeft: [-1, 0, 0], ArrowRight: [1, 0, 0], ArrowUp: [0, 1, 0], ArrowDown: [0, -1, 0],
    PageUp: [0, 0, 1], PageDown: [0, 0, -1],
  };
  document.addEventListener('keydown', (e) => {
    if (e.target.closest && e.target.closest('input, select, textarea, button')) return;
    if (keys[e.key]) {
      e.preventDefault();
      moveRegion(keys[e.key]);
    } else if (e.key === '+' || e.key === '=') {
      zoomRegion(0.8);
    } else if (e.key === '-') {
      zoomRegion(1.25);
    }
  });
  $('canvas').addEventListener('wheel', (e) => {
    e.preventDefault();
    zoomRegion(e.deltaY > 0 ? 1.1 : 1 / 1.1);
  }, { passive: false });
  $('stop').addEventListener('click', () => {
    clearTimeout(refineTimer);
    if (controller) controller.abort();
    api.stopPreview().catch(() => {});
    setBusy(false);
    setStatus('stopped');
  });
  $('export').addEventListener('click', startExport);
  $('export-cancel').addEventListener('click', () => {
    if (exportId !== null) api.cancelExport(exportId).catch(() => {});
  });
  $('save-png').addEventListener('click', async () => downloadBlob(await viewer.png(), `${name}.png`));
  $('copy-png').addEventListener('click', async () => {
    // The page is served from 127.0.0.1 or localhost, a secure context, so the clipboard is there.
    try {
      await navigator.clipboard.write([new ClipboardItem({ 'image/png': viewer.png() })]);
      setStatus('the picture is on the clipboard');
    } catch (e) {
      setStatus(`cannot copy the picture: ${e.message}`, true);
    }
  });
  $('save').addEventListener('click', () => {
    const text = `${JSON.stringify(panel.params(), null, 2)}\n`;
    downloadBlob(new Blob([text], { type: 'application/json' }), `${name}.json`);
  });
  $('load').addEventListener('click', () => $('load-file').click());
  $('load-file').addEventListener('change', async () => {
    const file = $('load-file').files[0];
    $('load-file').value = '';
    if (!file) return;
    // The server checks the text itself, so a JSON error names its line and column.
    const check = await api.check(await file.text());
    $('file-error').hidden = check.ok;
    if (!check.ok) {
      $('file-error').textContent = `${file.name}: ${check.error}`;
      return;
    }
    $('preset').value = '';
    applyParams(check.params, file.name.replace(/\.json$/i, ''));
  });
}

async function init() {
  wire();
  let info;
  try {
    [info, presets] = await Promise.all([api.info(), api.presets()]);
  } catch (e) {
    setStatus(`cannot reach the server: ${e.message}`, true);
    return;
  }
  $('version').textContent = `qjulia ${info.version}`;
  for (const p of presets) $('preset').add(new Option(`${p.name}`, p.name));
  for (const f of info.formats) $('format').add(new Option(`.${f}`, f));
  $('detail').max = $('detail-range').max = info.preview_max_resolution;
  viewChanged();
  applyParams(info.initial, info.initial_name.replace(/\.json$/i, ''));
  if (presets.some((p) => p.name === info.initial_name)) $('preset').value = info.initial_name;
  explore.ready = true;
}

window.addEventListener('error', (e) => explore.errors.push(String(e.message)));
window.addEventListener('unhandledrejection', (e) => explore.errors.push(String(e.reason)));
explore.background = kBackground;
// A downsampled copy of the view: the share of pixels that are not background and the grey
// level of each, for tests that compare two views.
explore.snapshot = () => {
  viewer.render();
  const source = $('canvas');
  const w = 96, h = Math.max(1, Math.round(96 * source.height / source.width));
  const c = document.createElement('canvas');
  c.width = w;
  c.height = h;
  const ctx = c.getContext('2d');
  ctx.drawImage(source, 0, 0, w, h);
  const d = ctx.getImageData(0, 0, w, h).data;
  const bg = [(kBackground >> 16) & 255, (kBackground >> 8) & 255, kBackground & 255];
  let covered = 0;
  const grey = [];
  for (let i = 0; i < d.length; i += 4) {
    if (Math.abs(d[i] - bg[0]) + Math.abs(d[i + 1] - bg[1]) + Math.abs(d[i + 2] - bg[2]) > 40) ++covered;
    grey.push(Math.round((d[i] + d[i + 1] + d[i + 2]) / 3));
  }
  return { coverage: covered / (w * h), grey };
};
init();
