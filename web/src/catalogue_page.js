// The catalogue: every scan as a card, searched and paged through the API
// (GET /v1/scans). The search lives in the address (#/?q=…&offset=…) so a
// search can be bookmarked and the back button works.
import { getJson, objectUrl } from './api.js';
import { clear, formatTime, h, notice } from './dom.js';
import { fabricFigures } from './fabric.js';
import { listRigs } from './rigs.js';

const PAGE_SIZE = 48;

const RANGE_FILTERS = [
  ['wales', 'Wales per cm'],
  ['courses', 'Courses per cm'],
  ['ends', 'Ends per cm'],
  ['picks', 'Picks per cm'],
];
const TEXT_FILTERS = ['q', 'tag', 'rig', 'status', 'from', 'to'];

function filterNames() {
  return [...TEXT_FILTERS, ...RANGE_FILTERS.flatMap(([name]) => [`${name}_min`, `${name}_max`])];
}

function searchForm(params) {
  const field = (name, label, attributes = {}) =>
    h(
      'div',
      { class: 'field' },
      h('label', { for: `f-${name}` }, label),
      h('input', { id: `f-${name}`, name, value: params.get(name) ?? '', ...attributes }),
    );
  const status = h(
    'select',
    { id: 'f-status', name: 'status' },
    ['', 'queued', 'running', 'done', 'failed', 'aborted'].map((value) =>
      h('option', { value, selected: params.get('status') === value }, value || 'any'),
    ),
  );
  // The rigs come from the catalogue (GET /v1/rigs); the one searched for
  // is an option before they arrive.
  const rig = h(
    'select',
    { id: 'f-rig', name: 'rig' },
    h('option', { value: '' }, 'any'),
    params.get('rig') ? h('option', { value: params.get('rig'), selected: true }, params.get('rig')) : null,
  );
  listRigs()
    .then(({ rigs }) => {
      for (const { name } of rigs)
        if (name !== params.get('rig')) rig.append(h('option', { value: name }, name));
    })
    .catch(() => {});
  const bound = (name, label, side, placeholder) =>
    h('input', {
      name: `${name}_${side}`,
      type: 'number',
      step: 'any',
      min: 0,
      value: params.get(`${name}_${side}`) ?? '',
      'aria-label': `${label}, ${side === 'min' ? 'at least' : 'at most'}`,
      placeholder,
    });
  const ranges = RANGE_FILTERS.map(([name, label]) =>
    h(
      'div',
      { class: 'range' },
      h('span', {}, label),
      bound(name, label, 'min', 'from'),
      bound(name, label, 'max', 'to'),
    ),
  );
  const openRanges = RANGE_FILTERS.some(([n]) => params.get(`${n}_min`) || params.get(`${n}_max`));
  const form = h(
    'form',
    { class: 'search', role: 'search', 'aria-label': 'Search scans' },
    field('q', 'Text', { type: 'search', placeholder: 'sample id or description' }),
    field('tag', 'Tag'),
    h('div', { class: 'field' }, h('label', { for: 'f-rig' }, 'Rig'), rig),
    h('div', { class: 'field' }, h('label', { for: 'f-status' }, 'Status'), status),
    field('from', 'From', { type: 'date' }),
    field('to', 'To', { type: 'date' }),
    h('details', { class: 'ranges', open: openRanges }, h('summary', {}, 'Measurements'), ranges),
    h(
      'div',
      { class: 'actions' },
      h('button', { type: 'submit', class: 'primary' }, 'Search'),
      h('a', { href: '#/', class: 'button' }, 'Clear'),
    ),
  );
  form.addEventListener('submit', (event) => {
    event.preventDefault();
    const next = new URLSearchParams();
    for (const name of filterNames()) {
      const value = form.elements[name]?.value?.trim();
      if (value) next.set(name, value);
    }
    location.hash = `#/?${next}`;
  });
  return form;
}

function statusBadge(status) {
  return h('span', { class: `badge status-${status}` }, status);
}

