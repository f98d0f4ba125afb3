// springbok's 3D viewer: the robot drawn from its model's collision shapes, the ground, the
// feet's ground forces as arrows, the template's rest points and where the template is, and
// the wrist's measured force. Two sources, one schema (the telemetry's field names,
// firmware/app/include/springbok/app/telemetry.hpp):
//   replay  window.SPRINGBOK_RUN = {title, t: [s...], series: {field: [values...]}}
//           (springbok-view writes it from a springbok-sim log.csv or a flight-recorder file)
//   live    window.SPRINGBOK_LIVE = {path}: one telemetry JSON object per WebSocket message
// window.SPRINGBOK_ROBOT is the compiled model (springbok-view's robot_json): bodies moved by
// joints about their joint frame's axis, collision primitives and frames in body frames.
//
// The page's URL hash: #t=SECONDS seeks there and pauses; #play plays from the start.
// After every drawn frame that is paused, <pre id="readback"> holds what the scene shows: the
// time, the base's position and each joint's angle read back from the scene graph (the
// browser test compares them with log.csv).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const robot = window.SPRINGBOK_ROBOT;
const run = window.SPRINGBOK_RUN || null;
const liveConfig = window.SPRINGBOK_LIVE || null;

const kFeet = ['lf', 'rf', 'lh', 'rh'];
const kForceScale_m_per_n = 1.0e-3;      // feet: 1 m of arrow per 1000 N
const kWristScale_m_per_n = 1.0e-2;      // wrist: 1 m of arrow per 100 N
const kSpeeds = [0.1, 0.25, 0.5, 1, 2, 4];

// ---- page -------------------------------------------------------------------------------
document.title = `springbok · ${run ? run.title : 'live'} · ${robot.name}`;
const style = document.createElement('style');
style.textContent = `
  html, body { margin: 0; height: 100%; overflow: hidden; font: 13px system-ui, sans-serif; }
  #hud { position: absolute; left: 8px; top: 8px; right: 8px; display: flex; gap: 8px;
         align-items: center; background: rgba(255,255,255,0.85); padding: 6px 8px; border-radius: 4px; }
  #hud input[type=range] { flex: 1; }
  #legend { position: absolute; left: 8px; bottom: 8px; background: rgba(255,255,255,0.85);
            padding: 6px 8px; border-radius: 4px; line-height: 1.5; }
  .swatch { display: inline-block; width: 10px; height: 10px; margin-right: 4px; }
  #readback { display: none; }`;
document.head.appendChild(style);
const hud = document.createElement('div');
hud.id = 'hud';
hud.innerHTML = `<b id="title"></b>
  <button id="play">play</button>
  <input id="seek" type="range" min="0" max="1" step="0.001" value="0">
  <span id="time">0.000 s</span>
  <select id="speed">${kSpeeds.map((s) => `<option value="${s}"${s === 1 ? ' selected' : ''}>${s}x</option>`).join('')}</select>
  <span id="fps"></span>`;
document.body.appendChild(hud);
const legend = document.createElement('div');
legend.id = 'legend';
const swatch = (color) => `<span class="swatch" style="background:${color}"></span>`;
legend.innerHTML = [
  `${swatch('#2a9d8f')}feet: the QP's ground forces (1 m = 1000 N)`,
  `${swatch('#e63946')}wrist: measured force F_e (1 m = 100 N)`,
  `${swatch('#8d99ae')}template rest points (base, hand)`,
  `${swatch('#f4a261')}template masses: where the template is`,
].join('<br>');
document.body.appendChild(legend);
const readback = document.createElement('pre');
readback.id = 'readback';
document.body.appendChild(readback);
const $ = (id) => document.getElementById(id);
$('title').textContent = `${robot.name} · ${run ? run.title : 'live'}`;

