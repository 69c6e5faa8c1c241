// CDBRDF_materials_curvature_brdf for three.js: a GLTFLoader plugin that reads the extension's table (a 16-bit
// PNG lookup texture and its axes, cdbrdf.gltf_table) and builds a ShaderMaterial that looks the table up per
// fragment at the fragment's curvature (the _CURVATURE vertex attribute, 1/mm), with the 5-D lookup of
// cdbrdf.interp in GLSL (lookup.js: window.CDBRDF_LOOKUP_GLSL, the one GLSL copy of the rule, shared with the
// viewer). The material GLTFLoader makes from the standard part (the fitted fallback) is kept beside it.
//
//   const loader = new GLTFLoader();
//   loader.register((parser) => new CdbrdfCurvatureBrdfExtension(parser));
//   const gltf = await loader.parseAsync(arrayBuffer, '');
//   // every mesh with the extension now wears the CDBRDF material; mesh.userData.cdbrdf has
//   // { material, fallback, table } (table: the uniforms and the extension's JSON)
import * as THREE from 'three';
import { decode as decodePng } from 'fast-png';

export const EXTENSION = 'CDBRDF_materials_curvature_brdf';
export const SUPPORTED_MAJOR = 1;

function lookupGlsl() {
  const src = globalThis.CDBRDF_LOOKUP_GLSL;
  if (typeof src !== 'string') throw new Error('cdbrdf: the GLSL lookup (lookup.js) is not loaded');
  return src;
}

// 1 / step of an evenly spaced axis of at least 3 nodes, else 0 (cdbrdf.interp._inv_step)
function invStep(axis) {
  if (axis.length < 3) return 0;
  const d0 = axis[1] - axis[0];
  for (let i = 1; i < axis.length - 1; i++) {
    const d = axis[i + 1] - axis[i];
    if (Math.abs(d - d0) > 1e-12 * Math.abs(d0)) return 0;
  }
  return 1 / d0;
}

// The table's uniforms from the extension's JSON and the lookup texture's PNG bytes.
export function tableUniforms(ext, pngBytes) {
  const major = parseInt(String(ext.version || '').split('.')[0], 10);
  if (!(major <= SUPPORTED_MAJOR)) throw new Error(`cdbrdf: ${EXTENSION} version ${ext.version} is newer than this renderer`);
  const lk = ext.lookup, enc = lk.encoding;
  if (enc.type !== 'unorm16') throw new Error(`cdbrdf: unknown lookup encoding ${enc.type}`);
  const png = decodePng(new Uint8Array(pngBytes));
  const nc = enc.scale.length, W = lk.width, R = lk.rowsPerLayer, K = lk.layers;
  if (png.depth !== 16 || png.width !== W || png.height !== R * K || png.channels !== nc) {
    throw new Error(`cdbrdf: the lookup texture is ${png.width} x ${png.height} x ${png.channels} at ${png.depth} bits, `
      + `expected ${W} x ${R * K} x ${nc} at 16`);
  }
  const n = W * R * K, rgba = new Float32Array(4 * n), q = png.data;
  for (let i = 0; i < n; i++) {
    for (let c = 0; c < 3; c++) {
      const j = nc === 1 ? 0 : c;
      rgba[4 * i + c] = enc.offset[j] + enc.scale[j] * (q[nc * i + j] / 65535);
    }
    rgba[4 * i + 3] = 1;
  }
  const tab = new THREE.DataArrayTexture(rgba, W, R, K);  // layer k: image rows k R .. k R + R - 1
  tab.format = THREE.RGBAFormat; tab.type = THREE.FloatType;
  tab.minFilter = tab.magFilter = THREE.NearestFilter; tab.generateMipmaps = false;
  tab.needsUpdate = true;
  const rows = [lk.kappa, lk.theta_l, lk.theta_v];
  const aw = Math.max(...rows.map((r) => r.length));
  const ax = new Float32Array(aw * 3);
  rows.forEach((r, j) => r.forEach((x, i) => { ax[j * aw + i] = x; }));
  const axes = new THREE.DataTexture(ax, aw, 3, THREE.RedFormat, THREE.FloatType);
  axes.minFilter = axes.magFilter = THREE.NearestFilter; axes.generateMipmaps = false;
  axes.needsUpdate = true;
  return {
    uTab: { value: tab }, uTexW: { value: W }, uAxes: { value: axes },
    uN: { value: new THREE.Vector3(lk.kappa.length, lk.theta_l.length, lk.theta_v.length) },
    uNphi: { value: new THREE.Vector2(lk.phi_l.count, lk.phi_v.count) },
    uPhi: { value: new THREE.Vector4(lk.phi_l.first, lk.phi_l.step, lk.phi_v.first, lk.phi_v.step) },
    uIso: { value: lk.isotropic ? 1 : 0 },
    uInvStep: { value: new THREE.Vector3(0, invStep(lk.theta_l), invStep(lk.theta_v)) },
  };
}

