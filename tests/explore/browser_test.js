#!/usr/bin/env node
// The page of `qjulia explore` in a real browser: Debian's chromium, headless, WebGL through
// SwiftShader, driven by puppeteer-core. It starts the server, loads the page, picks
// newton-cubic and checks that the canvas shows the mesh, changes the iterations and the method
// and sees the preview change, moves the region with an arrow key, shows a formula error at its
// column, shows standard and extended side by side with their Hausdorff distance, exports a .glb
// and checks it with the Khronos glTF validator, saves and copies a PNG, saves the parameter file
// and loads one, measures the preview latency of newton-cubic at 64^3 (OUT/latency.json) and
// takes the README's screenshot.
//
// usage: node browser_test.js --qjulia BIN [--chromium PATH] --out DIR [--screenshot FILE.png]
// (NODE_PATH: web/node_modules, for puppeteer-core and gltf-validator). Exit 0 when every check
// passed.
'use strict';

const { spawn } = require('child_process');
const fs = require('fs');
const os = require('os');
const path = require('path');
const puppeteer = require('puppeteer-core');
const validator = require('gltf-validator');

const args = { chromium: '/usr/bin/chromium' };
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
if (!args.qjulia || !args.out) {
  console.error('usage: node browser_test.js --qjulia BIN [--chromium PATH] --out DIR [--screenshot FILE.png]');
  process.exit(2);
}

let failures = 0;
function check(ok, what, detail = '') {
  console.log(`${ok ? 'PASS' : 'FAIL'}  ${what}${detail ? `: ${detail}` : ''}`);
  if (!ok) ++failures;
  return ok;
}
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
const median = (xs) => { const s = [...xs].sort((a, b) => a - b); return s[Math.floor(s.length / 2)]; };

// The share of pixels whose grey level differs by more than 16 between two snapshots.
function changed(a, b) {
  let n = 0;
  for (let i = 0; i < a.grey.length; ++i) if (Math.abs(a.grey[i] - b.grey[i]) > 16) ++n;
  return n / a.grey.length;
}

function startServer() {
  // The page starts on another preset, so picking newton-cubic is an edit.
  const server = spawn(args.qjulia, ['explore', '--preset', 'classic-julia', '--no-browser', '--port', '0'],
    { stdio: ['ignore', 'pipe', 'inherit'] });
  return new Promise((resolve, reject) => {
    let out = '';
    server.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/serving (http:\/\/\S+)/);
      if (m) resolve({ server, url: m[1] });
    });
    server.on('exit', (code) => reject(new Error(`qjulia explore exited with ${code}: ${out}`)));
    setTimeout(() => reject(new Error('qjulia explore printed no address within 20 s')), 20000);
  });
}

async function waitForFile(dir, name, timeoutMs = 60000) {
  const file = path.join(dir, name);
  const end = Date.now() + timeoutMs;
  while (Date.now() < end) {
    if (fs.existsSync(file) && !fs.existsSync(`${file}.crdownload`)) return file;
    await sleep(100);
  }
  throw new Error(`no download ${name} in ${dir}`);
}

// The JSON chunk of a GLB.
function glbJson(bytes) {
  const length = bytes.readUInt32LE(12);
  return JSON.parse(bytes.subarray(20, 20 + length).toString('utf8'));
}

