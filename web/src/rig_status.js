// psrigd's status, polled for the header and the rig page: what it is
// doing and how old its calibration is.
import { getJson } from './api.js';
import { clear, h } from './dom.js';

const listeners = new Set();
let latest = null;

export function latestStatus() {
  return latest;
}

export function onStatus(listener) {
  listeners.add(listener);
  if (latest) listener(latest);
  return () => listeners.delete(listener);
}

export async function refreshStatus() {
  try {
    latest = await getJson('/v1/status');
  } catch (error) {
    latest = { state: 'unreachable', error: error.message };
  }
  for (const listener of listeners) listener(latest);
  return latest;
}

// "calibrated 3 days ago", "calibration 40 days old", "no calibration".
export function calibrationText(status) {
  const calibration = status?.calibration;
  if (!calibration || status.role === 'catalogue') return null;
  if (calibration.missing) return { text: 'no calibration', warn: true };
  const days = Math.floor(calibration.age_days ?? 0);
  const age = days === 0 ? 'today' : days === 1 ? '1 day ago' : `${days} days ago`;
  return calibration.stale
    ? { text: `calibration ${days} days old: recalibrate`, warn: true }
    : { text: `calibrated ${age}`, warn: false };
}

export function stateText(status) {
  if (!status) return '…';
  if (status.state === 'unreachable') return 'psrigd unreachable';
  if (status.role === 'catalogue') return 'catalogue only';
  if (status.step) return `${status.state}: ${status.step} (${status.progress_percent ?? 0} %)`;
  return status.state;
}

export function startStatusWatch(element) {
  onStatus((status) => {
    const calibration = calibrationText(status);
    clear(
      element,
      h('span', { class: `state state-${status.state}` }, stateText(status)),
      status.queue_length ? h('span', {}, `${status.queue_length} queued`) : null,
      calibration ? h('span', { class: calibration.warn ? 'warn' : '' }, calibration.text) : null,
    );
  });
  refreshStatus();
  setInterval(() => {
    if (document.visibilityState === 'visible') refreshStatus();
  }, 3000);
}