// the uniforms' GLSL types: three sets ivec uniforms from Vector2/3 through uniform{2,3}iv
const SURFACE_VS = `
in vec4 cdbrdfTangent; in float cdbrdfCurvature;
out vec3 vWorld; out vec3 vN; out vec3 vT; out float vK;
void main() {
  vec4 wp = modelMatrix * vec4(position, 1.0);
  mat3 m = mat3(modelMatrix);
  vWorld = wp.xyz;
  vN = transpose(inverse(m)) * normal;
  vT = m * cdbrdfTangent.xyz;
  vK = cdbrdfCurvature;
  gl_Position = projectionMatrix * viewMatrix * wp;
}`;

export const MAX_ENV = 32;

function surfaceFS() {
  return `${lookupGlsl()}
in vec3 vWorld; in vec3 vN; in vec3 vT; in float vK;
uniform int uMode;               // 0: the plain BRDF (kappa = 0), 1: the CDBRDF, 2: the curvature (overlay)
uniform vec3 uLightDir;          // towards the light, world
uniform float uIrradiance;       // of the directional light (W m^-2; pi: a white Lambertian facing it is 1)
uniform float uExpo;             // 2^EV
uniform int uEnvN; uniform vec3 uEnvDir[${MAX_ENV}]; uniform vec3 uEnvL[${MAX_ENV}];  // radiance x solid angle
uniform int uShadowOn; uniform sampler2D uShadow; uniform mat4 uShadowMatrix; uniform float uShadowTexel;
uniform float uKScale;           // curvature scale (1: the attribute is in 1/mm)
out vec4 cdbrdfColor;
vec2 cdbrdfAngles(vec3 d, vec3 n, vec3 t, vec3 b) {
  vec3 l = vec3(dot(d, t), dot(d, b), dot(d, n));
  float th = degrees(acos(clamp(l.z, -1.0, 1.0)));
  float ph = length(l.xy) > 1e-7 ? degrees(atan(l.y, l.x)) : 0.0;
  if (ph < 0.0) ph += 360.0;
  return vec2(min(th, 90.0), ph);
}
vec3 cdbrdfSrgb(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
float cdbrdfShadow(vec3 p, vec3 n) {
  if (uShadowOn == 0) return 1.0;
  vec4 s = uShadowMatrix * vec4(p + n * (1.5 * uShadowTexel), 1.0);
  vec3 q = s.xyz / s.w * 0.5 + 0.5;
  if (any(lessThan(q.xy, vec2(0.0))) || any(greaterThan(q.xy, vec2(1.0)))) return 1.0;
  ivec2 size = textureSize(uShadow, 0);
  ivec2 c = ivec2(q.xy * vec2(size));
  float lit = 0.0;
  for (int dy = -1; dy <= 1; dy++) for (int dx = -1; dx <= 1; dx++) {
    float d = texelFetch(uShadow, clamp(c + ivec2(dx, dy), ivec2(0), size - 1), 0).r;
    lit += q.z <= d + 2e-4 ? 1.0 : 0.0;
  }
  return lit / 9.0;
}
void main() {
  vec3 n = normalize(vN);
  vec3 t = vT - dot(vT, n) * n;
  t = length(t) > 1e-8 ? normalize(t) : normalize(abs(n.x) < 0.9 ? cross(n, vec3(1, 0, 0)) : cross(n, vec3(0, 1, 0)));
  float k = vK * uKScale;
  vec3 v = normalize(cameraPosition - vWorld);
  vec3 ng = n;
  if (dot(v, n) < 0.0) { n = -n; k = -k; }  // the back side: the frame turned about x, as the renderer's plug-in
  vec3 b = cross(n, t);
  float kq = uMode == 0 ? 0.0 : k;
  vec2 av = cdbrdfAngles(v, n, t, b);
  vec3 c = vec3(0.0);
  float cl = dot(uLightDir, n);
  if (cl > 0.0 && uIrradiance > 0.0) {
    vec2 al = cdbrdfAngles(uLightDir, n, t, b);
    c += lookup(av.x, av.y, al.x, al.y, kq) * cl * uIrradiance * cdbrdfShadow(vWorld, n);
  }
  for (int i = 0; i < ${MAX_ENV}; i++) {
    if (i >= uEnvN) break;
    float ce = dot(uEnvDir[i], n);
    if (ce <= 0.0) continue;
    vec2 al = cdbrdfAngles(uEnvDir[i], n, t, b);
    c += lookup(av.x, av.y, al.x, al.y, kq) * ce * uEnvL[i];
  }
  vec3 s = cdbrdfSrgb(c * uExpo);
  if (uMode == 2) {
    float x = clamp(k / 0.25, -1.0, 1.0);
    s = x > 0.0 ? mix(vec3(1.0), vec3(0.85, 0.1, 0.1), x) : mix(vec3(1.0), vec3(0.1, 0.3, 0.9), -x);
  }
  cdbrdfColor = vec4(s, 1.0);
}`;
}

