// cdbrdf's glTF renderer page (cdbrdf view x.glb): the asset loaded by three.js's GLTFLoader with the
// CDBRDF_materials_curvature_brdf plugin, shaded per fragment with the table looked up at the fragment's
// curvature, one directional light (with a shadow map) and an environment (the studio sky, as a set of
// directions). The data come from data.js (window.CDBRDF_GLTF_DATA: the GLB in base64 and the view's
// options), so that the page opens from file:// too. window.cdbrdfGltf is the interface for scripts and tests.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { CdbrdfCurvatureBrdfExtension, EXTENSION, MAX_ENV, evaluateMany, lightingUniforms } from './extension.js';

const $ = (id) => document.getElementById(id);
const DATA = window.CDBRDF_GLTF_DATA;
const api = { errors: [] };
window.cdbrdfGltf = api;

function fail(text) {
  const m = $('message');
  m.textContent = text;
  m.style.display = 'block';
  return new Error(text);
}

function decode(b64) {
  const s = atob(b64), out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
  return out.buffer;
}

function base64(bytes) {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

const rad = (d) => d * Math.PI / 180;
// the z-up world's direction (theta from +z, phi from +x towards +y) in glTF's frame: (x, y, z) -> (x, z, -y)
function zUpDir(thetaDeg, phiDeg) {
  const x = Math.sin(rad(thetaDeg)) * Math.cos(rad(phiDeg)), y = Math.sin(rad(thetaDeg)) * Math.sin(rad(phiDeg));
  return new THREE.Vector3(x, Math.cos(rad(thetaDeg)), -y);
}

// The studio sky (cdbrdf.render.lighting.STUDIO_SKY: radiance at the zenith, horizon and below it, for a key
// light of irradiance pi) as MAX_ENV directions of a Fibonacci sphere, each radiance x its solid angle.
function skyDirections(sky, scale) {
  const [top, horizon, ground] = sky, dirs = [], ls = [], n = MAX_ENV;
  for (let i = 0; i < n; i++) {
    const y = 1 - 2 * (i + 0.5) / n, r = Math.sqrt(1 - y * y), a = i * Math.PI * (3 - Math.sqrt(5));
    const d = new THREE.Vector3(r * Math.cos(a), y, r * Math.sin(a));
    const L = y > 0 ? horizon + (top - horizon) * y : ground;
    dirs.push(d); ls.push(new THREE.Vector3(1, 1, 1).multiplyScalar(L * scale * 4 * Math.PI / n));
  }
  return { dirs, ls };
}

const state = {
  mode: 'cdbrdf', exposure: 0, light: [45, 0], irradiance: Math.PI, env: true, shadows: true, envScale: 1,
  renderer: '', software: false,
};
let renderer, scene, camera, controls, root, meshes = [], lighting, shadow, fallbackLights;

class ShadowMap {
  constructor(size) {
    this.size = size;
    this.target = new THREE.WebGLRenderTarget(size, size, { type: THREE.FloatType, format: THREE.RGBAFormat,
      minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter });
    this.camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.01, 10);
    this.material = new THREE.ShaderMaterial({ side: THREE.DoubleSide, glslVersion: THREE.GLSL3,
      vertexShader: 'void main() { gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0); }',
      fragmentShader: 'out vec4 depth; void main() { depth = vec4(gl_FragCoord.z); }' });
    this.matrix = new THREE.Matrix4();
  }

  update(lightDir) {
    const box = new THREE.Box3().setFromObject(root), sphere = box.getBoundingSphere(new THREE.Sphere());
    const r = Math.max(sphere.radius, 1e-6), c = sphere.center;
    const cam = this.camera;
    cam.left = -r; cam.right = r; cam.top = r; cam.bottom = -r; cam.near = 0.5 * r; cam.far = 3.5 * r;
    cam.position.copy(c).addScaledVector(lightDir, 2 * r);
    cam.up.set(Math.abs(lightDir.y) > 0.99 ? 1 : 0, Math.abs(lightDir.y) > 0.99 ? 0 : 1, 0);
    cam.lookAt(c);
    cam.updateProjectionMatrix(); cam.updateMatrixWorld();
    this.matrix.multiplyMatrices(cam.projectionMatrix, cam.matrixWorldInverse);
    const prev = renderer.getRenderTarget(), bg = scene.background, lights = fallbackLights.visible;
    scene.overrideMaterial = this.material; scene.background = null; fallbackLights.visible = false;
    renderer.setRenderTarget(this.target);
    renderer.setClearColor(0xffffff, 1);
    renderer.clear();
    renderer.render(scene, cam);
    renderer.setRenderTarget(prev);
    scene.overrideMaterial = null; scene.background = bg; fallbackLights.visible = lights;
    renderer.setClearColor(0x808080, 1);
    return 2 * r / this.size;  // a texel, world units
  }
}

