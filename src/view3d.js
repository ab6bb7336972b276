// tetopt HTML report: the 3D view of where the bad tets are (issue 30).
//
// Inlined into every report page at build time (cmake/embed_view3d.cmake)
// together with three.js from node_modules (pinned in package-lock.json).
// three.js arrives as three <script type="text/plain"> elements: its core,
// its module (which imports "./three.core.min.js") and OrbitControls (which
// imports "three").  They are loaded here as ES modules from blob: URLs, each
// import rewritten to the blob URL of the module it names, so the page needs
// no network and no server (file:// works).
//
// Data: <script type="application/json" id="tv-data">, written by
// src/html_report.cpp from view3d.hpp's sets: base64 little-endian typed
// arrays (Float32 positions relative to the mesh's bounding-box centre,
// Int32 indices, Float32 measures, Uint8 kinds and classes).
//
// The rest of the report does not depend on this script: when WebGL is
// missing the view says so and the tables and charts read as before.
//
// Hooks the tests use (tests/scripts/view3d_check.mjs): <html> gets
// data-view-ready="1" after the first frame (data-view-ms: performance.now()
// then), data-view-flying="0" when a camera flight ends;
// window.tetoptView.screenOf(id) gives the client coordinates of a tet's
// centroid in the current set.

const $ = (id) => document.getElementById(id);
const root = $('view3d');
const html = document.documentElement;

function say(msg) {
  const box = $('tv-canvas');
  if (box) box.innerHTML = '<p class="tv-msg"></p>', box.firstChild.textContent = msg;
}

function bytes(s) {
  if (Uint8Array.fromBase64) return Uint8Array.fromBase64(s);
  const bin = atob(s);
  const u = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; ++i) u[i] = bin.charCodeAt(i);
  return u;
}
const f32 = (s) => new Float32Array(bytes(s).buffer);
const i32 = (s) => new Int32Array(bytes(s).buffer);
const u8 = (s) => bytes(s);
const i8 = (s) => new Int8Array(bytes(s).buffer);

async function loadThree() {
  const text = (id) => $(id).textContent;
  const url = (src) => URL.createObjectURL(new Blob([src], { type: 'text/javascript' }));
  const core = url(text('tv-three-core'));
  const mod = url(text('tv-three-module').replaceAll('"./three.core.min.js"', JSON.stringify(core)));
  const orbit = url(text('tv-three-orbit').replace(/from\s*'three'/g, 'from ' + JSON.stringify(mod)));
  const THREE = await import(mod);
  const { OrbitControls } = await import(orbit);
  return { THREE, OrbitControls };
}

// Number formats of the table (src/html_report.cpp's f()).
const fmt = {
  fixed: (x, d) => (Number.isNaN(x) ? '–' : x.toFixed(d)),
  g6: (x) => {
    if (Number.isNaN(x)) return '–';
    if (x === 0) return '0';
    let s = x.toPrecision(6);
    if (s.includes('e')) {
      const [m, e] = s.split('e');
      const mm = m.includes('.') ? m.replace(/0+$/, '').replace(/\.$/, '') : m;
      const n = parseInt(e, 10);
      return mm + 'e' + (n < 0 ? '-' : '+') + String(Math.abs(n)).padStart(2, '0');
    }
    return s.includes('.') ? s.replace(/0+$/, '').replace(/\.$/, '') : s;
  },
};

let CLASS_NAMES = [];  // diagnose.cpp's tet_class_name(), from the data
const CLASS_COLOURS = ['#9fb3c8', '#e12d39', '#f0b429', '#2680c2'];
const PALETTE = ['#5b9bd5', '#70ad47', '#f2c38b', '#c9b1e0', '#f5a3a3', '#9ed9d6', '#e0d58f', '#b8c4d6',
  '#d9a7c7', '#a3c9a8', '#f0b7a1', '#9fb7f0'];
const BACK_COLOUR = '#d9c7a7';
const CAP_COLOUR = '#8e24aa';
const BOUND_COLOUR = '#111111';
// Worst to least bad among the poor tets.
const RAMP = ['#7a0019', '#d7301f', '#fc8d59', '#fdcc8a', '#fff3b0'];

