// The controls of the page and the parameter file they stand for. The panel keeps every key it
// has no control for (description, decimation, printing, more clip planes, a general slice) and
// writes them back unchanged.
import { families, familyById, detectFamily, constantNames } from './formulas.js';

const $ = (id) => document.getElementById(id);
const kAxisLetters = ['r', 'm', 'n', 'p'];
const kAxisLabels = { r: 'r (1)', m: 'm (i)', n: 'n (j)', p: 'p (k)' };
const kControlledKeys = ['formula', 'constants', 'mode', 'method', 'iterations', 'bailout', 'start',
  'slice', 'bounds', 'resolution'];

// A number input's value; null for an empty or unparsable field (the server names it).
function num(el) {
  const v = el.value.trim();
  if (v === '') return null;
  const n = Number(v);
  return Number.isFinite(n) ? n : null;
}

function radio(name) {
  return document.querySelector(`input[name=${name}]:checked`).value;
}

function setRadio(name, value) {
  const el = document.querySelector(`input[name=${name}][value="${value}"]`);
  if (el) el.checked = true;
}

const clone = (o) => JSON.parse(JSON.stringify(o));

export class Panel {
  // onEdit(): a parameter changed (a new preview is due); onView(): only the view changed.
  constructor({ onEdit, onView }) {
    this.onEdit = onEdit;
    this.onView = onView;
    this.extra = {};
    this.extraMesh = {};
    this.extraClips = [];
    this.generalSlice = null;
    this.constants = {};
    this.initialBounds = null;
    this.build();
  }

  build() {
    const family = $('family');
    for (const f of families) family.add(new Option(f.name, f.id), family.options.length - 1);
    for (let a = 0; a < 3; ++a) {
      const select = $(`axis-${a}`);
      for (const l of kAxisLetters) select.add(new Option(kAxisLabels[l], l));
      select.addEventListener('change', () => this.axisChanged(a));
    }
    const edit = () => this.onEdit();
    const view = () => this.onView();
    for (const name of ['mode', 'method']) {
      for (const el of document.querySelectorAll(`input[name=${name}]`)) {
        el.addEventListener('change', () => { this.updateVisibility(); edit(); });
      }
    }
    for (const id of ['iterations', 'bailout-escape', 'bailout-cutoff', 'fixed', 'resolution',
      'start-0', 'start-1', 'start-2', 'start-3', 'color', 'clip-on', 'clip-axis',
      'bmin-0', 'bmin-1', 'bmin-2', 'bmax-0', 'bmax-1', 'bmax-2']) {
      $(id).addEventListener(id === 'resolution' ? 'change' : 'input', edit);
    }
    $('formula').addEventListener('input', () => { this.formulaChanged(); edit(); });
    family.addEventListener('change', () => { this.familyChanged(); edit(); });
    $('degree').addEventListener('input', () => {
      if (family.value !== 'custom') { this.familyChanged(); edit(); }
    });
    this.pair('detail-range', 'detail');
    this.pair('iterations-range', 'iterations');
    this.pair('clip-d-range', 'clip-d');
    $('detail').addEventListener('input', edit);
    $('clip-d').addEventListener('input', () => { if ($('clip-on').checked) edit(); });
    for (const id of ['rot-0', 'rot-1', 'rot-2', 'shading', 'light-0', 'light-1', 'light-2',
      'intensity', 'ambient']) {
      $(id).addEventListener('input', view);
    }
  }

  // A range slider and a number field that show one value (the field's listeners see both).
  pair(rangeId, numberId) {
    const range = $(rangeId), number = $(numberId);
    range.addEventListener('input', () => {
      number.value = range.value;
      number.dispatchEvent(new Event('input'));
    });
    number.addEventListener('input', () => { range.value = number.value; });
  }

