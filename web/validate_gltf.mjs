// Khronos glTF validator on one file: node validate_gltf.mjs FILE.glb
// Prints the validator's JSON report on stdout; exit 0 when the report has no errors, 1 otherwise.
import { readFileSync } from 'node:fs';
import { basename } from 'node:path';
import validator from 'gltf-validator';

const file = process.argv[2];
if (!file) {
  console.error('usage: node validate_gltf.mjs FILE.glb');
  process.exit(2);
}
const report = await validator.validateBytes(new Uint8Array(readFileSync(file)), {
  uri: basename(file),
  maxIssues: 200,
  externalResourceFunction: () => Promise.reject(new Error('external resources are not allowed in a .glb export')),
});
process.stdout.write(JSON.stringify(report));
process.exit(report.issues.numErrors === 0 ? 0 : 1);
