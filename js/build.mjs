// Bundles the glTF renderer (src/page.js with three.js, GLTFLoader and the extension's plugin) and the plain
// three.js page's script into cdbrdf's package data (src/cdbrdf/view/assets/gltf/): plain scripts (IIFE), so
// that the pages open from file:// and need no network. Run by scripts/setup.sh (npm ci, then npm run build).
import { build } from 'esbuild';
import { fileURLToPath } from 'node:url';
import path from 'node:path';

const here = path.dirname(fileURLToPath(import.meta.url));
const out = path.join(here, '..', 'src', 'cdbrdf', 'view', 'assets', 'gltf');
const common = { bundle: true, format: 'iife', minify: true, target: ['es2020'], legalComments: 'eof',
  logLevel: 'warning' };
await build({ ...common, entryPoints: [path.join(here, 'src', 'page.js')], outfile: path.join(out, 'renderer.js') });
await build({ ...common, entryPoints: [path.join(here, 'src', 'plain.js')], outfile: path.join(out, 'three-plain.js') });
