// Rig control: start a scan, follow it live through psrigd's event stream,
// cancel it, switch every light off, and see psrigd's status and the age of
// its calibration.
import { followEvents, postJson } from './api.js';
import { clear, h, notice } from './dom.js';
import { calibrationText, onStatus, refreshStatus, stateText } from './rig_status.js';

function scanForm(onStarted) {
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
    h('div', { class: 'actions' }, h('button', { type: 'submit', class: 'primary' }, 'Scan')),
  );
  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    const body = {};
    if (sample.value.trim()) body.sample_id = sample.value.trim();
    if (description.value.trim()) body.description = description.value.trim();
    const tagList = tags.value.split(',').map((t) => t.trim()).filter(Boolean);
    if (tagList.length) body.tags = tagList;
    try {
      const { id } = await postJson('/v1/scans', body);
      notice(`Scan ${id} queued.`);
      onStarted(id, body.sample_id);
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

export function renderRig(main) {
  const followed = new Map();
  const list = h('ul', { class: 'followed-scans', 'aria-live': 'polite' });
  const statusList = h('dl', { class: 'figures' });
  const follow = (id, sampleId) => {
    if (followed.has(id)) {
      followed.get(id).name(sampleId);
      return followed.get(id);
    }
    const progress = scanProgress(id, sampleId);
    followed.set(id, progress);
    list.prepend(progress.item);
    return progress;
  };
  clear(
    main,
    h('h1', {}, 'Rig'),
    h('div', { class: 'rig-columns' },
      scanForm(follow),
      h('section', { 'aria-labelledby': 'status-title' }, h('h2', { id: 'status-title' }, 'psrigd'), statusList)),
    h('section', { 'aria-labelledby': 'live-title' }, h('h2', { id: 'live-title' }, 'Scans started or seen here'), list),
  );
  const stopWatching = onStatus((status) => {
    const calibration = calibrationText(status);
    const items = [
      ['State', stateText(status)],
      ['Queue', status.queue_length === undefined ? '—' : `${status.queue_length} of ${status.queue_limit}`],
      ['Completed', status.scans_completed ?? '—'],
      ['Failed', status.scans_failed ?? '—'],
      ['Lights', status.devices?.lights || '—'],
      ['Camera', status.devices?.camera || '—'],
      ['Calibration', calibration ? calibration.text : '—'],
    ];
    if (status.last_error?.message) items.push(['Last error', `${status.last_error.code_name}: ${status.last_error.message}`]);
    if (status.devices?.error) items.push(['Device error', status.devices.error]);
    clear(statusList, items.map(([k, v]) => [h('dt', {}, k), h('dd', {}, String(v))]));
    if (status.current_scan) follow(status.current_scan);
  });
  const stream = new AbortController();
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
