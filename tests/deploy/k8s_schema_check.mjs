// Schema check of Kubernetes manifests, offline: every object is validated against the
// Kubernetes API's OpenAPI schema as compiled by the npm package kubernetes-models (types,
// required fields, enums, formats), and its fields are checked against the API types' field
// lists (kubernetes-models' type declarations), so that a misspelt field fails as it would under
// `kubectl apply --validate=strict`. kubectl itself cannot do this without a cluster: it
// downloads the schema from the API server.
//
// usage: node k8s_schema_check.mjs NODE_MODULES_DIR MANIFEST.yaml...
//   NODE_MODULES_DIR holds kubernetes-models and js-yaml:
//   npm install --prefix DIR kubernetes-models@5.1.0 js-yaml@4   (then DIR/node_modules;
//   tests/deploy/deploy_checks.sh runs it as the test deploy.kubernetes.schema)
// Exit status: 0 all valid, 1 an object is invalid, 2 usage or setup error.
import fs from "node:fs";
import path from "node:path";
import { pathToFileURL } from "node:url";

const [modulesDir, ...files] = process.argv.slice(2);
if (!modulesDir || files.length === 0) {
  console.error("usage: node k8s_schema_check.mjs NODE_MODULES_DIR MANIFEST.yaml...");
  process.exit(2);
}
const modelsDir = path.join(modulesDir, "kubernetes-models");
const importFrom = (file) => import(pathToFileURL(file).href);
let yaml;
try {
  yaml = (await importFrom(path.join(modulesDir, "js-yaml", "dist", "js-yaml.mjs"))).default;
} catch (e) {
  console.error(`cannot load js-yaml from ${modulesDir}: ${e.message}`);
  process.exit(2);
}
const version = JSON.parse(fs.readFileSync(path.join(modelsDir, "package.json"), "utf8")).version;

// The fields of each API type, from the .d.ts files: "export interface IFoo { "field"?: Type; }"
// and "export type { IFoo as IIoK8sApiGroupV1Foo }". Types that are not objects (Quantity,
// IntOrString, maps) have no entry, and their contents are not checked here (ajv does).
const typeFields = new Map();  // global name (IIoK8s...) -> Map(field -> type text)
function parseDeclarations(file) {
  const text = fs.readFileSync(file, "utf8");
  const local = new Map();
  for (const m of text.matchAll(/^export interface (I\w+)(?: extends [\w, ]+)? \{\n([\s\S]*?)^\}/gm)) {
    const fields = new Map();
    for (const f of m[2].matchAll(/^ {4}"([^"]+)"\??: (.*)$/gm)) fields.set(f[1], f[2].replace(/;$/, ""));
    local.set(m[1], fields);
  }
  for (const m of text.matchAll(/^export type \{([^}]*)\}/gm)) {
    for (const alias of m[1].matchAll(/(I\w+) as (IIoK8s\w+)/g)) {
      if (local.has(alias[1])) typeFields.set(alias[2], local.get(alias[1]));
    }
  }
  return local;
}
function walkDeclarations(dir) {
  for (const entry of fs.readdirSync(dir, { withFileTypes: true })) {
    const p = path.join(dir, entry.name);
    if (entry.isDirectory()) walkDeclarations(p);
    else if (entry.name.endsWith(".d.ts")) parseDeclarations(p);
  }
}
walkDeclarations(modelsDir);
walkDeclarations(path.join(modulesDir, "@kubernetes-models", "apimachinery"));
if (typeFields.size < 100) {
  console.error(`only ${typeFields.size} API types read from ${modelsDir}: not a kubernetes-models install?`);
  process.exit(2);
}

function unknownFields(value, fields, where, out) {
  if (value === null || typeof value !== "object" || Array.isArray(value)) return;
  for (const [key, child] of Object.entries(value)) {
    if (!fields.has(key)) {
      out.push(`${where}.${key}: unknown field`);
      continue;
    }
    const type = fields.get(key);
    let m = type.match(/^(IIoK8s\w+)$/);
    if (m && typeFields.has(m[1])) unknownFields(child, typeFields.get(m[1]), `${where}.${key}`, out);
    m = type.match(/^Array<(IIoK8s\w+)>$/);
    if (m && typeFields.has(m[1]) && Array.isArray(child)) {
      child.forEach((item, i) => unknownFields(item, typeFields.get(m[1]), `${where}.${key}[${i}]`, out));
    }
  }
}

let failures = 0;
let checked = 0;
for (const file of files) {
  let docs;
  try {
    docs = yaml.loadAll(fs.readFileSync(file, "utf8"));
  } catch (e) {
    console.log(`FAIL ${file}: not YAML: ${e.message}`);
    failures++;
    continue;
  }
  for (const doc of docs) {
    if (doc === null || doc === undefined) continue;
    const name = `${file}: ${doc.kind}/${doc.metadata?.name ?? "?"}`;
    if (typeof doc.apiVersion !== "string" || typeof doc.kind !== "string") {
      console.log(`FAIL ${name}: no apiVersion or kind`);
      failures++;
      continue;
    }
    if (doc.apiVersion.startsWith("kustomize.config.k8s.io/")) {
      console.log(`skip ${name}: a kustomize file, not an API object (kubectl kustomize checks it)`);
      continue;
    }
    const modelFile = path.join(modelsDir, doc.apiVersion, `${doc.kind}.js`);
    if (!fs.existsSync(modelFile)) {
      console.log(`FAIL ${name}: no schema for ${doc.apiVersion} ${doc.kind} in kubernetes-models ${version}`);
      failures++;
      continue;
    }
    const Model = (await importFrom(modelFile))[doc.kind];
    const problems = [];
    try {
      new Model(doc).validate();
    } catch (e) {
      problems.push(...String(e.message).split(/,\s*(?=data)/));
    }
    const declarations = parseDeclarations(modelFile.replace(/\.js$/, ".d.ts"));
    unknownFields(doc, declarations.get(`I${doc.kind}`) ?? new Map(), doc.kind, problems);
    checked++;
    if (problems.length > 0) {
      failures++;
      console.log(`FAIL ${name}:`);
      for (const p of problems) console.log(`  ${p}`);
    } else {
      console.log(`ok   ${name}`);
    }
  }
}
console.log(`${checked} object(s) checked against the Kubernetes API schema of kubernetes-models ${version}, ` +
            `${failures} failure(s)`);
process.exit(failures > 0 ? 1 : 0);
