// Browser tests of the web catalogue: Debian's Chromium, headless, driven
// by puppeteer-core against a real psrigd on the simulated rig. Screenshots
// of every page land in $PSRIG_WEB_SCREENSHOTS for a reviewer.
//
//   PSRIGD=build/bin/psrigd PSRIG_SOURCE_DIR=. PSRIG_WEB_ROOT=build/web \
//     node --test web/tests/catalogue.test.mjs
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { createRequire } from 'node:module';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { after, before, describe, test } from 'node:test';
import puppeteer from 'puppeteer-core';
import { startPsrigd } from './psrigd.mjs';
import { postgresBinDir, startPostgres } from './postgres.mjs';

const require = createRequire(import.meta.url);
const chromiumPath = process.env.CHROMIUM ?? '/usr/bin/chromium';
const sourceDir = resolve(process.env.PSRIG_SOURCE_DIR ?? join(dirname(fileURLToPath(import.meta.url)), '../..'));
const psrigd = process.env.PSRIGD ?? join(sourceDir, 'build/bin/psrigd');
const webRoot = resolve(process.env.PSRIG_WEB_ROOT ?? join(sourceDir, 'build/web'));
const screenshots = resolve(process.env.PSRIG_WEB_SCREENSHOTS ?? join(sourceDir, 'build/web-screenshots'));
const TOKEN = 'browser-test-token-0123456789';

const missing = [
  [chromiumPath, 'Chromium (apt-get install chromium; scripts/install-deps does)'],
  [psrigd, 'psrigd (scripts/build)'],
  [join(webRoot, 'index.html'), 'the built catalogue (scripts/build)'],
].filter(([path]) => !existsSync(path));
const skip = missing.length ? `missing ${missing.map(([, what]) => what).join(', ')}` : false;

async function launch() {
  return puppeteer.launch({
    executablePath: chromiumPath,
    headless: true,
    args: [
      '--no-sandbox', // as root in CI
      '--use-angle=swiftshader', // WebGL without a GPU
      '--enable-unsafe-swiftshader',
      '--ignore-gpu-blocklist',
      '--window-size=1400,1000',
    ],
    defaultViewport: { width: 1400, height: 1000 },
  });
}

async function shot(page, name) {
  mkdirSync(screenshots, { recursive: true });
  await page.screenshot({ path: join(screenshots, `${name}.png`), fullPage: true });
}

// Console errors and failed requests fail the test that caused them.
function watch(page) {
  const problems = [];
  page.on('pageerror', (error) => problems.push(`page error: ${error.message}`));
  page.on('console', (message) => {
    if (message.type() === 'error' && !/401|Unauthorized/.test(message.text()))
      problems.push(`console: ${message.text()}`);
  });
  return problems;
}

async function scanUntilDone(daemon, body) {
  const response = await daemon.api('/v1/scans', {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
  });
  assert.equal(response.status, 202);
  const { id } = await response.json();
  for (let i = 0; i < 300; i++) {
    const row = await (await daemon.api(`/v1/scans/${id}`)).json();
    if (row.status === 'done') return row;
    assert.ok(['queued', 'running'].includes(row.status), `scan ${id}: ${JSON.stringify(row.error)}`);
    await new Promise((r) => setTimeout(r, 200));
  }
  throw new Error(`scan ${id} did not finish`);
}

// The canvas's pixels as a data URL (the renderer keeps its drawing buffer).
async function canvasPixels(page) {
  return page.$eval('canvas.swatch-canvas', (canvas) => {
    const probe = document.createElement('canvas');
    probe.width = 160;
    probe.height = 100;
    const g = probe.getContext('2d');
    g.drawImage(canvas, 0, 0, 160, 100);
    return Array.from(g.getImageData(0, 0, 160, 100).data);
  });
}

function spread(pixels) {
  const luma = [];
  for (let i = 0; i < pixels.length; i += 4) luma.push(pixels[i] * 0.3 + pixels[i + 1] * 0.59 + pixels[i + 2] * 0.11);
  const mean = luma.reduce((a, b) => a + b, 0) / luma.length;
  return Math.sqrt(luma.reduce((a, b) => a + (b - mean) ** 2, 0) / luma.length);
}

function meanDifference(a, b) {
  let sum = 0;
  for (let i = 0; i < a.length; i++) sum += Math.abs(a[i] - b[i]);
  return sum / a.length;
}