// ---- scene (z up, as the robot's world) ---------------------------------------------------
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setSize(window.innerWidth, window.innerHeight);
document.body.prepend(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xeef1f5);
const camera = new THREE.PerspectiveCamera(45, window.innerWidth / window.innerHeight, 0.01, 200);
camera.up.set(0, 0, 1);
camera.position.set(1.6, -2.4, 1.3);
const controls = new OrbitControls(camera, renderer.domElement);
controls.target.set(0, 0, 0.4);
scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8a8a, 2.0));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(2, -3, 5);
scene.add(sun);
// The ground: a 40 m square with 0.5 m squares drawn on it (a texture: thin lines drawn as
// lines vanish in some software renderers).
const gridCanvas = document.createElement('canvas');
gridCanvas.width = gridCanvas.height = 128;
{
  const g = gridCanvas.getContext('2d');
  g.fillStyle = '#dde3ea';
  g.fillRect(0, 0, 128, 128);
  g.fillStyle = '#9aa6b2';
  g.fillRect(0, 0, 128, 3);
  g.fillRect(0, 0, 3, 128);
}
const gridTexture = new THREE.CanvasTexture(gridCanvas);
gridTexture.wrapS = gridTexture.wrapT = THREE.RepeatWrapping;
gridTexture.repeat.set(80, 80);
gridTexture.anisotropy = 8;
gridTexture.colorSpace = THREE.SRGBColorSpace;
const ground = new THREE.Mesh(new THREE.PlaneGeometry(40, 40), new THREE.MeshLambertMaterial({ map: gridTexture }));
scene.add(ground);

window.addEventListener('resize', () => {
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(window.innerWidth, window.innerHeight);
  requestRender();
});

// ---- the robot from its model -------------------------------------------------------------
// A transform {rotation: row-major 3x3, translation} as a Matrix4.
function matrixOf(tf) {
  const r = tf.rotation, t = tf.translation;
  return new THREE.Matrix4().set(r[0], r[1], r[2], t[0], r[3], r[4], r[5], t[1], r[6], r[7], r[8], t[2], 0, 0, 0, 1);
}
function fixedChild(parent, tf) {
  const o = new THREE.Object3D();
  o.matrixAutoUpdate = false;
  o.matrix.copy(matrixOf(tf));
  parent.add(o);
  return o;
}

const base = new THREE.Object3D();  // body 0
scene.add(base);
const bodies = [base];
const jointObjects = [];
const armFirst = robot.arm_first_joint;
robot.joints.forEach((joint, i) => {
  const origin = fixedChild(bodies[joint.parent_body], joint.origin);
  const moving = new THREE.Object3D();
  moving.userData.axis = new THREE.Vector3(...joint.axis);
  origin.add(moving);
  bodies.push(moving);
  jointObjects.push(moving);
});
const materials = {
  base: new THREE.MeshStandardMaterial({ color: 0x41648c, roughness: 0.6 }),
  leg: new THREE.MeshStandardMaterial({ color: 0x3d4450, roughness: 0.6 }),
  arm: new THREE.MeshStandardMaterial({ color: 0xb0b7c0, roughness: 0.4 }),
  foot: new THREE.MeshStandardMaterial({ color: 0x1d1f22, roughness: 0.8 }),
};
function materialOf(body) {
  if (body === 0) return materials.base;
  return body - 1 >= armFirst ? materials.arm : materials.leg;
}
for (const c of robot.collisions) {
  let geometry;
  if (c.shape === 'box') geometry = new THREE.BoxGeometry(c.size[0], c.size[1], c.size[2]);
  else if (c.shape === 'cylinder') geometry = new THREE.CylinderGeometry(c.size[0], c.size[0], c.size[1], 24).rotateX(Math.PI / 2);
  else geometry = new THREE.SphereGeometry(c.size[0], 20, 12);
  const holder = fixedChild(bodies[c.body], c.origin);
  holder.add(new THREE.Mesh(geometry, c.shape === 'sphere' ? materials.foot : materialOf(c.body)));
}
const feet = robot.feet.frames.map((f) => fixedChild(bodies[f.body], f.placement));
const hand = fixedChild(bodies[robot.hand.body], robot.hand.placement);

// ---- overlays -----------------------------------------------------------------------------
const footArrows = kFeet.map(() => {
  const a = new THREE.ArrowHelper(new THREE.Vector3(0, 0, 1), new THREE.Vector3(), 0.1, 0x2a9d8f, 0.06, 0.035);
  scene.add(a);
  return a;
});
const wristArrow = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 0.1, 0xe63946, 0.06, 0.035);
scene.add(wristArrow);
function marker(color, radius, wire) {
  const m = new THREE.Mesh(new THREE.SphereGeometry(radius, 16, 10),
                           new THREE.MeshBasicMaterial({ color, wireframe: wire, transparent: true, opacity: 0.85 }));
  scene.add(m);
  return m;
}
const markers = {
  baseRest: marker(0x8d99ae, 0.035, true),
  handRest: marker(0x8d99ae, 0.025, true),
  baseTemplate: marker(0xf4a261, 0.025, false),
  handTemplate: marker(0xf4a261, 0.018, false),
};