// performance.now() at each stage, reported in data-view-stages.
const stages = [];
const stage = (name) => stages.push(name + ':' + performance.now().toFixed(0));

async function main() {
  stage('start');
  const data = JSON.parse($('tv-data').textContent);
  CLASS_NAMES = data.class_names;
  stage('json');
  const probe = document.createElement('canvas');
  if (!probe.getContext('webgl2') && !probe.getContext('webgl')) {
    say('This browser has no WebGL: the 3D view cannot be drawn. The tables below say the same in numbers.');
    console.warn('tetopt 3D view: no WebGL');
    html.setAttribute('data-view-ready', 'no-webgl');
    return;
  }
  const { THREE, OrbitControls } = await loadThree();
  stage('three');
  const box = $('tv-canvas');
  const W = () => Math.max(100, box.clientWidth), H = () => Math.max(100, box.clientHeight);

  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(W(), H());
  renderer.localClippingEnabled = true;
  box.replaceChildren(renderer.domElement);
  renderer.domElement.id = 'tv-gl';

  const scene = new THREE.Scene();
  scene.background = new THREE.Color('#f5f7fa');
  const diag = data.surface.diagonal > 0 ? data.surface.diagonal : 1;
  const camera = new THREE.PerspectiveCamera(35, W() / H(), diag * 1e-4, diag * 50);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x8899aa, 1.6));
  const head = new THREE.DirectionalLight(0xffffff, 1.6);
  camera.add(head);
  head.position.set(0.3, 0.5, 1);
  scene.add(camera);

  // ---- the surface, one group per ref ----
  const S = data.surface;
  const sgeo = new THREE.BufferGeometry();
  sgeo.setAttribute('position', new THREE.BufferAttribute(f32(S.xyz), 3));
  sgeo.setIndex(new THREE.BufferAttribute(new Uint32Array(i32(S.tris).buffer), 1));
  sgeo.computeVertexNormals();
  sgeo.computeBoundingBox();
  const clip = new THREE.Plane(new THREE.Vector3(1, 0, 0), Infinity);
  const surfMats = S.groups.map((g, k) => {
    sgeo.addGroup(3 * g[1], 3 * g[2], k);
    return new THREE.MeshLambertMaterial({ color: PALETTE[k % PALETTE.length], side: THREE.FrontSide,
      flatShading: true, transparent: true, opacity: 0.35, depthWrite: false, clippingPlanes: [clip] });
  });
  const backMat = new THREE.MeshLambertMaterial({ color: BACK_COLOUR, side: THREE.BackSide, flatShading: true,
    transparent: true, opacity: 0.35, depthWrite: false, clippingPlanes: [clip] });
  const front = new THREE.Mesh(sgeo, surfMats);
  const back = new THREE.Mesh(sgeo, backMat);
  front.renderOrder = back.renderOrder = 2;
  scene.add(front, back);

  // ---- the sets of poor tets ----
  const FV = data.face_vertex;  // conventions.hpp kFaceVertex: face f opposite vertex f
  const EV = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];
  function decodeSet(d) {
    const s = { name: d.name, label: d.label, below: d.below, xyz: f32(d.xyz), tets: i32(d.tets), ids: i32(d.ids),
      alpha: f32(d.alpha), dmin: f32(d.dihedral_min), dmax: f32(d.dihedral_max), kind: u8(d.kind),
      diagnosed: !!d.cls, offset: d.offset };
    s.n = s.ids.length;
    if (s.diagnosed) { s.cls = u8(d.cls); s.best = f32(d.best_alpha); s.cap = i8(d.cap_face); s.cfaces = u8(d.constrained_faces); }
    s.index = new Map();
    for (let i = 0; i < s.n; ++i) s.index.set(s.ids[i], i);
    return s;
  }
  const sets = data.sets.map(decodeSet);
  stage('decoded');
  const group = (s) => {
    const g = new THREE.Group();
    g.position.set(s.offset[0], s.offset[1], s.offset[2]);
    scene.add(g);
    return g;
  };
  const P = (s, t, i) => { const v = s.tets[4 * t + i]; return [s.xyz[3 * v], s.xyz[3 * v + 1], s.xyz[3 * v + 2]]; };
  for (const s of sets) {
    s.group = group(s);
    const pos = new Float32Array(s.n * 36);
    for (let t = 0; t < s.n; ++t)
      for (let f = 0; f < 4; ++f)
        for (let k = 0; k < 3; ++k) pos.set(P(s, t, FV[f][k]), 36 * t + 9 * f + 3 * k);
    const geo = new THREE.BufferGeometry();
    geo.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    geo.setAttribute('color', new THREE.BufferAttribute(new Float32Array(s.n * 36), 3));
    geo.computeVertexNormals();
    s.mesh = new THREE.Mesh(geo, new THREE.MeshLambertMaterial({ vertexColors: true, flatShading: true,
      side: THREE.DoubleSide, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1, clippingPlanes: [clip] }));
    s.mesh.renderOrder = 1;
    s.group.add(s.mesh);
    if (!s.diagnosed) continue;
    // Locked tets: their edges, coloured by class.
    const lp = [], lc = [], cp = [];
    const colour = new THREE.Color();
    for (let t = 0; t < s.n; ++t) {
      const c = s.cls[t];
      if (c === 1 || c === 2) {
        colour.set(CLASS_COLOURS[c]);
        for (const [a, b] of EV) { lp.push(...P(s, t, a), ...P(s, t, b)); lc.push(colour.r, colour.g, colour.b, colour.r, colour.g, colour.b); }
      }
      if (s.cap[t] >= 0) for (const i of FV[s.cap[t]]) cp.push(...P(s, t, i));
    }
    const lgeo = new THREE.BufferGeometry();
    lgeo.setAttribute('position', new THREE.Float32BufferAttribute(lp, 3));
    lgeo.setAttribute('color', new THREE.Float32BufferAttribute(lc, 3));
    s.locked = new THREE.LineSegments(lgeo, new THREE.LineBasicMaterial({ vertexColors: true, clippingPlanes: [clip] }));
    s.locked.renderOrder = 3;
    const cgeo = new THREE.BufferGeometry();
    cgeo.setAttribute('position', new THREE.Float32BufferAttribute(cp, 3));
    s.caps = new THREE.Mesh(cgeo, new THREE.MeshBasicMaterial({ color: CAP_COLOUR, side: THREE.DoubleSide, clippingPlanes: [clip] }));
    s.group.add(s.locked, s.caps);
    s.lockedCount = [0, 0, 0, 0];
    for (let t = 0; t < s.n; ++t) s.lockedCount[s.cls[t]]++;
    s.capCount = cp.length / 9;
  }
  // The triangle that holds the mesh-wide bound (diagnose.hpp), in the
  // surface's frame; shown with the capping triangles.
  let boundTri = null;
  if (data.bound) {
    const bgeo = new THREE.BufferGeometry();
    bgeo.setAttribute('position', new THREE.Float32BufferAttribute(data.bound.xyz, 3));
    boundTri = new THREE.Mesh(bgeo, new THREE.MeshBasicMaterial({ color: BOUND_COLOUR, side: THREE.DoubleSide,
      depthTest: false }));
    boundTri.renderOrder = 4;
    scene.add(boundTri);
  }

  // ---- colouring by the chosen measure ----
  const measures = {
    alpha: { label: 'α', get: (s, t) => s.alpha[t], higherBetter: true, fix: 4 },
    dmin: { label: 'min dihedral (°)', get: (s, t) => s.dmin[t], higherBetter: true, fix: 2 },
    dmax: { label: 'max dihedral (°)', get: (s, t) => s.dmax[t], higherBetter: false, fix: 2 },
    cls: { label: 'diagnosis class', get: (s, t) => (s.diagnosed ? s.cls[t] : 0), categorical: true },
  };
  const ramp = RAMP.map((c) => new THREE.Color(c));
  function rampColour(x, out) {  // x in [0,1], 0 worst
    const y = Math.min(1, Math.max(0, Number.isNaN(x) ? 0 : x)) * (ramp.length - 1);
    const i = Math.min(ramp.length - 2, Math.floor(y));
    return out.lerpColors(ramp[i], ramp[i + 1], y - i);
  }
  function range(key) {  // over every set, so before and after share a scale
    if (key === 'alpha') {
      let lo = Infinity;
      for (const s of sets) for (let t = 0; t < s.n; ++t) if (!Number.isNaN(s.alpha[t])) lo = Math.min(lo, s.alpha[t]);
      return [Math.min(lo, data.threshold), data.threshold];
    }
    let lo = Infinity, hi = -Infinity;
    for (const s of sets) for (let t = 0; t < s.n; ++t) { const v = measures[key].get(s, t); if (!Number.isNaN(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); } }
    return lo <= hi ? [lo, hi] : [0, 1];
  }
  const state = { set: sets.length - 1, measure: 'alpha', surface: true, tets: true, locked: true, caps: true,
    opacity: 0.35, clipAxis: -1, clipAt: 0.5, selected: -1 };
  function paint() {
    const m = measures[state.measure];
    const [lo, hi] = m.categorical ? [0, 1] : range(state.measure);
    const c = new THREE.Color();
    for (const s of sets) {
      const col = s.mesh.geometry.getAttribute('color');
      for (let t = 0; t < s.n; ++t) {
        const v = m.get(s, t);
        if (m.categorical) c.set(CLASS_COLOURS[v]);
        else rampColour(hi > lo ? (m.higherBetter ? (v - lo) / (hi - lo) : (hi - v) / (hi - lo)) : 0, c);
        for (let k = 0; k < 12; ++k) col.setXYZ(12 * t + k, c.r, c.g, c.b);
      }
      col.needsUpdate = true;
    }
    legend(lo, hi);
  }

  // ---- camera, controls, rendering on demand ----
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.enableDamping = false;
  controls.screenSpacePanning = true;
  const bb = sgeo.boundingBox;
  const centre = bb.getCenter(new THREE.Vector3());
  camera.position.copy(centre).add(new THREE.Vector3(0.8, -1.1, 0.9).normalize().multiplyScalar(diag * 1.3));
  controls.target.copy(centre);
  controls.update();
  let pending = false;
  function render() {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => { pending = false; renderer.render(scene, camera); });
  }
  controls.addEventListener('change', render);
  new ResizeObserver(() => {
    renderer.setSize(W(), H());
    camera.aspect = W() / H();
    camera.updateProjectionMatrix();
    render();
  }).observe(box);

  function apply() {
    for (const m of [...surfMats, backMat]) {
      // Back faces seen through a see-through front (the far side's inside)
      // at half the opacity, so the patch colours stay readable.
      m.opacity = m === backMat && state.opacity < 1 ? state.opacity / 2 : state.opacity;
      m.transparent = state.opacity < 1;
      m.depthWrite = state.opacity >= 1;
      m.needsUpdate = true;
    }
    front.visible = back.visible = state.surface;
    if (state.clipAxis < 0) clip.constant = Infinity;
    else {
      const n = [0, 0, 0];
      n[state.clipAxis] = -1;
      clip.normal.set(n[0], n[1], n[2]);
      const lo = bb.min.getComponent(state.clipAxis), hi = bb.max.getComponent(state.clipAxis);
      clip.constant = lo + state.clipAt * (hi - lo);  // keeps the side below the plane
    }
    sets.forEach((s, k) => {
      const on = k === state.set;
      s.group.visible = on;
      s.mesh.visible = on && state.tets;
      if (s.locked) s.locked.visible = on && state.locked;
      if (s.caps) s.caps.visible = on && state.caps;
    });
    if (boundTri) boundTri.visible = state.caps;
    render();
  }

  // ---- selection: click a tet, or a row of the table ----
  const pick = new THREE.Raycaster();
  let marker = null;
  function current() { return sets[state.set]; }
  function centroid(s, t) {
    const c = [0, 0, 0];
    for (let i = 0; i < 4; ++i) { const p = P(s, t, i); for (let k = 0; k < 3; ++k) c[k] += p[k] / 4; }
    return new THREE.Vector3(c[0] + s.offset[0], c[1] + s.offset[1], c[2] + s.offset[2]);
  }
  function rowHtml(s, t, fromData = false) {
    // The row of the table (#worst) when the tet is listed there; else the
    // same columns from the view's data (centroid from its float32 corners).
    const tr = !fromData && s.diagnosed && document.querySelector('#worst tr[data-tet="' + s.ids[t] + '"]');
    if (tr) return tr.innerHTML;
    const c = centroid(s, t), o = data.surface.origin;
    // As the table: no searched face reaches below γ -> "≥ γ" when it has a
    // constrained face, "–" when it has none.
    const best = !s.diagnosed ? '–' : !Number.isNaN(s.best[t]) ? fmt.fixed(s.best[t], 4)
      : s.cfaces[t] > 0 ? '≥ ' + data.threshold_text : '–';
    const cls = s.diagnosed ? '<td class="l c' + s.cls[t] + '">' + CLASS_NAMES[s.cls[t]] + '</td>'
      : '<td class="l">(diagnosed after the run only)</td>';
    return '<td>' + (s.ids[t] + 1) + '</td><td>' + fmt.fixed(s.alpha[t], 4) + '</td><td>' + fmt.fixed(s.dmin[t], 2) +
      '</td><td>' + fmt.fixed(s.dmax[t], 2) + '</td><td>' + s.kind[t] + '</td>' + cls + '<td>' + best + '</td><td>' +
      fmt.g6(c.x + o[0]) + '</td><td>' + fmt.g6(c.y + o[1]) + '</td><td>' + fmt.g6(c.z + o[2]) + '</td>';
  }
  function select(t) {
    const s = current();
    state.selected = t;
    if (marker) { marker.parent.remove(marker); marker.geometry.dispose(); marker = null; }
    const info = $('tv-info');
    if (t < 0) { info.innerHTML = '<p class="note">Click a tet, or a row of the table below, to see its row here.</p>'; render(); return; }
    const lp = [];
    for (const [a, b] of EV) lp.push(...P(s, t, a), ...P(s, t, b));
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(lp, 3));
    marker = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: '#000000', depthTest: false }));
    marker.renderOrder = 10;
    s.group.add(marker);
    const head = document.querySelector('#worst tr:first-child');
    info.innerHTML = '<p><b>' + s.label + '</b>: tet ' + (s.ids[t] + 1) + '</p><table id="tv-row">' +
      (head ? '<tr>' + head.innerHTML + '</tr>' : '') + '<tr data-tet="' + s.ids[t] + '">' + rowHtml(s, t) + '</tr></table>';
    for (const tr of document.querySelectorAll('#worst tr.tv-sel')) tr.classList.remove('tv-sel');
    const tr = s.diagnosed && document.querySelector('#worst tr[data-tet="' + s.ids[t] + '"]');
    if (tr) tr.classList.add('tv-sel');
    render();
  }
  let down = null;
  renderer.domElement.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
  renderer.domElement.addEventListener('pointerup', (e) => {
    if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 4) return;
    const r = renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1);
    pick.setFromCamera(ndc, camera);
    const s = current();
    // The nearest hit the plane does not cut away (the ray ignores it).
    const hit = state.tets ? pick.intersectObject(s.mesh, false).find((h) => !(clip.distanceToPoint(h.point) < 0)) : null;
    select(hit ? Math.floor(hit.faceIndex / 4) : -1);
  });

  let flight = 0;
  function flyTo(t) {
    const s = current();
    const c = centroid(s, t);
    let size = 0;
    for (const [a, b] of EV) {
      const p = P(s, t, a), q = P(s, t, b);
      size = Math.max(size, Math.hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]));
    }
    const dir = camera.position.clone().sub(controls.target).normalize();
    const dist = Math.max(size * 8, diag * 0.03);
    const p0 = camera.position.clone(), t0 = controls.target.clone(), p1 = c.clone().addScaledVector(dir, dist);
    const id = ++flight, start = performance.now(), ms = 600;
    html.setAttribute('data-view-flying', '1');
    const step = (now) => {
      if (id !== flight) return;
      const x = Math.min(1, (now - start) / ms), e = x * x * (3 - 2 * x);
      camera.position.lerpVectors(p0, p1, e);
      controls.target.lerpVectors(t0, c, e);
      controls.update();
      renderer.render(scene, camera);
      if (x < 1) requestAnimationFrame(step);
      else html.setAttribute('data-view-flying', '0');
    };
    requestAnimationFrame(step);
  }
  for (const tr of document.querySelectorAll('#worst tr[data-tet]')) {
    tr.classList.add('tv-link');
    tr.title = 'show this tet in the 3D view';
    tr.addEventListener('click', () => {
      const k = sets.findIndex((s) => s.diagnosed);
      const t = k >= 0 ? sets[k].index.get(+tr.dataset.tet) : undefined;
      if (t === undefined) return;
      if (state.set !== k) { state.set = k; syncControls(); apply(); }
      select(t);
      flyTo(t);
      root.scrollIntoView({ block: 'nearest', behavior: 'smooth' });
    });
  }

  // ---- controls and legend ----
  const ctl = $('tv-controls');
  const opt = (v, l, on) => '<option value="' + v + '"' + (on ? ' selected' : '') + '>' + l + '</option>';
  ctl.innerHTML =
    (sets.length > 1 ? '<div class="tv-row" id="tv-sets">' + sets.map((s, k) =>
      '<label><input type="radio" name="tv-set" value="' + k + '"' + (k === state.set ? ' checked' : '') + '> ' + s.label +
      '</label>').join(' ') + '</div>' : '') +
    '<div class="tv-row"><label>colour tets by <select id="tv-measure">' + opt('alpha', 'α', true) +
    opt('dmin', 'min dihedral') + opt('dmax', 'max dihedral') + opt('cls', 'diagnosis class') + '</select></label></div>' +
    '<div class="tv-row"><label><input type="checkbox" id="tv-show-tets" checked> poor tets</label> ' +
    '<label><input type="checkbox" id="tv-show-locked" checked> locked tets</label> ' +
    '<label><input type="checkbox" id="tv-show-caps" checked> capping triangles</label> ' +
    '<label><input type="checkbox" id="tv-show-surface" checked> surface</label></div>' +
    '<div class="tv-row"><label>surface opacity <input type="range" id="tv-opacity" min="0" max="100" value="35"></label></div>' +
    '<div class="tv-row"><label>cut away beyond a plane across <select id="tv-clip">' + opt(-1, 'off', true) + opt(0, 'x') + opt(1, 'y') +
    opt(2, 'z') + '</select></label> <input type="range" id="tv-clip-at" min="0" max="1000" value="500" disabled></div>' +
    '<div class="tv-row note">drag: rotate · right-drag or shift-drag: pan · wheel: zoom · click: pick a tet</div>';
  function syncControls() {
    const r = document.querySelector('input[name="tv-set"][value="' + state.set + '"]');
    if (r) r.checked = true;
    const s = current();
    $('tv-show-locked').disabled = !s.diagnosed;
    legend();
    select(-1);
  }
  for (const r of document.querySelectorAll('input[name="tv-set"]'))
    r.addEventListener('change', () => { state.set = +r.value; syncControls(); apply(); });
  $('tv-measure').addEventListener('change', (e) => { state.measure = e.target.value; paint(); render(); });
  const bind = (id, key) => $(id).addEventListener('change', (e) => { state[key] = e.target.checked; apply(); });
  bind('tv-show-tets', 'tets'); bind('tv-show-locked', 'locked'); bind('tv-show-caps', 'caps'); bind('tv-show-surface', 'surface');
  $('tv-opacity').addEventListener('input', (e) => { state.opacity = e.target.value / 100; apply(); });
  $('tv-clip').addEventListener('change', (e) => { state.clipAxis = +e.target.value; $('tv-clip-at').disabled = state.clipAxis < 0; apply(); });
  $('tv-clip-at').addEventListener('input', (e) => { state.clipAt = e.target.value / 1000; apply(); });

  let lastRange = [0, 1];
  function legend(lo, hi) {
    if (lo !== undefined) lastRange = [lo, hi];
    [lo, hi] = lastRange;
    const s = current(), m = measures[state.measure];
    const sw = (c, label) => '<span class="tv-key"><i style="background:' + c + '"></i>' + label + '</span>';
    let h = '<div><b>surface</b> (' + (S.by_patch ? 'patch ref' : 'region ref') + '): ';
    h += S.groups.slice(0, 24).map((g, k) => sw(PALETTE[k % PALETTE.length], g[0])).join('');
    if (S.groups.length > 24) h += ' … ' + (S.groups.length - 24) + ' more refs';
    h += sw(BACK_COLOUR, 'back face (inside out)') + '</div>';
    h += '<div><b>' + s.label + ': poor tets</b> (α &lt; ' + data.threshold + '; ' + s.n + (s.n < s.below ? ' worst of ' + s.below : '') + ' shown) ';
    if (m.categorical) h += [1, 2, 3].map((c) => sw(CLASS_COLOURS[c], CLASS_NAMES[c])).join('');
    else {
      const lab = (x) => x.toFixed(m.fix);
      h += m.label + ' <span class="tv-ramp" style="background:linear-gradient(to right,' + RAMP.join(',') + ')"></span> ' +
        (m.higherBetter ? lab(lo) + ' (worst) → ' + lab(hi) : lab(hi) + ' (worst) → ' + lab(lo));
    }
    h += '</div>';
    if (s.diagnosed) {
      h += '<div><b>locked tets</b> (edges): ' + sw(CLASS_COLOURS[1], 'by their boundary triangle: ' + s.lockedCount[1]) +
        sw(CLASS_COLOURS[2], 'by their constrained neighbours: ' + s.lockedCount[2]) + '</div>';
      h += '<div><b>capping triangles</b>: ' + sw(CAP_COLOUR, 'constrained triangles that cap their tet below α = ' +
        data.threshold + ' (no apex lifts it higher): ' + s.capCount) + '</div>';
    } else {
      h += '<div class="note">Locked tets and capping triangles: the diagnosis describes the mesh after the run.</div>';
    }
    if (data.bound) h += '<div>' + sw(BOUND_COLOUR, '<b>bound triangle</b>: the constrained triangle that holds the ' +
      'mesh-wide bound: any mesh keeping the boundary has worst α ≤ ' + data.bound.alpha.toFixed(4) + ' (tet ' +
      (data.bound.tet + 1) + ')') + '</div>';
    $('tv-legend').innerHTML = h;
  }

  window.tetoptView = {
    sets: sets.map((s) => s.name),
    get set() { return sets[state.set].name; },
    shown: () => current().n,
    // The panel's cells for tet `id` of the current set as built from the
    // view's data (what a tet the table does not list shows).
    rowFromData(id) {
      const s = current(), t = s.index.get(id);
      if (t === undefined) return null;
      const tr = document.createElement('tr');
      tr.innerHTML = rowHtml(s, t, true);
      return [...tr.children].map((td) => td.textContent);
    },
    screenOf(id) {
      const s = current(), t = s.index.get(id);
      if (t === undefined) return null;
      const v = centroid(s, t).project(camera), r = renderer.domElement.getBoundingClientRect();
      return { x: r.left + (v.x + 1) / 2 * r.width, y: r.top + (1 - v.y) / 2 * r.height };
    },
  };
  paint();
  syncControls();
  apply();
  stage('scene');
  requestAnimationFrame(() => {
    renderer.render(scene, camera);
    stage('frame');
    html.setAttribute('data-view-stages', stages.join(' '));
    html.setAttribute('data-view-ms', performance.now().toFixed(0));
    html.setAttribute('data-view-ready', '1');
  });
}

if (root) {
  main().catch((e) => {
    say('The 3D view could not be drawn: ' + e.message);
    console.error('tetopt 3D view:', e);
  });
}
