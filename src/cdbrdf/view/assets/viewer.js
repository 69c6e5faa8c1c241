// cdbrdf viewer: plain WebGL2, no library. The table's lookup runs in GLSL with the rule of
// cdbrdf.interp (multilinear in five axes, periodic azimuth, pole rule, clamped elevation and
// kappa, snapping, the isotropic rotation): one more implementation of that rule, tested against
// CDBRDF.evaluate (tests/test_viewer.py). The data come from data.js (window.CDBRDF_VIEWER_DATA),
// base64 assets written by cdbrdf.view.export, so that the page works from file:// as well.
(function () {
  'use strict';

  const DATA = window.CDBRDF_VIEWER_DATA;
  const $ = (id) => document.getElementById(id);
  const KMAX_OVERLAY = 0.25; // mm^-1 at full colour in the curvature overlay
  const SOFTWARE_COMPONENTS = 8; // CD-BTF components a software renderer starts with

  function fail(text) {
    const m = $('message');
    m.textContent = text;
    m.style.display = 'block';
    return new Error(text);
  }

  function decode(b64) {
    const s = atob(b64);
    const out = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
    return out.buffer;
  }

  function base64(bytes) {
    let s = '';
    for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
    return btoa(s);
  }

  function block(asset, name) {
    const b = asset.header.blocks[name];
    const T = { float32: Float32Array, float16: Uint16Array, uint8: Uint8Array, int32: Int32Array,
      uint32: Uint32Array }[b.dtype];
    return new T(asset.buffer, b.offset, b.bytes / T.BYTES_PER_ELEMENT);
  }

  // ---------------------------------------------------------------- GLSL
  // the 5-D lookup of cdbrdf.interp: written once, in lookup.js (shared with the glTF renderer)
  const LOOKUP_GLSL = window.CDBRDF_LOOKUP_GLSL + `

#ifdef BTF
// CD-BTF (cdbrdf.view.btf_asset): mean + sum_i w_i(u, v) basis_i, every term looked up by the rule above.
// Compiled only into the programs that draw a CD-BTF: the plain table's programs stay as small as before.
uniform int uBtf;                 // 1: the bound table is a CD-BTF
uniform sampler2DArray uComp;     // RGBA, a layer per kappa: texel i = sample * uPer + component (0: the mean)
uniform int uCompW, uPer;         // its width; 1 + the rank packed
uniform sampler2DArray uWts;      // RGBA32F (layer j: components 4j..4j+3) per texel, (u, v) = (x, y)
uniform ivec2 uTexels;            // n_u, n_v
uniform vec2 uRepeat;             // the repeat's size, mm
uniform int uRank;                // components used (<= uPer - 1)
uniform float uFadeLevels;        // levels of the texels' pyramid (cdbrdf.btf._neural.level_shapes)
uniform float uTexelSize;         // the larger side of a texel, mm

vec3 comp(int s, int layer, int j) { int i = s * uPer + j; return texelFetch(uComp, ivec3(i % uCompW, i / uCompW, layer), 0).rgb; }
vec4 wts(ivec2 t, int g) { return texelFetch(uWts, ivec3(t, g), 0); }

// A neural CD-BTF (cdbrdf.btf._neural): max(0, M (1 + fade o)), o the decoder on the texel's latent code (a
// pyramid level chosen by the footprint, bilinear between texel centres, linear between levels) and the query.
uniform int uNeural;            // 1: the bound CD-BTF has a decoder
uniform sampler2D uLat;         // RGBA32F: group g of code c at i = c * uLatG + g, texel (i % uLatW, i / uLatW)
uniform int uLatW, uLatG;       // its width; groups of 4 numbers per code
uniform ivec4 uLev[8];          // per level: n_u, n_v, first code
uniform int uNLev;
uniform sampler2D uDec;         // RGBA32F: a row per neuron, its weights in groups of 4 then (bias, 0, 0, 0)
uniform ivec4 uLay;             // groups of the first layer's input (code + 3 of features), hidden 1, hidden 2, outputs
uniform vec3 uDecC;             // kappa scale, luminance epsilon, offset
uniform vec4 uClampT;           // theta_v min, max, theta_l min, max
uniform float uTexelMM;         // the larger side of a level-0 texel, mm
vec4 latG(int c, int g) { int i = c * uLatG + g; return texelFetch(uLat, ivec2(i % uLatW, i / uLatW), 0); }
vec4 dec(int row, int g) { return texelFetch(uDec, ivec2(g, row), 0); }
void addCode(int lv, vec2 f, float s, inout vec4 z[8]) {
  ivec4 L = uLev[lv]; ivec2 n = L.xy;
  vec2 x = f * vec2(n) - 0.5, x0 = floor(x), t = x - x0;
  ivec2 i0 = clamp((ivec2(x0) % n + n) % n, ivec2(0), n - 1), i1 = (i0 + 1) % n;  // clamped: never outside
  for (int k = 0; k < 4; k++) {
    ivec2 c = ivec2(k % 2 == 0 ? i0.x : i1.x, k < 2 ? i0.y : i1.y);
    float w = s * (k % 2 == 0 ? 1.0 - t.x : t.x) * (k < 2 ? 1.0 - t.y : t.y);
    if (w == 0.0) continue;
    int code = L.z + c.y * n.x + c.x;
    for (int g = 0; g < 8; g++) { if (g >= uLatG) break; z[g] += w * latG(code, g); }
  }
}
vec3 neural(vec3 mean, float tv, float pv, float tl, float pl, float k, vec2 p, float fp) {
  float lam = log2(max(fp / uTexelMM, 1.0));
  float fade = clamp(float(uNLev) - lam, 0.0, 1.0);
  if (fade == 0.0) return mean;
  int lv = min(int(floor(lam)), uNLev - 1);
  float t = lv < uNLev - 1 ? lam - float(lv) : 0.0;
  vec4 x[11];
  for (int g = 0; g < 11; g++) x[g] = vec4(0.0);
  vec2 f = p / uRepeat; f -= floor(f);
  vec4 z[8];
  for (int g = 0; g < 8; g++) z[g] = vec4(0.0);
  addCode(lv, f, 1.0 - t, z);
  if (t > 0.0) addCode(lv + 1, f, t, z);
  for (int g = 0; g < 8; g++) { if (g >= uLatG) break; x[g] = z[g]; }
  if (uIso == 1) { pv = wrapAz(wrapAz(pv) - wrapAz(pl)); pl = 0.0; }
  tv = radians(clamp(tv, uClampT.x, uClampT.y)); tl = radians(clamp(tl, uClampT.z, uClampT.w));
  pv = radians(pv); pl = radians(pl);
  vec3 l = vec3(sin(tl) * cos(pl), sin(tl) * sin(pl), cos(tl)), v = vec3(sin(tv) * cos(pv), sin(tv) * sin(pv), cos(tv));
  vec3 h = l + v; h *= inversesqrt(max(dot(h, h), 1e-24));
  float lm = log(max(dot(mean, vec3(0.2126, 0.7152, 0.0722)), 0.0) + uDecC.y) - uDecC.z;
  x[uLatG] = vec4(l, v.x); x[uLatG + 1] = vec4(v.yz, h.xy); k = clamp(k, axisAt(0, 0), axisAt(0, uN.x - 1));
  x[uLatG + 2] = vec4(h.z, k / uDecC.x, lm, 0.0);
  vec4 a[32], b[32];
  int gin = uLay.x, h1 = uLay.y / 4, h2 = uLay.z / 4;
  for (int j = 0; j < 32; j++) {
    if (j >= h1) break;
    vec4 acc = vec4(0.0);
    for (int q = 0; q < 4; q++) {
      int row = 4 * j + q; float s = dec(row, gin).x;
      for (int g = 0; g < 11; g++) { if (g >= gin) break; s += dot(dec(row, g), x[g]); }
      acc[q] = max(s, 0.0);
    }
    a[j] = acc;
  }
  for (int j = 0; j < 32; j++) {
    if (j >= h2) break;
    vec4 acc = vec4(0.0);
    for (int q = 0; q < 4; q++) {
      int row = uLay.y + 4 * j + q; float s = dec(row, h1).x;
      for (int g = 0; g < 32; g++) { if (g >= h1) break; s += dot(dec(row, g), a[g]); }
      acc[q] = max(s, 0.0);
    }
    b[j] = acc;
  }
  vec3 o;
  for (int c = 0; c < 3; c++) {
    int row = uLay.y + uLay.z + min(c, uLay.w - 1); float s = dec(row, h2).x;
    for (int g = 0; g < 32; g++) { if (g >= h2) break; s += dot(dec(row, g), b[g]); }
    o[c] = s;
  }
  return max(mean * (1.0 + fade * o), 0.0);
}
// p: the position on the fabric, mm (periodic over the repeat); fp: the footprint there, mm (0: the texels)
vec3 lookupBTF(float tv, float pv, float tl, float pl, float k, vec2 p, float fp) {
  int ci[32]; int cl[32]; float cw[32];
  int n = 0;
  Cell cc = cell(tv, pv, tl, pl, k);
  FOR_CORNERS(cc, ci[n] = I; cl[n] = L; cw[n] = W; n++;)
  vec3 acc = vec3(0.0);
  for (int c = 0; c < 32; c++) { if (c >= n) break; acc += cw[c] * comp(ci[c], cl[c], 0); }
  if (uNeural == 1) acc = neural(acc, tv, pv, tl, pl, k, p, fp);
  // the components fade out over the last level of the pyramid (the texels' pyramid itself is not built here)
  float fadeC = clamp(uFadeLevels - log2(max(fp / uTexelSize, 1.0)), 0.0, 1.0);
  if (uRank == 0 || fadeC == 0.0) return acc;
  // the weights: periodic bilinear between texel centres (CDBTF.texel_weights)
  vec2 r = p / uRepeat;
  vec2 f = (r - floor(r)) * vec2(uTexels) - 0.5, f0 = floor(f), t = f - f0;
  ivec2 i0 = clamp((ivec2(f0) % uTexels + uTexels) % uTexels, ivec2(0), uTexels - 1), i1 = (i0 + 1) % uTexels;
  for (int g = 0; 4 * g < uRank; g++) {
    vec4 w = mix(mix(wts(i0, g), wts(ivec2(i1.x, i0.y), g), t.x), mix(wts(ivec2(i0.x, i1.y), g), wts(i1, g), t.x), t.y);
    for (int q = 0; q < 4; q++) {
      int j = 4 * g + q + 1;
      if (j > uRank) break;
      if (w[q] == 0.0) continue;
      vec3 s = vec3(0.0);
      for (int c = 0; c < 32; c++) { if (c >= n) break; s += cw[c] * comp(ci[c], cl[c], j); }
      acc += fadeC * w[q] * s;
    }
  }
  return acc;
}
#endif
vec3 srgb(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
}
`;

  // A curvature map (cdbrdf.mesh.curvature_map, packed by cdbrdf.view.asset.map_atlas): the lookup rule of
  // CurvatureMap (the level of the footprint, bilinear between texel centres, periodic, row 0 at the top, linear
  // between levels: trilinear, on the map's own prefiltered levels read with texelFetch, not WebGL's mip maps) and
  // the plug-in's use of it (cdbrdf.render._maps_jit: the detail's shape operator at the UV scale added to the
  // mesh's own, the eigenvalue of larger magnitude or the xx entry; the shading frame tilted as Mitsuba's
  // normalmap builds it). Written once; tested against the Python rule in tests/test_viewer_maps.py.
  const MAPS_GLSL = `
precision highp float; precision highp int; precision highp sampler2D;
uniform sampler2D uMap;     // RGBA: map texel j of a level at atlas texels 2 (offset + j), 2 (offset + j) + 1
uniform int uMapW;          // the atlas's width: texel i at (i % uMapW, i / uMapW)
uniform ivec4 uMapLev[16];  // per level: width, height, offset (map texels)
uniform int uMapN;          // levels
uniform vec4 uMapTr;        // texture transform: t = (ru u + ou, rv v + ov)
uniform vec2 uMapScale;     // UV scale, mm per UV unit (su, sv)
uniform float uMapMin;      // the finest level read (the curvature's neighbourhood)
uniform int uMapDir;        // 1: the directional curvature (xx), 0: the eigenvalue of larger magnitude
struct MapTexel { vec4 a; vec2 b; };  // (p, q, dp/du, dp/dv), (dq/du, dq/dv)
struct MapDetail { float p, q; vec3 k; };  // slopes and the shape operator (kxx, kxy, kyy), 1/mm, shading frame

// the level of a footprint (fu, fv) in UV units: log2 in level-0 texels along the map's longer axis
float mapLevel(vec2 f) {
  vec2 n = vec2(uMapLev[0].xy) * abs(uMapTr.xy);
  float t = max(f.x * n.x, f.y * n.y);
  return clamp(max(log2(max(t, 1e-30)), uMapMin), 0.0, float(uMapN - 1));
}
MapTexel mapFetch(int lv, ivec2 c) {
  ivec4 L = uMapLev[lv];
  int i = 2 * (L.z + c.y * L.x + c.x);
  MapTexel m;
  m.a = texelFetch(uMap, ivec2(i % uMapW, i / uMapW), 0);
  m.b = texelFetch(uMap, ivec2((i + 1) % uMapW, (i + 1) / uMapW), 0).xy;
  return m;
}
void mapAdd(inout MapTexel acc, MapTexel m, float w) { acc.a += w * m.a; acc.b += w * m.b; }
// level lv at texture coordinates t: bilinear between the four nearest texel centres, periodic
void mapBilinear(int lv, vec2 t, float s, inout MapTexel acc) {
  ivec2 n = uMapLev[lv].xy;
  vec2 x = vec2(t.x - floor(t.x), (1.0 - t.y) - floor(1.0 - t.y)) * vec2(n) - 0.5;
  vec2 x0 = floor(x), f = x - x0;
  ivec2 i0 = ivec2(x0);  // in [-1, n - 1]
  if (i0.x < 0) i0.x += n.x;
  if (i0.y < 0) i0.y += n.y;
  ivec2 i1 = ivec2(i0.x + 1 < n.x ? i0.x + 1 : 0, i0.y + 1 < n.y ? i0.y + 1 : 0);
  mapAdd(acc, mapFetch(lv, i0), s * (1.0 - f.x) * (1.0 - f.y));
  mapAdd(acc, mapFetch(lv, ivec2(i1.x, i0.y)), s * f.x * (1.0 - f.y));
  mapAdd(acc, mapFetch(lv, ivec2(i0.x, i1.y)), s * (1.0 - f.x) * f.y);
  mapAdd(acc, mapFetch(lv, i1), s * f.x * f.y);
}
// the six values at mesh UVs and a (fractional) level: trilinear
MapTexel mapTexel(vec2 uv, float level) {
  vec2 t = uv * uMapTr.xy + uMapTr.zw;
  float l = clamp(level, 0.0, float(uMapN - 1));
  int l0 = int(floor(l));
  float f = l - float(l0);
  MapTexel acc; acc.a = vec4(0.0); acc.b = vec2(0.0);
  mapBilinear(l0, t, l0 + 1 < uMapN ? 1.0 - f : 1.0, acc);
  if (l0 + 1 < uMapN && f > 0.0) mapBilinear(l0 + 1, t, f, acc);
  return acc;
}
// the detail at the UV scale in the shading frame; hand = -1 on a mirrored UV layout (flips q and kxy)
MapDetail mapDetail(MapTexel m, float hand) {
  MapDetail d;
  d.p = m.a.x; d.q = m.a.y * hand;
  d.k = vec3(m.a.z / uMapScale.x, (0.5 * m.a.w / uMapScale.y + 0.5 * m.b.x / uMapScale.x) * hand, m.b.y / uMapScale.y);
  return d;
}
// the curvature of the mesh's shape operator (sxx, sxy, syy) plus the detail's
float mapCurvature(vec3 mesh, MapDetail d, int directional) {
  vec3 s = mesh + d.k;
  if (directional == 1) return s.x;
  float mean = 0.5 * (s.x + s.z), half_ = sqrt(0.25 * (s.x - s.z) * (s.x - s.z) + s.y * s.y);
  return mean >= 0.0 ? mean + half_ : mean - half_;
}
// the tilted frame (columns s', t', n' in shading-frame coordinates) for the view direction wi there
mat3 mapFrame(float p, float q, vec3 wi) {
  vec3 n = normalize(vec3(p, q, 1.0));
  if (wi.z * dot(wi, n) <= 0.0) n.xy = -n.xy;  // mirrored about the normal when it faces away from the viewer
  vec3 s = normalize(vec3(1.0 - n.x * n.x, -n.x * n.y, -n.x * n.z));
  return mat3(s, cross(n, s), n);
}
`;

  const FULLSCREEN_VS = `#version 300 es
void main() { vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2)); gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }`;

  const EVAL_FS = `#version 300 es
${LOOKUP_GLSL}
uniform sampler2D uQ;  // two texels per query: (theta_v, phi_v, theta_l, phi_l), (kappa, u_mm, v_mm, 1 + footprint mm: at (u, v))
out vec4 o;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 a = texelFetch(uQ, ivec2(2 * p.x, p.y), 0);
  vec4 b = texelFetch(uQ, ivec2(2 * p.x + 1, p.y), 0);
#ifdef BTF
  o = vec4(uBtf == 1 && b.w > 0.5 ? lookupBTF(a.x, a.y, a.z, a.w, b.x, b.yz, b.w - 1.0) : lookup(a.x, a.y, a.z, a.w, b.x), 1.0);
#else
  o = vec4(lookup(a.x, a.y, a.z, a.w, b.x), 1.0);
#endif
}`;

  // the map's rule at given points, for the tests: queries of three texels (u, v, level or -1: from the
  // footprint, fu), (fv, sxx, sxy, syy), (hand, wi in the shading frame); uOut picks four of the outputs
  const MAP_EVAL_FS = `#version 300 es
${MAPS_GLSL}
uniform sampler2D uQ; uniform int uOut;
out vec4 o;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 a = texelFetch(uQ, ivec2(3 * p.x, p.y), 0), b = texelFetch(uQ, ivec2(3 * p.x + 1, p.y), 0);
  vec4 c = texelFetch(uQ, ivec2(3 * p.x + 2, p.y), 0);
  float lv = a.z >= 0.0 ? a.z : mapLevel(vec2(a.w, b.x));
  MapTexel m = mapTexel(a.xy, lv);
  MapDetail d = mapDetail(m, c.x);
  mat3 f = mapFrame(d.p, d.q, c.yzw);
  if (uOut == 0) o = m.a;
  else if (uOut == 1) o = vec4(m.b, lv, mapCurvature(b.yzw, d, 0));
  else if (uOut == 2) o = vec4(mapCurvature(b.yzw, d, 1), f[2]);
  else o = vec4(f[0], d.q);
}`;

  const POLAR_FS = `#version 300 es
${LOOKUP_GLSL}
uniform vec2 uL; uniform float uK; uniform vec2 uSize; uniform float uExpo;
out vec4 o;
void main() {
  vec2 q = gl_FragCoord.xy / uSize * 2.0 - 1.0;
  float r = length(q);
  if (r > 1.0) { o = vec4(0.125, 0.125, 0.125, 1.0); return; }
  float pv = r > 0.0 ? degrees(atan(q.y, q.x)) : 0.0;
  if (pv < 0.0) pv += 360.0;
  o = vec4(srgb(lookup(min(r * 90.0, 90.0), pv, uL.x, uL.y, uK) * uExpo), 1.0);
}`;

  const SURFACE_VS = `#version 300 es
in vec3 aPos; in vec3 aNrm; in vec3 aTan; in float aK;
uniform mat4 uMVP; uniform int uSurf; uniform float uAmp, uWave, uStandK, uWidth, uDepth;
#if defined(BTF) || defined(MAPS)
in vec2 aUV;            // a mesh's UVs (zero without)
#endif
#ifdef BTF
uniform vec2 uUvScale;  // mm of fabric per UV unit (cdbrdf view --uv-scale, the renderer's uv_scale)
#endif
#ifdef MAPS
in vec4 aShape;         // the mesh's own shape operator (sxx, sxy, syy; 1/mm, x = dP/du) and the UV handedness
out vec2 vMapUV; out vec4 vShape;
#endif
out vec3 vWorld; out vec3 vN; out vec3 vT; out float vK; out float vS; out vec2 vUV;
void main() {
  vec3 p = aPos;
  vN = aNrm; vT = aTan; vK = aK; vS = 0.0; vUV = vec2(0.0);
#ifdef MAPS
  vMapUV = aUV; vShape = aShape;
#endif
  if (uSurf == 1) {          // sine sheet: z = A sin(2 pi x / L)
    float x = (aPos.x - 0.5) * uWidth;
    p = vec3(x, (aPos.y - 0.5) * uDepth, uAmp * sin(6.283185307179586 * x / uWave));
    vS = x;
    vUV = vec2(x + 0.5 * uWidth, aPos.y * uDepth);  // the renderer's UVs times uv_scale = (width, depth), mm
  } else if (uSurf == 2) {   // a stand of constant curvature: arc length s across
    float span = uWidth;
    if (abs(uStandK) > 1e-6) span = min(uWidth, 0.9 * 3.141592653589793 / abs(uStandK));
    float s = (aPos.x - 0.5) * span, a = uStandK * s;
    float x = abs(a) < 1e-4 ? s : sin(a) / uStandK;
    float z = abs(a) < 1e-4 ? -0.5 * uStandK * s * s : (cos(a) - 1.0) / uStandK;
    p = vec3(x, (aPos.y - 0.5) * uDepth, z);
    vS = s;
    vUV = vec2(s + 0.5 * uWidth, aPos.y * uDepth);  // arc length across: mm of the flat fabric
  }
#ifdef BTF
  else vUV = aUV * uUvScale;  // a mesh: its UVs in mm of fabric
#endif
  vWorld = p;
  gl_Position = uMVP * vec4(p, 1.0);
}`;

  const SURFACE_FS = `#version 300 es
${LOOKUP_GLSL}
#ifdef MAPS
${MAPS_GLSL}
in vec2 vMapUV; in vec4 vShape;
#endif
in vec3 vWorld; in vec3 vN; in vec3 vT; in float vK; in float vS; in vec2 vUV;
uniform int uSurf; uniform float uAmp, uWave, uStandK;
uniform float uWeaveScale;  // BTF: decode the CD-BTF at (u, v) / scale (sheet, stand, a mesh with UVs)
uniform vec3 uEye; uniform vec3 uLight; uniform float uExpo;  // uExpo = pi * 2^EV (irradiance pi: white = 1)
uniform int uEnv; uniform vec3 uEnvDir[9]; uniform float uEnvW[9];
uniform int uMode; uniform float uSplitX; uniform int uOverlay; uniform float uKmax; uniform int uPick;
out vec4 o;
float gFootprint = 0.0;  // the pixel's extent on the fabric (mm), from the derivatives in main (uniform control flow)
vec3 reflectance(vec2 av, vec2 al, float k) {
#ifdef BTF
  return lookupBTF(av.x, av.y, al.x, al.y, k, vUV / uWeaveScale, gFootprint);
#else
  return lookup(av.x, av.y, al.x, al.y, k);
#endif
}
vec2 angles(vec3 d, vec3 n, vec3 t, vec3 b) {
  vec3 l = vec3(dot(d, t), dot(d, b), dot(d, n));
  float th = degrees(acos(clamp(l.z, -1.0, 1.0)));
  float ph = length(l.xy) > 1e-7 ? degrees(atan(l.y, l.x)) : 0.0;
  if (ph < 0.0) ph += 360.0;
  return vec2(min(th, 90.0), ph);
}
// the cosine of a light direction at the point: 0 below the shading normal ns or the (tilted) normal n
float cosLight(vec3 l, vec3 n, vec3 ns) { return dot(l, ns) > 0.0 ? max(dot(l, n), 0.0) : 0.0; }
void main() {
#ifdef BTF
  vec2 pUV = vUV / uWeaveScale;
  gFootprint = max(length(dFdx(pUV)), length(dFdy(pUV)));
#endif
#ifdef MAPS
  // the footprint in UV units along u and v: the UV partials of the pixel (the plug-in's duv_dx, duv_dy)
  float mapLv = mapLevel(max(abs(dFdx(vMapUV)), abs(dFdy(vMapUV))));
#endif
  vec3 n, t; float k;
  if (uSurf == 1) {
    float w = 6.283185307179586 / uWave, d1 = uAmp * w * cos(w * vS);
    n = normalize(vec3(-d1, 0.0, 1.0)); t = normalize(vec3(1.0, 0.0, d1));
    k = uAmp * w * w * sin(w * vS) / pow(1.0 + d1 * d1, 1.5);  // crest convex: kappa > 0
  } else if (uSurf == 2) {
    float a = uStandK * vS;
    n = vec3(sin(a), 0.0, cos(a)); t = vec3(cos(a), 0.0, -sin(a)); k = uStandK;
  } else {
    n = normalize(vN); t = normalize(vT - dot(vT, n) * n); k = vK;
  }
  vec3 b = cross(n, t);
  vec3 v = normalize(uEye - vWorld);
  bool front = dot(v, n) > 0.0;
  vec3 ns = n;  // the shading normal
#ifdef MAPS
  // the map's detail: its curvature added to the mesh's shape operator, the frame tilted by its slopes
  MapDetail md = mapDetail(mapTexel(vMapUV, mapLv), vShape.w < 0.0 ? -1.0 : 1.0);
  k = mapCurvature(vShape.xyz, md, uMapDir);
  mat3 sh = mat3(t, b, n), tilt = mapFrame(md.p, md.q, vec3(dot(v, t), dot(v, b), dot(v, n)));
  t = sh * tilt[0]; b = sh * tilt[1]; n = sh * tilt[2];
#endif
  float kq = (uMode == 0 || (uMode == 2 && gl_FragCoord.x < uSplitX)) ? 0.0 : k;
  vec2 av = angles(v, n, t, b);
  if (uPick == 1) { vec2 al = angles(uLight, n, t, b); o = front ? vec4(av, al) : vec4(-1.0); return; }
  if (uPick == 2) { o = vec4(kq, k, front ? 1.0 : 0.0, dot(uLight, ns) > 0.0 ? dot(uLight, n) : dot(uLight, ns)); return; }
  vec3 c = vec3(0.0);
  if (!front) {
    c = vec3(0.02);
  } else if (uEnv == 0) {
    float cl = cosLight(uLight, n, ns);
    if (cl > 0.0) { vec2 al = angles(uLight, n, t, b); c = reflectance(av, al, kq) * cl * uExpo; }
  } else {
    for (int i = 0; i < 9; i++) {
      float cl = cosLight(uEnvDir[i], n, ns);
      if (cl <= 0.0) continue;
      vec2 al = angles(uEnvDir[i], n, t, b);
      c += uEnvW[i] * reflectance(av, al, kq) * cl * uExpo;
    }
  }
  vec3 s = srgb(c);
  if (uOverlay == 1) {
    float x = clamp(k / uKmax, -1.0, 1.0);
    vec3 fc = x > 0.0 ? mix(vec3(1.0), vec3(0.85, 0.1, 0.1), x) : mix(vec3(1.0), vec3(0.1, 0.3, 0.9), -x);
    s = mix(s, fc, 0.6);
  }
  if (uMode == 2 && abs(gl_FragCoord.x - uSplitX) < 1.0) s = vec3(1.0);
  o = vec4(s, 1.0);
}`;

  // ---------------------------------------------------------------- matrices
  function perspective(fovy, aspect, near, far) {
    const f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
    return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
  }
  function lookAt(e, c, up) {
    const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    const norm = (a) => { const l = Math.hypot(a[0], a[1], a[2]); return [a[0] / l, a[1] / l, a[2] / l]; };
    const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const z = norm(sub(e, c)), x = norm(cross(up, z)), y = cross(z, x);
    return [x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -dot(x, e), -dot(y, e), -dot(z, e), 1];
  }
  function mul(a, b) {  // column-major a * b
    const o = new Array(16).fill(0);
    for (let c = 0; c < 4; c++) for (let r = 0; r < 4; r++) for (let k = 0; k < 4; k++) o[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
    return o;
  }
  const rad = (d) => d * Math.PI / 180;
  const dirOf = (thetaDeg, phiDeg) => [Math.sin(rad(thetaDeg)) * Math.cos(rad(phiDeg)),
    Math.sin(rad(thetaDeg)) * Math.sin(rad(phiDeg)), Math.cos(rad(thetaDeg))];

  // a small sky: zenith, four at 35 degrees, four at 65 degrees; weights sum to 1 (white Lambertian facing up: 1)
  const ENV = (function () {
    const d = [[0, 0]], w = [1.0];
    for (let i = 0; i < 4; i++) { d.push([35, 45 + 90 * i]); w.push(0.9); }
    for (let i = 0; i < 4; i++) { d.push([65, 90 * i]); w.push(0.6); }
    const dirs = d.map(([t, p]) => dirOf(t, p));
    const lamb = dirs.reduce((s, x, i) => s + w[i] * x[2], 0);
    return { dirs: dirs.flat(), w: w.map((x) => x / lamb) };
  })();

  // ---------------------------------------------------------------- GL setup
  const canvas = $('view');
  const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
  const state = {
    // the sine sheet's geometry comes from data.js (cdbrdf.mesh.SineSheet, mm), set in init()
    surface: 'sheet', amplitude: NaN, wavelength: NaN, width: NaN, depth: NaN, standKappa: 0.13,
    lightTheta: 45.0, lightPhi: 0.0, env: false, exposure: 0.0, mode: 'cdbrdf', split: 0.5, overlay: false,
    side: false, cam: { elevation: 50.0, azimuth: -90.0, distance: 150.0 }, mosaicTable: 0, mosaicK: 0,
    pick: null, drawCalls: 0, weave: true, weaveScale: 1.0, components: 0, maps: true,
  };
  const viewer = { errors: [] };
  window.cdbrdfViewer = viewer;

  // their locations: aUV only in the CD-BTF and map programs, aShape only in the map programs
  const ATTRIBS = ['aPos', 'aNrm', 'aTan', 'aK', 'aUV', 'aShape'];
  function compile(vs, fs) {
    const p = gl.createProgram();
    for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
      const s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw fail('shader: ' + gl.getShaderInfoLog(s));
      gl.attachShader(p, s);
    }
    ATTRIBS.forEach((name, i) => gl.bindAttribLocation(p, i, name));  // one VAO layout for every program
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw fail('shader link: ' + gl.getProgramInfoLog(p));
    const u = {};
    const n = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS);
    for (let i = 0; i < n; i++) {
      const name = gl.getActiveUniform(p, i).name.replace(/\[0\]$/, '');
      u[name] = gl.getUniformLocation(p, name);
    }
    return { p, u };
  }

  function uploadTable(asset, index) {
    const h = asset.header, tex = h.lookup.texture;
    const limits = { MAX_TEXTURE_SIZE: gl.getParameter(gl.MAX_TEXTURE_SIZE),
      MAX_ARRAY_TEXTURE_LAYERS: gl.getParameter(gl.MAX_ARRAY_TEXTURE_LAYERS) };
    const over = [];
    if (tex.width > limits.MAX_TEXTURE_SIZE) over.push(`texture width ${tex.width} > MAX_TEXTURE_SIZE ${limits.MAX_TEXTURE_SIZE}`);
    if (tex.height > limits.MAX_TEXTURE_SIZE) over.push(`texture height ${tex.height} > MAX_TEXTURE_SIZE ${limits.MAX_TEXTURE_SIZE}`);
    if (tex.layers > limits.MAX_ARRAY_TEXTURE_LAYERS) over.push(`${tex.layers} curvatures > MAX_ARRAY_TEXTURE_LAYERS ${limits.MAX_ARRAY_TEXTURE_LAYERS}`);
    if (over.length) throw fail(`${h.name}: too large for this GPU's textures (${over.join('; ')}); resample it with cdbrdf view --grid THETA_STEP,PHI_STEP`);
    const half = tex.type === 'float16';
    const t = gl.createTexture();
    gl.activeTexture(gl.TEXTURE0 + 2 * index);
    gl.bindTexture(gl.TEXTURE_2D_ARRAY, t);
    gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage3D(gl.TEXTURE_2D_ARRAY, 0, half ? gl.RGBA16F : gl.RGBA32F, tex.width, tex.height, tex.layers, 0,
      gl.RGBA, half ? gl.HALF_FLOAT : gl.FLOAT, block(asset, 'lookup'));
    const L = h.lookup, n = Math.max(L.kappa.length, L.theta_l.length, L.theta_v.length);
    const axes = new Float32Array(3 * n);
    [L.kappa, L.theta_l, L.theta_v].forEach((a, r) => a.forEach((x, i) => { axes[r * n + i] = x; }));
    const ta = gl.createTexture();
    gl.activeTexture(gl.TEXTURE0 + 2 * index + 1);
    gl.bindTexture(gl.TEXTURE_2D, ta);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.R32F, n, 3, 0, gl.RED, gl.FLOAT, axes);
    const [nk, npl, ntl, npv, ntv] = L.shape;
    return { asset, h, unit: 2 * index, N: [nk, ntl, ntv], Nphi: [npl, npv],
      phi: [L.phi_l0, L.phi_l_step, L.phi_v0, L.phi_v_step], iso: L.isotropic ? 1 : 0,
      invStep: [0, L.theta_l_inv_step, L.theta_v_inv_step], texW: tex.width,
      samples: block(asset, 'samples'), measured: block(asset, 'measured'),
      fillMethod: block(asset, 'fill_method'), fillSource: block(asset, 'fill_source'),
      btf: h.kind === 'btf' ? uploadBTF(asset, index, limits) : null };
  }

  // a CD-BTF's components (1 + rank texels per sample) and per-texel weights: units 8 + 2 index, 9 + 2 index
  const BTF_UNIT = 8;
  function uploadBTF(asset, index, limits) {
    const h = asset.header, b = h.btf, c = b.components, w = b.weights;
    const over = [];
    for (const [what, t] of [['components', c], ['weights', w]]) {
      if (t.width > limits.MAX_TEXTURE_SIZE || t.height > limits.MAX_TEXTURE_SIZE) over.push(`${what} texture ${t.width} x ${t.height} > MAX_TEXTURE_SIZE ${limits.MAX_TEXTURE_SIZE}`);
      if (t.layers > limits.MAX_ARRAY_TEXTURE_LAYERS) over.push(`${what}: ${t.layers} layers > MAX_ARRAY_TEXTURE_LAYERS ${limits.MAX_ARRAY_TEXTURE_LAYERS}`);
    }
    if (over.length) throw fail(`${h.name}: the CD-BTF is too large for this GPU's textures (${over.join('; ')}); use fewer components with cdbrdf view --rank N`);
    const half = c.type === 'float16';
    const tex = (unit, width, height, layers, data, f16) => {
      const t = gl.createTexture();
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D_ARRAY, t);
      gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D_ARRAY, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
      gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
      gl.texImage3D(gl.TEXTURE_2D_ARRAY, 0, f16 ? gl.RGBA16F : gl.RGBA32F, width, height, layers, 0, gl.RGBA,
        f16 ? gl.HALF_FLOAT : gl.FLOAT, data);
    };
    tex(BTF_UNIT + 2 * index, c.width, c.height, c.layers, block(asset, 'components'), half);
    tex(BTF_UNIT + 2 * index + 1, w.width, w.height, w.layers, block(asset, 'weights'), false);
    const out = { unit: BTF_UNIT + 2 * index, compW: c.width, per: c.per_sample, rank: b.rank, rankTotal: b.rank_total,
      texels: b.texels, repeat: b.repeat_mm, neural: null, fadeLevels: b.levels };
    if (b.neural) {  // the latent pyramid and the decoder: 2D float textures, units NEURAL_UNIT + 2 index (+ 1)
      const nn = b.neural, tex2 = (unit, t, data) => {
        const x = gl.createTexture();
        gl.activeTexture(gl.TEXTURE0 + unit);
        gl.bindTexture(gl.TEXTURE_2D, x);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
        gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
        gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, t.width, t.height, 0, gl.RGBA, gl.FLOAT, data);
      };
      for (const [what, t] of [['latents', nn.latents], ['decoder', nn.decoder]]) {
        if (t.width > limits.MAX_TEXTURE_SIZE || t.height > limits.MAX_TEXTURE_SIZE) throw fail(`${h.name}: the CD-BTF's ${what} texture ${t.width} x ${t.height} exceeds MAX_TEXTURE_SIZE ${limits.MAX_TEXTURE_SIZE}`);
      }
      tex2(NEURAL_UNIT + 2 * index, nn.latents, block(asset, 'latents'));
      tex2(NEURAL_UNIT + 2 * index + 1, nn.decoder, block(asset, 'decoder'));
      out.neural = { unit: NEURAL_UNIT + 2 * index, latW: nn.latents.width, latG: nn.latents.groups,
        levels: nn.levels, layers: nn.layers, constants: nn.constants, clamp: nn.clamp, texelMM: nn.texel_mm };
    }
    return out;
  }
  const NEURAL_UNIT = 20;
  // the components a table uses now: the slider's cap, at most what was packed
  const rankUsed = (tab) => (tab.btf ? Math.max(0, Math.min(tab.btf.rank, state.components)) : 0);

  function bindTable(prog, tab) {
    gl.uniform1i(prog.u.uTab, tab.unit);
    gl.uniform1i(prog.u.uAxes, tab.unit + 1);
    gl.uniform3i(prog.u.uN, tab.N[0], tab.N[1], tab.N[2]);
    gl.uniform2i(prog.u.uNphi, tab.Nphi[0], tab.Nphi[1]);
    gl.uniform4f(prog.u.uPhi, tab.phi[0], tab.phi[1], tab.phi[2], tab.phi[3]);
    gl.uniform1i(prog.u.uIso, tab.iso);
    gl.uniform3f(prog.u.uInvStep, tab.invStep[0], tab.invStep[1], tab.invStep[2]);
    gl.uniform1i(prog.u.uTexW, tab.texW);
    const b = tab.btf;
    if (b && 'uComp' in prog.u) {  // a program with the CD-BTF decode (withBTF), drawing a CD-BTF
      gl.uniform1i(prog.u.uBtf, 1);
      gl.uniform1i(prog.u.uComp, b.unit); gl.uniform1i(prog.u.uWts, b.unit + 1);
      gl.uniform1i(prog.u.uCompW, b.compW); gl.uniform1i(prog.u.uPer, b.per);
      gl.uniform2i(prog.u.uTexels, b.texels[0], b.texels[1]);
      gl.uniform2f(prog.u.uRepeat, b.repeat[0], b.repeat[1]);
      gl.uniform1i(prog.u.uRank, rankUsed(tab));
      gl.uniform1f(prog.u.uFadeLevels, b.fadeLevels);
      gl.uniform1f(prog.u.uTexelSize, Math.max(b.repeat[0] / b.texels[0], b.repeat[1] / b.texels[1]));
      const nn = b.neural;
      gl.uniform1i(prog.u.uNeural, nn ? 1 : 0);
      if (nn) {
        gl.uniform1i(prog.u.uLat, nn.unit); gl.uniform1i(prog.u.uDec, nn.unit + 1);
        gl.uniform1i(prog.u.uLatW, nn.latW); gl.uniform1i(prog.u.uLatG, nn.latG);
        const lev = new Int32Array(32);
        nn.levels.forEach((l, i) => lev.set([l[0], l[1], l[2], 0], 4 * i));
        gl.uniform4iv(prog.u.uLev, lev);
        gl.uniform1i(prog.u.uNLev, nn.levels.length);
        gl.uniform4i(prog.u.uLay, nn.layers[0], nn.layers[1], nn.layers[2], nn.layers[3]);
        gl.uniform3f(prog.u.uDecC, nn.constants[0], nn.constants[1], nn.constants[2]);
        gl.uniform4f(prog.u.uClampT, nn.clamp[0], nn.clamp[1], nn.clamp[2], nn.clamp[3]);
        gl.uniform1f(prog.u.uTexelMM, nn.texelMM);
      }
    }
  }

  function gridGeometry(nx, ny) {  // (s, t) in [0, 1]^2 as positions; the vertex shader shapes it
    const pos = new Float32Array((nx + 1) * (ny + 1) * 3), idx = new Uint32Array(nx * ny * 6);
    let p = 0, q = 0;
    for (let i = 0; i <= nx; i++) for (let j = 0; j <= ny; j++) { pos[p++] = i / nx; pos[p++] = j / ny; pos[p++] = 0; }
    for (let i = 0; i < nx; i++) for (let j = 0; j < ny; j++) {
      const a = i * (ny + 1) + j, b = a + ny + 1;
      idx.set([a, b, b + 1, a, b + 1, a + 1], q); q += 6;
    }
    return { pos, idx };
  }

  function makeVAO(pos, nrm, tan, kap, idx, uv, shape) {  // at the bound locations (ATTRIBS), for every program
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    const attr = (name, data, size) => {
      const loc = ATTRIBS.indexOf(name);
      if (!data) {
        gl.disableVertexAttribArray(loc);
        if (size === 1) gl.vertexAttrib1f(loc, 0); else if (size === 2) gl.vertexAttrib2f(loc, 0, 0);
        else if (size === 4) gl.vertexAttrib4f(loc, 0, 0, 0, 1); else gl.vertexAttrib3f(loc, 0, 0, 1);
        return;
      }
      const b = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, b);
      gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, size, gl.FLOAT, false, 0, 0);
    };
    attr('aPos', pos, 3); attr('aNrm', nrm, 3); attr('aTan', tan, 3); attr('aK', kap, 1); attr('aUV', uv || null, 2);
    attr('aShape', shape || null, 4);
    const ib = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ib);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, idx, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return { vao, count: idx.length };
  }

  let surfProg, evalProg, polarProg, surfBtfProg = null, evalBtfProg = null, tables = [], surfaces = {}, emptyVAO;
  let surfMapProg = null, surfBtfMapProg = null, mapEvalProg = null;
  const withBTF = (src) => src.replace('#version 300 es', '#version 300 es\n#define BTF 1');
  const withMaps = (src) => src.replace('#version 300 es', '#version 300 es\n#define MAPS 1');

  // a mesh's curvature map (cdbrdf.view.asset.map_atlas): its levels in one RGBA texture, bound to MAP_UNIT to draw
  const MAP_UNIT = 12;
  function uploadMap(asset) {
    const m = asset.header.map, at = m.atlas, max = gl.getParameter(gl.MAX_TEXTURE_SIZE);
    if (at.width > max || at.height > max) throw fail(`${m.name}: its levels' texture ${at.width} x ${at.height} exceeds this GPU's MAX_TEXTURE_SIZE ${max}`);
    const half = at.type === 'float16', t = gl.createTexture();
    gl.activeTexture(gl.TEXTURE0 + MAP_UNIT);
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage2D(gl.TEXTURE_2D, 0, half ? gl.RGBA16F : gl.RGBA32F, at.width, at.height, 0, gl.RGBA,
      half ? gl.HALF_FLOAT : gl.FLOAT, block(asset, 'map'));
    const lev = new Int32Array(64);
    m.levels.forEach((l, i) => lev.set([l[0], l[1], l[2], 0], 4 * i));
    return { tex: t, h: m, lev };
  }
  function bindMap(prog, map) {
    const u = prog.u, m = map.h;
    gl.activeTexture(gl.TEXTURE0 + MAP_UNIT);
    gl.bindTexture(gl.TEXTURE_2D, map.tex);
    gl.uniform1i(u.uMap, MAP_UNIT);
    gl.uniform1i(u.uMapW, m.atlas.width);
    gl.uniform4iv(u.uMapLev, map.lev);
    gl.uniform1i(u.uMapN, m.levels.length);
    gl.uniform4f(u.uMapTr, m.transform[0], m.transform[1], m.transform[2], m.transform[3]);
    gl.uniform2f(u.uMapScale, m.uv_scale_mm[0], m.uv_scale_mm[1]);
    gl.uniform1f(u.uMapMin, m.min_level);
    gl.uniform1i(u.uMapDir, 0);  // the viewer reads the curvature of larger magnitude, as cdbrdf render's default
  }
  let pickFBO = null, evalFBO = null, polarFBO = null;

  function floatFBO(w, h, depth) {
    const tex = gl.createTexture();
    gl.activeTexture(gl.TEXTURE7);
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, w, h, 0, gl.RGBA, gl.FLOAT, null);
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
    let rb = null;
    if (depth) {
      rb = gl.createRenderbuffer();
      gl.bindRenderbuffer(gl.RENDERBUFFER, rb);
      gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, w, h);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, rb);
    }
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    return { fb, tex, rb, w, h };
  }
  function freeFBO(f) { if (f) { gl.deleteFramebuffer(f.fb); gl.deleteTexture(f.tex); if (f.rb) gl.deleteRenderbuffer(f.rb); } }

  // ---------------------------------------------------------------- drawing
  function viewports() {
    const W = canvas.width, H = canvas.height;
    if (state.side && tables.length > 1) {
      const w = Math.floor(W / 2);
      return [{ x: 0, y: 0, w, h: H, tab: tables[0] }, { x: w, y: 0, w: W - w, h: H, tab: tables[1] }];
    }
    return [{ x: 0, y: 0, w: W, h: H, tab: tables[0] }];
  }

  function eye() {
    const c = state.cam, el = rad(c.elevation), az = rad(c.azimuth);
    return [c.distance * Math.cos(el) * Math.cos(az), c.distance * Math.cos(el) * Math.sin(az), c.distance * Math.sin(el)];
  }

  function drawSurface(vp, pick) {
    const s = surfaces[state.surface];
    const weave = !!(vp.tab.btf && state.weave && (s.kind !== 0 || s.uv));  // a mesh without UVs: the tile mean
    const mapped = !!(s.map && state.maps);
    const prog = weave ? (mapped ? surfBtfMapProg : surfBtfProg) : (mapped ? surfMapProg : surfProg), u = prog.u, e = eye();
    gl.viewport(vp.x, vp.y, vp.w, vp.h);
    gl.useProgram(prog.p);
    bindTable(prog, vp.tab);
    const up = Math.abs(state.cam.elevation) > 89.9 ? [0, 1, 0] : [0, 0, 1];
    const mvp = mul(perspective(rad(35), vp.w / vp.h, state.cam.distance / 50, state.cam.distance * 10), lookAt(e, [0, 0, 0], up));
    gl.uniformMatrix4fv(u.uMVP, false, mvp);
    gl.uniform1i(u.uSurf, s.kind);
    gl.uniform1f(u.uAmp, state.amplitude); gl.uniform1f(u.uWave, state.wavelength);
    gl.uniform1f(u.uStandK, state.standKappa);
    gl.uniform1f(u.uWidth, state.width); gl.uniform1f(u.uDepth, state.depth);
    gl.uniform3fv(u.uEye, e);
    gl.uniform3fv(u.uLight, dirOf(state.lightTheta, state.lightPhi));
    gl.uniform1f(u.uExpo, Math.PI * Math.pow(2, state.exposure));
    gl.uniform1i(u.uEnv, state.env ? 1 : 0);
    gl.uniform3fv(u.uEnvDir, ENV.dirs); gl.uniform1fv(u.uEnvW, ENV.w);
    gl.uniform1i(u.uMode, { brdf: 0, cdbrdf: 1, split: 2 }[state.mode]);
    gl.uniform1f(u.uSplitX, vp.x + state.split * vp.w);
    gl.uniform1i(u.uOverlay, state.overlay ? 1 : 0);
    gl.uniform1f(u.uKmax, KMAX_OVERLAY);
    gl.uniform1i(u.uPick, pick || 0);
    if (weave) { gl.uniform1f(u.uWeaveScale, state.weaveScale); gl.uniform2fv(u.uUvScale, s.uvScale || [1, 1]); }
    if (mapped) bindMap(prog, s.map);
    gl.bindVertexArray(s.vao);
    gl.drawElements(gl.TRIANGLES, s.count, gl.UNSIGNED_INT, 0);  // one draw call per surface
    state.drawCalls++;
    gl.bindVertexArray(null);
  }

  function draw() {
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, canvas.width, canvas.height);
    gl.clearColor(0.19, 0.19, 0.19, 1);
    gl.enable(gl.DEPTH_TEST);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    for (const vp of viewports()) drawSurface(vp, 0);
    drawPolar();
    updateText();
  }

  function crestCurvature() {  // of the sine sheet: A (2 pi / L)^2
    return state.amplitude * Math.pow(2 * Math.PI / state.wavelength, 2);
  }

  function fmtK(k) {
    const r = Math.abs(k) > 1e-9 ? `radius ${(1 / Math.abs(k)).toFixed(2)} mm` : 'flat';
    return `${k.toFixed(3)} mm^-1 (${r})`;
  }

  function updateText() {
    $('bendOut').textContent = `${state.amplitude.toFixed(2)} mm`;
    $('waveOut').textContent = `${state.wavelength.toFixed(1)} mm`;
    $('standKOut').textContent = `${state.standKappa.toFixed(3)}`;
    $('crest').textContent = state.surface === 'stand' ? fmtK(state.standKappa) + ' (stand)' : fmtK(crestCurvature());
    $('lightTOut').textContent = `${state.lightTheta.toFixed(1)} deg`;
    $('lightPOut').textContent = `${state.lightPhi.toFixed(1)} deg`;
    $('expoOut').textContent = `${state.exposure >= 0 ? '+' : ''}${state.exposure.toFixed(1)}`;
    $('compsOut').textContent = String(state.components);
    $('scaleOut').textContent = `${state.weaveScale.toFixed(1)}x`;
    $('btfInfo').textContent = btfText();
    const s = surfaces[state.surface];
    $('mapsLabel').style.display = s && s.map ? '' : 'none';
    $('mapInfo').textContent = mapText();
  }

  // what the surface panel says of the shown mesh's curvature map
  function mapText() {
    const s = surfaces[state.surface];
    if (!s || !s.map) return '';
    const m = s.map.h, f = (x) => Number(x).toPrecision(4).replace(/\.?0+$/, '');
    const scale = m.uv_scale_mm[0] === m.uv_scale_mm[1] ? f(m.uv_scale_mm[0]) : m.uv_scale_mm.map(f).join(' x ');
    return `${m.name}: ${m.source}, one repeat per ${m.tile_mm.map(f).join(' x ')} mm (UV scale ${scale} mm per UV ` +
      `unit); looked up per pixel by its footprint on ${m.levels.length} levels from ${m.texels[0]} x ${m.texels[1]} ` +
      `texels of ${f(m.texel_mm)} mm (none finer than the curvature's ${f(m.neighbourhood_mm)} mm neighbourhood)` +
      (state.maps ? '' : '; off: the mesh\'s own curvature and normals') + (m.note ? `\n${m.note}` : '');
  }

  // what the weave panel says: per CD-BTF, the components used of the file's rank, and why fewer
  function btfText() {
    const s = surfaces[state.surface], mesh = s && s.kind === 0;
    const uvs = mesh && s.uv ? `; UVs x ${s.uvScale.map((x) => x.toPrecision(3)).join(' x ')} mm` : '';
    return tables.filter((t) => t.btf).map((t) => {
      const b = t.btf, used = rankUsed(t), tex = `${b.texels[0]} x ${b.texels[1]} texels over ` +
        `${b.repeat[0].toPrecision(3)} x ${b.repeat[1].toPrecision(3)} mm`;
      let why = '';
      const e = t.h.btf.relative_rms_error_used;
      if (b.rank < b.rankTotal) why = `; the export kept the leading ${b.rank} (${t.h.btf.rank < t.h.btf.rank_fits ? '--rank' : 'the GPU texture size'}${e == null ? '' : `, relative RMS error ${(100 * e).toFixed(1)} %`})`;
      if (used < b.rank) why += `; the leading ${used}${state.software ? ' on software rendering' : ''}, the components slider goes up to ${b.rank}`;
      const shown = !state.weave ? 'showing the tile mean' : mesh && !s.uv ? 'this mesh has no UVs: tile mean' :
        `weave at ${state.weaveScale === 1 ? 'true size' : `${state.weaveScale.toFixed(1)}x size`}${uvs}`;
      const nn = b.neural ? `neural (a ${b.neural.layers[1]}-${b.neural.layers[2]} decoder on ${b.neural.levels.length} levels of codes, filtered by the pixel's footprint)` +
        (b.rankTotal ? ` + ${used} of ${b.rankTotal} residual components` : '') : null;
      return `${t.h.name}: CD-BTF, ${nn || `rank ${used} used of ${b.rankTotal}`}${why}; ${tex}; ${shown}`;
    }).join('\n');
  }

  function readFloatPass(fbo, x, y, w, h) {
    const out = new Float32Array(w * h * 4);
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo.fb);
    gl.readPixels(x, y, w, h, gl.RGBA, gl.FLOAT, out);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    return out;
  }

  // pick pass: the query (angles) and the curvature at a pixel, for a rectangle of the canvas
  function pickPass(x, y, w, h) {
    if (!pickFBO || pickFBO.w !== canvas.width || pickFBO.h !== canvas.height) {
      freeFBO(pickFBO); pickFBO = floatFBO(canvas.width, canvas.height, true);
    }
    const res = [];
    for (const mode of [1, 2]) {
      gl.bindFramebuffer(gl.FRAMEBUFFER, pickFBO.fb);
      gl.viewport(0, 0, canvas.width, canvas.height);
      gl.clearColor(-1, -1, -1, -1);
      gl.enable(gl.DEPTH_TEST);
      gl.enable(gl.SCISSOR_TEST);
      gl.scissor(x, y, w, h);
      gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
      for (const vp of viewports()) drawSurface(vp, mode);
      gl.disable(gl.SCISSOR_TEST);
      res.push(readFloatPass(pickFBO, x, y, w, h));
    }
    return res;
  }

  function pickAt(px, py) {  // px, py: CSS pixels from the top left of the canvas
    const x = Math.round(px * canvas.width / canvas.clientWidth);
    const y = canvas.height - 1 - Math.round(py * canvas.height / canvas.clientHeight);
    const [q, k] = pickPass(x, y, 1, 1);
    if (!(k[2] > 0.5)) { state.pick = null; $('pickout').textContent = 'no surface there'; return null; }
    const vp = viewports().find((v) => x >= v.x && x < v.x + v.w);
    const r = { theta_v: q[0], phi_v: q[1], theta_l: q[2], phi_l: q[3], kappa: k[0], kappa_surface: k[1],
      table: tables.indexOf(vp.tab) };
    state.pick = r;
    $('pickout').textContent = `table      ${vp.tab.h.name}\ntheta_v    ${r.theta_v.toFixed(2)} deg\nphi_v      ${r.phi_v.toFixed(2)} deg\n` +
      `theta_l    ${r.theta_l.toFixed(2)} deg\nphi_l      ${r.phi_l.toFixed(2)} deg\nkappa      ${r.kappa.toFixed(4)} mm^-1` +
      (r.kappa !== r.kappa_surface ? ` (surface ${r.kappa_surface.toFixed(4)}; plain BRDF)` : '') +
      (k[3] <= 0 ? '\n(light below this point\'s horizon)' : '');
    state.mosaicTable = r.table;
    $('mosaicTable').value = String(r.table);
    const ks = vp.tab.h.axes.kappa;
    let best = 0;
    ks.forEach((kk, i) => { if (Math.abs(kk - r.kappa) < Math.abs(ks[best] - r.kappa)) best = i; });
    state.mosaicK = best;
    fillKappaSelect();
    drawMosaic();
    draw();
    return r;
  }

  // ---------------------------------------------------------------- GPU evaluate
  function evaluateMany(queries, tableIndex) {
    const tab = tables[tableIndex || 0];
    if (!tab) throw new Error(`table ${tableIndex}: not loaded`);
    const n = queries.length, per = 512, rows = Math.max(1, Math.ceil(n / per)), cols = Math.min(per, Math.max(1, n));
    const q = new Float32Array(cols * 2 * rows * 4);
    const ok = new Array(n);
    queries.forEach((x, i) => {
      // azimuths reduced exactly in float64 (fmod, as cdbrdf.interp.wrap_azimuth) before float32 loses them
      const wrap = (a) => (Math.abs(a) < 360 ? a : a % 360);
      const [tv, pv0, tl, pl0, k, u, v, fp] = x.map(Number);
      const pv = wrap(pv0), pl = wrap(pl0), at = x.length >= 7;  // a position (u, v) in mm: the CD-BTF there
      ok[i] = [tv, pv, tl, pl, k].every(Number.isFinite) && tv >= 0 && tv <= 90 && tl >= 0 && tl <= 90 &&
        (!at || (Number.isFinite(u) && Number.isFinite(v)));
      const r = Math.floor(i / per), c = i % per, o = (r * cols * 2 + 2 * c) * 4;
      if (ok[i]) q.set([tv, pv, tl, pl, k, at ? u : 0, at ? v : 0, at ? 1 + (Number.isFinite(fp) && fp > 0 ? fp : 0) : 0], o);
    });
    const qt = gl.createTexture();
    gl.activeTexture(gl.TEXTURE6);
    gl.bindTexture(gl.TEXTURE_2D, qt);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, cols * 2, rows, 0, gl.RGBA, gl.FLOAT, q);
    if (!evalFBO || evalFBO.w !== cols || evalFBO.h !== rows) { freeFBO(evalFBO); evalFBO = floatFBO(cols, rows, false); }
    gl.bindFramebuffer(gl.FRAMEBUFFER, evalFBO.fb);
    gl.viewport(0, 0, cols, rows);
    gl.disable(gl.DEPTH_TEST);
    const ep = tab.btf ? evalBtfProg : evalProg;
    gl.useProgram(ep.p);
    bindTable(ep, tab);
    gl.uniform1i(ep.u.uQ, 6);
    gl.bindVertexArray(emptyVAO);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.bindVertexArray(null);
    const out = readFloatPass(evalFBO, 0, 0, cols, rows);
    gl.deleteTexture(qt);
    const nc = tab.h.n_channels;
    return queries.map((_, i) => {
      if (!ok[i]) return new Array(nc).fill(NaN);
      const r = Math.floor(i / per), c = i % per, o = (r * cols + c) * 4;
      return nc === 3 ? [out[o], out[o + 1], out[o + 2]] : [out[o]];
    });
  }

  function mapEvaluate(queries, key) {
    const s = surfaces[key || state.surface];
    if (!s || !s.map) throw new Error(`surface ${key || state.surface}: has no curvature map`);
    if (!mapEvalProg) mapEvalProg = compile(FULLSCREEN_VS, MAP_EVAL_FS);
    const n = queries.length, per = 512, rows = Math.max(1, Math.ceil(n / per)), cols = Math.min(per, Math.max(1, n));
    const q = new Float32Array(cols * 3 * rows * 4);
    queries.forEach((x, i) => {
      const r = Math.floor(i / per), c = i % per;
      q.set(x.slice(0, 12).map(Number), (r * cols * 3 + 3 * c) * 4);
    });
    const qt = gl.createTexture();
    gl.activeTexture(gl.TEXTURE6);
    gl.bindTexture(gl.TEXTURE_2D, qt);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, cols * 3, rows, 0, gl.RGBA, gl.FLOAT, q);
    if (!evalFBO || evalFBO.w !== cols || evalFBO.h !== rows) { freeFBO(evalFBO); evalFBO = floatFBO(cols, rows, false); }
    gl.useProgram(mapEvalProg.p);
    bindMap(mapEvalProg, s.map);
    gl.uniform1i(mapEvalProg.u.uQ, 6);
    const outs = [];
    for (let k = 0; k < 4; k++) {
      gl.bindFramebuffer(gl.FRAMEBUFFER, evalFBO.fb);
      gl.viewport(0, 0, cols, rows);
      gl.disable(gl.DEPTH_TEST);
      gl.uniform1i(mapEvalProg.u.uOut, k);
      gl.bindVertexArray(emptyVAO);
      gl.drawArrays(gl.TRIANGLES, 0, 3);
      gl.bindVertexArray(null);
      outs.push(readFloatPass(evalFBO, 0, 0, cols, rows));
    }
    gl.deleteTexture(qt);
    return queries.map((_, i) => {
      const o = (Math.floor(i / per) * cols + (i % per)) * 4;
      const [a, b, c, d] = outs.map((x) => Array.from(x.subarray(o, o + 4)));
      return [...a, b[0], b[1], b[2], b[3], ...c, d[0], d[1], d[2], d[3]];
    });
  }

  // ---------------------------------------------------------------- polar slice
  const polarCanvas = $('polar'), polarCtx = polarCanvas.getContext('2d');
  let polarKey = '';
  function drawPolar() {  // only when what it shows changed: its read-back would stall every orbit frame
    const tab = tables[state.mosaicTable] || tables[0];
    const W = polarCanvas.width, H = polarCanvas.height;
    const key = JSON.stringify([tables.indexOf(tab), state.lightTheta, state.lightPhi, state.mosaicK, state.exposure]);
    if (key === polarKey) return;
    polarKey = key;
    if (!polarFBO) polarFBO = floatFBO(W, H, false);
    gl.bindFramebuffer(gl.FRAMEBUFFER, polarFBO.fb);
    gl.viewport(0, 0, W, H);
    gl.disable(gl.DEPTH_TEST);
    gl.useProgram(polarProg.p);
    bindTable(polarProg, tab);
    gl.uniform2f(polarProg.u.uL, state.lightTheta, state.lightPhi);
    gl.uniform1f(polarProg.u.uK, tab.h.axes.kappa[state.mosaicK] ?? 0);
    gl.uniform2f(polarProg.u.uSize, W, H);
    gl.uniform1f(polarProg.u.uExpo, Math.PI * Math.pow(2, state.exposure));
    gl.bindVertexArray(emptyVAO);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.bindVertexArray(null);
    const px = readFloatPass(polarFBO, 0, 0, W, H);
    const img = polarCtx.createImageData(W, H);
    for (let y = 0; y < H; y++) for (let x = 0; x < W; x++) {
      const s = ((H - 1 - y) * W + x) * 4, d = (y * W + x) * 4;
      img.data[d] = Math.round(px[s] * 255); img.data[d + 1] = Math.round(px[s + 1] * 255);
      img.data[d + 2] = Math.round(px[s + 2] * 255); img.data[d + 3] = 255;
    }
    polarCtx.putImageData(img, 0, 0);
    // the light's direction
    const r = state.lightTheta / 90 * (W / 2);
    polarCtx.strokeStyle = '#ffd27a';
    polarCtx.beginPath();
    polarCtx.arc(W / 2 + r * Math.cos(rad(state.lightPhi)), H / 2 - r * Math.sin(rad(state.lightPhi)), 4, 0, 2 * Math.PI);
    polarCtx.stroke();
  }

  // ---------------------------------------------------------------- mosaic
  const mosaicCanvas = $('mosaic'), mosaicCtx = mosaicCanvas.getContext('2d');
  function srgb8(x) {
    x = Math.min(Math.max(x, 0), 1);
    return Math.round(255 * (x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055));
  }
  // The Fig. 7 image is rows x cols (light x view directions). A table much wider than tall (an
  // isotropic one has a single light azimuth) is shown wrapped: its view-azimuth groups run in
  // bands of `per` groups, one band under the other, like lines of text, so the picture stays
  // roughly square. (x, y) are display cells; (r, c) the Fig. 7 row and column.
  function mosaicGeometry(tab) {
    const ax = tab.h.axes, tv = ax.theta_v.length, pv = ax.phi_v.length;
    const cols = pv * tv, rows = ax.phi_l.length * ax.theta_l.length;
    const per = cols > 2 * rows ? Math.min(pv, Math.max(1, Math.round(Math.sqrt(pv * rows / tv)))) : pv;
    const bands = Math.ceil(pv / per), W = per * tv, H = bands * rows;
    const cell = Math.max(1, Math.floor(432 / Math.max(W, H)));
    return { cols, rows, tv, pv, per, bands, W, H, cell };
  }
  function toDisplay(g, r, c) {
    const ipv = Math.floor(c / g.tv), band = Math.floor(ipv / g.per);
    return { x: (ipv % g.per) * g.tv + (c % g.tv), y: band * g.rows + r };
  }
  function fromDisplay(g, x, y) {
    if (x < 0 || y < 0 || x >= g.W || y >= g.H) return null;
    const ipv = Math.floor(y / g.rows) * g.per + Math.floor(x / g.tv);
    if (ipv >= g.pv) return null;
    return { r: y % g.rows, c: ipv * g.tv + (x % g.tv) };
  }
  function drawMosaic() {
    const tab = tables[state.mosaicTable] || tables[0];
    const ax = tab.h.axes, nc = tab.h.n_channels, g = mosaicGeometry(tab), k = state.mosaicK;
    mosaicCanvas.width = g.W * g.cell; mosaicCanvas.height = g.H * g.cell;
    const img = mosaicCtx.createImageData(g.W, g.H);
    const f = Math.PI * Math.pow(2, state.exposure), per = g.cols * g.rows;
    for (let i = 0; i < img.data.length; i += 4) { img.data[i] = img.data[i + 1] = img.data[i + 2] = 40; img.data[i + 3] = 255; }
    for (let r = 0; r < g.rows; r++) for (let c = 0; c < g.cols; c++) {
      const s = k * per + r * g.cols + c, p = toDisplay(g, r, c), d = (p.y * g.W + p.x) * 4;
      for (let ch = 0; ch < 3; ch++) img.data[d + ch] = srgb8(tab.samples[s * nc + (nc === 3 ? ch : 0)] * f);
    }
    const off = document.createElement('canvas');
    off.width = g.W; off.height = g.H;
    off.getContext('2d').putImageData(img, 0, 0);
    mosaicCtx.imageSmoothingEnabled = false;
    mosaicCtx.drawImage(off, 0, 0, g.W * g.cell, g.H * g.cell);
    mosaicCtx.strokeStyle = 'rgba(255,160,60,0.9)';
    mosaicCtx.lineWidth = 1;
    for (let r = 0; r < g.rows; r++) for (let c = 0; c < g.cols; c++) {
      if (tab.measured[k * per + r * g.cols + c]) continue;
      const p = toDisplay(g, r, c);
      mosaicCtx.beginPath();
      mosaicCtx.moveTo(p.x * g.cell, (p.y + 1) * g.cell); mosaicCtx.lineTo((p.x + 1) * g.cell, p.y * g.cell);
      mosaicCtx.stroke();
    }
    const line = (x0, y0, x1, y1) => { mosaicCtx.beginPath(); mosaicCtx.moveTo(x0, y0); mosaicCtx.lineTo(x1, y1); mosaicCtx.stroke(); };
    mosaicCtx.strokeStyle = 'rgba(0,0,0,0.6)';  // azimuth groups
    for (let i = 1; i < g.per; i++) line(i * g.tv * g.cell, 0, i * g.tv * g.cell, g.H * g.cell);
    for (let b = 0; b < g.bands; b++) for (let i = 1; i < ax.phi_l.length; i++) {
      const y = (b * g.rows + i * ax.theta_l.length) * g.cell;
      line(0, y, g.W * g.cell, y);
    }
    mosaicCtx.strokeStyle = 'rgba(255,255,255,0.8)';  // bands of a wrapped mosaic
    for (let b = 1; b < g.bands; b++) line(0, b * g.rows * g.cell, g.W * g.cell, b * g.rows * g.cell);
    const p = state.pick;
    if (p && p.table === tables.indexOf(tab)) {  // the cell the clicked point reads (nearest sample)
      const near = (axis, x, periodic) => {
        let best = 0, bd = Infinity;
        axis.forEach((a, i) => { let d = Math.abs(a - x); if (periodic) d = Math.min(d, 360 - d); if (d < bd) { bd = d; best = i; } });
        return best;
      };
      let pv = p.phi_v, pl = p.phi_l;
      if (tab.h.symmetry === 'isotropic') { pv = ((pv - pl) % 360 + 360) % 360; pl = 0; }
      const c = near(ax.phi_v, pv, true) * ax.theta_v.length + near(ax.theta_v, p.theta_v, false);
      const r = near(ax.phi_l, pl, true) * ax.theta_l.length + near(ax.theta_l, p.theta_l, false);
      const q = toDisplay(g, r, c);
      mosaicCtx.strokeStyle = '#00ffff'; mosaicCtx.lineWidth = 2;
      mosaicCtx.strokeRect(q.x * g.cell - 1, q.y * g.cell - 1, g.cell + 2, g.cell + 2);
      state.pickCell = { row: r, col: c, kappa_index: k };
    }
  }
  function unravel(flat, shape) {
    const out = new Array(shape.length);
    for (let i = shape.length - 1; i >= 0; i--) { out[i] = flat % shape[i]; flat = Math.floor(flat / shape[i]); }
    return out;
  }
  function sampleText(tab, flat) {
    const ax = tab.h.axes, shape = [ax.kappa.length, ax.phi_l.length, ax.theta_l.length, ax.phi_v.length, ax.theta_v.length];
    const [ik, ipl, itl, ipv, itv] = unravel(flat, shape);
    const az = tab.h.symmetry === 'isotropic' ? 'dphi' : 'phi_v';
    return `theta_v ${ax.theta_v[itv]}, ${az} ${ax.phi_v[ipv]}, theta_l ${ax.theta_l[itl]}, phi_l ${ax.phi_l[ipl]}, kappa ${ax.kappa[ik]}`;
  }
  function hoverMosaic(ev) {
    const tab = tables[state.mosaicTable] || tables[0], g = mosaicGeometry(tab);
    const rect = mosaicCanvas.getBoundingClientRect();
    const q = fromDisplay(g, Math.floor((ev.clientX - rect.left) / rect.width * g.W),
      Math.floor((ev.clientY - rect.top) / rect.height * g.H));
    if (q === null) return;
    $('readout').textContent = readout(tab, state.mosaicK, q.r, q.c);
  }
  function readout(tab, k, r, c) {
    const g = mosaicGeometry(tab), nc = tab.h.n_channels, flat = k * g.cols * g.rows + r * g.cols + c;
    const vals = Array.from(tab.samples.subarray(flat * nc, flat * nc + nc)).map((x) => x.toPrecision(4));
    const meas = tab.measured[flat] === 1;
    const method = tab.h.fill_methods[String(tab.fillMethod[flat])] || '?';
    const src = tab.fillSource[flat];
    let text = `${sampleText(tab, flat)}\nvalue   ${vals.join(', ')} ${tab.h.quantity === 'brdf' ? 'sr^-1' : '(relative)'}\n`;
    text += meas ? (tab.h.resampled_from ? 'measured (resampled from the file\'s grid)' : 'measured') : `filled (${method})`;
    if (!meas) text += src >= 0 ? `\nfill source: ${sampleText(tab, src)}` : '\nfill source: unknown';
    return text;
  }

  // ---------------------------------------------------------------- UI
  function fillKappaSelect() {
    const tab = tables[state.mosaicTable] || tables[0], sel = $('mosaicK');
    sel.innerHTML = '';
    tab.h.axes.kappa.forEach((k, i) => { const o = document.createElement('option'); o.value = String(i); o.textContent = `${k} mm^-1`; sel.appendChild(o); });
    state.mosaicK = Math.min(state.mosaicK, tab.h.axes.kappa.length - 1);
    sel.value = String(state.mosaicK);
  }

  function setDefaultCamera() {
    const s = surfaces[state.surface];
    state.cam.distance = s.distance;
  }

  function bindUI() {
    const num = (id, key, after) => $(id).addEventListener('input', (e) => { state[key] = Number(e.target.value); if (after) after(); draw(); });
    num('bend', 'amplitude'); num('wave', 'wavelength'); num('standK', 'standKappa');
    num('lightT', 'lightTheta'); num('lightP', 'lightPhi'); num('split', 'split');
    num('expo', 'exposure', drawMosaic);
    $('env').addEventListener('change', (e) => { state.env = e.target.checked; draw(); });
    $('overlay').addEventListener('change', (e) => { state.overlay = e.target.checked; draw(); });
    $('side').addEventListener('change', (e) => { state.side = e.target.checked; draw(); });
    $('mode').addEventListener('change', (e) => { state.mode = e.target.value; draw(); });
    num('comps', 'components'); num('scale', 'weaveScale');
    $('weave').addEventListener('change', (e) => { state.weave = e.target.checked; draw(); });
    $('maps').addEventListener('change', (e) => { state.maps = e.target.checked; draw(); });
    $('surface').addEventListener('change', (e) => { state.surface = e.target.value; setDefaultCamera(); draw(); });
    $('mosaicTable').addEventListener('change', (e) => { state.mosaicTable = Number(e.target.value); fillKappaSelect(); drawMosaic(); draw(); });
    $('mosaicK').addEventListener('change', (e) => { state.mosaicK = Number(e.target.value); drawMosaic(); draw(); });
    mosaicCanvas.addEventListener('mousemove', hoverMosaic);
    let drag = null;
    canvas.addEventListener('contextmenu', (e) => e.preventDefault());
    canvas.addEventListener('mousedown', (e) => { drag = { x: e.clientX, y: e.clientY, moved: false, light: e.shiftKey || e.button === 2 }; });
    window.addEventListener('mouseup', (e) => {
      if (drag && !drag.moved && e.target === canvas) {
        const r = canvas.getBoundingClientRect();
        pickAt(e.clientX - r.left, e.clientY - r.top);
      }
      drag = null;
    });
    window.addEventListener('mousemove', (e) => {
      if (!drag) return;
      const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      if (Math.abs(dx) + Math.abs(dy) > 2) drag.moved = true;
      if (!drag.moved) return;
      drag.x = e.clientX; drag.y = e.clientY;
      if (drag.light) {
        state.lightPhi = ((state.lightPhi - dx * 0.5) % 360 + 360) % 360;
        state.lightTheta = Math.min(89, Math.max(0, state.lightTheta + dy * 0.3));
        $('lightT').value = state.lightTheta; $('lightP').value = state.lightPhi;
      } else {
        state.cam.azimuth -= dx * 0.4;
        state.cam.elevation = Math.min(90, Math.max(-10, state.cam.elevation + dy * 0.3));
      }
      draw();
    });
    canvas.addEventListener('wheel', (e) => { e.preventDefault(); state.cam.distance *= Math.exp(e.deltaY * 0.001); draw(); }, { passive: false });
  }

  function init() {
    if (!DATA || !DATA.tables || !DATA.tables.length) throw fail('no table data (data.js is missing or empty)');
    if (!gl) throw fail('this browser has no WebGL2: the viewer needs it (try a current Chrome, Firefox or Safari)');
    if (!gl.getExtension('EXT_color_buffer_float')) throw fail('this browser cannot render to float textures (EXT_color_buffer_float): the GPU lookup cannot be read back');
    surfProg = compile(SURFACE_VS, SURFACE_FS);
    evalProg = compile(FULLSCREEN_VS, EVAL_FS);
    polarProg = compile(FULLSCREEN_VS, POLAR_FS);
    emptyVAO = gl.createVertexArray();
    tables = DATA.tables.map((a, i) => uploadTable({ header: a.header, buffer: decode(a.data) }, i));
    const btfs = tables.filter((t) => t.btf);
    if (btfs.length) { surfBtfProg = compile(withBTF(SURFACE_VS), withBTF(SURFACE_FS)); evalBtfProg = compile(FULLSCREEN_VS, withBTF(EVAL_FS)); }
    // software WebGL (SwiftShader, llvmpipe) takes seconds a frame per few dozen components: it starts with
    // the leading SOFTWARE_COMPONENTS (ordered by energy; the page says so, the slider goes up to all)
    const dbg = gl.getExtension('WEBGL_debug_renderer_info');
    state.renderer = String(gl.getParameter(dbg ? dbg.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
    state.software = /swiftshader|llvmpipe|softpipe|software|basic render/i.test(state.renderer);
    const packed = Math.max(0, ...btfs.map((t) => t.btf.rank));
    state.components = state.software ? Math.min(packed, SOFTWARE_COMPONENTS) : packed;
    $('weaveBox').style.display = btfs.length ? '' : 'none';
    $('comps').max = String(packed); $('comps').value = String(state.components);
    const grid = gridGeometry(480, 8);
    surfaces.sheet = Object.assign(makeVAO(grid.pos, null, null, null, grid.idx), { kind: 1, label: 'sine sheet', distance: 150 });
    surfaces.stand = Object.assign(makeVAO(grid.pos, null, null, null, grid.idx), { kind: 2, label: 'cylinder stand', distance: 150 });
    for (const [key, m] of Object.entries(DATA.meshes || {})) {
      const a = { header: m.header, buffer: decode(m.data) }, h = a.header;
      const size = Math.max(...h.size_mm);
      const uv = h.uv && h.blocks.uv ? block(a, 'uv') : null;  // older assets: no UVs
      const map = uv && h.map && h.blocks.map && h.blocks.shape ? uploadMap(a) : null;
      surfaces[key] = Object.assign(makeVAO(block(a, 'position'), block(a, 'normal'), block(a, 'tangent'),
        block(a, 'curvature'), block(a, 'index'), uv, map ? block(a, 'shape') : null), { kind: 0, label: h.name,
        distance: h.frame ? h.frame.distance_mm : 2.2 * size, frame: h.frame || null,
        uv: !!uv, uvScale: uv ? h.uv_scale_mm.map(Number) : null, map });
    }
    if (Object.values(surfaces).some((x) => x.map)) {  // the map programs only where a mesh has a map
      surfMapProg = compile(withMaps(SURFACE_VS), withMaps(SURFACE_FS));
      if (btfs.length) surfBtfMapProg = compile(withMaps(withBTF(SURFACE_VS)), withMaps(withBTF(SURFACE_FS)));
    }
    const sel = $('surface'), opt = DATA.options || {};
    for (const [key, s] of Object.entries(surfaces)) { const o = document.createElement('option'); o.value = key; o.textContent = s.label; sel.appendChild(o); }
    const first = surfaces[opt.surface];
    if (first) {  // cdbrdf view --mesh: the page opens on the mesh, framed as cdbrdf render frames it
      state.surface = opt.surface;
      const f = first.frame;
      if (f) state.cam = { elevation: f.elevation_deg, azimuth: f.azimuth_deg, distance: f.distance_mm };
      else state.cam.distance = first.distance;
    }
    sel.value = state.surface;
    const ms = $('mosaicTable');
    tables.forEach((t, i) => { const o = document.createElement('option'); o.value = String(i); o.textContent = t.h.name; ms.appendChild(o); });
    $('tables').textContent = tables.map((t) => `${t.h.name} (${t.h.material || 'table'}, ${t.h.quantity}, ${t.h.symmetry}${t.btf ? ', CD-BTF' : ''})`).join('  |  ');
    state.side = tables.length > 1;
    $('side').checked = state.side;
    if (tables.length < 2) $('sideLabel').style.display = 'none';
    const sheet = (DATA.surfaces || {}).sheet;
    if (!sheet) throw fail('no sine sheet geometry (data.js is from another version)');
    state.amplitude = sheet.amplitude_mm; state.wavelength = sheet.wavelength_mm;
    state.width = sheet.width_mm; state.depth = sheet.depth_mm;
    $('bend').value = state.amplitude; $('wave').value = state.wavelength;
    state.exposure = Number.isFinite(opt.exposure_ev) ? opt.exposure_ev : tables[0].h.exposure_ev;
    $('expo').value = state.exposure;
    const k0 = tables[0].h.axes.kappa;
    state.mosaicK = k0.indexOf(k0.reduce((b, k) => (Math.abs(k - 0.13) < Math.abs(b - 0.13) ? k : b), k0[0]));
    fillKappaSelect();
    bindUI();
    drawMosaic();
    draw();
  }

  // ---------------------------------------------------------------- the JS interface
  const redraw = (f) => (...args) => { f(...args); draw(); return Promise.resolve(viewer.state()); };
  Object.assign(viewer, {
    evaluate: (tv, pv, tl, pl, k, opts) => Promise.resolve(evaluateMany([[tv, pv, tl, pl, k ?? 0]], (opts || {}).table)[0]),
    evaluateMany: (queries, opts) => Promise.resolve(evaluateMany(queries, (opts || {}).table)),
    setMode: redraw((m) => {
      if (!['brdf', 'cdbrdf', 'split'].includes(m)) throw new Error(`mode: ${m} is not one of brdf, cdbrdf, split`);
      state.mode = m; $('mode').value = m;
    }),
    setBend: redraw((a) => { state.amplitude = Number(a); $('bend').value = a; }),
    setWavelength: redraw((l) => { state.wavelength = Number(l); $('wave').value = l; }),
    setStandCurvature: redraw((k) => { state.standKappa = Number(k); $('standK').value = k; }),
    setLight: redraw((t, p) => { state.lightTheta = Number(t); state.lightPhi = Number(p); $('lightT').value = t; $('lightP').value = p; }),
    setCamera: redraw((elevation, azimuth, distance) => {
      if (elevation != null) state.cam.elevation = Number(elevation);
      if (azimuth != null) state.cam.azimuth = Number(azimuth);
      if (distance != null) state.cam.distance = Number(distance);
    }),
    setSurface: redraw((s) => {
      if (!surfaces[s]) throw new Error(`surface: ${s} is not one of ${Object.keys(surfaces).join(', ')}`);
      state.surface = s; $('surface').value = s; setDefaultCamera();
    }),
    setExposure: redraw((ev) => { state.exposure = Number(ev); $('expo').value = ev; drawMosaic(); }),
    setEnvironment: redraw((on) => { state.env = !!on; $('env').checked = state.env; }),
    setSplit: redraw((x) => { state.split = Number(x); $('split').value = x; }),
    setOverlay: redraw((on) => { state.overlay = !!on; $('overlay').checked = state.overlay; }),
    setSideBySide: redraw((on) => { state.side = !!on; $('side').checked = state.side; }),
    // a CD-BTF: the weave (true) or the tile mean (false); the components used; the weave drawn `s` times its size
    setWeave: redraw((on) => { state.weave = !!on; $('weave').checked = state.weave; }),
    // a mesh's curvature map: looked up (true) or left out (false: the mesh's own curvature and normals)
    setMaps: redraw((on) => { state.maps = !!on; $('maps').checked = state.maps; }),
    // the map's rule at points (tests): rows [u, v, level (-1: from the footprint), fu, fv, sxx, sxy, syy, hand,
    // wi.x, wi.y, wi.z] -> [p, q, dp/du, dp/dv, dq/du, dq/dv, level, kappa max, kappa directional, n'.xyz, s'.xyz, q]
    mapEvaluate: (queries, opts) => Promise.resolve(mapEvaluate(queries, (opts || {}).surface)),
    setComponents: redraw((n) => { state.components = Math.max(0, Math.round(Number(n))); $('comps').value = n; }),
    setWeaveScale: redraw((x) => {
      if (!(Number(x) > 0)) throw new Error(`weave scale: expected a positive number, got ${x}`);
      state.weaveScale = Number(x); $('scale').value = x;
    }),
    setSize: redraw((w, h) => { canvas.width = w; canvas.height = h; }),
    pick: (x, y) => Promise.resolve(pickAt(x, y)),
    mosaicReadout: (table, k, row, col) => readout(tables[table || 0], k, row, col),
    // the shown mosaic's layout (display cells W x H of `cell` pixels, wrapped in `bands` of `per`
    // view-azimuth groups) and the Fig. 7 row and column a display cell shows (null: none)
    mosaicLayout: () => Object.assign(mosaicGeometry(tables[state.mosaicTable] || tables[0]),
      { width: mosaicCanvas.width, height: mosaicCanvas.height }),
    mosaicAt: (x, y) => {
      const q = fromDisplay(mosaicGeometry(tables[state.mosaicTable] || tables[0]), x, y);
      return q === null ? null : { row: q.r, col: q.c };
    },
    surfaces: () => Object.keys(surfaces),
    // per-pixel curvature the lookup used (kappa_query, kappa_surface, front, n.l) for the whole canvas
    // (float32 RGBA rows from the bottom, base64)
    curvatureImage: () => Promise.resolve({ width: canvas.width, height: canvas.height,
      data: base64(new Uint8Array(pickPass(0, 0, canvas.width, canvas.height)[1].buffer)) }),
    // the canvas as 8-bit RGBA rows from the bottom, base64
    pixels: () => {
      const out = new Uint8Array(canvas.width * canvas.height * 4);
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      gl.readPixels(0, 0, canvas.width, canvas.height, gl.RGBA, gl.UNSIGNED_BYTE, out);
      return { width: canvas.width, height: canvas.height, data: base64(out) };
    },
    // mean time of n frames (ms), each finished on the GPU (a reference: a flat-shaded draw when flat is true)
    frameTime: (n, flat) => {
      const frame = () => {
        if (flat) drawFlat(); else { gl.bindFramebuffer(gl.FRAMEBUFFER, null); gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT); for (const vp of viewports()) drawSurface(vp, 0); }
        const px = new Uint8Array(4);
        gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);  // waits for the frame to finish
      };
      frame();
      const t0 = performance.now();
      for (let i = 0; i < n; i++) frame();
      const ms = (performance.now() - t0) / n;
      draw();
      return Promise.resolve(ms);
    },
    state: () => JSON.parse(JSON.stringify(Object.assign({}, state, {
      crestCurvatureText: $('crest').textContent, crestCurvature: crestCurvature(), btfText: $('btfInfo').textContent,
      mapText: mapText(), mapped: Object.keys(surfaces).filter((k) => surfaces[k].map),
      btf: tables.map((t) => (t.btf ? { rank: t.btf.rank, rankTotal: t.btf.rankTotal, used: rankUsed(t) } : null)),
      tables: tables.map((t) => t.h.name), surfaces: Object.keys(surfaces) }))),
  });

  let flatProg = null;
  function drawFlat() {  // the reference draw of the benchmark: the same mesh, Lambert shading, no table
    if (!flatProg) {
      flatProg = compile(SURFACE_VS, `#version 300 es
precision highp float; precision highp int;
in vec3 vWorld; in vec3 vN; in vec3 vT; in float vK; in float vS;
uniform int uSurf; uniform float uAmp, uWave, uStandK; uniform vec3 uLight;
out vec4 o;
void main() {
  vec3 n;
  if (uSurf == 1) { float w = 6.283185307179586 / uWave; n = normalize(vec3(-uAmp * w * cos(w * vS), 0.0, 1.0)); }
  else if (uSurf == 2) { float a = uStandK * vS; n = vec3(sin(a), 0.0, cos(a)); }
  else n = normalize(vN);
  o = vec4(vec3(max(dot(n, uLight), 0.0)), 1.0);
}`);
    }
    const s = surfaces[state.surface], u = flatProg.u, e = eye();
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, canvas.width, canvas.height);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(flatProg.p);
    for (const vp of viewports()) {
      gl.viewport(vp.x, vp.y, vp.w, vp.h);
      const up = Math.abs(state.cam.elevation) > 89.9 ? [0, 1, 0] : [0, 0, 1];
      gl.uniformMatrix4fv(u.uMVP, false, mul(perspective(rad(35), vp.w / vp.h, state.cam.distance / 50, state.cam.distance * 10), lookAt(e, [0, 0, 0], up)));
      gl.uniform1i(u.uSurf, s.kind); gl.uniform1f(u.uAmp, state.amplitude); gl.uniform1f(u.uWave, state.wavelength);
      gl.uniform1f(u.uStandK, state.standKappa); gl.uniform1f(u.uWidth, state.width); gl.uniform1f(u.uDepth, state.depth);
      gl.uniform3fv(u.uLight, dirOf(state.lightTheta, state.lightPhi));
      gl.bindVertexArray(s.vao);  // attribute locations match: same vertex shader, bound by name at link
      gl.drawElements(gl.TRIANGLES, s.count, gl.UNSIGNED_INT, 0);
      gl.bindVertexArray(null);
    }
  }

  viewer.ready = new Promise((resolve, reject) => {
    try { init(); resolve(viewer.state()); } catch (e) { viewer.errors.push(String(e.message || e)); fail(String(e.message || e)); reject(e); }
  });
  viewer.ready.catch(() => {});  // the page shows the message; scripts that await ready see the rejection
})();