// The card's picture: the albedo thumbnail, the relit view on hover or
// focus. Both come through the API with the token, as object URLs.
function thumbnail(scan, urls) {
  const img = h('img', {
    alt: `Albedo of ${scan.sample_id || `scan ${scan.id}`}`,
    loading: 'lazy',
    width: 256,
    height: 192,
  });
  const frame = h('div', { class: 'thumb' }, img);
  if (scan.status !== 'done') {
    frame.classList.add('empty');
    img.remove();
    frame.append(h('span', {}, scan.status === 'running' ? 'scanning…' : 'no maps'));
    return frame;
  }
  let albedo = null;
  let relit = null;
  objectUrl(`/v1/scans/${scan.id}/thumbnail`)
    .then((url) => {
      albedo = url;
      urls.push(url);
      img.src = url;
    })
    .catch(() => frame.classList.add('empty'));
  const showRelit = async () => {
    if (!relit) {
      try {
        relit = await objectUrl(`/v1/scans/${scan.id}/relit`);
        urls.push(relit);
      } catch {
        return;
      }
    }
    img.src = relit;
  };
  const showAlbedo = () => {
    if (albedo) img.src = albedo;
  };
  frame.addEventListener('mouseenter', showRelit);
  frame.addEventListener('mouseleave', showAlbedo);
  frame.addEventListener('focusin', showRelit);
  frame.addEventListener('focusout', showAlbedo);
  return frame;
}

function card(scan, urls) {
  const figures = fabricFigures(scan.fabric ?? scan.report?.fabric);
  const title = scan.sample_id || `scan ${scan.id}`;
  return h(
    'li',
    { class: 'card' },
    h(
      'a',
      { href: `#/scans/${scan.id}`, class: 'card-link' },
      thumbnail(scan, urls),
      h('h3', {}, title),
    ),
    scan.description ? h('p', { class: 'description' }, scan.description) : null,
    h(
      'p',
      { class: 'meta' },
      statusBadge(scan.status),
      h('time', { datetime: scan.created }, formatTime(scan.created)),
      scan.rig ? h('span', { class: 'rig' }, scan.rig) : null,
    ),
    scan.tags?.length ? h('ul', { class: 'tags' }, scan.tags.map((t) => h('li', {}, t))) : null,
    figures.length ? h('p', { class: 'figures' }, figures.join(' · ')) : null,
  );
}

export function renderCatalogue(main, params) {
  const urls = [];
  const offset = Math.max(0, Number(params.get('offset')) || 0);
  const results = h('section', { class: 'results', 'aria-label': 'Scans', 'aria-busy': 'true' });
  clear(main, h('h1', {}, 'Scans'), searchForm(params), results);

  const query = new URLSearchParams();
  for (const name of filterNames()) if (params.get(name)) query.set(name, params.get(name));
  query.set('limit', PAGE_SIZE);
  query.set('offset', offset);

  let gone = false;
  getJson(`/v1/scans?${query}`)
    .then((answer) => {
      if (gone) return;
      const scans = answer.scans ?? [];
      const total = answer.total;
      const pageLink = (to, label, rel) => {
        const next = new URLSearchParams(params);
        next.set('offset', to);
        return h('a', { href: `#/?${next}`, class: 'button', rel }, label);
      };
      const first = scans.length ? offset + 1 : 0;
      const counted =
        typeof total === 'number'
          ? `${first}–${offset + scans.length} of ${total.toLocaleString()}`
          : `${first}–${offset + scans.length}`;
      const pager = h(
        'nav',
        { class: 'pager', 'aria-label': 'Pages of scans' },
        offset > 0 ? pageLink(Math.max(0, offset - PAGE_SIZE), '← Newer', 'prev') : null,
        h('span', { class: 'count' }, scans.length ? `Scans ${counted}` : 'No scans match.'),
        (typeof total === 'number' ? offset + scans.length < total : scans.length === PAGE_SIZE)
          ? pageLink(offset + PAGE_SIZE, 'Older →', 'next')
          : null,
      );
      clear(results, pager, h('ul', { class: 'cards' }, scans.map((s) => card(s, urls))));
      results.setAttribute('aria-busy', 'false');
    })
    .catch((error) => {
      if (gone) return;
      clear(results, h('p', { class: 'error', role: 'alert' }, `Cannot list scans: ${error.message}`));
      results.setAttribute('aria-busy', 'false');
      notice(error.message, 'error');
    });
  return () => {
    gone = true;
    for (const url of urls) URL.revokeObjectURL(url);
  };
}
