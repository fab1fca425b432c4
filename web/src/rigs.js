// The lab's rigs as the catalogue knows them (GET /v1/rigs): each rig's
// name, whether it is online, and what its psrigd last said it was doing.
// One rig with the embedded catalogue; every rig of the lab with a shared one.
import { getJson } from './api.js';
import { h } from './dom.js';
import { calibrationText, stateText } from './rig_status.js';

export async function listRigs() {
  const answer = await getJson('/v1/rigs');
  return { rigs: answer.rigs ?? [], role: answer.role ?? 'rig' };
}

// "2 s ago", "5 min ago".
function ago(seconds) {
  if (typeof seconds !== 'number') return '—';
  if (seconds < 90) return `${Math.max(0, Math.round(seconds))} s ago`;
  if (seconds < 5400) return `${Math.round(seconds / 60)} min ago`;
  return `${Math.round(seconds / 3600)} h ago`;
}

export function rigStateText(rig) {
  if (!rig.online) return rig.status?.state === 'stopped' ? 'stopped' : 'offline';
  return stateText(rig.status);
}

// One row per rig: its state, queue, calibration and when it was last heard from.
export function rigsTable(rigs) {
  const row = (rig) => {
    const calibration = calibrationText(rig.status);
    return h(
      'tr',
      { dataset: { rig: rig.name, online: String(rig.online) } },
      h('th', { scope: 'row' }, rig.name, rig.this ? h('span', { class: 'this-rig' }, ' (this psrigd)') : null),
      h('td', {}, h('span', { class: `badge ${rig.online ? 'status-done' : 'status-failed'}` }, rig.online ? 'online' : 'offline')),
      h('td', { class: 'rig-state' }, rigStateText(rig)),
      h('td', {}, rig.status?.queue_length ?? '—'),
      h('td', { class: calibration?.warn ? 'warn' : '' }, calibration ? calibration.text : '—'),
      h('td', {}, ago(rig.seen_seconds_ago)),
    );
  };
  return h(
    'table',
    { class: 'rigs' },
    h('caption', {}, 'Each rig as its psrigd last reported it'),
    h('thead', {}, h('tr', {}, ['Rig', 'Online', 'State', 'Queue', 'Calibration', 'Last seen'].map((t) => h('th', { scope: 'col' }, t)))),
    h('tbody', {}, rigs.map(row)),
  );
}
