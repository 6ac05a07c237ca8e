// Builds the viewer's page into OUTDIR: app.js (src/main.js and three.js, bundled and minified by esbuild),
// index.html and style.css. `rmpmarl view` serves exactly the files of OUTDIR.
// usage: node web/build.mjs OUTDIR
import * as esbuild from 'esbuild';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const PRODUCTS = ['app.js', 'index.html', 'style.css'];

const outArg = process.argv[2];
if (!outArg || process.argv.length > 3) {
  console.error('usage: node build.mjs OUTDIR');
  process.exit(2);
}
const out = path.resolve(outArg);
fs.mkdirSync(out, { recursive: true });
// OUTDIR is served as it is: refuse to build into a directory that holds anything else
const others = fs.readdirSync(out).filter((f) => !PRODUCTS.includes(f));
if (others.length > 0) {
  console.error(`build.mjs: ${out} holds files that are not the page's (${others.join(', ')}); `
    + 'the server would serve them too. Remove them or choose an empty directory.');
  process.exit(1);
}

try {
  await esbuild.build({
    entryPoints: [path.join(here, 'src', 'main.js')],
    outfile: path.join(out, 'app.js'),
    bundle: true,
    minify: true,
    format: 'iife',
    target: ['es2020'],
    legalComments: 'eof',
    logLevel: 'warning',
  });
} catch (e) {
  // esbuild has printed the errors
  process.exit(1);
}
for (const f of ['index.html', 'style.css']) fs.copyFileSync(path.join(here, f), path.join(out, f));
console.log(`built ${PRODUCTS.map((f) => `${f} (${fs.statSync(path.join(out, f)).size} B)`).join(', ')} into ${out}`);
