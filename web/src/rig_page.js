// Rig control: start a scan (on this psrigd's rig, or with a shared
// catalogue on any rig of the lab), follow it live through psrigd's event
// stream (a scan on another rig: its row, polled), cancel it, switch every
// light off, and see each rig's status and the age of its calibration.
import { followEvents, getJson, postJson } from './api.js';
import { clear, h, notice } from './dom.js';
import { calibrationText, onStatus, refreshStatus, stateText } from './rig_status.js';
import { listRigs, rigsTable } from './rigs.js';

// The rig a scan goes to: this psrigd's own unless another is chosen.
function rigChoice() {
  const select = h('select', { id: 'scan-rig', name: 'rig' });
  return {
    select,
    update(rigs) {
      const chosen = select.value;
      clear(select, rigs.map((rig) =>
        h('option', { value: rig.name, selected: chosen ? rig.name === chosen : rig.this },
          `${rig.name}${rig.online ? '' : ' (offline)'}`)));
    },
    // Nothing when this psrigd's own rig is chosen (or the list is not in yet).
    remote(rigs) {
      const rig = rigs.find((r) => r.name === select.value);
      return rig && !rig.this ? rig.name : null;
    },
  };
}

function scanForm(onStarted, rigs) {
  const field = (name, label, input) =>
    h('div', { class: 'field' }, h('label', { for: `scan-${name}` }, label), input);
  const sample = h('input', { id: 'scan-sample', name: 'sample_id', maxlength: 128, autocomplete: 'off' });
  const description = h('textarea', { id: 'scan-description', name: 'description', rows: 2, maxlength: 2000 });
  const tags = h('input', { id: 'scan-tags', name: 'tags', placeholder: 'comma separated', autocomplete: 'off' });
  const form = h(
    'form',
    { class: 'start-scan', 'aria-labelledby': 'start-title' },
    h('h2', { id: 'start-title' }, 'Start a scan'),
    field('sample', 'Sample id', sample),
    field('description', 'Description', description),
    field('tags', 'Tags', tags),
    field('rig', 'Rig', rigs.choice.select),
    h('div', { class: 'actions' }, h('button', { type: 'submit', class: 'primary' }, 'Scan')),
  );
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    const body = {};
    if (sample.value.trim()) body.sample_id = sample.value.trim();
    if (description.value.trim()) body.description = description.value.trim();
    const tagList = tags.value.split(',').map((t) => t.trim()).filter(Boolean);
    if (tagList.length) body.tags = tagList;
    const remote = rigs.choice.remote(rigs.list);
    if (remote) body.rig = remote;
    try {
      const { id } = await postJson('/v1/scans', body);
      notice(remote ? `Scan ${id} queued on ${remote}.` : `Scan ${id} queued.`);
      onStarted(id, body.sample_id, remote);
      form.reset();
      refreshStatus();
    } catch (error) {
      notice(`The scan was not started: ${error.message}`, 'error');
    }
  });
  return form;
}

// One followed scan: its steps as they come, a progress bar, Cancel.
function scanProgress(id, sampleId) {
  const bar = h('progress', { max: 100, value: 0, 'aria-label': `Scan ${id} progress` });
  const step = h('span', { class: 'step' }, 'queued');
  const result = h('span', { class: 'result' });
  const cancel = h('button', { type: 'button' }, 'Cancel');
  cancel.addEventListener('click', async () => {
    try {
      await postJson(`/v1/scans/${id}/cancel`);
    } catch (error) {
      notice(`Cancel: ${error.message}`, 'error');
    }
  });
  const link = h('a', { href: `#/scans/${id}` }, sampleId || `scan ${id}`);
  const item = h('li', { class: 'followed', dataset: { scan: id, state: 'queued' } },
    link, step, bar, result, cancel);
  return {
    item,
    // The event stream may name the scan before the POST that started it
    // returns: the sample id comes later.
    name(sample) {
      if (sample) link.textContent = sample;
    },
    update(message) {
      const data = message.data;
      if (message.event === 'progress') {
        item.dataset.state = 'running';
        step.textContent = data.step ?? '';
        bar.value = data.percent ?? 0;
      } else if (message.event === 'done') {
        item.dataset.state = 'done';
        bar.value = 100;
        step.textContent = 'done';
        const error = data.angular_error_deg;
        result.textContent = typeof error === 'number' ? `${error.toFixed(2)}° mean error` : '';
        cancel.remove();
      } else if (message.event === 'error') {
        item.dataset.state = data.status ?? 'failed';
        step.textContent = data.status ?? 'failed';
        result.textContent = data.error ?? '';
        result.classList.add('error');
        cancel.remove();
      }
    },
  };
}