async function main() {
  fs.mkdirSync(args.out, { recursive: true });
  const downloads = fs.mkdtempSync(path.join(args.out, 'downloads-'));
  const { server, url } = await startServer();
  console.log(`server: ${url}`);
  const browser = await puppeteer.launch({
    executablePath: args.chromium,
    headless: true,
    args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
      '--window-size=1280,800'],
    downloadBehavior: { policy: 'allow', downloadPath: downloads },
  });
  const problems = [];
  try {
    await browser.defaultBrowserContext().overridePermissions(url.replace(/\/$/, ''),
      ['clipboard-read', 'clipboard-write', 'clipboard-sanitized-write']);
    const page = await browser.newPage();
    page.on('pageerror', (e) => problems.push(`page error: ${e.message}`));
    page.on('console', (m) => {
      // Chromium logs every 4xx answer to a fetch; those the response handler below expects are not problems.
      if (m.type() === 'error' && !/^Failed to load resource: the server responded with a status of (400|409)\b/.test(m.text())) {
        problems.push(`console: ${m.text()}`);
      }
    });
    page.on('response', (r) => {
      // A 400 is a shown message (the formula error below) and a 409 a cancelled preview.
      if (r.status() >= 400 && ![400, 409].includes(r.status())) problems.push(`HTTP ${r.status()} ${r.url()}`);
    });
    await page.setViewport({ width: 1280, height: 800 });
    await page.goto(url);
    await page.waitForFunction(() => window.explore && window.explore.ready && window.explore.shown, { timeout: 60000 });
    check(await page.$eval('#preset', (e) => e.value) === 'classic-julia', 'the page starts with the preset given to the server');

    const state = () => page.evaluate(() => ({
      generation: explore.generation, shown: explore.shown, compare: explore.compare,
    }));
    // Waits until the newest edit's preview at `resolution` is on screen.
    const waitShown = async (resolution, timeout = 60000) => {
      try {
        await page.waitForFunction((res) => explore.shown && explore.shown.generation === explore.generation &&
          explore.shown.resolution === res, { timeout }, resolution);
      } catch (e) {
        // What the page was doing, for the log.
        const seen = await page.evaluate(() => ({
          generation: explore.generation, shown: explore.shown, retries: explore.retries,
          status: document.getElementById('status').textContent,
        }));
        throw new Error(`no preview at ${resolution}^3 of the newest edit within ${timeout} ms: ` +
          `${JSON.stringify(seen)}; ${e.message}`);
      }
      return state();
    };
    const snapshot = () => page.evaluate(() => explore.snapshot());
    const setField = async (selector, value) => {
      await page.$eval(selector, (e, v) => {
        e.value = v;
        e.dispatchEvent(new Event('input', { bubbles: true }));
      }, String(value));
    };
    const detail = await page.$eval('#detail', (e) => Number(e.value));

    // newton-cubic: the canvas shows the mesh.
    await page.select('#preset', 'newton-cubic');
    let s = await waitShown(detail);
    check(await page.$eval('#formula', (e) => e.value) === '(2*h^3+1)/(3*h^2)', 'picking newton-cubic sets its formula');
    check(await page.$eval('#family', (e) => e.value) === 'newton' && await page.$eval('#degree', (e) => e.value) === '3',
      "its formula is the family Newton's map for h^n - 1 with degree 3");
    const cubicFaces = s.shown.figures.faces;
    check(cubicFaces > 10000, 'newton-cubic is meshed', `${s.shown.figures.faces} faces at ${detail}^3`);
    const cubic = await snapshot();
    check(cubic.coverage > 0.08, 'the canvas shows the mesh', `${(cubic.coverage * 100).toFixed(1)}% of the pixels are not background`);

    // Fewer iterations: a thicker cut-off shell.
    await setField('#iterations', 6);
    s = await waitShown(detail);
    const fewer = await snapshot();
    check(s.shown.figures.faces !== cubicFaces && changed(cubic, fewer) > 0.02, 'changing the iterations changes the preview',
      `${(changed(cubic, fewer) * 100).toFixed(1)}% of the pixels changed`);
    // The standard method (R = 4): the bailout ball with holes (the paper's table 1).
    await page.click('input[name=method][value=escape]');
    s = await waitShown(detail);
    const escape = await snapshot();
    check(changed(fewer, escape) > 0.05, 'changing the method changes the preview',
      `${(changed(fewer, escape) * 100).toFixed(1)}% of the pixels changed, ${s.shown.figures.faces} faces`);
    await page.click('input[name=method][value=cutoff]');
    await setField('#iterations', 12);
    await waitShown(detail);

    // An arrow key moves the region by a tenth of the box.
    const before = await snapshot();
    await page.focus('#canvas');
    await page.keyboard.press('ArrowRight');
    s = await waitShown(detail);
    const bounds = await page.$$eval('#bmin-0, #bmax-0', (es) => es.map((e) => Number(e.value)));
    check(Math.abs(bounds[0] + 1.6) < 1e-9 && Math.abs(bounds[1] - 2.4) < 1e-9, 'ArrowRight moves the box along x',
      `x from ${bounds[0]} to ${bounds[1]}`);
    const moved = await snapshot();
    check(changed(before, moved) > 0.02, 'the moved region shows another part of the set',
      `${(changed(before, moved) * 100).toFixed(1)}% of the pixels changed`);
    await page.click('#reset-region');
    await waitShown(detail);

    // The view's controls (QHD's rotation window, illumination model and lights) redraw at once.
    let view = await snapshot();
    for (const [selector, value] of [['#rot-0', 60], ['#shading', 'simple'], ['#intensity', 0.6],
      ['#ambient', 1.5], ['#light-0', 4]]) {
      if (selector === '#shading') await page.select(selector, value); else await setField(selector, value);
      const next = await snapshot();
      check(changed(view, next) > 0.01, `${selector} changes the view`, `${(changed(view, next) * 100).toFixed(1)}% of the pixels changed`);
      view = next;
    }
    for (const [selector, value] of [['#rot-0', -25], ['#intensity', 2.5], ['#ambient', 0.35], ['#light-0', -1]]) {
      await setField(selector, value);
    }
    await page.select('#shading', 'phong');

    // The degree of the family, the clip plane and the choice of X-Y-Z are new parameter sets.
    const edits = [
      ['degree 4', async () => setField('#degree', 4), async () => (await page.$eval('#formula', (e) => e.value)) === '(3*h^4+1)/(4*h^3)'],
      ['the clip plane', async () => page.click('#clip-on'), async () => true],
      ['the fourth component p = 0.3', async () => setField('#fixed', 0.3), async () => true],
    ];
    for (const [what, edit, ok] of edits) {
      const previous = await snapshot();
      const faces = (await state()).shown.figures.faces;
      await edit();
      s = await waitShown(detail);
      const next = await snapshot();
      check(await ok() && s.shown.figures.faces !== faces && changed(previous, next) > 0.01, `${what} changes the preview`,
        `${faces} -> ${s.shown.figures.faces} faces, ${(changed(previous, next) * 100).toFixed(1)}% of the pixels changed`);
    }
    await setField('#fixed', 0);
    await page.click('#clip-on');
    await setField('#degree', 3);
    await waitShown(detail);

    // Any three of the four components as X-Y-Z, on a map with non-real coefficients (one with
    // real coefficients has the same section in every space through the real axis).
    await page.select('#preset', 'pq-quadratic');
    s = await waitShown(detail);
    const rmn = await snapshot();
    const rmnFaces = s.shown.figures.faces;
    await page.select('#axis-2', 'p');
    s = await waitShown(detail);
    const rmp = await snapshot();
    check(await page.$eval('#fixed-label', (e) => e.textContent) === 'n =' && s.shown.figures.faces !== rmnFaces &&
      changed(rmn, rmp) > 0.01, 'X-Y-Z = r m p changes the preview',
    `${rmnFaces} -> ${s.shown.figures.faces} faces, ${(changed(rmn, rmp) * 100).toFixed(1)}% of the pixels changed`);

    // Mandelbrot: the start point h0 instead of the constant c.
    await page.select('#preset', 'quaternion-mandelbrot');
    s = await waitShown(detail);
    check(await page.$eval('#start-row', (e) => !e.hidden) && (await page.$$('#const-c-0')).length === 0 &&
      await page.$eval('input[name=mode][value=mandelbrot]', (e) => e.checked) && s.shown.figures.faces > 1000,
    'Mandelbrot shows h0 instead of c and meshes', `${s.shown.figures.faces} faces`);
    await page.select('#preset', 'newton-cubic');
    await waitShown(detail);

    // A formula error appears under the formula, the caret at the parser's column.
    await setField('#formula', '(2*h^3+1)/(3*h^');
    await page.waitForFunction(() => !document.getElementById('formula-error').hidden, { timeout: 20000 });
    const error = await page.$eval('#formula-error', (e) => e.textContent);
    const lines = error.split('\n');
    check(lines[1] === `${' '.repeat(15)}^` && /formula 1:16: expected a literal real exponent/.test(lines[2]),
      'a formula error is shown inline at its column', JSON.stringify(error));
    await setField('#formula', '(2*h^3+1)/(3*h^2)');
    await waitShown(detail);
    check(await page.$eval('#formula-error', (e) => e.hidden), 'the error goes when the formula is right again');

    // Preview latency: newton-cubic at 64^3, from the edit to the mesh on screen. Every edit is
    // a new parameter set (the cut-off r moves by 1e-4), so none comes from the server's cache.
    await setField('#detail', 64);
    await waitShown(64);
    const latencies = [];
    const meshMs = [];  // of each, the server's run_pipeline()
    let cached = 0;
    for (let k = 1; k <= 7; ++k) {
      await setField('#bailout-cutoff', (0.01 + k * 1e-4).toFixed(4));
      s = await waitShown(64);
      latencies.push(s.shown.latencyMs);
      meshMs.push(s.shown.figures.seconds * 1000);
      if (s.shown.figures.cached) ++cached;
    }
    // Bursts of edits as while typing (one every 80 ms, each cancelling the preview of the one
    // before): from the last edit of a burst to its mesh on screen.
    const bursts = [];
    for (let b = 0; b < 4; ++b) {
      for (let k = 1; k <= 5; ++k) {
        await setField('#bailout-cutoff', (0.012 + b * 1e-3 + k * 1e-4).toFixed(4));
        if (k < 5) await sleep(80);
      }
      s = await waitShown(64);
      bursts.push(s.shown.latencyMs);
      if (s.shown.figures.cached) ++cached;
    }
    await setField('#bailout-cutoff', 0.01);
    await waitShown(64);
    const warm = latencies.slice(1);  // the first one after the detail change is cold
    const ms = (xs) => xs.map((x) => x.toFixed(0)).join(', ');
    console.log(`preview latency, newton-cubic at 64^3, edit to mesh on screen: median ${median(warm).toFixed(0)} ms, ` +
      `max ${Math.max(...warm).toFixed(0)} ms over ${warm.length} edits (${ms(latencies)} ms)`);
    console.log(`preview latency after a burst of 5 edits 80 ms apart, from the last edit: median ` +
      `${median(bursts).toFixed(0)} ms, max ${Math.max(...bursts).toFixed(0)} ms (${ms(bursts)} ms)`);
    const load = os.loadavg()[0];
    console.log(`of the single edits, meshing on the server: ${ms(meshMs)} ms; load average ${load.toFixed(2)} ` +
      `on ${os.cpus().length} cores (target: 500 ms from the last edit)`);
    fs.writeFileSync(path.join(args.out, 'latency.json'), `${JSON.stringify({
      preset: 'newton-cubic', resolution: 64, single_edits_ms: latencies, bursts_ms: bursts,
      median_single_ms: median(warm), median_burst_ms: median(bursts), server_mesh_ms: meshMs,
      load_average: load, cores: os.cpus().length, target_ms: 500,
    }, null, 1)}\n`);
    check(cached === 0 && warm.every((x) => x > 0) && bursts.every((x) => x > 0),
      'the latency of every edit was measured on a fresh mesh');

    // A preview cancelled by something other than this page's own edits and Stop (a request of
    // an older edit that reached the server late, another page) is asked for again: here the
    // refined preview is cancelled through the API while it runs.
    {
      const retries = await page.evaluate(() => explore.retries);
      // The edit's quick preview, then its refined one while it runs.
      await setField('#detail', detail);
      await setField('#bailout-cutoff', 0.0105);
      await waitShown(64);
      try {
        await page.waitForFunction((res) => explore.running && explore.running.generation === explore.generation &&
          explore.running.resolution === res, { timeout: 60000, polling: 5 }, detail);
      } catch (e) {
        const seen = await page.evaluate(() => ({ generation: explore.generation, running: explore.running,
          shown: explore.shown, detail: document.getElementById('detail').value }));
        throw new Error(`the refined preview did not start: ${JSON.stringify(seen)}`);
      }
      let stopped = false;
      for (let k = 0; k < 500 && !stopped; ++k) {
        const r = await fetch(new URL('/api/preview/cancel', url), { method: 'POST', body: '' });
        stopped = (await r.json()).stopped === true;
        if (!stopped) await sleep(5);
      }
      s = await waitShown(detail);
      const after = await page.evaluate(() => explore.retries);
      check(stopped && after > retries, 'a preview that something else cancelled is asked for again and shown',
        `cancelled while running: ${stopped}, retries ${retries} -> ${after}, ${s.shown.figures.faces} faces at ${detail}^3`);
    }

    // Standard and extended side by side, with their Hausdorff distance.
    await setField('#detail', 96);
    await setField('#bailout-escape', 2);  // the paper's table 1: the bailout ball with holes
    await page.click('#side-by-side');
    await page.waitForFunction(() => explore.compare && explore.compare.generation === explore.generation &&
      explore.compare.resolution === 96, { timeout: 90000 });
    s = await state();
    check(s.compare.hausdorff > 0.5, 'side by side shows the Hausdorff distance of the two methods',
      `${s.compare.hausdorff.toFixed(3)} at 96^3 (standard ${s.compare.a.faces} faces, extended ${s.compare.b.faces})`);
    check(!(await page.$eval('#label-b', (e) => e.hidden)), 'both views are labelled');
    if (args.screenshot) {
      await page.setViewport({ width: 1120, height: 700 });
      await page.evaluate(() => new Promise((resolve) => requestAnimationFrame(() => resolve())));
      await page.screenshot({ path: args.screenshot });
      console.log(`screenshot: ${args.screenshot}`);
      await page.setViewport({ width: 1280, height: 800 });
    }
    await page.click('#side-by-side');
    await waitShown(96);

    // Export at full resolution as .glb, downloaded by the browser, checked by the validator.
    await setField('#resolution', 96);
    await page.select('#format', 'glb');
    await page.click('#export');
    const glbFile = await waitForFile(downloads, 'newton-cubic.glb', 120000);
    const bytes = fs.readFileSync(glbFile);
    const report = await validator.validateBytes(new Uint8Array(bytes), { format: 'glb', writeTimestamp: false });
    check(report.issues.numErrors === 0 && report.issues.numWarnings === 0, 'the exported .glb passes the glTF validator',
      `${report.issues.numErrors} errors, ${report.issues.numWarnings} warnings, ${report.info.totalTriangleCount} triangles`);
    const extras = glbJson(bytes).asset.extras;
    check(extras.formula === '(2*h^3+1)/(3*h^2)' && extras.resolution === 96, 'the export records its parameters',
      `resolution ${extras.resolution}`);
    const exportState = await page.evaluate(() => explore.exportState);
    check(exportState.state === 'done' && exportState.faces === report.info.totalTriangleCount,
      'the export status and the file agree', `${exportState.faces} faces in ${exportState.seconds.toFixed(2)} s`);

    // The picture and the parameter file, saved; a parameter file loaded.
    await page.click('#save-png');
    const png = fs.readFileSync(await waitForFile(downloads, 'newton-cubic.png'));
    check(png.subarray(1, 4).toString() === 'PNG' && png.length > 2000, 'Save PNG downloads the view', `${png.length} bytes`);
    await page.click('#copy-png');
    await page.waitForFunction(() => /clipboard/.test(document.getElementById('status').textContent), { timeout: 20000 });
    const copied = await page.evaluate(async () => {
      const items = await navigator.clipboard.read();
      if (!items.length || !items[0].types.includes('image/png')) {
        return { type: items.map((i) => i.types.join('+')).join(', '), status: document.getElementById('status').textContent };
      }
      const blob = await items[0].getType('image/png');
      const bytes = new Uint8Array(await blob.arrayBuffer());
      return { type: blob.type, size: bytes.length, magic: String.fromCharCode(...bytes.subarray(1, 4)) };
    });
    check(copied.type === 'image/png' && copied.magic === 'PNG' && copied.size > 2000,
      'Copy picture puts the view on the clipboard as PNG', copied.size ? `${copied.size} bytes` : JSON.stringify(copied));
    await page.click('#save');
    const saved = JSON.parse(fs.readFileSync(await waitForFile(downloads, 'newton-cubic.json'), 'utf8'));
    check(saved.formula === '(2*h^3+1)/(3*h^2)' && saved.resolution === 96 && saved.iterations === 12,
      'Save parameters downloads the parameter file');
    const loadFile = path.join(args.out, 'loaded.json');
    fs.writeFileSync(loadFile, JSON.stringify({ ...saved, iterations: 7, bounds: { min: [-1, -2, -2], max: [3, 2, 2] } }));
    const input = await page.$('#load-file');
    await input.uploadFile(loadFile);
    await page.waitForFunction(() => document.getElementById('iterations').value === '7', { timeout: 20000 });
    s = await waitShown(96);
    check(await page.$eval('#bmin-0', (e) => e.value) === '-1', 'Load parameters fills the panel and meshes it');

    if (problems.length) console.log(problems.join('\n'));
    check(problems.length === 0, 'no page error, console error or unexpected HTTP error');
  } finally {
    await browser.close();
    const exited = new Promise((resolve) => server.on('exit', (code, signal) => resolve({ code, signal })));
    server.kill('SIGINT');
    const { code } = await exited;
    check(code === 130, 'SIGINT ends the server with exit code 130', `exit ${code}`);
  }
}

main().then(() => {
  console.log(failures ? `${failures} check(s) failed` : 'all checks passed');
  // The downloads stay for a look only when a check failed.
  if (!failures) {
    for (const d of fs.readdirSync(args.out)) {
      if (d.startsWith('downloads-')) fs.rmSync(path.join(args.out, d), { recursive: true, force: true });
    }
  }
  process.exit(failures ? 1 : 0);
}, (e) => {
  console.error(`browser_test: ${e.stack || e}`);
  process.exit(1);
});
