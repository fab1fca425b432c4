// The page's frame: the header (status, the lights-off button), the token
// dialog and the router between the catalogue, a scan and the rig.
import './style.css';
import { onTokenNeeded, postJson } from './api.js';
import { clear, notice } from './dom.js';
import { renderCatalogue } from './catalogue_page.js';
import { renderScan } from './scan_page.js';
import { renderRig } from './rig_page.js';
import { onStatus, startStatusWatch } from './rig_status.js';

const main = document.getElementById('main');
let leavePage = () => {};

function askToken(reason) {
  const dialog = document.getElementById('token-dialog');
  const input = document.getElementById('token-input');
  document.getElementById('token-reason').textContent = reason;
  input.value = '';
  dialog.showModal();
  return new Promise((resolve) => {
    dialog.addEventListener(
      'close',
      () => resolve(dialog.returnValue === 'ok' && input.value ? input.value : null),
      { once: true },
    );
  });
}
onTokenNeeded(askToken);

function route() {
  leavePage();
  const hash = location.hash.replace(/^#/, '') || '/';
  const [path, query = ''] = hash.split('?');
  const params = new URLSearchParams(query);
  const scan = path.match(/^\/scans\/(\d+)$/);
  for (const link of document.querySelectorAll('[data-nav]')) {
    const current = (link.dataset.nav === 'rig') === (path === '/rig');
    if (current) link.setAttribute('aria-current', 'page');
    else link.removeAttribute('aria-current');
  }
  clear(main);
  if (scan) leavePage = renderScan(main, Number(scan[1]));
  else if (path === '/rig') leavePage = renderRig(main);
  else leavePage = renderCatalogue(main, params);
  leavePage = leavePage ?? (() => {});
}

document.getElementById('lights-off').addEventListener('click', async () => {
  try {
    await postJson('/v1/lights/off');
    notice('Every LED is off; running and queued scans were stopped.');
  } catch (error) {
    notice(`Lights off failed: ${error.message}`, 'error');
  }
});

window.addEventListener('hashchange', route);
startStatusWatch(document.getElementById('rig-summary'));
// A catalogue-only psrigd has no lights of its own to switch off.
onStatus((status) => {
  document.getElementById('lights-off').hidden = status.role === 'catalogue';
});
route();
