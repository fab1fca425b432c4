// Validates a JSON document against a JSON schema (draft-07) with Ajv,
// formats included (date-time, ...). Prints {"valid": bool, "errors": [...]}.
// Usage: node validate-json-schema.mjs SCHEMA.json DOCUMENT.json
import { readFile } from 'node:fs/promises';
import Ajv from 'ajv';
import addFormats from 'ajv-formats';

const [schemaFile, documentFile] = process.argv.slice(2);
if (!schemaFile || !documentFile) {
  console.error('usage: node validate-json-schema.mjs SCHEMA.json DOCUMENT.json');
  process.exit(2);
}
const schema = JSON.parse(await readFile(schemaFile, 'utf8'));
const document = JSON.parse(await readFile(documentFile, 'utf8'));
// strict: false: the U3M schema carries annotations Ajv's strict mode rejects.
const ajv = new Ajv({ allErrors: true, strict: false });
addFormats(ajv);
const validate = ajv.compile(schema);
const valid = validate(document);
console.log(JSON.stringify({ valid, errors: validate.errors ?? [] }, null, 2));