function applyState() {
  const L = zUpDir(state.light[0], state.light[1]).normalize();
  const u = lighting;
  u.uLightDir.value.copy(L);
  u.uIrradiance.value = state.irradiance;
  u.uExpo.value = Math.pow(2, state.exposure);
  u.uMode.value = { brdf: 0, cdbrdf: 1, curvature: 2 }[state.mode] ?? 1;
  const sky = skyDirections(DATA.options.sky || [0.35, 0.25, 0.12], state.envScale);
  u.uEnvN.value = state.env ? MAX_ENV : 0;
  sky.dirs.forEach((d, i) => { u.uEnvDir.value[i].copy(d); u.uEnvL.value[i].copy(sky.ls[i]); });
  // the camera's angle per pixel (the curvature map's footprint): 2 tan(fov / 2) / height, three's fov vertical
  u.uPixelAngle.value = 2 * Math.tan(rad(camera.fov) / 2) / renderer.getContext().drawingBufferHeight;
  const fallback = state.mode === 'fallback';
  for (const m of meshes) m.material = fallback ? m.userData.cdbrdf.fallback : m.userData.cdbrdf.material;
  // the fallback: three's own lights, the same key and a hemisphere light standing for the sky
  const [sun, hemi] = fallbackLights.children;
  sun.position.copy(L); sun.intensity = state.irradiance;
  const [top, horizon, ground] = DATA.options.sky || [0.35, 0.25, 0.12];
  hemi.color.setScalar(0.5 * (top + horizon)); hemi.groundColor.setScalar(ground);
  hemi.intensity = state.env ? Math.PI * state.envScale : 0;
  fallbackLights.visible = fallback;
  renderer.toneMapping = THREE.LinearToneMapping;
  renderer.toneMappingExposure = Math.pow(2, state.exposure);
  if (state.shadows && state.irradiance > 0) {
    u.uShadowTexel.value = shadow.update(L);
    u.uShadow.value = shadow.target.texture; u.uShadowMatrix.value.copy(shadow.matrix); u.uShadowOn.value = 1;
  } else {
    u.uShadowOn.value = 0;
  }
  $('modeSel').value = state.mode; $('expo').value = state.exposure; $('env').checked = state.env;
  $('lightT').value = state.light[0]; $('lightP').value = ((state.light[1] % 360) + 360) % 360;
}

function draw() {
  renderer.render(scene, camera);
}

function setCameraFrom(c) {
  // c: position, target, up (glTF frame, metres), fov_deg along the picture's smaller side
  const w = renderer.domElement.width, h = renderer.domElement.height;
  camera.aspect = w / h;
  const t = Math.tan(rad(c.fov_deg) / 2);
  camera.fov = 2 * Math.atan(w >= h ? t : t * h / w) * 180 / Math.PI;  // three's fov is vertical
  camera.position.fromArray(c.position);
  camera.up.fromArray(c.up);
  controls.target.fromArray(c.target);
  camera.lookAt(controls.target);
  const d = camera.position.distanceTo(controls.target);
  camera.near = c.near ?? d / 100; camera.far = c.far ?? d * 100;
  camera.updateProjectionMatrix();
  controls.update();
  state.camera = c;
}

function bindUI() {
  $('modeSel').addEventListener('change', (e) => { state.mode = e.target.value; applyState(); draw(); });
  $('expo').addEventListener('input', (e) => { state.exposure = Number(e.target.value); applyState(); draw(); });
  $('env').addEventListener('change', (e) => { state.env = e.target.checked; applyState(); draw(); });
  $('lightT').addEventListener('input', (e) => { state.light[0] = Number(e.target.value); applyState(); draw(); });
  $('lightP').addEventListener('input', (e) => { state.light[1] = Number(e.target.value); applyState(); draw(); });
  controls.addEventListener('change', draw);
}