describe('web catalogue', { skip }, () => {
  let daemon;
  let browser;
  before(async () => {
    daemon = await startPsrigd({ psrigd, sourceDir, webRoot, rigName: 'bench-1' });
    browser = await launch();
  });
  after(async () => {
    await browser?.close();
    await daemon?.stop();
  });

  test('static files: MIME types, no listing, nothing outside the folder', async () => {
    const index = await fetch(`${daemon.url}/`);
    assert.equal(index.status, 200);
    assert.match(index.headers.get('content-type'), /^text\/html/);
    assert.match(index.headers.get('content-security-policy'), /default-src 'self'/);
    const html = await index.text();
    const script = html.match(/src="\.?\/?(assets\/[^"]+\.js)"/)[1];
    const js = await fetch(`${daemon.url}/${script}`);
    assert.equal(js.status, 200);
    assert.match(js.headers.get('content-type'), /javascript/);
    assert.equal((await fetch(`${daemon.url}/assets/`)).status, 404); // no listing
    for (const path of ['/../rig.toml', '/%2e%2e/rig.toml', '/assets/../../rig.toml'])
      assert.equal((await fetch(`${daemon.url}${path}`)).status === 200, false, path);
  });

  test('start a scan, follow it live, find it, open it, see it in 3D', async () => {
    const page = await browser.newPage();
    const problems = watch(page);
    await page.goto(`${daemon.url}/#/rig`);
    await page.waitForSelector('form.start-scan');
    await page.type('#scan-sample', 'JERSEY-0042');
    await page.type('#scan-description', 'Cotton single jersey, navy');
    await page.type('#scan-tags', 'cotton, knit');
    await page.click('form.start-scan button[type=submit]');
    // Live progress from the event stream: a step shows, then done.
    await page.waitForSelector('li.followed[data-state=running], li.followed[data-state=done]', { timeout: 30_000 });
    await page.waitForSelector('li.followed[data-state=done]', { timeout: 60_000 });
    await shot(page, 'rig');
    const steps = await page.$eval('li.followed', (li) => li.textContent);
    assert.match(steps, /JERSEY-0042/);

    // Search by text and by tag.
    await page.goto(`${daemon.url}/#/`);
    await page.waitForSelector('form.search');
    await page.type('#f-q', 'jersey-00');
    await page.click('form.search button[type=submit]');
    await page.waitForFunction(() => document.querySelectorAll('li.card').length === 1);
    await page.waitForFunction(() => document.querySelector('li.card img')?.naturalWidth > 0);
    await shot(page, 'catalogue');
    assert.match(await page.$eval('li.card', (c) => c.textContent), /Cotton single jersey, navy/);

    await page.click('li.card a');
    await page.waitForSelector('.viewer[data-ready=true]', { timeout: 60_000 });
    await page.waitForFunction(() => Number(document.querySelector('canvas.swatch-canvas').dataset.frames) > 5);
    await page.click('#sv-orbit'); // stop the orbit: the picture changes only when we move the light
    const before = await canvasPixels(page);
    assert.ok(spread(before) > 8, `the 3D view looks blank (luma spread ${spread(before).toFixed(1)})`);
    await page.$eval('#sv-light-azimuth', (input) => {
      input.value = String((Number(input.value) + 150) % 360);
      input.dispatchEvent(new Event('input'));
    });
    await new Promise((r) => setTimeout(r, 500));
    const moved = await canvasPixels(page);
    assert.ok(meanDifference(before, moved) > 2, 'moving the light did not change the picture');
    await shot(page, 'scan');

    // Download the glTF from the page, as a designer would, and validate it.
    const downloads = mkdtempSync(join(tmpdir(), 'psrig-downloads-'));
    const cdp = await page.createCDPSession();
    await cdp.send('Browser.setDownloadBehavior', { behavior: 'allow', downloadPath: downloads });
    const [glbButton] = await page.$$('xpath/.//button[contains(., ".glb")]');
    await glbButton.click();
    const glb = join(downloads, 'JERSEY-0042.glb');
    for (let i = 0; i < 100 && !existsSync(glb); i++) await new Promise((r) => setTimeout(r, 100));
    assert.ok(existsSync(glb), `no download in ${downloads}: ${readdirSync(downloads)}`);
    const validator = join(sourceDir, 'tools/node/validate-gltf.mjs');
    assert.ok(existsSync(join(sourceDir, 'tools/node/node_modules/gltf-validator')),
      'the glTF-Validator is not installed: run scripts/install-deps');
    const report = JSON.parse(execFileSync('node', [validator, glb], { encoding: 'utf8' }));
    assert.equal(report.issues.numErrors, 0, JSON.stringify(report.issues.messages));
    assert.equal(report.issues.numWarnings, 0, JSON.stringify(report.issues.messages));
    rmSync(downloads, { recursive: true, force: true });
    assert.deepEqual(problems, []);
    await page.close();
  });

  test('a sample id with markup stays text', async () => {
    const id = '<script>window.__owned=1</script><img src=x onerror="window.__owned=2">';
    const row = await scanUntilDone(daemon, { sample_id: id, description: '<b>bold?</b>' });
    const page = await browser.newPage();
    await page.goto(`${daemon.url}/#/`);
    await page.waitForSelector('li.card h3');
    const titles = await page.$$eval('li.card h3', (hs) => hs.map((h) => h.textContent));
    assert.ok(titles.includes(id));
    await page.goto(`${daemon.url}/#/scans/${row.id}`);
    await page.waitForSelector('h1');
    assert.equal(await page.$eval('h1', (h) => h.textContent), id);
    assert.equal(await page.evaluate(() => window.__owned), undefined);
    assert.equal(await page.$$eval('main script, main b', (e) => e.length), 0);
    await page.close();
  });

  test('a rig filter, and each rig with its status', async () => {
    await scanUntilDone(daemon, { sample_id: 'RIG-FILTER' });
    const page = await browser.newPage();
    const problems = watch(page);
    await page.goto(`${daemon.url}/#/`);
    await page.waitForSelector('#f-rig option[value="bench-1"]');
    const { total } = await (await daemon.api('/v1/scans?limit=1')).json();
    await page.select('#f-rig', 'bench-1');
    await page.click('form.search button[type=submit]');
    await page.waitForFunction(
      (n) => location.hash.includes('rig=bench-1') &&
        document.querySelector('section.results')?.getAttribute('aria-busy') === 'false' &&
        document.querySelectorAll('li.card').length === n,
      {}, Math.min(total, 48));
    const rigs = await page.$$eval('li.card .meta .rig', (spans) => spans.map((span) => span.textContent));
    assert.ok(rigs.length > 0 && rigs.every((rig) => rig === 'bench-1'), rigs.join());
    await page.goto(`${daemon.url}/#/?rig=no-such-rig`);
    await page.waitForFunction(() => /No scans match/.test(document.querySelector('.pager .count')?.textContent ?? ''));
    await page.goto(`${daemon.url}/#/rig`);
    await page.waitForSelector('table.rigs tr[data-rig="bench-1"][data-online="true"]');
    const state = await page.$eval('table.rigs tr[data-rig="bench-1"] .rig-state', (td) => td.textContent);
    assert.match(state, /idle|scanning|processing/);
    assert.equal(await page.$eval('#scan-rig', (select) => select.value), 'bench-1');
    assert.deepEqual(problems, []);
    await page.close();
  });

  test('Cancel stops a queued scan; All lights off stops everything', async () => {
    const page = await browser.newPage();
    await page.goto(`${daemon.url}/#/rig`);
    await page.waitForSelector('form.start-scan');
    // Three at once: the first runs, the others wait and can be cancelled.
    for (const id of ['Q-1', 'Q-2', 'Q-3']) {
      await page.$eval('#scan-sample', (input, value) => (input.value = value), id);
      await page.click('form.start-scan button[type=submit]');
      await page.waitForFunction((value) => [...document.querySelectorAll('li.followed a')].some((a) => a.textContent === value), {}, id);
    }
    const cancel = await page.waitForSelector('xpath/.//li[contains(@class, "followed")][a[text()="Q-3"]]//button[text()="Cancel"]');
    await cancel.click();
    await page.waitForFunction(() =>
      [...document.querySelectorAll('li.followed')].some((li) => li.querySelector('a').textContent === 'Q-3' && li.dataset.state === 'aborted'));
    await page.click('#lights-off');
    await page.waitForFunction(() => /Every LED is off/.test(document.getElementById('notices').textContent));
    // Every scan has ended, none is left waiting, and psrigd still serves.
    await page.waitForFunction(() => [...document.querySelectorAll('li.followed')].every((li) => !['queued', 'running'].includes(li.dataset.state)), { timeout: 30_000 });
    const status = await (await daemon.api('/v1/status')).json();
    assert.equal(status.queue_length, 0);
    assert.ok(['idle', 'error'].includes(status.state), status.state);
    await shot(page, 'rig-lights-off');
    await page.close();
  });

  test('no serious accessibility violations (axe-core)', async () => {
    const axe = readFileSync(require.resolve('axe-core/axe.min.js'), 'utf8');
    const page = await browser.newPage();
    for (const [name, hash] of [['catalogue', '#/'], ['rig', '#/rig']]) {
      await page.goto(`${daemon.url}/${hash}`);
      await page.waitForSelector('main h1');
      await page.evaluate(axe);
      const result = await page.evaluate(async () => window.axe.run(document, { resultTypes: ['violations'] }));
      const serious = result.violations.filter((v) => ['serious', 'critical'].includes(v.impact));
      assert.deepEqual(serious.map((v) => `${name}: ${v.id}: ${v.help}: ${v.nodes.map((n) => n.target.join(' ')).join(', ')}`), []);
    }
    await page.close();
  });
});

