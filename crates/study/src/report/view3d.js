// The report's 3-D view (crates/study/src/report/view3d.rs): reads the data blob
// <script type="application/json" id="crashrig-3d"> and draws it with the three.js bundle inlined
// before this script (global THREE_VIEW). Loads nothing; without WebGL it shows the static
// picture beside it. Sets data-v3d-* attributes on <body> for `cargo xtask report-check`.
// It draws just after the page's load event, so the page opens (and its other figures show)
// before the WebGL set-up runs.
window.addEventListener('load', function () { setTimeout(view3d, 0); });
function view3d() {
  'use strict';
  var body = document.body;
  var root = document.getElementById('v3d');
  var blobEl = document.getElementById('crashrig-3d');
  if (!root || !blobEl) { return; }
  var data = JSON.parse(blobEl.textContent);
  var T = window.THREE_VIEW;
  var canvasBox = document.getElementById('v3d-canvas');
  var fallback = document.getElementById('v3d-fallback');
  var select = document.getElementById('v3d-layout');
  var status = document.getElementById('v3d-status');
  function useFallback(why) {
    canvasBox.hidden = true;
    fallback.hidden = false;
    document.getElementById('v3d-why').textContent = why;
    document.getElementById('v3d-controls').hidden = true;
    body.setAttribute('data-v3d', 'fallback');
  }
  var renderer = null;
  try {
    // One WebGL 2 context (what three.js needs), made here and handed to the renderer: asking
    // for it is the test, and a second context would double the set-up time.
    var attrs = { alpha: false, depth: true, stencil: false, antialias: true, premultipliedAlpha: true, preserveDrawingBuffer: true };
    var canvas = document.createElement('canvas');
    var ctx = T ? canvas.getContext('webgl2', attrs) : null;
    if (!ctx) { throw new Error('no WebGL'); }
    renderer = new T.WebGLRenderer({ canvas: canvas, context: ctx, antialias: true, preserveDrawingBuffer: true });
  } catch (e) {
    useFallback('This browser offers no WebGL (it may be switched off, or the graphics driver is not supported), so the interactive 3-D view cannot run; this static picture shows the first layout from the same viewpoint.');
    return;
  }

  var BG = 0xffffff;
  renderer.setClearColor(BG, 1);
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  canvasBox.insertBefore(renderer.domElement, canvasBox.firstChild);
  var labels = document.getElementById('v3d-labels');
  var SVG = 'http://www.w3.org/2000/svg';
  var leaders = document.createElementNS(SVG, 'svg');
  leaders.setAttribute('class', 'v3d-leaders');
  var leaderPath = document.createElementNS(SVG, 'path');
  leaderPath.setAttribute('stroke', '#555');
  leaderPath.setAttribute('stroke-width', '1');
  leaderPath.setAttribute('fill', 'none');
  leaders.appendChild(leaderPath);
  canvasBox.insertBefore(leaders, labels);
  var hiddenNote = document.getElementById('v3d-hidden');
  var scene = new T.Scene();
  var camera = new T.PerspectiveCamera(40, 2, 1, 1e6);
  camera.up.set(0, 0, 1);
  scene.add(new T.AmbientLight(0xffffff, 1.6));
  var sun = new T.DirectionalLight(0xffffff, 1.6);
  sun.position.set(0.4, -0.6, 1);
  scene.add(sun);
  var controls = new T.OrbitControls(camera, renderer.domElement);
  controls.enableDamping = false;
  controls.screenSpacePanning = true;
  var content = new T.Group();
  scene.add(content);
  var labelList = [];

  // ---- colours: the σ scale, split at the threshold --------------------------------------
  function lerp(a, b, t) { return a + (b - a) * t; }
  function ramp(stops, t) {
    t = Math.min(1, Math.max(0, t));
    var k = Math.min(stops.length - 2, Math.floor(t * (stops.length - 1)));
    var u = t * (stops.length - 1) - k;
    var a = stops[k], b = stops[k + 1];
    return [lerp(a[0], b[0], u), lerp(a[1], b[1], u), lerp(a[2], b[2], u)];
  }
  // Below the threshold: dark blue → teal → light green; at and above it: orange → dark red.
  var BELOW = [[0.10, 0.20, 0.60], [0.05, 0.55, 0.65], [0.45, 0.80, 0.35]];
  var ABOVE = [[1.00, 0.60, 0.10], [0.85, 0.15, 0.10], [0.45, 0.00, 0.10]];
  function niceCeil(v) {
    if (!(v > 0)) { return 1; }
    var p = Math.pow(10, Math.floor(Math.log10(v)));
    var m = [1, 2, 2.5, 5, 10];
    for (var i = 0; i < m.length; i++) { if (m[i] * p >= v * (1 - 1e-12)) { return m[i] * p; } }
    return 10 * p;
  }
  function sigmaColour(s, thr, top) {
    if (s < thr) { return ramp(BELOW, s / thr); }
    return ramp(ABOVE, top > thr ? (s - thr) / (top - thr) : 1);
  }
  function css(c) {
    return 'rgb(' + Math.round(255 * c[0]) + ',' + Math.round(255 * c[1]) + ',' + Math.round(255 * c[2]) + ')';
  }

  // ---- sprites for round and hollow points --------------------------------------------
  function spriteTexture(hollow) {
    var c = document.createElement('canvas');
    c.width = c.height = 64;
    var g = c.getContext('2d');
    g.beginPath();
    g.arc(32, 32, hollow ? 24 : 28, 0, 2 * Math.PI);
    if (hollow) { g.lineWidth = 9; g.strokeStyle = '#fff'; g.stroke(); } else { g.fillStyle = '#fff'; g.fill(); }
    return new T.CanvasTexture(c);
  }
  var disc = spriteTexture(false), ring = spriteTexture(true);

  // ---- geometry helpers ---------------------------------------------------------------
  function rotOpk(a) {
    // R_world_from_cam = Rx(ω)·Ry(φ)·Rz(κ) (docs/CONVENTIONS.md); columns: camera x, y, z.
    var d = Math.PI / 180, o = a[0] * d, p = a[1] * d, k = a[2] * d;
    var co = Math.cos(o), so = Math.sin(o), cp = Math.cos(p), sp = Math.sin(p), ck = Math.cos(k), sk = Math.sin(k);
    return [
      [cp * ck, -cp * sk, sp],
      [co * sk + so * sp * ck, co * ck - so * sp * sk, -so * cp],
      [so * sk - co * sp * ck, so * ck + co * sp * sk, co * cp]
    ];
  }
  function col(R, j) { return new T.Vector3(R[0][j], R[1][j], R[2][j]); }
  function lookAt(from, to) {
    // Camera axes for an aimed camera: z towards `to`, x horizontal, y down.
    var z = new T.Vector3().subVectors(to, from).normalize();
    var up = new T.Vector3(0, 0, 1);
    var x = new T.Vector3().crossVectors(z, up);
    if (x.lengthSq() < 1e-12) { x.set(1, 0, 0); }
    x.normalize();
    var y = new T.Vector3().crossVectors(z, x);
    return [x, y, z];
  }
  function segments(list, colour, dashed) {
    var g = new T.BufferGeometry();
    g.setAttribute('position', new T.Float32BufferAttribute(list, 3));
    var m = dashed
      ? new T.LineDashedMaterial({ color: colour, dashSize: dashed, gapSize: dashed * 0.7 })
      : new T.LineBasicMaterial({ color: colour });
    var l = new T.LineSegments(g, m);
    if (dashed) { l.computeLineDistances(); }
    return l;
  }
  // Label priority when two would overlap: the rig's cameras, the layout's cameras, the axes,
  // the markers (render() places them in this order and hides what finds no free place).
  var RANK = { rig: 0, cam: 1, axis: 2, marker: 3 };
  // `away`: a point the label keeps to the far side of (a camera's pyramid, an axis' origin);
  // `shape`: the points whose screen box other labels keep clear of (a camera's pyramid).
  function addLabel(text, pos, cls, away, shape) {
    // Two cameras at one place (an observer standing at a rig camera): one label for both.
    for (var i = 0; i < labelList.length; i++) {
      if (labelList[i].pos.distanceTo(pos) < 1 && labelList[i].el.className.indexOf('axis') < 0) {
        labelList[i].el.textContent += ' = ' + text;
        labelList[i].w = 0;
        return;
      }
    }
    var el = document.createElement('div');
    el.className = 'v3d-label ' + (cls || '');
    el.textContent = text;
    labels.appendChild(el);
    labelList.push({ el: el, pos: pos.clone(), rank: RANK[cls] === undefined ? 9 : RANK[cls], w: 0, h: 0,
      away: away || null, shape: shape || [] });
  }
  function frustum(C, axes, size, colour, list) {
    var x = axes[0], y = axes[1], z = axes[2];
    var d = size, w = size * 0.55, h = size * 0.35;
    var corners = [[-1, -1], [1, -1], [1, 1], [-1, 1]].map(function (s) {
      return C.clone().addScaledVector(z, d).addScaledVector(x, s[0] * w).addScaledVector(y, s[1] * h);
    });
    for (var i = 0; i < 4; i++) {
      var a = corners[i], b = corners[(i + 1) % 4];
      list.push(C.x, C.y, C.z, a.x, a.y, a.z, a.x, a.y, a.z, b.x, b.y, b.z);
    }
    // The image's top edge (−y): a small triangle, so that "up" in the image reads.
    var t0 = corners[0], t1 = corners[1];
    var tm = t0.clone().add(t1).multiplyScalar(0.5).addScaledVector(y, -h * 0.5);
    list.push(t0.x, t0.y, t0.z, tm.x, tm.y, tm.z, tm.x, tm.y, tm.z, t1.x, t1.y, t1.z);
    return corners.concat([C.clone().addScaledVector(z, d), tm]);
  }

  // ---- the scene's extent (every layout and camera: switching keeps the scale) --------------
  var lo = new T.Vector3(Infinity, Infinity, Infinity), hi = new T.Vector3(-Infinity, -Infinity, -Infinity);
  function grow(p) { lo.min(p); hi.max(p); }
  data.layouts.forEach(function (l) {
    l.points.forEach(function (p) { grow(new T.Vector3(p[0], p[1], p[2])); });
    (l.cameras || []).forEach(function (c) { grow(new T.Vector3().fromArray(c.world_from_cam.position_mm)); });
  });
  data.trajectories.forEach(function (t) {
    t.epochs.forEach(function (p) { if (p) { grow(new T.Vector3(p[0], p[1], p[2])); } });
  });
  if (!isFinite(lo.x)) { lo.set(-500, -500, -500); hi.set(500, 500, 500); }
  var centre = lo.clone().add(hi).multiplyScalar(0.5);
  var size = Math.max(hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 100);

  // ---- the σ ellipsoids' enlargement: the largest semi-axis drawn at ~2.5 % of the scene ------
  var maxAxis = 0;
  data.trajectories.forEach(function (t) {
    (t.ellipsoids || []).forEach(function (e) {
      e.semi_axes_mm.forEach(function (a) { maxAxis = Math.max(maxAxis, Math.hypot(a[0], a[1], a[2])); });
    });
  });
  var ellScale = maxAxis > 0 ? niceCeil(0.025 * size / maxAxis) : 1;

  function showLayout(k) {
    while (content.children.length) {
      var c = content.children.pop();
      if (c.geometry) { c.geometry.dispose(); }
    }
    labels.textContent = '';
    labelList = [];
    var l = data.layouts[k];
    var thr = l.threshold_mm;
    var finite = l.points.map(function (p) { return p[3]; }).filter(function (s) { return s !== null; });
    // The bar ends at 3× the threshold at most (as the heat maps do), so that the part below the
    // threshold stays readable when a few points have a far larger σ; beyond it the colour is the
    // bar's last ("… mm and more").
    var top = niceCeil(Math.min(Math.max(Math.max.apply(null, finite.concat([0])), 1.25 * thr), 3 * thr));
    var pos = [], colr = [], hollow = [], above = 0;
    l.points.forEach(function (p) {
      if (p[3] === null) { hollow.push(p[0], p[1], p[2]); return; }
      var c = sigmaColour(p[3], thr, top);
      if (p[3] >= thr) { above++; }
      pos.push(p[0], p[1], p[2]);
      colr.push(c[0], c[1], c[2]);
    });
    if (pos.length) {
      var g = new T.BufferGeometry();
      g.setAttribute('position', new T.Float32BufferAttribute(pos, 3));
      g.setAttribute('color', new T.Float32BufferAttribute(colr, 3));
      content.add(new T.Points(g, new T.PointsMaterial({ size: 11, sizeAttenuation: false, vertexColors: true, map: disc, alphaTest: 0.5 })));
    }
    if (hollow.length) {
      var h = new T.BufferGeometry();
      h.setAttribute('position', new T.Float32BufferAttribute(hollow, 3));
      content.add(new T.Points(h, new T.PointsMaterial({ size: 11, sizeAttenuation: false, color: 0x8a8a8a, map: ring, alphaTest: 0.5 })));
    }
    // The grid's bounding box, faint: depth cue.
    var gl = new T.Vector3(Infinity, Infinity, Infinity), gh = new T.Vector3(-Infinity, -Infinity, -Infinity);
    l.points.forEach(function (p) { var v = new T.Vector3(p[0], p[1], p[2]); gl.min(v); gh.max(v); });
    if (isFinite(gl.x)) {
      var b = [];
      var xs = [gl.x, gh.x], ys = [gl.y, gh.y], zs = [gl.z, gh.z];
      for (var i = 0; i < 2; i++) { for (var j = 0; j < 2; j++) {
        b.push(xs[0], ys[i], zs[j], xs[1], ys[i], zs[j]);
        b.push(xs[i], ys[0], zs[j], xs[i], ys[1], zs[j]);
        b.push(xs[i], ys[j], zs[0], xs[i], ys[j], zs[1]);
      } }
      content.add(segments(b, 0xcccccc));
    }
    var gridCentre = isFinite(gl.x) ? gl.clone().add(gh).multiplyScalar(0.5) : centre;
    // The layout's own cameras (blue) and, where they are in this frame, the rig's (orange).
    var fs = 0.07 * size, blue = [], orange = [], link = [];
    (l.cameras || []).forEach(function (c) {
      var C = new T.Vector3().fromArray(c.world_from_cam.position_mm);
      var a = c.world_from_cam.angles_deg;
      var axes = a ? [0, 1, 2].map(function (j) { return col(rotOpk(a), j); }) : lookAt(C, gridCentre);
      var shape = frustum(C, axes, fs, 0, blue);
      var feed = ({ outward: 'A', inward: 'B', tie: 'C' })[c.from];
      addLabel(c.name + (a ? ' (fixed)' : '') + (feed && !l.rig_in_frame ? ' · σ of ' + feed : ''), C, 'cam', shape[4], shape);
    });
    var rig = {};
    if (l.rig_in_frame) {
      data.cameras.forEach(function (c) {
        var C = new T.Vector3().fromArray(c.world_from_cam.position_mm);
        var R = rotOpk(c.world_from_cam.angles_deg);
        var shape = frustum(C, [0, 1, 2].map(function (j) { return col(R, j); }), fs * 0.8, 0, orange);
        rig[c.name] = C;
        addLabel(({ outward: 'A (outward)', inward: 'B (inward)', tie: 'C (tie)' })[c.name] || c.name, C, 'rig', shape[4], shape);
      });
      [['outward', 'inward'], ['inward', 'tie']].forEach(function (p) {
        if (rig[p[0]] && rig[p[1]]) { link.push(rig[p[0]].x, rig[p[0]].y, rig[p[0]].z, rig[p[1]].x, rig[p[1]].y, rig[p[1]].z); }
      });
    }
    if (blue.length) { content.add(segments(blue, 0x1060c0)); }
    if (orange.length) { content.add(segments(orange, 0xd06000)); }
    if (link.length) { content.add(segments(link, 0xd06000, 0.01 * size)); }
    // Axes at the grid's lower corner.
    var o = isFinite(gl.x) ? gl : lo, al = 0.12 * size;
    // Drawn over everything: they lie on the grid box's edges, with which they would otherwise
    // fight for the same pixels and show as dashes.
    [segments([o.x, o.y, o.z, o.x + al, o.y, o.z], 0xcc0000),
      segments([o.x, o.y, o.z, o.x, o.y + al, o.z], 0x008800),
      segments([o.x, o.y, o.z, o.x, o.y, o.z + al], 0x0000cc)].forEach(function (a) {
      a.material.depthTest = false;
      a.renderOrder = 2;
      content.add(a);
    });
    addLabel('x', new T.Vector3(o.x + al, o.y, o.z), 'axis', o);
    addLabel('y', new T.Vector3(o.x, o.y + al, o.z), 'axis', o);
    addLabel('z', new T.Vector3(o.x, o.y, o.z + al), 'axis', o);
    // Measured markers: trajectories (the same in every layout) and their σ ellipsoids.
    var traj = [];
    data.trajectories.forEach(function (t) {
      var prev = null, first = null;
      t.epochs.forEach(function (p) {
        if (p && prev) { traj.push(prev[0], prev[1], prev[2], p[0], p[1], p[2]); }
        if (p && !first) { first = p; }
        prev = p;
      });
      if (first && data.trajectories.length <= 24) { addLabel(t.marker, new T.Vector3(first[0], first[1], first[2]), 'marker'); }
      (t.ellipsoids || []).forEach(function (e) {
        var m = new T.Matrix4();
        var a = e.semi_axes_mm.map(function (v) { return new T.Vector3(v[0], v[1], v[2]).multiplyScalar(ellScale); });
        m.makeBasis(a[0], a[1], a[2]);
        m.setPosition(e.position_mm[0], e.position_mm[1], e.position_mm[2]);
        var s = new T.Mesh(new T.SphereGeometry(1, 24, 16), new T.MeshLambertMaterial({
          color: e.role === 'reference' ? 0x7030a0 : 0xe02080, transparent: true, opacity: 0.55 }));
        s.applyMatrix4(m);
        content.add(s);
      });
    });
    if (traj.length) { content.add(segments(traj, 0x333333)); }
    status.textContent = l.points.length + ' grid points: ' + (l.points.length - hollow.length / 3) + ' measurable, ' + above + ' of them at or above the threshold of ' + thr + ' mm, ' + (hollow.length / 3) + ' not measurable.' +
      (!l.rig_in_frame && data.cameras.length ? ' The rig\'s cameras A, B and C are not drawn: no camera of this layout that takes its σ from one of them stands where the rig places that camera, so the rig\'s frame is not known to be this grid\'s frame.' : '');
    legendBar(thr, top);
    body.setAttribute('data-v3d-layout', l.name);
    render();
  }

  function legendBar(thr, top) {
    var bar = document.getElementById('v3d-bar');
    var stops = [];
    for (var i = 0; i <= 20; i++) {
      var s = top * i / 20;
      stops.push(css(sigmaColour(Math.min(s, top), thr, top)) + ' ' + (100 * i / 20).toFixed(1) + '%');
    }
    // A hard break at the threshold.
    var f = 100 * thr / top;
    stops.push(css(sigmaColour(thr * 0.999, thr, top)) + ' ' + f.toFixed(2) + '%');
    stops.push(css(sigmaColour(thr, thr, top)) + ' ' + f.toFixed(2) + '%');
    stops.sort(function (a, b) { return parseFloat(a.split(' ').pop()) - parseFloat(b.split(' ').pop()); });
    bar.style.background = 'linear-gradient(to right,' + stops.join(',') + ')';
    var tick = document.getElementById('v3d-thr');
    tick.style.left = f + '%';
    // The threshold's label centred under its mark, but kept within the bar near either end.
    var text = document.getElementById('v3d-thr-text');
    text.textContent = 'threshold ' + thr + ' mm';
    text.style.left = f < 15 ? '-3px' : (f > 85 ? 'auto' : '');
    text.style.right = f > 85 ? '0' : '';
    text.style.textAlign = f < 15 ? 'left' : (f > 85 ? 'right' : '');
    document.getElementById('v3d-top').textContent = top + ' mm and more';
  }

  function resize() {
    var w = canvasBox.clientWidth, h = canvasBox.clientHeight;
    if (w < 10 || h < 10) { return; }
    renderer.setSize(w, h, true);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }
  var v = new T.Vector3();
  function screen(p, W, H) {
    v.copy(p).project(camera);
    return { x: (v.x + 1) / 2 * W, y: (1 - v.y) / 2 * H, z: v.z };
  }
  function hits(a, list) {
    for (var i = 0; i < list.length; i++) {
      var b = list[i];
      if (a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]) { return true; }
    }
    return false;
  }
  // The labels, placed so that none covers another: by rank (rig, cameras, axes, markers), each
  // at the first free place of a few around its point (on the side away from its pyramid or
  // axis first), keeping clear of the other labels, the other labelled points and, where it can,
  // the other cameras' pyramids; farther out with a leader line; hidden (and counted under the
  // view) when no place is free.
  function placeLabels() {
    var W = canvasBox.clientWidth, H = canvasBox.clientHeight;
    var taken = [], pyramids = [], lines = [], shown = 0, hidden = 0;
    labelList.forEach(function (L) {
      var s = screen(L.pos, W, H);
      L.x = s.x; L.y = s.y; L.depth = s.z;
      L.vis = s.z < 1 && s.x >= -0.025 * W && s.x <= 1.025 * W && s.y >= -0.025 * H && s.y <= 1.025 * H;
      L.box = null;
      if (L.vis) { taken.push([L.x - 4, L.y - 4, L.x + 4, L.y + 4]); }
      if (L.vis && L.shape.length) {
        var b = [L.x, L.y, L.x, L.y];
        L.shape.forEach(function (p) {
          var q = screen(p, W, H);
          b = [Math.min(b[0], q.x), Math.min(b[1], q.y), Math.max(b[2], q.x), Math.max(b[3], q.y)];
        });
        pyramids.push({ owner: L, box: b });
      }
    });
    var order = labelList.slice().sort(function (a, b) { return a.rank - b.rank || a.depth - b.depth; });
    order.forEach(function (L) {
      if (!L.vis) { L.el.style.display = 'none'; return; }
      L.el.style.display = '';
      if (!L.w) { L.w = L.el.offsetWidth; L.h = L.el.offsetHeight; }
      var w = L.w, h = L.h, ax = 1, ay = 0;
      if (L.away) {
        var a = screen(L.away, W, H), dx = L.x - a.x, dy = L.y - a.y, n = Math.hypot(dx, dy);
        if (n > 1) { ax = dx / n; ay = dy / n; }
      }
      var others = pyramids.filter(function (p) { return p.owner !== L; }).map(function (p) { return p.box; });
      var pick = null;
      [[8, others], [8, []], [34, others], [34, []]].some(function (tier) {
        var r = tier[0];
        // Around the point at distance r: east, north-east, … (screen y down), the one
        // pointing away from `away` first.
        var d = 0.7 * r, spots = [
          [1, 0, r, -h / 2], [0.7, -0.7, d, -h - d], [0, -1, -w / 2, -h - r], [-0.7, -0.7, -w - d, -h - d],
          [-1, 0, -w - r, -h / 2], [-0.7, 0.7, -w - d, d], [0, 1, -w / 2, r], [0.7, 0.7, d, d]
        ];
        spots.sort(function (p, q) { return (q[0] * ax + q[1] * ay) - (p[0] * ax + p[1] * ay); });
        return spots.some(function (sp) {
          var x = Math.round(L.x + sp[2]), y = Math.round(L.y + sp[3]);
          var box = [x - 1, y - 1, x + w + 1, y + h + 1];
          if (x < 0 || y < 0 || x + w > W || y + h > H || hits(box, taken) || hits(box, tier[1])) { return false; }
          pick = { box: box, x: x, y: y, far: r > 8 };
          return true;
        });
      });
      if (!pick) { L.el.style.display = 'none'; hidden++; return; }
      taken.push(pick.box);
      shown++;
      L.box = pick.box;
      L.el.style.transform = 'translate(' + pick.x + 'px,' + pick.y + 'px)';
      if (pick.far) {
        var ex = Math.min(Math.max(L.x, pick.x), pick.x + w), ey = Math.min(Math.max(L.y, pick.y), pick.y + h);
        lines.push('M' + L.x.toFixed(1) + ' ' + L.y.toFixed(1) + 'L' + ex.toFixed(1) + ' ' + ey.toFixed(1));
      }
    });
    leaders.setAttribute('viewBox', '0 0 ' + W + ' ' + H);
    leaderPath.setAttribute('d', lines.join(''));
    hiddenNote.textContent = hidden ? hidden + (hidden === 1 ? ' label' : ' labels') + ' hidden where ' + (hidden === 1 ? 'it' : 'they') + ' would cover another: rotate or zoom to see ' + (hidden === 1 ? 'it' : 'them') + '.' : '';
    body.setAttribute('data-v3d-labels', shown + '/' + (shown + hidden));
  }
  function render() {
    resize();
    renderer.render(scene, camera);
    placeLabels();
  }
  // The opening view: from the front left, above, at the distance at which every grid point,
  // camera and marker of every layout (and the cameras' pyramids) fits in the canvas with a
  // margin, whatever its aspect.
  var fitPoints = [];
  data.layouts.forEach(function (l) {
    l.points.forEach(function (p) { fitPoints.push(new T.Vector3(p[0], p[1], p[2])); });
    (l.cameras || []).forEach(function (c) { fitPoints.push(new T.Vector3().fromArray(c.world_from_cam.position_mm)); });
    if (l.rig_in_frame) {
      data.cameras.forEach(function (c) { fitPoints.push(new T.Vector3().fromArray(c.world_from_cam.position_mm)); });
    }
  });
  data.trajectories.forEach(function (t) {
    t.epochs.forEach(function (p) { if (p) { fitPoints.push(new T.Vector3(p[0], p[1], p[2])); } });
  });
  function home() {
    resize();
    var dir = new T.Vector3(-0.55, -0.75, 0.55).normalize();
    var right = new T.Vector3().crossVectors(dir, new T.Vector3(0, 0, 1)).normalize().negate();
    var up = new T.Vector3().crossVectors(right, dir).negate();
    var tv = Math.tan(camera.fov * Math.PI / 360), th = tv * camera.aspect, m = 0.95, pad = 0.05 * size;
    // A point p (relative to the centre) is in the picture when its distance along the view
    // axis, d − p·dir, is at least |p·right| / (th·m) and |p·up| / (tv·m).
    var d = 0.45 * size / tv, rel = new T.Vector3(), target = centre.clone();
    // Twice: the distance for the points around the target, then the target moved to the middle
    // of what that picture shows, so that the margins left and right (above and below) are equal.
    for (var pass = 0; pass < 2 && fitPoints.length; pass++) {
      d = 0;
      fitPoints.forEach(function (p) {
        rel.subVectors(p, target);
        var a = rel.dot(dir);
        d = Math.max(d, a + (Math.abs(rel.dot(right)) + pad) / (th * m), a + (Math.abs(rel.dot(up)) + pad) / (tv * m));
      });
      var x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
      fitPoints.forEach(function (p) {
        rel.subVectors(p, target);
        var z = d - rel.dot(dir), x = rel.dot(right) / z, y = rel.dot(up) / z;
        x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y);
      });
      if (pass === 0) { target.addScaledVector(right, d * (x0 + x1) / 2).addScaledVector(up, d * (y0 + y1) / 2); }
    }
    camera.position.copy(target).addScaledVector(dir, d);
    controls.target.copy(target);
    camera.near = d / 100;
    camera.far = d * 100;
    camera.updateProjectionMatrix();
    controls.update();
  }
  if (location.hash === '#v3d-shot') {
    // The section alone (the screenshots of `cargo xtask report-check`).
    Array.prototype.forEach.call(body.children, function (c) {
      if (!c.contains(root) && c.tagName !== 'SCRIPT') { c.style.display = 'none'; }
    });
  }
  controls.addEventListener('change', render);
  window.addEventListener('resize', render);
  var sec = root.closest('details');
  if (sec) { sec.addEventListener('toggle', render); }
  data.layouts.forEach(function (l, k) {
    var o = document.createElement('option');
    o.value = String(k);
    o.textContent = l.name;
    select.appendChild(o);
  });
  select.addEventListener('change', function () { showLayout(Number(select.value)); });
  document.getElementById('v3d-home').addEventListener('click', function () { home(); render(); });
  document.getElementById('v3d-scale').textContent = '×' + ellScale;
  home();
  showLayout(0);
  body.setAttribute('data-v3d', 'webgl');

  // ---- what the browser check reads ---------------------------------------------------
  function pixels() {
    render();
    var g = renderer.getContext(), w = g.drawingBufferWidth, h = g.drawingBufferHeight;
    var px = new Uint8Array(w * h * 4);
    g.readPixels(0, 0, w, h, g.RGBA, g.UNSIGNED_BYTE, px);
    return px;
  }
  function drawn(px) {
    var n = 0;
    for (var i = 0; i < px.length; i += 4) { if (px[i] < 250 || px[i + 1] < 250 || px[i + 2] < 250) { n++; } }
    return n;
  }
  // Pairs of shown labels that overlap on screen, and labels not wholly inside the canvas.
  function labelFaults() {
    var c = canvasBox.getBoundingClientRect(), n = 0;
    var r = labelList.filter(function (L) { return L.el.style.display !== 'none'; }).map(function (L) { return L.el.getBoundingClientRect(); });
    r.forEach(function (a, i) {
      if (a.left < c.left - 0.5 || a.top < c.top - 0.5 || a.right > c.right + 0.5 || a.bottom > c.bottom + 0.5) { n++; }
      for (var j = i + 1; j < r.length; j++) {
        var b = r[j];
        if (a.left < b.right && b.left < a.right && a.top < b.bottom && b.top < a.bottom) { n++; }
      }
    });
    return n;
  }
  function camLabelsHidden() {
    return labelList.filter(function (L) { return L.rank <= RANK.cam && L.vis && L.el.style.display === 'none'; }).length;
  }
  function differ(a, b) {
    var n = 0;
    for (var i = 0; i < a.length; i += 4) { if (a[i] !== b[i] || a[i + 1] !== b[i + 1] || a[i + 2] !== b[i + 2]) { n++; } }
    return n;
  }
  var before = pixels();
  // Navigation start to the first picture drawn (readPixels waits for it), by the page's clock.
  body.setAttribute('data-v3d-ms', String(Math.round(performance.now())));
  var gl0 = renderer.getContext();
  body.setAttribute('data-v3d-canvas-w', String(gl0.drawingBufferWidth));
  body.setAttribute('data-v3d-canvas-h', String(gl0.drawingBufferHeight));
  body.setAttribute('data-v3d-drawn', String(drawn(before)));
  if (location.hash === '#v3d-selftest') {
    // A left-button drag across the canvas, as a user does it (pointer id 1 is the mouse's).
    var el = renderer.domElement, r = el.getBoundingClientRect();
    var x0 = r.left + r.width / 2, y0 = r.top + r.height / 2;
    var ev = function (type, x, y, buttons) {
      el.dispatchEvent(new PointerEvent(type, { pointerId: 1, pointerType: 'mouse', isPrimary: true, button: 0, buttons: buttons, clientX: x, clientY: y, bubbles: true, cancelable: true, composed: true }));
    };
    ev('pointerdown', x0, y0, 1);
    for (var s = 1; s <= 10; s++) { ev('pointermove', x0 + 12 * s, y0 + 3 * s, 1); }
    ev('pointerup', x0 + 120, y0 + 30, 0);
    var rotated = pixels();
    var faults = labelFaults();
    body.setAttribute('data-v3d-rotated', String(differ(before, rotated)));
    body.setAttribute('data-v3d-layouts', String(data.layouts.length));
    if (data.layouts.length > 1) {
      select.value = '1';
      select.dispatchEvent(new Event('change'));
      body.setAttribute('data-v3d-switched', String(differ(rotated, pixels())));
      faults += labelFaults();
    }
    // Every layout as it opens (Reset view): no two labels overlap, none sticks out of the
    // canvas, every camera's label is shown.
    var camHidden = 0, shownLabels = [];
    data.layouts.forEach(function (l, k) {
      select.value = String(k);
      select.dispatchEvent(new Event('change'));
      home();
      render();
      faults += labelFaults();
      camHidden += camLabelsHidden();
      shownLabels.push(body.getAttribute('data-v3d-labels'));
    });
    body.setAttribute('data-v3d-label-faults', String(faults));
    body.setAttribute('data-v3d-cam-labels-hidden', String(camHidden));
    body.setAttribute('data-v3d-labels-per-layout', shownLabels.join(' '));
    body.setAttribute('data-v3d-selftest', 'done');
  }
}