async function init() {
  if (!DATA || !DATA.glb) throw fail('no asset (data.js is missing or empty)');
  const canvas = $('view');
  renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
  const gl = renderer.getContext();
  if (!gl.getExtension('EXT_color_buffer_float')) throw fail('this browser cannot render to float textures (EXT_color_buffer_float)');
  const dbg = gl.getExtension('WEBGL_debug_renderer_info');
  state.renderer = String(gl.getParameter(dbg ? dbg.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
  state.software = /swiftshader|llvmpipe|softpipe|software|basic render/i.test(state.renderer);
  renderer.setPixelRatio(1);
  renderer.setSize(DATA.options.width || 960, DATA.options.height || 600, false);
  renderer.setClearColor(0x808080, 1);
  scene = new THREE.Scene();
  camera = new THREE.PerspectiveCamera(30, 1, 0.01, 100);
  controls = new OrbitControls(camera, canvas);
  lighting = lightingUniforms();
  const loader = new GLTFLoader();
  loader.register((parser) => new CdbrdfCurvatureBrdfExtension(parser, { lighting }));
  const gltf = await loader.parseAsync(decode(DATA.glb), '');
  root = gltf.scene;
  scene.add(root);
  root.traverse((o) => { if (o.isMesh && o.userData.cdbrdf) meshes.push(o); });
  if (!meshes.length) throw fail(`the asset has no material with the ${EXTENSION} extension`);
  fallbackLights = new THREE.Group();
  fallbackLights.add(new THREE.DirectionalLight(0xffffff, Math.PI), new THREE.HemisphereLight(0xffffff, 0x000000, 0));
  scene.add(fallbackLights);
  shadow = new ShadowMap(2048);
  const o = DATA.options;
  state.exposure = Number.isFinite(o.exposure_ev) ? o.exposure_ev : 0;
  if (o.light) { state.light = [o.light[0], o.light[1]]; state.irradiance = o.light[2]; }
  if (o.environment === false) state.env = false;
  state.info = meshes[0].userData.cdbrdf.extension;
  $('title').textContent = `${DATA.name}: ${state.info.material || 'table'} (${state.info.symmetry}, curvature ${state.info.curvature.mode})`;
  setCameraFrom(o.camera);
  applyState();
  bindUI();
  draw();
}

function pixels() {
  const gl = renderer.getContext(), w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
  const out = new Uint8Array(w * h * 4);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, out);
  return { width: w, height: h, data: base64(out) };
}

const redraw = (f) => (...args) => {
  try { f(...args); } catch (e) { return Promise.reject(e); }
  applyState(); draw();
  return Promise.resolve(api.state());
};
Object.assign(api, {
  setMode: redraw((m) => {
    if (!['cdbrdf', 'brdf', 'fallback', 'curvature'].includes(m)) throw new Error(`mode: ${m} is not one of cdbrdf, brdf, fallback, curvature`);
    state.mode = m;
  }),
  setExposure: redraw((ev) => { state.exposure = Number(ev); }),
  setLight: redraw((t, p, irradiance) => { state.light = [Number(t), Number(p)]; if (irradiance != null) state.irradiance = Number(irradiance); }),
  setEnvironment: redraw((on, scale) => { state.env = !!on; if (scale != null) state.envScale = Number(scale); }),
  setShadows: redraw((on) => { state.shadows = !!on; }),
  setSize: redraw((w, h) => { renderer.setSize(w, h, false); setCameraFrom(state.camera); }),
  setCamera: redraw((c) => setCameraFrom(c)),
  pixels: () => pixels(),
  evaluateMany: (queries) => Promise.resolve(evaluateMany(renderer, meshes[0].userData.cdbrdf.table, queries)),
  // the lookup of another asset's table (a GLB in base64), read by the same plugin, on this page's renderer
  evaluateAsset: async (glbBase64, queries) => {
    const loader = new GLTFLoader();
    loader.register((parser) => new CdbrdfCurvatureBrdfExtension(parser, { lighting, apply: false }));
    const g = await loader.parseAsync(decode(glbBase64), '');
    let table = null;
    g.scene.traverse((o) => { if (!table && o.isMesh && o.userData.cdbrdf) table = o.userData.cdbrdf.table; });
    if (!table) throw new Error(`the asset has no material with the ${EXTENSION} extension`);
    const out = evaluateMany(renderer, table, queries);
    table.uTab.value.dispose(); table.uAxes.value.dispose();
    return out;
  },
  // mean milliseconds of n frames, each finished (a 1-pixel read-back waits for it)
  frameTime: (n) => {
    const gl = renderer.getContext(), px = new Uint8Array(4);
    const frame = () => { draw(); gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px); };
    frame();
    const t0 = performance.now();
    for (let i = 0; i < n; i++) frame();
    return Promise.resolve((performance.now() - t0) / n);
  },
  info: () => ({ vertices: meshes.reduce((s, m) => s + m.geometry.attributes.position.count, 0),
    fallback: meshes[0].userData.cdbrdf.fallback.type, extension: state.info,
    curvatureMap: !!meshes[0].userData.cdbrdf.map }),
  state: () => JSON.parse(JSON.stringify(Object.assign({}, state, { info: undefined }))),
});

api.ready = init().then(() => api.state(), (e) => { const msg = String(e && e.message || e); api.errors.push(msg); fail(msg); throw e; });
api.ready.catch(() => {});
