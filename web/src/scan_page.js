// One scan: the 3D view of its seamless tile, its maps (the height with a
// scale bar in millimetres), the report's figures and every download.
import { arrayBuffer, download, getJson, objectUrl } from './api.js';
import { clear, formatNumber, formatTime, h, notice } from './dom.js';
import { fabricFigures } from './fabric.js';
import { SwatchView, materialFromGlb } from './swatch_view.js';

// The exports psrigd serves as one file each (GET /v1/scans/{id}/export/{format}).
const EXPORTS = [
  ['glb', 'glTF 2.0 (.glb): Blender, web, game engines', 'glb'],
  ['u3ma', 'U3M 1.1 (.u3ma): CLO3D, Browzwear', 'u3ma'],
];

function figure(label, value) {
  return [h('dt', {}, label), h('dd', {}, value)];
}

function mapFigure(scan, name, caption, urls, extra = null) {
  const img = h('img', { alt: caption, width: 320, height: 240 });
  objectUrl(`/v1/scans/${scan.id}/files/${name}`)
    .then((url) => {
      urls.push(url);
      img.src = url;
    })
    .catch(() => img.replaceWith(h('span', { class: 'missing' }, `${name}: not available`)));
  return h('figure', { class: 'map' }, img, extra, h('figcaption', {}, caption));
}

// The height map's scale: black is the lowest point, white the highest.
function heightScale(report) {
  const height = report?.height;
  const range = height?.png_range;
  if (!Array.isArray(range)) return null;
  const units = height.units === 'mm' ? 'mm' : 'px';
  const [low, high] = range;
  const digits = units === 'mm' ? 3 : 2;
  return h(
    'div',
    { class: 'height-scale', role: 'img', 'aria-label': `Height from ${low.toFixed(digits)} to ${high.toFixed(digits)} ${units}` },
    h('span', {}, `${low.toFixed(digits)} ${units}`),
    h('span', { class: 'bar' }),
    h('span', {}, `${high.toFixed(digits)} ${units}`),
  );
}

// scan.json's calibration: {"file", "created", "applied": ["lights", ...]}.
function calibrationText(calibration) {
  if (!calibration || typeof calibration !== 'object') return 'none (light directions from rig.toml)';
  const version = String(calibration.file ?? '').match(/calibrations\/(\d+)\//)?.[1];
  const applied = Array.isArray(calibration.applied) ? calibration.applied.join(', ') : '';
  return `${version ? `version ${version}` : 'yes'}${calibration.created ? ` of ${formatTime(calibration.created)}` : ''}${applied ? `: ${applied}` : ''}`;
}

function reportFigures(scan) {
  const report = scan.report ?? {};
  const pixels = report.pixels ?? {};
  const matrix = report.light_matrix ?? {};
  const items = [];
  if (typeof pixels.total === 'number')
    items.push(figure('Valid pixels', `${pixels.valid.toLocaleString()} of ${pixels.total.toLocaleString()} (${((100 * pixels.valid) / pixels.total).toFixed(1)} %)`));
  if (report.residual) items.push(figure('Residual', `mean ${formatNumber(report.residual.mean, 4)}, 95th percentile ${formatNumber(report.residual.p95, 4)} of full scale`));
  if (typeof matrix.condition_number === 'number') items.push(figure('Light matrix condition', formatNumber(matrix.condition_number, 2)));
  if (report.height) items.push(figure('Height range', `${formatNumber(report.height.range, 3)} ${report.height.units ?? ''} (${report.height.method ?? ''})`));
  const error = report.ground_truth?.angular_error_deg?.mean;
  if (typeof error === 'number') items.push(figure('Angular error vs. truth', `${error.toFixed(2)}° mean`));
  const fabric = fabricFigures(scan.fabric ?? report.fabric);
  if (fabric.length) items.push(figure('Fabric', fabric.join(' · ')));
  items.push(figure('Calibration', calibrationText(report.inputs?.calibration)));
  const directions = matrix.directions;
  const table = Array.isArray(directions)
    ? h(
        'table',
        { class: 'lights' },
        h('caption', {}, 'Light directions (x, y, z)'),
        h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'LED'), h('th', { scope: 'col' }, 'x'), h('th', { scope: 'col' }, 'y'), h('th', { scope: 'col' }, 'z'))),
        h('tbody', {}, directions.map((d, i) => h('tr', {}, h('th', { scope: 'row' }, String(i)), d.map((c) => h('td', {}, c.toFixed(3)))))),
      )
    : null;
  return [h('dl', { class: 'figures' }, items), table];
}