describe('web catalogue with a token', { skip }, () => {
  let daemon;
  let browser;
  before(async () => {
    daemon = await startPsrigd({ psrigd, sourceDir, webRoot, token: TOKEN });
    browser = await launch();
  });
  after(async () => {
    await browser?.close();
    await daemon?.stop();
  });

  test('asks for the token once, refuses a wrong one clearly, never puts it in a URL', async () => {
    const page = await browser.newPage();
    const urls = [];
    page.on('request', (request) => urls.push(request.url()));
    await page.goto(`${daemon.url}/#/`);
    await page.waitForSelector('#token-dialog[open]');
    await page.type('#token-input', 'wrong-token-wrong-token');
    await page.click('#token-dialog button[value=ok]');
    await page.waitForFunction(() => /refused/.test(document.getElementById('token-reason').textContent));
    assert.ok(await page.$('#token-dialog[open]'));
    await page.$eval('#token-input', (input) => (input.value = ''));
    await page.type('#token-input', TOKEN);
    await page.click('#token-dialog button[value=ok]');
    await page.waitForSelector('.pager .count');
    assert.match(await page.$eval('.pager .count', (e) => e.textContent), /No scans match/);
    // Later requests reuse it: no second question.
    await page.goto(`${daemon.url}/#/rig`);
    await page.waitForSelector('form.start-scan');
    assert.equal(await page.$('#token-dialog[open]'), null);
    await shot(page, 'rig-with-token');
    assert.ok(urls.every((url) => !url.includes(TOKEN)), 'the token appeared in a URL');
    await page.close();
  });
});

