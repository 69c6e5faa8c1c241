// The 5-D lookup of cdbrdf.interp in GLSL ES 3.00, written once for cdbrdf's browser renderers: the viewer
// (viewer.js) and the glTF renderer (gltf.js, the CDBRDF_materials_curvature_brdf extension). Multilinear in
// five axes, periodic azimuth, pole rule, clamped elevation and kappa, snapping, the isotropic rotation;
// tested against CDBRDF.evaluate (tests/test_viewer.py; the lookup conformance suite through the glTF
// renderer). Its uniforms, the table as a float texture array (a layer per kappa node) and the axes' nodes,
// are laid out by cdbrdf.view.asset (the viewer) and the glTF renderer from cdbrdf.gltf_table's texture.
window.CDBRDF_LOOKUP_GLSL = `
precision highp float; precision highp int;
precision highp sampler2DArray; precision highp sampler2D;
uniform sampler2DArray uTab;  // RGBA, a layer per kappa: the Fig. 7 image row-major, folded into rows of uTexW
uniform int uTexW;            // texture width: texel i = row * n_columns + column lies at (i % uTexW, i / uTexW)
uniform sampler2D uAxes;      // R32F rows: 0 kappa, 1 theta_l, 2 theta_v (lookup nodes)
uniform ivec3 uN;             // node counts: kappa, theta_l, theta_v
uniform ivec2 uNphi;          // n_phi_l, n_phi_v
uniform vec4 uPhi;            // phi_l0, phi_l_step, phi_v0, phi_v_step
uniform int uIso;             // 1: isotropic (phi_v holds phi_v - phi_l)
uniform vec3 uInvStep;        // 1 / step of evenly spaced axes (kappa: always 0, theta_l, theta_v), 0 where uneven
const float SNAP = 1e-6;      // cdbrdf.interp.SNAP_TOLERANCE["float32"]

float snapw(float w) { return w < SNAP ? 0.0 : (w > 1.0 - SNAP ? 1.0 : w); }
float wrapAz(float x) { return abs(x) < 360.0 ? x : x - 360.0 * trunc(x / 360.0); }
float axisAt(int row, int i) { return texelFetch(uAxes, ivec2(i, row), 0).r; }

// the two nodes of x on a sorted axis (clamped at both ends): node i, weight w of node i+1
void linearNodes(int row, int n, float inv, float x, out int i, out float w) {
  i = 0; w = 0.0;
  if (n < 2) return;
  float a0 = axisAt(row, 0);
  x = clamp(x, a0, axisAt(row, n - 1));
  int lo = 0, hi = n - 1;  // largest lo <= n-2 with axis[lo] <= x
  if (inv > 0.0) {         // evenly spaced: by multiplication (as the RGB kernel), kept within the axis
    lo = clamp(int((x - a0) * inv), 0, n - 2);
    if (axisAt(row, lo) > x) lo = max(lo - 1, 0);
    else if (lo < n - 2 && axisAt(row, lo + 1) <= x) lo += 1;
  } else {
    while (hi - lo > 1) { int mid = (lo + hi) / 2; if (axisAt(row, mid) <= x) lo = mid; else hi = mid; }
  }
  float a = axisAt(row, lo), b = axisAt(row, lo + 1);
  i = lo; w = snapw((x - a) / (b - a));
}

// the two nodes of an azimuth on the evenly spaced circle
void periodicNodes(float phi0, float step, int n, float x, out int i0, out int i1, out float w) {
  i0 = 0; i1 = 0; w = 0.0;
  if (n < 2) return;
  float u = (wrapAz(x) - phi0) / step;
  float f = floor(u);
  w = snapw(u - f);
  int fi = int(f);
  i0 = ((fi % n) + n) % n; i1 = (i0 + 1) % n;
}

// The 5-D rule (cdbrdf.interp), written once: cell() finds the nodes and weights (the pole rule
// included); FOR_CORNERS(c, BODY) runs BODY for each corner of non-zero weight with I (the flat
// sample index, row * n_columns + column), L (the layer: the kappa node) and W (its weight). A
// macro, not a function filling arrays: the plain lookup stays as fast as a hand-written loop.
struct Cell { int ik, itl, itv, ipl0, ipl1, ipv0, ipv1; float wk, wtl, wtv, wpl, wpv; };
Cell cell(float tv, float pv, float tl, float pl, float k) {
  Cell c;
  if (uIso == 1) { pv = wrapAz(wrapAz(pv) - wrapAz(pl)); pl = 0.0; }
  linearNodes(0, uN.x, uInvStep.x, k, c.ik, c.wk);
  linearNodes(1, uN.y, uInvStep.y, tl, c.itl, c.wtl);
  linearNodes(2, uN.z, uInvStep.z, tv, c.itv, c.wtv);
  periodicNodes(uPhi.x, uPhi.y, uNphi.x, pl, c.ipl0, c.ipl1, c.wpl);
  periodicNodes(uPhi.z, uPhi.w, uNphi.y, pv, c.ipv0, c.ipv1, c.wpv);
  // pole rule: on elevation node 0 with weight 1 the azimuth must not matter
  if (c.itl == 0 && c.wtl == 0.0) { c.wpl = 0.0; if (uIso == 1) c.wpv = 0.0; }
  if (c.itv == 0 && c.wtv == 0.0) c.wpv = 0.0;
  return c;
}
#define FOR_CORNERS(c, BODY) \
  for (int a_ = 0; a_ < 2; a_++) { \
    float fa_ = a_ == 0 ? 1.0 - c.wk : c.wk; if (fa_ == 0.0) continue; \
    for (int b_ = 0; b_ < 2; b_++) { \
      float fb_ = fa_ * (b_ == 0 ? 1.0 - c.wpl : c.wpl); if (fb_ == 0.0) continue; \
      for (int c_ = 0; c_ < 2; c_++) { \
        float fc_ = fb_ * (c_ == 0 ? 1.0 - c.wtl : c.wtl); if (fc_ == 0.0) continue; \
        int row_ = (b_ == 0 ? c.ipl0 : c.ipl1) * uN.y + c.itl + c_; \
        for (int d_ = 0; d_ < 2; d_++) { \
          float fd_ = fc_ * (d_ == 0 ? 1.0 - c.wpv : c.wpv); if (fd_ == 0.0) continue; \
          for (int e_ = 0; e_ < 2; e_++) { \
            float W = fd_ * (e_ == 0 ? 1.0 - c.wtv : c.wtv); if (W == 0.0) continue; \
            int I = row_ * uNphi.y * uN.z + (d_ == 0 ? c.ipv0 : c.ipv1) * uN.z + c.itv + e_; \
            int L = c.ik + a_; \
            BODY \
          } } } } }

vec3 lookup(float tv, float pv, float tl, float pl, float k) {
  Cell c = cell(tv, pv, tl, pl, k);
  vec3 acc = vec3(0.0);
  FOR_CORNERS(c, acc += W * texelFetch(uTab, ivec3(I % uTexW, I / uTexW, L), 0).rgb;)
  return acc;
}
`;