function downloads(scan) {
  const files = scan.files ?? [];
  const button = (path, name, label) =>
    h('button', {
      type: 'button',
      onclick: () => download(path, name).catch((e) => notice(`${label}: ${e.message}`, 'error')),
    }, label);
  const base = (scan.sample_id || `scan-${scan.id}`).replace(/[^\w.-]+/g, '_');
  return h(
    'section',
    { class: 'downloads', 'aria-labelledby': 'downloads-title' },
    h('h2', { id: 'downloads-title' }, 'Downloads'),
    h('h3', {}, 'Materials'),
    h('p', { class: 'buttons' }, EXPORTS.map(([format, label, ext]) =>
      button(`/v1/scans/${scan.id}/export/${format}`, `${base}.${ext}`, label))),
    h('h3', {}, 'Frames and maps'),
    h('p', { class: 'buttons' }, files.map((name) => button(`/v1/scans/${scan.id}/files/${name}`, `${base}-${name}`, name))),
  );
}

export function renderScan(main, id) {
  const urls = [];
  let view = null;
  let gone = false;
  clear(main, h('p', { 'aria-busy': 'true' }, `Loading scan ${id}…`));
  getJson(`/v1/scans/${id}`)
    .then((scan) => {
      if (gone) return;
      const title = scan.sample_id || `scan ${scan.id}`;
      const viewer = h('div', { class: 'viewer' });
      clear(
        main,
        h('p', {}, h('a', { href: '#/' }, '← All scans')),
        h('h1', {}, title),
        scan.description ? h('p', { class: 'description' }, scan.description) : null,
        h('p', { class: 'meta' }, h('span', { class: `badge status-${scan.status}` }, scan.status), ' ',
          h('time', { datetime: scan.created }, formatTime(scan.created)),
          scan.tags?.length ? [' · ', scan.tags.join(', ')] : null),
        scan.error ? h('p', { class: 'error' }, `${scan.error.code_name}: ${scan.error.message}`) : null,
        scan.status === 'done'
          ? [
              h('section', { class: 'view3d', 'aria-labelledby': 'view-title' }, h('h2', { id: 'view-title' }, 'The swatch in 3D'), viewer),
              h('section', { 'aria-labelledby': 'maps-title' }, h('h2', { id: 'maps-title' }, 'Maps'),
                h('div', { class: 'maps' },
                  mapFigure(scan, 'albedo.png', 'Albedo', urls),
                  mapFigure(scan, 'normal.png', 'Normal', urls),
                  mapFigure(scan, 'height.png', 'Height', urls, heightScale(scan.report)))),
              h('section', { 'aria-labelledby': 'report-title' }, h('h2', { id: 'report-title' }, 'Report'), reportFigures(scan)),
            ]
          : null,
        downloads(scan),
      );
      if (scan.status !== 'done') return;
      view = new SwatchView(viewer);
      arrayBuffer(`/v1/scans/${id}/export/glb`)
        .then(materialFromGlb)
        .then((material) => {
          if (!gone) view.show(material);
          viewer.dataset.ready = 'true';
        })
        .catch((error) => {
          viewer.dataset.ready = 'failed';
          notice(`3D view: ${error.message}`, 'error');
        });
    })
    .catch((error) => {
      if (gone) return;
      clear(main, h('p', {}, h('a', { href: '#/' }, '← All scans')),
        h('p', { class: 'error', role: 'alert' }, error.status === 404 ? `There is no scan ${id}.` : `Cannot load scan ${id}: ${error.message}`));
    });
  return () => {
    gone = true;
    view?.dispose();
    for (const url of urls) URL.revokeObjectURL(url);
  };
}
