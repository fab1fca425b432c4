// A real psrigd on the simulated rig for the browser tests: config/sim.toml
// at 160x120 with storage in a temp directory, on a free port, optionally
// with a token, a rig name, a shared catalogue (its URL and storage root)
// and the catalogue-only role.
import { spawn } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { createServer } from 'node:net';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

export function freePort() {
  return new Promise((resolve, reject) => {
    const server = createServer();
    server.once('error', reject);
    server.listen(0, '127.0.0.1', () => {
      const { port } = server.address();
      server.close(() => resolve(port));
    });
  });
}

export async function startPsrigd({
  psrigd, sourceDir, webRoot, token = null, rigName = null, catalogueUrl = null, storageRoot = null, role = 'rig',
}) {
  const dir = mkdtempSync(join(tmpdir(), 'psrig-web-'));
  const port = await freePort();
  let text = readFileSync(join(sourceDir, 'config/sim.toml'), 'utf8');
  const replace = (from, to) => {
    if (!text.includes(from)) throw new Error(`config/sim.toml no longer has ${from}`);
    text = text.replace(from, to);
  };
  replace('width = 640', 'width = 160');
  replace('height = 480', 'height = 120');
  replace('root = "../out/scans"', `root = "${storageRoot ?? 'scans'}"`);
  replace('port = 8470', `port = ${port}\nweb_root = "${webRoot}"${token ? `\ntoken = "${token}"` : ''}` +
    `${rigName ? `\nrig_name = "${rigName}"` : ''}\nrole = "${role}"`);
  if (catalogueUrl) text += `\n[catalogue]\nurl = "${catalogueUrl}"\n`;
  const config = join(dir, 'rig.toml');
  writeFileSync(config, text);
  const child = spawn(psrigd, ['--config', config], { stdio: ['ignore', 'ignore', 'pipe'] });
  let log = '';
  child.stderr.on('data', (chunk) => (log += chunk));
  const url = `http://127.0.0.1:${port}`;
  const deadline = Date.now() + 20_000;
  for (;;) {
    if (child.exitCode !== null) throw new Error(`psrigd exited (${child.exitCode}):\n${log}`);
    try {
      const response = await fetch(`${url}/index.html`);
      if (response.ok) break;
    } catch {
      // not listening yet
    }
    if (Date.now() > deadline) throw new Error(`psrigd did not answer within 20 s:\n${log}`);
    await new Promise((r) => setTimeout(r, 100));
  }
  return {
    url,
    dir,
    log: () => log,
    async api(path, options = {}) {
      const headers = { ...(options.headers ?? {}) };
      if (token) headers.Authorization = `Bearer ${token}`;
      return fetch(`${url}${path}`, { ...options, headers });
    },
    async stop() {
      if (child.exitCode === null) {
        child.kill('SIGTERM');
        await new Promise((resolve) => child.once('exit', resolve));
      }
      rmSync(dir, { recursive: true, force: true });
    },
  };
}
