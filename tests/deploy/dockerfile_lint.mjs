// Lints a Dockerfile offline with the npm package dockerfile-utils (the validator of the VS Code
// Docker extension's language server): unknown instructions and flags, bad arguments (ports,
// ARG/ENV syntax, HEALTHCHECK options, ...). No container engine is needed, and nothing is built.
// usage: node dockerfile_lint.mjs NODE_MODULES_DIR Dockerfile
// Exit status: 0 no diagnostic, 1 diagnostics (each printed with its line), 2 usage or setup error.
import fs from "node:fs";
import path from "node:path";
import { createRequire } from "node:module";

const [modulesDir, file] = process.argv.slice(2);
if (!modulesDir || !file) {
  console.error("usage: node dockerfile_lint.mjs NODE_MODULES_DIR Dockerfile");
  process.exit(2);
}
let utils;
try {
  utils = createRequire(path.join(path.resolve(modulesDir), "x.js"))("dockerfile-utils");
} catch (e) {
  console.error(`cannot load dockerfile-utils from ${modulesDir}: ${e.message}`);
  process.exit(2);
}
const version = JSON.parse(fs.readFileSync(path.join(modulesDir, "dockerfile-utils", "package.json"), "utf8")).version;
const diagnostics = utils.validate(fs.readFileSync(file, "utf8"), {});
for (const d of diagnostics) console.log(`${file}:${d.range.start.line + 1}: ${d.message}`);
console.log(`${file}: ${diagnostics.length} diagnostic(s) from dockerfile-utils ${version}`);
process.exit(diagnostics.length > 0 ? 1 : 0);