// A scan on another rig: its steps are on that rig's event stream, so its
// row is read every second until it has finished.
function pollRow(id, progress, signal) {
  const tick = async () => {
    if (signal.aborted) return;
    try {
      const row = await getJson(`/v1/scans/${id}`);
      if (row.status === 'running') progress.update({ event: 'progress', data: { step: `running on ${row.rig}`, percent: 50 } });
      else if (row.status === 'done') return progress.update({ event: 'done', data: {} });
      else if (row.status !== 'queued')
        return progress.update({ event: 'error', data: { status: row.status, error: row.error?.message } });
    } catch {
      // the catalogue busy or away: try again
    }
    setTimeout(tick, 1000);
  };
  tick();
}

export function renderRig(main) {
  const followed = new Map();
  const stream = new AbortController();
  const list = h('ul', { class: 'followed-scans', 'aria-live': 'polite' });
  const statusList = h('dl', { class: 'figures' });
  const rigsSection = h('section', { 'aria-labelledby': 'rigs-title', class: 'rigs' },
    h('h2', { id: 'rigs-title' }, 'Rigs'), h('p', { class: 'missing' }, 'asking psrigd…'));
  const rigs = { list: [], choice: rigChoice() };
  const showRigs = async () => {
    try {
      rigs.list = (await listRigs()).rigs;
      rigs.choice.update(rigs.list);
      clear(rigsSection, h('h2', { id: 'rigs-title' }, 'Rigs'), rigsTable(rigs.list));
    } catch (error) {
      clear(rigsSection, h('h2', { id: 'rigs-title' }, 'Rigs'), h('p', { class: 'error' }, `Cannot list the rigs: ${error.message}`));
    }
  };
  const follow = (id, sampleId, remote = null) => {
    if (followed.has(id)) {
      followed.get(id).name(sampleId);
      return followed.get(id);
    }
    const progress = scanProgress(id, sampleId);
    followed.set(id, progress);
    list.prepend(progress.item);
    if (remote) pollRow(id, progress, stream.signal);
    return progress;
  };
  clear(
    main,
    h('h1', {}, 'Rig'),
    h('div', { class: 'rig-columns' },
      scanForm(follow, rigs),
      h('section', { 'aria-labelledby': 'status-title' }, h('h2', { id: 'status-title' }, 'psrigd'), statusList)),
    rigsSection,
    h('section', { 'aria-labelledby': 'live-title' }, h('h2', { id: 'live-title' }, 'Scans started or seen here'), list),
  );
  const stopWatching = onStatus((status) => {
    const calibration = calibrationText(status);
    const items = [
      ['Rig', status.role === 'catalogue' ? 'none: this psrigd serves the catalogue' : status.rig ?? '—'],
      ['Catalogue', status.catalogue === 'postgresql' ? 'shared (PostgreSQL)' : status.catalogue ? 'this rig’s own (SQLite)' : '—'],
      ['State', stateText(status)],
      ['Queue', status.queue_length === undefined ? '—' : `${status.queue_length} of ${status.queue_limit}`],
      ['Completed', status.scans_completed ?? '—'],
      ['Failed', status.scans_failed ?? '—'],
      ['Lights', status.devices?.lights || '—'],
      ['Camera', status.devices?.camera || '—'],
      ['Calibration', calibration ? calibration.text : '—'],
    ];
    // No rig here: the rest would describe nothing.
    if (status.role === 'catalogue') items.splice(3);
    if (status.last_error?.message) items.push(['Last error', `${status.last_error.code_name}: ${status.last_error.message}`]);
    if (status.devices?.error) items.push(['Device error', status.devices.error]);
    clear(statusList, items.map(([k, v]) => [h('dt', {}, k), h('dd', {}, String(v))]));
    if (status.current_scan) follow(status.current_scan);
    showRigs();
  });
  followEvents((message) => {
    const id = message.data?.id;
    if (!id) return;
    follow(id, message.data.sample_id).update(message);
    if (message.event !== 'progress') refreshStatus();
  }, stream.signal).catch((error) => notice(`Live progress stopped: ${error.message}`, 'error'));
  return () => {
    stream.abort();
    stopWatching();
  };
}
