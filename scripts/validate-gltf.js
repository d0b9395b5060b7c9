#!/usr/bin/env node
// Validates one glTF 2.0 file (.gltf with its external buffers/images, or .glb) with the Khronos
// glTF-Validator (npm package `gltf-validator`, fetched by scripts/setup.sh into .tools/) and prints
// the validation report as JSON on stdout.
//
// Usage: node scripts/validate-gltf.js FILE
// Exit status: 0 = no errors (warnings and infos allowed), 1 = the report has errors,
//              2 = could not run (bad usage, unreadable file, validator package missing).
// The package is looked up in $DUOLOD_NODE_TOOLS/node_modules, then in .tools/node_modules beside
// this script's repository, then on Node's normal module path.
'use strict';

const fs = require('fs');
const path = require('path');

function loadValidator() {
  const roots = [];
  if (process.env.DUOLOD_NODE_TOOLS) roots.push(path.join(process.env.DUOLOD_NODE_TOOLS, 'node_modules'));
  roots.push(path.join(__dirname, '..', '.tools', 'node_modules'));
  for (const root of roots) {
    const candidate = path.join(root, 'gltf-validator');
    if (fs.existsSync(candidate)) return require(candidate);
  }
  return require('gltf-validator');  // throws when it is nowhere
}

async function main() {
  if (process.argv.length !== 3) {
    process.stderr.write('usage: validate-gltf.js FILE.gltf|FILE.glb\n');
    return 2;
  }
  let validator;
  try {
    validator = loadValidator();
  } catch (error) {
    process.stderr.write('validate-gltf: the gltf-validator npm package is missing (run scripts/setup.sh): ' +
                         error.message + '\n');
    return 2;
  }
  const file = path.resolve(process.argv[2]);
  let bytes;
  try {
    bytes = fs.readFileSync(file);
  } catch (error) {
    process.stderr.write('validate-gltf: ' + file + ': ' + error.message + '\n');
    return 2;
  }
  const report = await validator.validateBytes(new Uint8Array(bytes), {
    uri: path.basename(file),
    maxIssues: 0,
    writeTimestamp: false,  // reports are deterministic
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (error, data) => {
          if (error) reject(error.toString());
          else resolve(new Uint8Array(data));
        });
      }),
  });
  process.stdout.write(JSON.stringify(report, null, 2) + '\n');
  return report.issues.numErrors > 0 ? 1 : 0;
}

main().then((status) => process.exit(status), (error) => {
  process.stderr.write('validate-gltf: ' + (error && error.stack ? error.stack : String(error)) + '\n');
  process.exit(2);
});
