// Runs the Khronos glTF validator (npm package gltf-validator) over each file given: prints its
// counts and the first issues, exits 1 when any file has an error (warnings and hints are shown).
// Usage: NODE_PATH=<dir with node_modules> node gltf_validate.js FILE...
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function validate(file) {
  const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
    uri: path.basename(file),
    maxIssues: 50,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
          err ? reject(err.toString()) : resolve(new Uint8Array(data)));
      }),
  });
  const i = report.issues;
  console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints ` +
              `(gltf-validator ${report.validatorVersion})`);
  for (const m of i.messages.slice(0, 10)) console.log(`  ${m.severity === 0 ? 'error' : 'note'} ${m.code} at ${m.pointer}: ${m.message}`);
  return i.numErrors;
}

(async () => {
  let errors = 0;
  for (const file of process.argv.slice(2)) errors += await validate(file);
  process.exit(errors > 0 ? 1 : 0);
})().catch((e) => {
  console.error(`gltf_validate: ${e}`);
  process.exit(2);
});