// ---- one frame of the schema onto the scene ------------------------------------------------
const tmp = new THREE.Vector3();
function setArrow(arrow, origin, force, scale) {
  const n = Math.hypot(force[0], force[1], force[2]);
  arrow.visible = n * scale > 0.005;
  if (!arrow.visible) return;
  arrow.position.copy(origin);
  arrow.setDirection(tmp.set(force[0] / n, force[1] / n, force[2] / n));
  const length = n * scale;
  arrow.setLength(length, Math.min(0.08, 0.3 * length), Math.min(0.045, 0.18 * length));
}
function setMarker(m, v) {
  m.visible = v.every(Number.isFinite) && (v[0] !== 0 || v[1] !== 0 || v[2] !== 0);
  if (m.visible) m.position.set(v[0], v[1], v[2]);
}
const add3 = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];

function show(get) {
  base.position.set(get('base_x_m'), get('base_y_m'), get('base_z_m'));
  base.quaternion.set(get('base_qx'), get('base_qy'), get('base_qz'), get('base_qw')).normalize();
  robot.joints.forEach((joint, i) => {
    const o = jointObjects[i];
    o.quaternion.setFromAxisAngle(o.userData.axis, get(`q_${joint.name}_rad`));
  });
  scene.updateMatrixWorld(true);
  const world = new THREE.Vector3();
  kFeet.forEach((f, i) => {
    feet[i].getWorldPosition(world);
    setArrow(footArrows[i], world, [get(`${f}_force_x_n`), get(`${f}_force_y_n`), get(`${f}_force_z_n`)], kForceScale_m_per_n);
  });
  hand.getWorldPosition(world);
  setArrow(wristArrow, world, [get('fe_x_n'), get('fe_y_n'), get('fe_z_n')], kWristScale_m_per_n);
  const triple = (name, unit) => ['x', 'y', 'z'].map((a) => get(`${name}_${a}_${unit}`));
  const baseRest = triple('base_rest', 'm'), handRest = triple('hand_rest', 'm');
  setMarker(markers.baseRest, baseRest);
  setMarker(markers.handRest, handRest);
  setMarker(markers.baseTemplate, add3(baseRest, triple('base_displacement', 'm')));
  setMarker(markers.handTemplate, add3(handRest, triple('hand_displacement', 'm')));
}

// What the scene shows, read back from it: the base's pose and each joint's angle about its axis.
function writeReadback(timeS, index) {
  const joints = {};
  robot.joints.forEach((joint, i) => {
    const o = jointObjects[i], q = o.quaternion, a = o.userData.axis;
    joints[joint.name] = 2 * Math.atan2(q.x * a.x + q.y * a.y + q.z * a.z, q.w);
  });
  readback.textContent = JSON.stringify({
    time_s: timeS, index, base: [base.position.x, base.position.y, base.position.z], joints,
  });
}

// ---- the camera follows the base -----------------------------------------------------------
const lastTarget = new THREE.Vector3();
let cameraPlaced = false;
function follow() {
  const target = tmp.set(base.position.x, base.position.y, Math.max(0.2, base.position.z * 0.8));
  if (!cameraPlaced) {
    controls.target.copy(target);
    camera.position.copy(target).add(new THREE.Vector3(1.6, -2.4, 0.9));
    cameraPlaced = true;
  } else {
    camera.position.add(lastTarget.clone().subVectors(target, controls.target));
    controls.target.copy(target);
  }
  lastTarget.copy(target);
  controls.update();
}

// ---- rendering and time ---------------------------------------------------------------------
let frame = () => {};  // draws one frame: the replay's or the live view's (below)
let renderQueued = false;
function requestRender() {
  if (renderQueued) return;
  renderQueued = true;
  requestAnimationFrame(frame);
}
controls.addEventListener('change', requestRender);