// The shared lighting uniforms (one object: every CDBRDF material of a scene points at it).
export function lightingUniforms() {
  const dirs = [], ls = [];
  for (let i = 0; i < MAX_ENV; i++) { dirs.push(new THREE.Vector3()); ls.push(new THREE.Vector3()); }
  return {
    uMode: { value: 1 }, uLightDir: { value: new THREE.Vector3(0, 1, 0) }, uIrradiance: { value: Math.PI },
    uExpo: { value: 1 }, uEnvN: { value: 0 }, uEnvDir: { value: dirs }, uEnvL: { value: ls },
    uShadowOn: { value: 0 }, uShadow: { value: null }, uShadowMatrix: { value: new THREE.Matrix4() },
    uShadowTexel: { value: 0 }, uKScale: { value: 1 },
  };
}

export function cdbrdfMaterial(table, lighting) {
  return new THREE.ShaderMaterial({
    name: 'cdbrdf', glslVersion: THREE.GLSL3, side: THREE.DoubleSide,
    uniforms: Object.assign({}, table, lighting),
    vertexShader: SURFACE_VS, fragmentShader: surfaceFS(),
  });
}

// The lookup alone, on queries (theta_v, phi_v, theta_l, phi_l, kappa): a full-screen pass into a float target.
export function evaluateMany(renderer, table, queries) {
  const n = queries.length, w = Math.max(1, Math.min(n, 1024)), h = Math.max(1, Math.ceil(n / w));
  const q = new Float32Array(w * h * 8);
  const bad = new Uint8Array(n);
  queries.forEach((r, i) => {
    const ok = r.every((x) => Number.isFinite(x)) && r[0] >= 0 && r[0] <= 90 && r[2] >= 0 && r[2] <= 90;
    bad[i] = ok ? 0 : 1;
    q.set(ok ? [r[0], r[1], r[2], r[3], r[4], 0, 0, 0] : [0, 0, 0, 0, 0, 0, 0, 0], 8 * i);
  });
  const qt = new THREE.DataTexture(q, 2 * w, h, THREE.RGBAFormat, THREE.FloatType);
  qt.minFilter = qt.magFilter = THREE.NearestFilter; qt.needsUpdate = true;
  const mat = new THREE.RawShaderMaterial({
    glslVersion: THREE.GLSL3,
    uniforms: Object.assign({ uQ: { value: qt } }, table),
    vertexShader: `in vec3 position; void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }`,
    fragmentShader: `${lookupGlsl()}
uniform sampler2D uQ;
out vec4 o;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 a = texelFetch(uQ, ivec2(2 * p.x, p.y), 0), b = texelFetch(uQ, ivec2(2 * p.x + 1, p.y), 0);
  o = vec4(lookup(a.x, a.y, a.z, a.w, b.x), 1.0);
}`,
  });
  const quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), mat);
  const scene = new THREE.Scene(); scene.add(quad);
  const target = new THREE.WebGLRenderTarget(w, h, { type: THREE.FloatType, format: THREE.RGBAFormat,
    minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter, depthBuffer: false });
  const cam = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
  const prev = renderer.getRenderTarget();
  renderer.setRenderTarget(target);
  renderer.render(scene, cam);
  const out = new Float32Array(w * h * 4);
  renderer.readRenderTargetPixels(target, 0, 0, w, h, out);
  renderer.setRenderTarget(prev);
  target.dispose(); qt.dispose(); mat.dispose(); quad.geometry.dispose();
  const res = [];
  for (let i = 0; i < n; i++) res.push(bad[i] ? [NaN, NaN, NaN] : [out[4 * i], out[4 * i + 1], out[4 * i + 2]]);
  return res;
}

