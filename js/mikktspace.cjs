// The reference MikkTSpace (npm mikktspace, compiled to WebAssembly) on unindexed triangles read as JSON from
// standard input ({position, normal, uv}: flat arrays), its tangents as JSON on standard output. Used by the tests.
const { generateTangents } = require('mikktspace');

let text = '';
process.stdin.on('data', (d) => { text += d; });
process.stdin.on('end', () => {
  const m = JSON.parse(text);
  const t = generateTangents(new Float32Array(m.position), new Float32Array(m.normal), new Float32Array(m.uv));
  process.stdout.write(JSON.stringify(Array.from(t)));
});
