// The Khronos glTF validator on each file named: prints one JSON line per file (its report). Used by the tests.
import { validateBytes } from 'gltf-validator';
import { readFile } from 'node:fs/promises';
import path from 'node:path';

for (const file of process.argv.slice(2)) {
  const data = new Uint8Array(await readFile(file));
  const report = await validateBytes(data, {
    uri: path.basename(file),
    maxIssues: 0,
    externalResourceFunction: (uri) => readFile(path.join(path.dirname(file), decodeURIComponent(uri)))
      .then((b) => new Uint8Array(b)),
  });
  process.stdout.write(JSON.stringify({ file, report }) + '\n');
}