// The GLTFLoader plugin.
export class CdbrdfCurvatureBrdfExtension {
  constructor(parser, options = {}) {
    this.parser = parser;
    this.name = EXTENSION;
    this.lighting = options.lighting || lightingUniforms();
    this.apply = options.apply !== false;  // wear the CDBRDF material at once (else: the fallback)
  }

  async _table(ext) {
    const json = this.parser.json;
    const tex = json.textures[ext.lookup.texture.index];
    const image = json.images[tex.source];
    const view = await this.parser.getDependency('bufferView', image.bufferView);
    return tableUniforms(ext, view);
  }

  async afterRoot(result) {
    const json = this.parser.json, cache = new Map(), meshes = [];
    result.scene.traverse((o) => { if (o.isMesh) meshes.push(o); });
    for (const mesh of meshes) {
      const assoc = this.parser.associations.get(mesh.material);
      const index = assoc ? assoc.materials : undefined;
      const def = index !== undefined ? json.materials[index] : null;
      const ext = def && def.extensions ? def.extensions[EXTENSION] : null;
      if (!ext) continue;
      const g = mesh.geometry;
      const kName = String(ext.curvature.attribute || '_CURVATURE').toLowerCase();
      if (!g.attributes[kName]) throw new Error(`cdbrdf: the mesh has no ${ext.curvature.attribute} attribute`);
      if (!g.attributes.tangent) throw new Error('cdbrdf: the mesh has no TANGENT attribute');
      g.setAttribute('cdbrdfCurvature', g.attributes[kName]);
      g.setAttribute('cdbrdfTangent', g.attributes.tangent);
      if (!cache.has(index)) cache.set(index, this._table(ext));
      const table = await cache.get(index);
      const material = cdbrdfMaterial(table, this.lighting);
      mesh.userData.cdbrdf = { material, fallback: mesh.material, table, extension: ext };
      if (this.apply) mesh.material = material;
    }
  }
}