  axisChanged(a) {
    // The three axes stay distinct: the axis that had the chosen letter takes the old one.
    const chosen = $(`axis-${a}`).value;
    for (let b = 0; b < 3; ++b) {
      if (b !== a && $(`axis-${b}`).value === chosen) $(`axis-${b}`).value = this.previousAxes[a];
    }
    this.previousAxes = [0, 1, 2].map((i) => $(`axis-${i}`).value);
    this.updateVisibility();
    this.onEdit();
  }

  formulaChanged() {
    const found = detectFamily($('formula').value);
    $('family').value = found ? found.family.id : 'custom';
    if (found) $('degree').value = found.degree;
    this.renderConstants();
  }

  familyChanged() {
    const f = familyById($('family').value);
    if (!f) return;
    const n = Math.max(2, Math.min(12, Math.round(Number($('degree').value) || 3)));
    $('degree').value = n;
    $('formula').value = f.text(n);
    for (const [name, value] of Object.entries(f.constants)) {
      if (!(name in this.constants)) this.constants[name] = value.slice();
    }
    setRadio('method', f.method);
    this.updateVisibility();
    this.renderConstants();
  }

  // One row of four numbers (w, x, y, z) per constant the formula uses.
  renderConstants() {
    const box = $('constants');
    const names = this.constantNames();
    const shown = [...box.querySelectorAll('.constant')].map((r) => r.dataset.name);
    if (shown.join() === names.join()) return;  // keep the fields (and the focus) as they are
    box.replaceChildren();
    for (const name of names) {
      if (!(name in this.constants)) this.constants[name] = [0, 0, 0, 0];
      const row = document.createElement('div');
      row.className = 'row constant';
      row.dataset.name = name;
      const label = document.createElement('span');
      label.className = 'name';
      label.textContent = name;
      row.append(label);
      this.constants[name].forEach((v, i) => {
        const input = document.createElement('input');
        input.type = 'number';
        input.step = '0.01';
        input.className = 'q';
        input.id = `const-${name}-${i}`;
        input.value = v;
        input.title = `${name}: ${'wxyz'[i]} (${['1', 'i', 'j', 'k'][i]})`;
        input.addEventListener('input', () => {
          this.constants[name][i] = num(input);
          this.onEdit();
        });
        row.append(input);
      });
      box.append(row);
    }
  }

  constantNames() {
    const mandelbrot = radio('mode') === 'mandelbrot';
    return constantNames($('formula').value).filter((n) => !(mandelbrot && n === 'c'));
  }

  updateVisibility() {
    $('start-row').hidden = radio('mode') !== 'mandelbrot';
    const used = [0, 1, 2].map((i) => $(`axis-${i}`).value);
    $('fixed-label').textContent = `${kAxisLetters.find((l) => !used.includes(l))} =`;
    $('slice-row').hidden = this.generalSlice !== null;
    $('slice-general').hidden = this.generalSlice === null;
    this.renderConstants();
  }

  method() { return radio('method'); }
  sideBySide() { return $('side-by-side').checked; }
  detail() { return Math.round(num($('detail')) || 128); }
  bailout(method) { return num($(`bailout-${method}`)); }

  bounds() {
    return {
      min: [0, 1, 2].map((a) => num($(`bmin-${a}`))),
      max: [0, 1, 2].map((a) => num($(`bmax-${a}`))),
    };
  }

  setBounds(b) {
    const round = (v) => Number(v.toPrecision(10));  // no 0.30000000000000004 in the fields
    for (let a = 0; a < 3; ++a) {
      $(`bmin-${a}`).value = round(b.min[a]);
      $(`bmax-${a}`).value = round(b.max[a]);
    }
    const half = Math.max(...[0, 1, 2].map((a) => b.max[a] - b.min[a]));
    for (const id of ['clip-d-range']) {
      $(id).min = -half;
      $(id).max = half;
      $(id).step = half / 100;
    }
  }

