// Validates a .glb or .gltf with the Khronos glTF-Validator; prints its
// report as JSON (issues.numErrors, numWarnings, numInfos, messages).
// Usage: node validate-gltf.mjs FILE
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';

const file = process.argv[2];
if (!file) {
  console.error('usage: node validate-gltf.mjs FILE.glb|FILE.gltf');
  process.exit(2);
}
const bytes = new Uint8Array(await readFile(file));
const report = await validator.validateBytes(bytes, {
  uri: path.basename(file),
  maxIssues: 0,
  externalResourceFunction: (uri) =>
    readFile(path.join(path.dirname(file), decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
});
console.log(JSON.stringify(report, null, 2));
