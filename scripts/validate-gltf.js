// Validates glTF/GLB files with the Khronos glTF-Validator; prints one summary line each.
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');
(async () => {
  let failed = 0;
  for (const file of process.argv.slice(2)) {
    const data = new Uint8Array(fs.readFileSync(file));
    const report = await validator.validateBytes(data, {
      uri: file,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, d) => err ? reject(err.toString()) : resolve(new Uint8Array(d)));
      }),
    });
    const i = report.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos`);
    for (const m of i.messages.filter(m => m.severity === 0)) console.log(`  ${m.code} ${m.pointer || ''} ${m.message}`);
    if (i.numErrors > 0) failed++;
  }
  process.exit(failed ? 1 : 0);
})();