  // The parameter file the panel stands for (resolution: the export's).
  params() {
    const p = clone(this.extra);
    const mode = radio('mode'), method = radio('method');
    p.formula = $('formula').value;
    p.constants = {};
    for (const name of this.constantNames()) p.constants[name] = this.constants[name].slice();
    p.mode = mode;
    p.method = method;
    p.iterations = num($('iterations'));
    p.bailout = num($(`bailout-${method}`));
    if (mode === 'mandelbrot') p.start = [0, 1, 2, 3].map((i) => num($(`start-${i}`)));
    p.slice = this.generalSlice
      ? clone(this.generalSlice)
      : { axes: [0, 1, 2].map((i) => $(`axis-${i}`).value).join(''), fixed: num($('fixed')) };
    p.bounds = this.bounds();
    p.resolution = num($('resolution'));
    const mesh = clone(this.extraMesh);
    mesh.color = $('color').value;
    const clips = this.extraClips.map((c) => c.slice());
    if ($('clip-on').checked) {
      clips.unshift([...$('clip-axis').value.split(',').map(Number), num($('clip-d'))]);
    }
    if (clips.length) mesh.clip = clips;
    p.mesh = mesh;
    return p;
  }

  // Shows the parameter file `p` (as /api/check or /api/presets give it).
  setParams(p) {
    this.extra = clone(p);
    for (const key of kControlledKeys) delete this.extra[key];
    delete this.extra.mesh;
    this.extraMesh = clone(p.mesh || {});
    delete this.extraMesh.color;
    delete this.extraMesh.clip;
    setRadio('mode', p.mode);
    setRadio('method', p.method);
    $('formula').value = p.formula;
    for (const [name, value] of Object.entries(p.constants || {})) this.constants[name] = value.slice();
    $('iterations').value = p.iterations;
    $('iterations-range').value = Math.min(p.iterations, 64);
    $(`bailout-${p.method}`).value = p.bailout;
    (p.start || [0, 0, 0, 0]).forEach((v, i) => { $(`start-${i}`).value = v; });
    this.generalSlice = p.slice.origin ? clone(p.slice) : null;
    if (!this.generalSlice) {
      [...p.slice.axes].forEach((l, i) => { $(`axis-${i}`).value = l; });
      $('fixed').value = p.slice.fixed;
    }
    this.previousAxes = [0, 1, 2].map((i) => $(`axis-${i}`).value);
    this.setBounds(p.bounds);
    this.initialBounds = clone(p.bounds);
    $('resolution').value = p.resolution;
    $('color').value = (p.mesh && p.mesh.color) || 'none';
    // The first clip plane along an axis goes to the controls; the others stay as they are.
    const clips = ((p.mesh && p.mesh.clip) || []).map((c) => c.slice());
    const first = clips.length ? clips[0] : null;
    const axis = first && [...$('clip-axis').options].find((o) => o.value === first.slice(0, 3).join(','));
    $('clip-on').checked = Boolean(axis);
    if (axis) {
      $('clip-axis').value = axis.value;
      $('clip-d').value = first[3];
      $('clip-d-range').value = first[3];
      clips.shift();
    }
    this.extraClips = clips;
    this.formulaChanged();
    this.updateVisibility();
  }

  view() {
    return {
      rotation: [0, 1, 2].map((i) => Number($(`rot-${i}`).value)),
      shading: $('shading').value,
      lights: {
        position: [0, 1, 2].map((i) => num($(`light-${i}`)) ?? 0),
        intensity: Number($('intensity').value),
        ambient: Number($('ambient').value),
      },
    };
  }

  // The parser's message under the formula, with a caret at its column; null clears it.
  showFormulaError(message, column) {
    const box = $('formula-error');
    $('formula').classList.toggle('invalid', message !== null);
    box.hidden = message === null;
    if (message === null) return;
    const caret = column ? `${' '.repeat(column - 1)}^\n` : '';
    box.textContent = `${$('formula').value}\n${caret}${message}`;
  }
}
