// Validates a glTF/GLB with Khronos's validator; prints one line per error
// (`error CODE POINTER`) and a summary line. Used by formats/tests/formats_reference.rs.
import { readFileSync } from 'node:fs';
import validator from 'gltf-validator';

const path = process.argv[2];
const report = await validator.validateBytes(new Uint8Array(readFileSync(path)));
for (const m of report.issues.messages) {
  if (m.severity === 0) console.log(`error ${m.code} ${m.pointer ?? ''} ${m.message}`);
}
const { numErrors, numWarnings, numInfos } = report.issues;
console.log(`summary errors ${numErrors} warnings ${numWarnings} infos ${numInfos}`);
