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
#ifdef CDBRDF_MAP
in vec2 cdbrdfUv; in vec3 cdbrdfShape;
out vec2 vUv; out vec3 vShape; out float vHand;
#endif
void main() {
  vec4 wp = modelMatrix * vec4(position, 1.0);
  mat3 m = mat3(modelMatrix);
  vWorld = wp.xyz;
  vN = transpose(inverse(m)) * normal;
  vT = m * cdbrdfTangent.xyz;
  vK = cdbrdfCurvature;
#ifdef CDBRDF_MAP
  vUv = vec2(cdbrdfUv.x, 1.0 - cdbrdfUv.y);  // the map's convention: v up (glTF's runs down)
  vShape = cdbrdfShape; vHand = cdbrdfTangent.w;
#endif
  gl_Position = projectionMatrix * viewMatrix * wp;
}`;

// The curvature map (cdbrdf.mesh.curvature_map's rule; the renderer's plug-in reads it the same way): the level of
// the pixel's footprint on the cloth (distance x pixel angle / max(|cos theta_v|, 1/8), in texels through |dP/du|,
// |dP/dv|), never finer than the curvature's neighbourhood, trilinear between levels, bilinear and periodic within
// one; the texel's slopes tilt the normal, its derivatives give the detail's shape operator, added to the mesh's.
const MAP_GLSL = `
#ifdef CDBRDF_MAP
in vec2 vUv; in vec3 vShape; in float vHand;
uniform sampler2D uMapA; uniform sampler2D uMapB;   // p, q, dp/du | dp/dv, dq/du, dq/dv (decoded, float)
uniform ivec3 uMapLevel[16]; uniform int uMapN;      // per level: first row, width, height
uniform vec4 uMapTransform; uniform vec2 uMapUvScale; uniform float uMapMinLevel; uniform float uPixelAngle;
uniform int uDirectional;
void mapFetch(int lv, vec2 t, inout vec3 a, inout vec3 b, float wt) {
  ivec3 L = uMapLevel[lv];
  vec2 x = vec2((t.x - floor(t.x)) * float(L.y) - 0.5, ((1.0 - t.y) - floor(1.0 - t.y)) * float(L.z) - 0.5);
  vec2 x0 = floor(x), f = x - x0;
  ivec2 i0 = ivec2(x0), n = L.yz;
  i0 = (i0 % n + n) % n;
  ivec2 i1 = (i0 + 1) % n;
  for (int k = 0; k < 4; k++) {
    ivec2 c = ivec2(k % 2 == 0 ? i0.x : i1.x, k < 2 ? i0.y : i1.y);
    float w = wt * (k % 2 == 0 ? 1.0 - f.x : f.x) * (k < 2 ? 1.0 - f.y : f.y);
    ivec2 at = ivec2(c.x, L.x + c.y);
    a += w * texelFetch(uMapA, at, 0).rgb; b += w * texelFetch(uMapB, at, 0).rgb;
  }
}
// the map's (p, q) and the total shape operator (xx, xy, yy) in the frame x = dP/du, y = n x x
void mapDetail(vec3 world, vec3 v, vec3 n, out vec2 pq, out vec3 S) {
  vec3 dpx = dFdx(world), dpy = dFdy(world);
  vec2 dux = dFdx(vUv), duy = dFdy(vUv);
  float det = dux.x * duy.y - dux.y * duy.x;
  vec3 dpdu = abs(det) > 1e-20 ? (dpx * duy.y - dpy * dux.y) / det : vec3(0.0);
  vec3 dpdv = abs(det) > 1e-20 ? (dpy * dux.x - dpx * duy.x) / det : vec3(0.0);
  float w = length(cameraPosition - world) * uPixelAngle / max(abs(dot(v, n)), 0.125);
  vec2 tex = vec2(float(uMapLevel[0].y), float(uMapLevel[0].z)) * abs(uMapTransform.xy);
  float fp = max(w / max(length(dpdu), 1e-30) * tex.x, w / max(length(dpdv), 1e-30) * tex.y);
  float lv = clamp(max(log2(max(fp, 1e-30)), uMapMinLevel), 0.0, float(uMapN - 1));
  int l0 = int(floor(lv)); float f = lv - float(l0);
  vec2 t = vUv * uMapTransform.xy + uMapTransform.zw;
  vec3 a = vec3(0.0), b = vec3(0.0);
  mapFetch(l0, t, a, b, 1.0 - f);
  if (f > 0.0 && l0 + 1 < uMapN) mapFetch(l0 + 1, t, a, b, f);
  float h = vHand < 0.0 ? -1.0 : 1.0;  // a mirrored UV layout: dP/dv along -y
  pq = vec2(a.x, a.y * h);
  S = vShape + vec3(a.z / uMapUvScale.x, (0.5 * b.x / uMapUvScale.y + 0.5 * b.y / uMapUvScale.x) * h, b.z / uMapUvScale.y);
}
#endif
`;

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
${MAP_GLSL}
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
  bool back = dot(v, n) < 0.0;
#ifdef CDBRDF_MAP
  vec2 pq; vec3 S;
  mapDetail(vWorld, v, n, pq, S);
  k = uDirectional == 1 ? S.x : (0.5 * (S.x + S.z) >= 0.0 ? 0.5 * (S.x + S.z) + sqrt(0.25 * (S.x - S.z) * (S.x - S.z) + S.y * S.y)
                                                           : 0.5 * (S.x + S.z) - sqrt(0.25 * (S.x - S.z) * (S.x - S.z) + S.y * S.y));
  k *= uKScale;
#endif
  if (back) { n = -n; k = -k; }  // the back side: the frame turned about x, as the renderer's plug-in
  vec3 b = cross(n, t);
#ifdef CDBRDF_MAP
  {  // the normal (p, q, 1) of the shading frame, as Mitsuba's normalmap (mirrored to the viewer's side)
    vec2 d = back ? vec2(-pq.x, pq.y) : pq;
    vec3 wl = vec3(dot(v, t), dot(v, b), dot(v, n));
    vec3 nl = normalize(vec3(d, 1.0));
    if (wl.z * dot(wl, nl) <= 0.0) nl.xy = -nl.xy;
    vec3 sl = normalize(vec3(1.0 - nl.x * nl.x, -nl.x * nl.y, -nl.x * nl.z));
    vec3 tl = cross(nl, sl);
    vec3 n2 = nl.x * t + nl.y * b + nl.z * n, t2 = sl.x * t + sl.y * b + sl.z * n, b2 = tl.x * t + tl.y * b + tl.z * n;
    n = normalize(n2); t = normalize(t2); b = normalize(b2);
  }
#endif
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
    uShadowTexel: { value: 0 }, uKScale: { value: 1 }, uPixelAngle: { value: 0 },
  };
}

export function cdbrdfMaterial(table, lighting, map = null) {
  return new THREE.ShaderMaterial({
    name: 'cdbrdf', glslVersion: THREE.GLSL3, side: THREE.DoubleSide,
    defines: map ? { CDBRDF_MAP: '' } : {},
    uniforms: Object.assign({}, table, lighting, map || {}),
    vertexShader: SURFACE_VS, fragmentShader: surfaceFS(),
  });
}

function decodeAtlas(pngBytes, enc, first) {
  const png = decodePng(new Uint8Array(pngBytes));
  if (png.depth !== 16 || png.channels !== 3) throw new Error('cdbrdf: a curvature map image is not 16-bit RGB');
  const n = png.width * png.height, out = new Float32Array(4 * n), q = png.data;
  for (let i = 0; i < n; i++) {
    for (let c = 0; c < 3; c++) out[4 * i + c] = enc.offset[first + c] + enc.scale[first + c] * (q[3 * i + c] / 65535);
    out[4 * i + 3] = 1;
  }
  const t = new THREE.DataTexture(out, png.width, png.height, THREE.RGBAFormat, THREE.FloatType);
  t.minFilter = t.magFilter = THREE.NearestFilter; t.generateMipmaps = false; t.needsUpdate = true;
  return t;
}

// The curvature map's uniforms (ext.curvature.map) from its two PNG atlases.
export function mapUniforms(ext, pngA, pngB) {
  const m = ext.curvature.map, enc = m.encoding;
  if (enc.type !== 'unorm16') throw new Error(`cdbrdf: unknown curvature map encoding ${enc.type}`);
  if (m.levels.length > 16) throw new Error('cdbrdf: a curvature map of more than 16 levels');
  const levels = new Int32Array(48);  // three sets an ivec3 array from a flat array
  for (let i = 0; i < 16; i++) levels.set(m.levels[Math.min(i, m.levels.length - 1)], 3 * i);
  return {
    uMapA: { value: decodeAtlas(pngA, enc, 0) }, uMapB: { value: decodeAtlas(pngB, enc, 3) },
    uMapLevel: { value: levels }, uMapN: { value: m.levels.length },
    uMapTransform: { value: new THREE.Vector4(...m.transform) }, uMapUvScale: { value: new THREE.Vector2(...m.uvScale) },
    uMapMinLevel: { value: m.minLevel }, uDirectional: { value: ext.curvature.mode === 'directional' ? 1 : 0 },
  };
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

  async _image(textureIndex) {
    const json = this.parser.json;
    const image = json.images[json.textures[textureIndex].source];
    return this.parser.getDependency('bufferView', image.bufferView);
  }

  async _table(ext) {
    return tableUniforms(ext, await this._image(ext.lookup.texture.index));
  }

  async _map(ext) {
    const m = ext.curvature && ext.curvature.map;
    if (!m) return null;
    const [a, b] = await Promise.all(m.textures.map((t) => this._image(t.index)));
    return mapUniforms(ext, a, b);
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
      if (!cache.has(index)) cache.set(index, Promise.all([this._table(ext), this._map(ext)]));
      let [table, map] = await cache.get(index);
      const sName = String(ext.curvature.shapeAttribute || '').toLowerCase();
      if (map && g.attributes[sName] && g.attributes.uv) {
        g.setAttribute('cdbrdfShape', g.attributes[sName]);
        g.setAttribute('cdbrdfUv', g.attributes.uv);
      } else {
        map = null;  // a map needs the mesh's UVs and shape operator
      }
      const material = cdbrdfMaterial(table, this.lighting, map);
      mesh.userData.cdbrdf = { material, fallback: mesh.material, table, map, extension: ext };
      if (this.apply) mesh.material = material;
    }
  }
}
