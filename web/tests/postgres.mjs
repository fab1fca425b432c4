// A throwaway PostgreSQL server for the browser tests of a lab's shared
// catalogue, as tests/support/postgres_server.h makes one for the C++
// tests: Debian's initdb and pg_ctl into a temporary directory, listening
// on a Unix socket there only, as the `postgres` user when the tests run
// as root (postgres refuses root).
import { execFileSync, spawnSync } from 'node:child_process';
import { chmodSync, chownSync, existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';

// Where initdb, pg_ctl and psql are, or null.
export function postgresBinDir() {
  const hasTools = (dir) => ['initdb', 'pg_ctl', 'psql'].every((tool) => existsSync(join(dir, tool)));
  if (process.env.PSRIG_POSTGRES_BIN) return hasTools(process.env.PSRIG_POSTGRES_BIN) ? process.env.PSRIG_POSTGRES_BIN : null;
  if (!existsSync('/usr/lib/postgresql')) return null;
  const versions = readdirSync('/usr/lib/postgresql')
    .map((version) => join('/usr/lib/postgresql', version, 'bin'))
    .filter(hasTools)
    .sort((a, b) => parseFloat(a.split('/').at(-2)) - parseFloat(b.split('/').at(-2)));
  return versions.at(-1) ?? null;
}

export function startPostgres() {
  const bin = postgresBinDir();
  if (!bin) throw new Error('no PostgreSQL server programs (apt-get install postgresql-15)');
  const root = process.getuid() === 0;
  const user = root
    ? { uid: Number(execFileSync('id', ['-u', 'postgres'], { encoding: 'utf8' })), gid: Number(execFileSync('id', ['-g', 'postgres'], { encoding: 'utf8' })) }
    : {};
  const dir = mkdtempSync(join(tmpdir(), 'psrig-web-postgres-'));
  chmodSync(dir, 0o711);
  const data = join(dir, 'data');
  const socket = join(dir, 'socket');
  for (const sub of [data, socket]) {
    mkdirSync(sub);
    if (root) chownSync(sub, user.uid, user.gid);
  }
  if (root) chownSync(dir, user.uid, user.gid);
  const run = (tool, args) => {
    const result = spawnSync(join(bin, tool), args, { cwd: dir, encoding: 'utf8', ...user });
    if (result.status !== 0) throw new Error(`${tool} failed: ${result.stderr}${result.stdout}`);
    return result.stdout;
  };
  run('initdb', ['-D', data, '-A', 'trust', '-U', 'psrig', '-E', 'UTF8', '--locale=C', '--no-sync']);
  run('pg_ctl', ['-D', data, '-w', '-l', join(dir, 'server.log'), '-o',
    `-c listen_addresses='' -c unix_socket_directories='${socket}' -c fsync=off`, 'start']);
  let databases = 0;
  return {
    createDatabase() {
      const name = `web_${process.pid}_${++databases}`;
      run('psql', ['-h', socket, '-U', 'psrig', '-d', 'postgres', '-c', `CREATE DATABASE ${name}`]);
      return `postgresql://psrig@${encodeURIComponent(socket)}/${name}`;
    },
    log: () => readFileSync(join(dir, 'server.log'), 'utf8'),
    stop() {
      spawnSync(join(bin, 'pg_ctl'), ['-D', data, '-m', 'immediate', 'stop'], { cwd: dir, ...user });
      rmSync(dir, { recursive: true, force: true });
    },
  };
}