// Several rigs on one shared PostgreSQL catalogue, seen through a
// catalogue-only psrigd: each rig's status, a scan started on the rig
// chosen, the catalogue filtered by rig.
const labSkip = skip || (postgresBinDir() ? false : 'no PostgreSQL server programs (apt-get install postgresql-15; scripts/install-deps does)');

describe("web catalogue over a lab's rigs", { skip: labSkip }, () => {
  let postgres;
  let shared;
  let rigA;
  let rigB;
  let front;
  let browser;
  before(async () => {
    postgres = startPostgres();
    const catalogueUrl = postgres.createDatabase();
    shared = mkdtempSync(join(tmpdir(), 'psrig-web-shared-'));
    const common = { psrigd, sourceDir, webRoot, catalogueUrl, storageRoot: shared };
    rigA = await startPsrigd({ ...common, rigName: 'rig-a' });
    rigB = await startPsrigd({ ...common, rigName: 'rig-b' });
    front = await startPsrigd({ ...common, rigName: 'front', role: 'catalogue' });
    browser = await launch();
  });
  after(async () => {
    await browser?.close();
    for (const daemon of [front, rigB, rigA]) await daemon?.stop();
    postgres?.stop();
    if (shared) rmSync(shared, { recursive: true, force: true });
  });

  test("each rig's status; a scan on the rig chosen; the catalogue by rig", async () => {
    const page = await browser.newPage();
    const problems = watch(page);
    await page.goto(`${front.url}/#/rig`);
    for (const name of ['rig-a', 'rig-b'])
      await page.waitForSelector(`table.rigs tr[data-rig="${name}"][data-online="true"]`);
    assert.equal(await page.$eval('#lights-off', (button) => getComputedStyle(button).display), 'none',
      'no lights here to switch off');
    await page.select('#scan-rig', 'rig-b');
    await page.type('#scan-sample', 'LAB-B-1');
    await page.click('form.start-scan button[type=submit]');
    await page.waitForSelector('li.followed[data-state=done]', { timeout: 60_000 });
    await shot(page, 'rigs');
    // Scanned by rig B's own psrigd.
    const onB = await (await rigB.api('/v1/scans?q=LAB-B-1')).json();
    assert.equal(onB.total, 1);
    assert.equal(onB.scans[0].rig, 'rig-b');

    await page.goto(`${front.url}/#/?rig=rig-b`);
    await page.waitForFunction(() => document.querySelectorAll('li.card').length === 1);
    await page.waitForFunction(() => document.querySelector('li.card img')?.naturalWidth > 0);
    assert.match(await page.$eval('li.card', (card) => card.textContent), /LAB-B-1[\s\S]*rig-b/);
    await shot(page, 'catalogue-by-rig');
    await page.goto(`${front.url}/#/?rig=rig-a`);
    await page.waitForFunction(() => /No scans match/.test(document.querySelector('.pager .count')?.textContent ?? ''));
    assert.deepEqual(problems, []);
    await page.close();
  });
});
