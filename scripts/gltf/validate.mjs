// Validates glTF files with the Khronos glTF validator (npm `gltf-validator`, pinned in
// package.json / package-lock.json). Prints each report's summary and messages; exits 1 when any
// file has an error, 2 on usage errors.
import { readFile } from "node:fs/promises";
import { createRequire } from "node:module";
import path from "node:path";

const require = createRequire(import.meta.url);
const validator = require("gltf-validator");

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error("usage: node validate.mjs FILE.gltf …");
  process.exit(2);
}
let failed = false;
for (const file of files) {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    externalResourceFunction: (uri) =>
      readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
  });
  const issues = report.issues;
  console.log(
    `${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ${issues.numInfos} infos, ${issues.numHints} hints (gltf-validator ${report.validatorVersion})`,
  );
  for (const m of issues.messages) {
    const severity = ["error", "warning", "info", "hint"][m.severity] ?? m.severity;
    console.log(`  ${severity} ${m.code} ${m.pointer ?? ""}: ${m.message}`);
  }
  if (issues.numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