let frames = 0, fpsSince = performance.now();
function countFrame(now) {
  ++frames;
  if (now - fpsSince >= 1000) {
    $('fps').textContent = `${(frames * 1000 / (now - fpsSince)).toFixed(0)} fps`;
    window.springbokFps = frames * 1000 / (now - fpsSince);
    frames = 0;
    fpsSince = now;
  }
}

if (run) {
  const t = run.t, n = t.length;
  const duration = n > 0 ? t[n - 1] - t[0] : 0;
  const series = run.series;
  let index = 0, playing = false, speed = 1, playTime = t[0], lastNow = null;
  const seek = $('seek');
  seek.max = String(duration);
  // The last sample at or before `time`.
  const indexAt = (time) => {
    let lo = 0, hi = n - 1;
    if (time <= t[0]) return 0;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (t[mid] <= time + 1e-9) lo = mid; else hi = mid - 1;
    }
    return lo;
  };
  const draw = () => {
    const i = index;
    show((name) => (series[name] ? series[name][i] : 0));
    follow();
    $('time').textContent = `${t[i].toFixed(3)} / ${t[n - 1].toFixed(3)} s`;
    seek.value = String(t[i] - t[0]);
    if (!playing) writeReadback(t[i], i);
  };
  const setPlaying = (p) => {
    playing = p;
    $('play').textContent = p ? 'pause' : 'play';
    lastNow = null;
    requestRender();
  };
  window.springbokSeek = (time) => {
    playTime = time;
    index = indexAt(time);
    setPlaying(false);
    draw();
    renderer.render(scene, camera);
  };
  $('play').onclick = () => {
    if (!playing && index === n - 1) playTime = t[0];
    setPlaying(!playing);
  };
  seek.oninput = () => window.springbokSeek(t[0] + Number(seek.value));
  $('speed').onchange = () => { speed = Number($('speed').value); };
  window.addEventListener('keydown', (e) => { if (e.key === ' ') $('play').onclick(); });
  frame = (now) => {
    renderQueued = false;
    if (playing) {
      if (lastNow !== null) playTime += speed * (now - lastNow) / 1000;
      lastNow = now;
      if (playTime >= t[n - 1]) { playTime = t[n - 1]; playing = false; $('play').textContent = 'play'; }
      index = indexAt(playTime);
      requestRender();
    }
    draw();
    renderer.render(scene, camera);
    countFrame(now);
  };
  const hash = new URLSearchParams(location.hash.slice(1));
  if (hash.has('t')) window.springbokSeek(t[0] + Number(hash.get('t')));
  else {
    window.springbokSeek(t[0]);
    if (hash.has('play')) setPlaying(true);
  }
} else {
  // Live: the newest telemetry record is drawn at the screen's rate.
  let latest = null, received = 0, rateSince = performance.now();
  $('play').disabled = true;
  $('seek').disabled = true;
  $('speed').disabled = true;
  const status = (text) => { $('time').textContent = text; };
  const connect = () => {
    const ws = new WebSocket(`ws://${location.host}${liveConfig.path}`);
    let told = false;
    ws.onmessage = (e) => {
      try { latest = JSON.parse(e.data); } catch (err) { return; /* not a record */ }
      ++received;
      if (!told) {  // the first record: drawn now, and the server told (it ends the page's load)
        frame(performance.now());
        ws.send('drawn');
        told = true;
      }
      requestRender();
    };
    ws.onopen = () => status('connected: waiting for telemetry');
    ws.onclose = () => { status('disconnected: retrying'); setTimeout(connect, 1000); };
  };
  connect();
  // The page's load waits for its first record to be drawn (live_server.cpp: /first-record).
  const firstRecord = new Image();
  firstRecord.hidden = true;
  firstRecord.src = '/first-record';
  document.body.appendChild(firstRecord);
  frame = (now) => {
    renderQueued = false;
    if (latest) {
      const record = latest;
      show((name) => (typeof record[name] === 'number' ? record[name] : 0));
      follow();
      if (now - rateSince >= 1000) {
        status(`t = ${record.timestamp.toFixed(3)} s · ${(received * 1000 / (now - rateSince)).toFixed(0)} records/s`);
        received = 0;
        rateSince = now;
      }
      writeReadback(record.timestamp, -1);
    }
    renderer.render(scene, camera);
    countFrame(now);
  };
  requestRender();
}
