// teachcam studio: the page app. Everything it shows is computed by the server (the library's
// pipeline, check and report model); this script draws it. For tests it keeps its counters in
// `window.teachcamStudio` and mirrors the main ones in data attributes.
import * as THREE from "three";
import { OrbitControls } from "three/OrbitControls";

const token = new URLSearchParams(location.search).get("token") || "";
const studio = (window.teachcamStudio = {
  framesDrawn: 0, // live frames drawn on the camera canvases
  fps: 0, // frames drawn in the last second
  lastFrame: null, // the last live frame's header
  sceneRenders: 0, // 3-D renders
  toolVisible: false, // the tool has a pose and projects inside the 3-D view
  toolPixelSeen: false, // a pixel of the tool's colour was read back at its place in the 3-D canvas
  lostMarked: 0, // lost frames marked on the trail
  robot: null, // the last robot check
  armFrame: 0, // the frame of the checked path the arm shows
  reviewDraws: 0, // review figures drawn
  reviewCutoffHz: null,
  reviewSignature: null, // a digest of the plotted review data (changes when the curve does)
  reviewFigures: null, // the review's figure slots last drawn
  status: null, // the last /api/status
  tokenRefused: null, // true when the page was opened without this studio's token
  viewOnly: null, // why nothing is tracked (a recording without a rig), or null
  calibration: null, // the last /api/calibrate
  coverageHistory: [], // cells filled over all cameras, at each poll of a running calibration
  calibrationRenders: 0, // renders of the calibrated rig in 3-D
  frameMs: 0, // smoothed time to draw a live frame on the camera canvases, ms
  renderMs: 0, // smoothed time of a 3-D render, ms
});

const $ = (id) => document.getElementById(id);

function showError(message) {
  $("error").textContent = message || "";
}

async function api(path, options = {}) {
  const headers = { "x-teachcam-token": token };
  if (options.body !== undefined) headers["content-type"] = "application/json";
  const response = await fetch(path, { ...options, headers });
  const text = await response.text();
  let body;
  try {
    body = JSON.parse(text);
  } catch {
    body = { error: text };
  }
  if (!response.ok) throw new Error(body.error || response.statusText);
  return body;
}

function post(path, body) {
  return api(path, { method: "POST", body: JSON.stringify(body ?? {}) });
}

// ---- tabs ----
for (const button of document.querySelectorAll("nav button")) {
  button.addEventListener("click", () => {
    for (const b of document.querySelectorAll("nav button")) b.classList.toggle("active", b === button);
    for (const tab of document.querySelectorAll(".tab")) tab.classList.toggle("active", tab.id === `tab-${button.dataset.tab}`);
    if (button.dataset.tab === "live") resizeScene();
    if (button.dataset.tab === "review") requestReview();
    if (button.dataset.tab === "robot") openRobotTab();
    if (button.dataset.tab === "calibrate") pollCalibration();
    history.replaceState(null, "", `${location.search}#${button.dataset.tab}`);
  });
}
// A link to a tab (`#review`, `#robot`) opens it.
function openTabOfLink() {
  const button = document.querySelector(`nav button[data-tab="${location.hash.slice(1)}"]`);
  if (button) button.click();
}

// ---- cameras ----
const cameraViews = [];

function cameraView(index, camera) {
  let view = cameraViews[index];
  if (view && view.canvas.width === camera.width && view.canvas.height === camera.height) return view;
  if (!view) {
    const card = document.createElement("div");
    card.className = "camera";
    const canvas = document.createElement("canvas");
    const caption = document.createElement("div");
    caption.className = "caption";
    card.append(canvas, caption);
    $("cameras").append(card);
    view = cameraViews[index] = { card, canvas, caption, context: canvas.getContext("2d", { willReadFrequently: true }), image: null };
  }
  view.canvas.width = Math.max(camera.width, 1);
  view.canvas.height = Math.max(camera.height, 1);
  view.canvas.dataset.camera = camera.name;
  view.image = view.context.createImageData(view.canvas.width, view.canvas.height);
  layoutCameras();
  return view;
}

// The camera tiles fill the pane's width and the window's height: as many columns as give
// the largest tiles with every camera above the fold.
function layoutCameras() {
  const box = $("cameras");
  const n = cameraViews.length;
  if (n === 0 || !$("tab-live").classList.contains("active")) return;
  const gap = 8;
  const caption = 22;
  const width = box.clientWidth;
  const height = Math.max(window.innerHeight - box.getBoundingClientRect().top - 12, 120);
  const first = cameraViews[0].canvas;
  const aspect = first.width / Math.max(first.height, 1);
  let best = { columns: 1, tile: 0 };
  for (let columns = 1; columns <= n; columns += 1) {
    const rows = Math.ceil(n / columns);
    const across = (width - gap * (columns - 1)) / columns;
    const down = ((height - gap * (rows - 1)) / rows - caption) * aspect;
    const tile = Math.min(across, down);
    if (tile > best.tile) best = { columns, tile };
  }
  const tile = Math.max(Math.floor(best.tile), 80);
  box.style.gridTemplateColumns = `repeat(${best.columns}, ${tile}px)`;
  studio.cameraColumns = best.columns;
}

// The 3-D view as tall as the window allows (the legend and arm controls below it).
function layoutScene() {
  const top = sceneBox.getBoundingClientRect().top;
  const height = Math.max(Math.min(window.innerHeight - top - 70, 900), 300);
  sceneBox.style.height = `${Math.round(height)}px`;
}

function drawCamera(index, camera, pixels) {
  const view = cameraView(index, camera);
  const { context, image } = view;
  const rgba = image.data;
  for (let i = 0, j = 0; i < pixels.length; i += 1, j += 4) {
    const v = pixels[i];
    rgba[j] = v;
    rgba[j + 1] = v;
    rgba[j + 2] = v;
    rgba[j + 3] = 255;
  }
  context.putImageData(image, 0, 0);
  const s = camera.scale || 1;
  context.lineWidth = 1.5;
  context.strokeStyle = "#3fbf6f";
  for (const [x, y, r] of camera.blobs) {
    context.beginPath();
    // Pixel centres: full-size (x, y) lies at ((x + 0.5) / s) in the preview's coordinates.
    context.arc((x + 0.5) / s, (y + 0.5) / s, Math.max(r / s + 2, 3), 0, 2 * Math.PI);
    context.stroke();
  }
  context.fillStyle = "#ff8800";
  context.font = "11px system-ui, sans-serif";
  placeLabels(context, camera, s);
  let caption = `${camera.name}: ${camera.blobs.length} blobs, ${camera.labels.length} labelled`;
  const m = camera.measured;
  if (m) {
    // A view-only studio: what the detector measured of this frame, and its limits.
    const radii = camera.blobs.map((b) => b[2]);
    const sizes = radii.length ? `, radius ${Math.min(...radii).toFixed(1)}–${Math.max(...radii).toFixed(1)} px` : "";
    caption = `${camera.name} (${camera.image_width}×${camera.image_height}): ${camera.blobs.length} blobs${sizes}; background ${m.background.toFixed(1)}, noise σ ${m.noise_std.toFixed(2)}, threshold ${m.threshold}${m.threshold === m.auto_threshold ? " (auto)" : ` (auto ${m.auto_threshold})`} of ${m.full_scale}; blobs kept from ${m.min_area_px} to ${m.max_area_px} px², roundness ≥ ${m.min_roundness}`;
    view.card.dataset.threshold = m.threshold;
  }
  view.caption.textContent = caption;
  view.card.dataset.blobs = camera.blobs.length;
}

// Marker labels placed apart: each takes the first spot around its blob (8 directions, then
// farther) that overlaps no label placed before it and no blob; a thin line joins a label
// moved away to its blob.
const LABEL_SPOTS = [];
for (const distance of [7, 14, 22]) {
  for (const [dx, dy] of [[1, -1], [1, 1], [-1, -1], [-1, 1], [1, 0], [-1, 0], [0, -1], [0, 1]]) LABEL_SPOTS.push([dx * distance, dy * distance, distance]);
}

function placeLabels(context, camera, s) {
  const taken = camera.blobs.map(([x, y, r]) => {
    const radius = Math.max(r / s + 2, 3);
    return { x0: (x + 0.5) / s - radius, y0: (y + 0.5) / s - radius, x1: (x + 0.5) / s + radius, y1: (y + 0.5) / s + radius };
  });
  const overlaps = (a) => taken.some((b) => a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1);
  const height = 11;
  let crowded = 0;
  for (const [x, y, marker] of camera.labels) {
    const text = `m${marker}`;
    const width = context.measureText(text).width;
    const px = (x + 0.5) / s;
    const py = (y + 0.5) / s;
    let chosen = null;
    for (const [dx, dy, distance] of LABEL_SPOTS) {
      const x0 = dx > 0 ? px + dx : dx < 0 ? px + dx - width : px - width / 2;
      const y0 = dy > 0 ? py + dy : dy < 0 ? py + dy - height : py - height / 2;
      const box = { x0, y0, x1: x0 + width, y1: y0 + height, distance };
      if (!overlaps(box)) {
        chosen = box;
        break;
      }
    }
    if (!chosen) {
      crowded += 1;
      chosen = { x0: px + 7, y0: py - 7 - height, x1: px + 7 + width, y1: py - 7, distance: 7 };
    }
    taken.push(chosen);
    if (chosen.distance > 7) {
      context.strokeStyle = "rgba(255,136,0,0.6)";
      context.lineWidth = 1;
      context.beginPath();
      context.moveTo(px, py);
      context.lineTo((chosen.x0 + chosen.x1) / 2, (chosen.y0 + chosen.y1) / 2);
      context.stroke();
    }
    context.fillText(text, chosen.x0, chosen.y1 - 2);
  }
  studio.labelsCrowded = crowded;
}

const drawTimes = [];

function onFrame(buffer) {
  const began = performance.now();
  const length = new DataView(buffer).getUint32(0, true);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  let offset = 4 + length;
  header.cameras.forEach((camera, index) => {
    const size = camera.width * camera.height;
    drawCamera(index, camera, new Uint8Array(buffer, offset, size));
    offset += size;
  });
  updateTool(header);
  // The 3-D view moves with the frames it shows (a browser's animation frames may come slower
  // than the cameras' when it renders in software).
  if (sceneReady && $("tab-live").classList.contains("active")) renderScene();
  else needsRender = true;
  studio.lastFrame = header;
  studio.framesDrawn += 1;
  const now = performance.now();
  drawTimes.push(now);
  while (drawTimes.length && now - drawTimes[0] > 1000) drawTimes.shift();
  studio.fps = drawTimes.length;
  const status = $("pose-status");
  status.textContent = header.status;
  status.dataset.status = header.status;
  status.title = header.reason || "";
  studio.frameMs = 0.9 * studio.frameMs + 0.1 * (performance.now() - began);
}

setInterval(() => {
  const now = performance.now();
  while (drawTimes.length && now - drawTimes[0] > 1000) drawTimes.shift();
  studio.fps = drawTimes.length;
  $("fps").textContent = studio.fps;
  $("fps").dataset.fps = studio.fps;
  $("frames").textContent = studio.framesDrawn;
  $("frames").dataset.frames = studio.framesDrawn;
}, 250);

function connect() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const socket = new WebSocket(`${scheme}://${location.host}/api/live?token=${encodeURIComponent(token)}`);
  socket.binaryType = "arraybuffer";
  socket.onmessage = (event) => onFrame(event.data);
  socket.onclose = () => setTimeout(connect, 1000);
}

// ---- controls ----
$("threshold-auto").addEventListener("change", async () => {
  $("threshold").disabled = $("threshold-auto").checked;
  await setControls({ threshold: $("threshold-auto").checked ? "auto" : Number($("threshold").value) });
});
$("threshold").addEventListener("change", () => setControls({ threshold: Number($("threshold").value) }));
$("exposure").addEventListener("input", () => {
  const unit = studio.status?.exposure?.unit;
  $("exposure-value").textContent = unit === "ms" ? `${$("exposure").value} ms` : `${Number($("exposure").value).toFixed(2)}×`;
});
$("exposure").addEventListener("change", () => setControls({ exposure: Number($("exposure").value) }));

async function setControls(body) {
  try {
    await post("/api/controls", body);
    showError("");
  } catch (error) {
    showError(error.message);
  }
}

// ---- record / stop ----
$("record").addEventListener("click", async () => {
  try {
    if (studio.status?.recording) {
      const done = await post("/api/stop");
      $("record-state").textContent = `wrote ${done.folder}: ${done.frames} frames (${done.dropped} sets dropped), the tracked take as take.mcap (${done.tool_messages} poses, ROS 2)`;
    } else {
      const started = await post("/api/record");
      $("record-state").textContent = `recording into ${started.folder}`;
    }
    showError("");
    await pollStatus();
  } catch (error) {
    showError(error.message);
  }
});

let exposureConfigured = false;

async function pollStatus() {
  try {
    const status = await api("/api/status");
    studio.status = status;
    $("source").textContent = status.source;
    $("server-fps").textContent = status.fps.toFixed(1);
    const record = $("record");
    record.textContent = status.recording ? "■ Stop" : "● Record";
    record.classList.toggle("recording", status.recording);
    if (status.recording) $("record-state").textContent = `recording into ${status.recording_folder}: ${status.recording_frames} frames`;
    showError(status.error || "");
    if (!exposureConfigured) {
      exposureConfigured = true;
      const exposure = status.exposure;
      const slider = $("exposure");
      if (!exposure.supported) {
        slider.disabled = true;
        $("exposure-label").title = exposure.reason;
        $("exposure-value").textContent = "fixed";
      } else if (exposure.unit === "ms") {
        slider.min = 0.1;
        slider.max = 50;
        slider.step = 0.1;
        slider.value = exposure.value ?? 5;
        $("exposure-value").textContent = exposure.value ? `${exposure.value} ms` : "driver's";
      } else {
        slider.value = exposure.value;
      }
    }
  } catch (error) {
    showError(error.message);
  }
}

// ---- 3-D view ----
const sceneBox = $("scene");
// No multisampling: in a software renderer (a headless browser, a machine without a GPU) it
// costs more than the rest of the page.
const renderer = new THREE.WebGLRenderer({ antialias: false });
renderer.setPixelRatio(1);
sceneBox.append(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x0c0e11);
const view3 = new THREE.PerspectiveCamera(45, 1, 1, 100000);
const orbit = new OrbitControls(view3, renderer.domElement);
orbit.enableDamping = false;
// The scene is drawn when something in it changed (a frame, the view, the arm), not at the
// display's rate: a software renderer would otherwise take the CPU the live view needs.
let needsRender = true;
orbit.addEventListener("change", () => {
  needsRender = true;
});
scene.add(new THREE.AmbientLight(0xffffff, 0.6));
const sun = new THREE.DirectionalLight(0xffffff, 0.9);
sun.position.set(1000, 2000, 3000);
scene.add(sun);

const TOOL_COLOUR = 0xff8800;
const tool = new THREE.Group();
tool.visible = false;
scene.add(tool);
const toolMarkers = [];
const TRAIL = 900;
const trailPositions = new Float32Array(3 * TRAIL);
const trailGeometry = new THREE.BufferGeometry();
trailGeometry.setAttribute("position", new THREE.BufferAttribute(trailPositions, 3));
trailGeometry.setDrawRange(0, 0);
const trail = new THREE.Line(trailGeometry, new THREE.LineBasicMaterial({ color: 0x4fc3f7 }));
trail.frustumCulled = false;
scene.add(trail);
let trailCount = 0;
const LOST = 300;
const lostPositions = new Float32Array(3 * LOST);
const lostGeometry = new THREE.BufferGeometry();
lostGeometry.setAttribute("position", new THREE.BufferAttribute(lostPositions, 3));
lostGeometry.setDrawRange(0, 0);
const lost = new THREE.Points(lostGeometry, new THREE.PointsMaterial({ color: 0xe5484d, size: 7, sizeAttenuation: false }));
lost.frustumCulled = false;
scene.add(lost);
let lostCount = 0;
let lastTip = null;
let lastFrameIndex = null;
let framed = false;

function pushRing(positions, count, capacity, point, geometry) {
  if (count < capacity) {
    positions.set(point, 3 * count);
    count += 1;
  } else {
    positions.copyWithin(0, 3);
    positions.set(point, 3 * (capacity - 1));
  }
  geometry.attributes.position.needsUpdate = true;
  geometry.setDrawRange(0, count);
  return count;
}

function updateTool(frame) {
  const restarted = lastFrameIndex !== null && frame.frame < lastFrameIndex;
  lastFrameIndex = frame.frame;
  if (restarted) {
    trailCount = 0;
    trailGeometry.setDrawRange(0, 0);
  }
  if (frame.tool) {
    const [x, y, z] = frame.tool.position_mm;
    const [qw, qx, qy, qz] = frame.tool.quaternion;
    tool.position.set(x, y, z);
    tool.quaternion.set(qx, qy, qz, qw);
    tool.visible = true;
    lastTip = frame.tool.tip_mm;
    trailCount = pushRing(trailPositions, trailCount, TRAIL, lastTip, trailGeometry);
    if (!framed) {
      // The first pose: the cell now holds the tool too.
      framed = true;
      if (!cellBox.containsPoint(new THREE.Vector3(x, y, z))) {
        cellBox.expandByPoint(new THREE.Vector3(x, y, z));
        frameView();
      }
    }
  } else {
    tool.visible = false;
    if (lastTip) {
      lostCount = pushRing(lostPositions, lostCount, LOST, lastTip, lostGeometry);
      studio.lostMarked += 1;
    }
  }
}

let sceneInfo = null;
let sceneReady = false;

// The cell's extent: the cameras, the world origin, and the tool's trail once seen.
const cellBox = new THREE.Box3();

function viewUp() {
  // The rig's mean "up" (cameras' −y): a world with z into the table and one with z up both
  // show the floor below.
  const up = new THREE.Vector3();
  for (const camera of sceneInfo?.cameras ?? []) {
    const r = camera.rotation;
    up.sub(new THREE.Vector3(r[0][1], r[1][1], r[2][1]));
  }
  return up.lengthSq() > 0 ? up.normalize() : new THREE.Vector3(0, 0, 1);
}

function frameView() {
  // The whole cell in view: from beyond the cameras' mean position, far enough back that the
  // cell's bounding sphere fits the narrower field of view.
  const centre = cellBox.getCenter(new THREE.Vector3());
  const radius = Math.max(cellBox.getSize(new THREE.Vector3()).length() / 2, 200);
  const eye = new THREE.Vector3();
  const cameras = sceneInfo?.cameras ?? [];
  for (const camera of cameras) eye.add(new THREE.Vector3(...camera.position_mm));
  if (cameras.length === 0) eye.set(0, -1000, 1000);
  else eye.divideScalar(cameras.length);
  const up = viewUp();
  view3.up.copy(up);
  // From the cameras' side, 35° above the floor: the floor, its grid and the frusta in depth.
  const side = eye.sub(centre);
  side.addScaledVector(up, -side.dot(up));
  if (side.lengthSq() < 1e-6) side.set(1, 0, 0).addScaledVector(up, -up.x);
  side.normalize();
  const elevation = THREE.MathUtils.degToRad(35);
  const direction = side.multiplyScalar(Math.cos(elevation)).addScaledVector(up, Math.sin(elevation));
  const halfFov = THREE.MathUtils.degToRad(view3.fov / 2);
  const narrow = Math.min(halfFov, Math.atan(Math.tan(halfFov) * view3.aspect));
  const distance = (1.05 * radius) / Math.sin(narrow);
  view3.position.copy(centre.clone().add(direction.normalize().multiplyScalar(distance)));
  view3.near = Math.max(distance / 100, 1);
  view3.far = distance * 20;
  view3.updateProjectionMatrix();
  orbit.target.copy(centre);
  orbit.update();
  studio.framedRadiusMm = radius;
  needsRender = true;
}

// The height of the 3-D view's text, mm: readable from the distance the cell is framed at.
function textMm() {
  return Math.max(cellBox.getSize(new THREE.Vector3()).length() / 45, 15);
}

// A text label that faces the viewer, `height` mm tall.
function label(text, height, colour = "#e3e6ea") {
  const canvas = document.createElement("canvas");
  const context = canvas.getContext("2d");
  const font = "bold 48px system-ui, sans-serif";
  context.font = font;
  canvas.width = Math.ceil(context.measureText(text).width) + 16;
  canvas.height = 64;
  context.font = font;
  context.fillStyle = colour;
  context.textBaseline = "middle";
  context.fillText(text, 8, 32);
  const texture = new THREE.CanvasTexture(canvas);
  texture.colorSpace = THREE.SRGBColorSpace;
  const sprite = new THREE.Sprite(new THREE.SpriteMaterial({ map: texture, depthTest: false, transparent: true }));
  sprite.scale.set((height * canvas.width) / canvas.height, height, 1);
  sprite.center.set(0, 0.5);
  sprite.renderOrder = 2;
  return sprite;
}

// Axes of `length` mm with x, y, z and a name at the origin.
function labelledAxes(name, length) {
  const group = new THREE.Group();
  group.add(new THREE.AxesHelper(length));
  const size = textMm();
  for (const [axis, colour, at] of [["x", "#ff5555", [1, 0, 0]], ["y", "#55ff55", [0, 1, 0]], ["z", "#5599ff", [0, 0, 1]]]) {
    const tag = label(axis, size, colour);
    tag.position.set(...at.map((a) => a * length * 1.08));
    group.add(tag);
  }
  const title = label(name, size);
  title.position.set(size / 2, -size, 0);
  group.add(title);
  group.name = name;
  return group;
}

// The floor: a grid in the world's xy plane (the table a rig is calibrated on) with round
// spacing, and a scale bar one cell long with its length written on it.
function addFloor() {
  const size = cellBox.getSize(new THREE.Vector3());
  const centre = cellBox.getCenter(new THREE.Vector3());
  const span = Math.max(size.x, size.y, 500);
  const steps = [10, 20, 50, 100, 200, 250, 500, 1000, 2000, 5000];
  const cell = steps.find((s) => span / s <= 16) ?? 5000;
  const cells = 2 * Math.ceil(span / cell / 2) + 2;
  const grid = new THREE.GridHelper(cells * cell, cells, 0x3a434e, 0x262c34);
  grid.rotation.x = Math.PI / 2; // GridHelper lies in xz; the floor is the world's xy.
  grid.position.set(Math.round(centre.x / cell) * cell, Math.round(centre.y / cell) * cell, 0);
  grid.name = "floor";
  scene.add(grid);
  const half = (cells * cell) / 2;
  const start = new THREE.Vector3(grid.position.x - half + cell, grid.position.y - half + cell / 2, 0);
  const end = start.clone().add(new THREE.Vector3(cell, 0, 0));
  const bar = new THREE.Line(new THREE.BufferGeometry().setFromPoints([start, end]), new THREE.LineBasicMaterial({ color: 0xffffff }));
  bar.name = "scale-bar";
  scene.add(bar);
  const text = cell >= 1000 ? `${cell / 1000} m` : `${cell} mm`;
  const tag = label(text, textMm());
  tag.position.copy(start).add(new THREE.Vector3(0, textMm(), 0));
  scene.add(tag);
  studio.gridCellMm = cell;
  studio.scaleBar = text;
}

const palette = [0x7986cb, 0x4db6ac, 0xffd54f, 0xba68c8, 0x90a4ae, 0xf06292];

// A camera's frustum (as /api/scene and /api/calibrate give cameras): lines from its centre
// to the corners of its image at the depth of the world origin along its axis (the working
// volume), at least 200 mm.
function cameraFrustum(camera, colour) {
  const r = camera.rotation;
  const position = new THREE.Vector3(...camera.position_mm);
  const axis = new THREE.Vector3(r[0][2], r[1][2], r[2][2]);
  const depth = Math.max(-position.dot(axis), 200);
  const corner = (u, v) => {
    const x = ((u - camera.cx) / camera.fx) * depth;
    const y = ((v - camera.cy) / camera.fy) * depth;
    const z = depth;
    return new THREE.Vector3(
      r[0][0] * x + r[0][1] * y + r[0][2] * z,
      r[1][0] * x + r[1][1] * y + r[1][2] * z,
      r[2][0] * x + r[2][1] * y + r[2][2] * z,
    ).add(position);
  };
  const corners = [corner(0, 0), corner(camera.width, 0), corner(camera.width, camera.height), corner(0, camera.height)];
  const points = [];
  for (let k = 0; k < 4; k += 1) points.push(position, corners[k], corners[k], corners[(k + 1) % 4]);
  const frustum = new THREE.LineSegments(new THREE.BufferGeometry().setFromPoints(points), new THREE.LineBasicMaterial({ color: colour }));
  frustum.name = camera.name;
  return { frustum, position, corners };
}

async function loadScene() {
  sceneInfo = await api("/api/scene");
  if (sceneInfo.view_only) {
    // No rig: the cameras' frames and detections only.
    studio.viewOnly = sceneInfo.view_only;
    document.body.classList.add("view-only");
    $("view-only").textContent = `View only: ${sceneInfo.view_only}`;
    $("view-only").hidden = false;
    for (const tab of ["review", "robot"]) {
      const button = document.querySelector(`nav button[data-tab="${tab}"]`);
      button.disabled = true;
      button.title = "nothing is tracked without a rig";
    }
    $("record").disabled = true;
    $("record").title = "nothing is tracked without a rig";
    sceneReady = true;
    return;
  }
  cellBox.makeEmpty();
  cellBox.expandByPoint(new THREE.Vector3(0, 0, 0));
  sceneInfo.cameras.forEach((camera, i) => {
    const { frustum, position, corners: c } = cameraFrustum(camera, palette[i % palette.length]);
    scene.add(frustum);
    const name = label(camera.name, 60, `#${palette[i % palette.length].toString(16).padStart(6, "0")}`);
    name.position.copy(position);
    scene.add(name);
    cellBox.expandByPoint(position);
    for (const p of c) cellBox.expandByPoint(p);
  });
  addFloor();
  const axesLength = 2 * studio.gridCellMm;
  scene.add(labelledAxes("world = work object", axesLength));
  const markerMaterial = new THREE.MeshBasicMaterial({ color: TOOL_COLOUR });
  const radius = sceneInfo.tool.marker_diameter_mm / 2;
  const centroid = new THREE.Vector3();
  for (const m of sceneInfo.tool.markers_mm) {
    const sphere = new THREE.Mesh(new THREE.SphereGeometry(radius, 16, 12), markerMaterial);
    sphere.position.set(...m);
    tool.add(sphere);
    toolMarkers.push(sphere);
    centroid.add(sphere.position);
  }
  centroid.divideScalar(Math.max(sceneInfo.tool.markers_mm.length, 1));
  const tip = new THREE.Vector3(...sceneInfo.tool.tip_mm);
  const shaft = new THREE.Line(new THREE.BufferGeometry().setFromPoints([centroid, tip]), new THREE.LineBasicMaterial({ color: 0xffffff }));
  tool.add(shaft);
  for (const m of toolMarkers) tool.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints([m.position, centroid]), new THREE.LineBasicMaterial({ color: TOOL_COLOUR })));
  const tipBall = new THREE.Mesh(new THREE.SphereGeometry(2.5, 12, 8), new THREE.MeshBasicMaterial({ color: 0xffffff }));
  tipBall.position.copy(tip);
  tool.add(tipBall);
  // The markers also as points of a fixed size on screen: seen from the whole cell's distance
  // a 12 mm sphere is a pixel or two.
  const glyphs = new THREE.Points(
    new THREE.BufferGeometry().setFromPoints(sceneInfo.tool.markers_mm.map((m) => new THREE.Vector3(...m))),
    new THREE.PointsMaterial({ color: TOOL_COLOUR, size: 6, sizeAttenuation: false }),
  );
  tool.add(glyphs);
  frameView();
  sceneReady = true;
}

function resizeScene() {
  layoutScene();
  layoutCameras();
  const width = sceneBox.clientWidth || 640;
  const height = sceneBox.clientHeight || 480;
  renderer.setSize(width, height, false);
  renderer.domElement.style.width = "100%";
  renderer.domElement.style.height = "100%";
  view3.aspect = width / height;
  view3.updateProjectionMatrix();
  needsRender = true;
}
window.addEventListener("resize", resizeScene);

const probe = new Uint8Array(4 * 25);

function checkToolOnScreen() {
  // Is the tool inside the view, and is its colour in the canvas where it projects?
  if (!tool.visible || toolMarkers.length === 0) {
    studio.toolVisible = false;
    sceneBox.dataset.toolVisible = "false";
    return;
  }
  const canvas = renderer.domElement;
  let seen = false;
  let inside = false;
  const gl = renderer.getContext();
  for (const marker of toolMarkers) {
    const p = marker.getWorldPosition(new THREE.Vector3()).project(view3);
    if (Math.abs(p.x) > 1 || Math.abs(p.y) > 1 || p.z > 1) continue;
    inside = true;
    const px = Math.round(((p.x + 1) / 2) * canvas.width);
    const py = Math.round(((p.y + 1) / 2) * canvas.height);
    gl.readPixels(px - 2, py - 2, 5, 5, gl.RGBA, gl.UNSIGNED_BYTE, probe);
    for (let k = 0; k < 25; k += 1) {
      const [r, g, b] = [probe[4 * k], probe[4 * k + 1], probe[4 * k + 2]];
      if (r > 200 && g > 90 && g < 180 && b < 70) seen = true;
    }
  }
  studio.toolVisible = inside;
  studio.toolPixelSeen = studio.toolPixelSeen || seen;
  sceneBox.dataset.toolVisible = String(inside);
  sceneBox.dataset.toolPixelSeen = String(studio.toolPixelSeen);
}

// ---- the robot arm ----
const arm = new THREE.Group();
arm.visible = false;
scene.add(arm);
const armMaterial = new THREE.MeshLambertMaterial({ color: 0xb0bec5 });
const jointMaterial = new THREE.MeshLambertMaterial({ color: 0x546e7a });
const armLinks = [];
const armJoints = [];
const armPath = new THREE.Line(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ color: 0x81c784 }));
arm.add(armPath);
let armPlaying = false;
let armPlayStart = 0;

function showRobot(result) {
  studio.robot = result;
  const frames = result.path.filter((f) => f.links_mm);
  const [px, py, pz] = result.wobj_frame.position_mm;
  const [qw, qx, qy, qz] = result.wobj_frame.quaternion;
  // The arm's points are in its base; the scene is the work object's frame: wobj_from_base.
  const baseFromWobj = new THREE.Matrix4().compose(new THREE.Vector3(px, py, pz), new THREE.Quaternion(qx, qy, qz, qw), new THREE.Vector3(1, 1, 1));
  arm.matrixAutoUpdate = false;
  arm.matrix.copy(baseFromWobj.clone().invert());
  arm.matrixWorldNeedsUpdate = true;
  if (armLinks.length === 0) {
    arm.add(labelledAxes("robot base", 2 * (studio.gridCellMm || 100)));
    // The first arm shown: the cell now holds its base too.
    const base = new THREE.Vector3().applyMatrix4(arm.matrix);
    if (!cellBox.containsPoint(base)) {
      cellBox.expandByPoint(base);
      frameView();
    }
    for (let k = 0; k < 6; k += 1) {
      const link = new THREE.Mesh(new THREE.CylinderGeometry(18, 18, 1, 12), armMaterial);
      arm.add(link);
      armLinks.push(link);
    }
    for (let k = 0; k < 7; k += 1) {
      const joint = new THREE.Mesh(new THREE.SphereGeometry(24, 16, 12), jointMaterial);
      arm.add(joint);
      armJoints.push(joint);
    }
  }
  armPath.geometry.setFromPoints(result.path.map((f) => new THREE.Vector3(...f.tcp_mm)));
  const scrub = $("arm-scrub");
  scrub.max = Math.max(frames.length - 1, 0);
  scrub.value = 0;
  $("arm-controls").hidden = frames.length === 0;
  arm.visible = frames.length > 0;
  studio.armFrames = frames;
  showArmFrame(0);
}

function showArmFrame(index) {
  const frames = studio.armFrames || [];
  const frame = frames[index];
  if (!frame) return;
  studio.armFrame = index;
  const points = frame.links_mm.map((p) => new THREE.Vector3(...p));
  points.forEach((p, k) => armJoints[k].position.copy(p));
  const yAxis = new THREE.Vector3(0, 1, 0);
  for (let k = 0; k < 6; k += 1) {
    const a = points[k];
    const b = points[k + 1];
    const d = b.clone().sub(a);
    const length = d.length();
    const link = armLinks[k];
    link.visible = length > 1e-6;
    link.position.copy(a.clone().add(b).multiplyScalar(0.5));
    link.scale.set(1, Math.max(length, 1e-6), 1);
    if (length > 1e-6) link.quaternion.setFromUnitVectors(yAxis, d.normalize());
  }
  $("arm-frame").textContent = `frame ${frame.frame} · t ${frame.time_s.toFixed(2)} s · joints ${frame.joints_deg.map((j) => j.toFixed(1)).join(", ")}°`;
  $("arm-scrub").value = index;
  needsRender = true;
}

$("arm-scrub").addEventListener("input", () => {
  armPlaying = false;
  $("arm-play").textContent = "▶ play";
  showArmFrame(Number($("arm-scrub").value));
});
$("arm-play").addEventListener("click", () => {
  armPlaying = !armPlaying;
  $("arm-play").textContent = armPlaying ? "❚❚ pause" : "▶ play";
  const frames = studio.armFrames || [];
  const at = frames[studio.armFrame]?.time_s ?? 0;
  armPlayStart = performance.now() - 1000 * at;
});

function stepArm() {
  const frames = studio.armFrames || [];
  if (!armPlaying || frames.length === 0) return;
  const end = frames[frames.length - 1].time_s;
  let t = (performance.now() - armPlayStart) / 1000;
  if (t > end) {
    armPlayStart = performance.now();
    t = 0;
  }
  let index = studio.armFrame;
  if (frames[index].time_s > t) index = 0;
  while (index + 1 < frames.length && frames[index + 1].time_s <= t) index += 1;
  if (index !== studio.armFrame) showArmFrame(index);
}

function renderScene() {
  needsRender = false;
  const began = performance.now();
  renderer.render(scene, view3);
  studio.renderMs = 0.9 * studio.renderMs + 0.1 * (performance.now() - began);
  studio.sceneRenders += 1;
  if (studio.sceneRenders % 10 === 0) checkToolOnScreen();
}

function render() {
  stepArm();
  if (needsRender) renderScene();
  requestAnimationFrame(render);
}

// ---- robot tab ----
function robotQuery() {
  const params = new URLSearchParams({
    robot: $("robot-name").value,
    wobj: $("wobj").value.trim(),
    tcp: $("tcp").value.trim(),
    cutoff_hz: $("cutoff").value,
    token,
  });
  // The strokes and span as `teachcam export` takes them (empty: its defaults).
  for (const [name, id] of [["from_s", "span-from"], ["to_s", "span-to"], ["lift_mm", "lift-mm"], ["pause_s", "pause-s"]]) {
    const value = $(id).value.trim();
    if (value) params.set(name, value);
  }
  if ($("free-tool-axis").checked) params.set("free_tool_axis", "true");
  return params.toString();
}

const exportLinks = { rapid: "export-rapid", krl: "export-krl", "krl-dat": "export-krl-dat", urscript: "export-urscript" };
const exportMaker = { rapid: "ABB", krl: "KUKA", "krl-dat": "KUKA", urscript: "Universal Robots" };

function setExports(result) {
  for (const [dialect, id] of Object.entries(exportLinks)) {
    const link = $(id);
    const usable = result && result.passes && result.maker === exportMaker[dialect];
    if (usable) link.href = `/api/export/${dialect}?${robotQuery()}`;
    else link.removeAttribute("href");
    link.classList.toggle("disabled", !usable);
    link.title = usable ? "" : result ? (result.passes ? `for ${exportMaker[dialect]} robots` : "the check fails: no program") : "check first";
  }
}
setExports(null);

async function checkRobot() {
  $("robot-summary").textContent = "checking…";
  try {
    const result = await api(`/api/robot?${robotQuery()}`);
    const verdict = result.passes ? "the robot can run this path" : `${result.failing} of ${result.frames} frames fail (${result.unreachable} out of reach)`;
    $("robot-summary").textContent = `${result.robot}: ${result.frames} frames checked at ${result.cutoff_hz} Hz; ${verdict}; peak joint speed ${(100 * result.peak_speed_ratio).toFixed(0)} % of the limit. ${result.suggestions.map((s) => s.text).join(" ")}`;
    const rows = result.limits.map((l, i) => `<tr><td>axis ${i + 1}</td><td>${l.min_deg.toFixed(1)}</td><td>${l.max_deg.toFixed(1)}</td><td>${l.max_speed_deg_s.toFixed(0)}</td><td>${l.peak_speed_deg_s.toFixed(1)}</td><td class="${l.speed_margin < 0.1 ? "tight" : ""}">${(100 * l.speed_margin).toFixed(0)} %</td></tr>`);
    $("robot-limits").innerHTML = `<tr><th></th><th>min °</th><th>max °</th><th>max °/s</th><th>peak °/s</th><th>speed margin</th></tr>${rows.join("")}`;
    const placement = result.placement || { from: "given", note: "" };
    $("robot-placement").textContent =
      placement.from === "given" ? `work object ${result.wobj} (given)` : `work object ${result.wobj}: ${placement.note}`;
    $("robot-placement").dataset.from = placement.from;
    const strokes = result.strokes.map((st) => `${st.first_frame}-${st.last_frame}`).join(", ");
    $("robot-strokes").textContent = [
      `${result.strokes.length} stroke${result.strokes.length === 1 ? "" : "s"} (frames ${strokes})`,
      result.no_stroke ? `${result.no_stroke}: checked whole` : "",
      result.tool_axis ?? "",
    ].filter((t) => t).join("; ");
    $("robot-strokes").dataset.strokes = result.strokes.length;
    const suggestion = result.suggestions.find((s) => s.wobj);
    const use = $("use-suggestion");
    use.disabled = !suggestion;
    use.dataset.wobj = suggestion ? suggestion.wobj : "";
    showRobot(result);
    setExports(result);
  } catch (error) {
    $("robot-summary").textContent = error.message;
    setExports(null);
  }
}

$("robot-form").addEventListener("submit", (event) => {
  event.preventDefault();
  checkRobot();
});
$("use-suggestion").addEventListener("click", () => {
  $("wobj").value = $("use-suggestion").dataset.wobj;
  checkRobot();
});
for (const id of ["wobj", "tcp", "span-from", "span-to", "lift-mm", "pause-s", "free-tool-axis"]) $(id).addEventListener("change", () => setExports(null));
// Choosing a robot checks the take on it (the arm appears in the 3-D view).
$("robot-name").addEventListener("change", () => {
  setExports(null);
  checkRobot();
});
// The first time the tab opens on a take, it checks at once: from the suggested placement
// when the default cannot work.
let robotChecked = false;
function openRobotTab() {
  if (robotChecked) return;
  if (!studio.status || studio.status.take_frames < 30) {
    $("robot-summary").textContent = "waiting for a take (let the source run, or record one)";
    if ($("tab-robot").classList.contains("active")) setTimeout(openRobotTab, 1000);
    return;
  }
  robotChecked = true;
  checkRobot();
}

// ---- review ----
let reviewTimer = null;
let reviewSerial = 0;

function requestReview() {
  clearTimeout(reviewTimer);
  reviewTimer = setTimeout(drawReview, 80);
}

function digest(value) {
  // A short digest of the figures' numbers, so that a test can see the plotted data change.
  const text = JSON.stringify(value);
  let h = 2166136261;
  for (let i = 0; i < text.length; i += 1) h = Math.imul(h ^ text.charCodeAt(i), 16777619);
  return (h >>> 0).toString(16);
}

async function drawReview() {
  const cutoff = $("cutoff").value;
  $("cutoff-value").textContent = `${Number(cutoff).toFixed(1)} Hz`;
  if (!window.teachcamReview) {
    $("review-state").textContent = "the review figures are not available in this build";
    return;
  }
  if (!studio.status || studio.status.take_frames < 30) {
    $("review-state").textContent = "waiting for a take (let the source run, or record one)";
    // Ask again while the tab is open: the take grows as frames are tracked.
    if ($("tab-review").classList.contains("active")) reviewTimer = setTimeout(drawReview, 1000);
    return;
  }
  const serial = ++reviewSerial;
  $("review-state").textContent = "smoothing…";
  try {
    const review = await api(`/api/review?cutoff_hz=${encodeURIComponent(cutoff)}`);
    if (serial !== reviewSerial) return;
    const figures = review.figures;
    window.teachcamReview.draw($("review"), figures);
    studio.reviewDraws += 1;
    studio.reviewCutoffHz = Number(cutoff);
    studio.reviewSignature = digest(figures);
    studio.reviewFigures = figures;
    $("review").dataset.draws = studio.reviewDraws;
    $("review").dataset.signature = studio.reviewSignature;
    $("review-state").textContent = `${review.frames} frames of the take, cut-off ${Number(cutoff).toFixed(1)} Hz`;
  } catch (error) {
    $("review-state").textContent = error.message;
  }
}

$("cutoff").addEventListener("input", () => {
  $("cutoff-value").textContent = `${Number($("cutoff").value).toFixed(1)} Hz`;
  requestReview();
  setExports(null);
});

// ---- calibrate tab ----
// The server runs the library's `calibrate wand`; the page polls its state: each camera's
// coverage filling while the dance is detected, then the result, the rig in 3-D, the save.
let calibTimer = null;
let calibResultShown = null;
let calib3 = null;

const CALIB_RUNNING = ["detecting", "detecting_ground", "calibrating"];

function fillSelect(select, options, keepEmpty) {
  const chosen = select.value;
  const wanted = options.map((o) => `${o.id}|${o.what}`).join(",");
  if (select.dataset.options === wanted) return;
  select.dataset.options = wanted;
  for (const option of Array.from(select.options)) if (!keepEmpty || option.value) option.remove();
  for (const o of options) {
    const option = document.createElement("option");
    option.value = o.id;
    option.textContent = `${o.id}: ${o.what}`;
    option.title = o.path;
    select.append(option);
  }
  if (options.some((o) => o.id === chosen)) select.value = chosen;
}

async function pollCalibration() {
  clearTimeout(calibTimer);
  let state;
  try {
    state = await api("/api/calibrate");
  } catch (error) {
    showError(error.message);
    return;
  }
  studio.calibration = state;
  const active = $("tab-calibrate").classList.contains("active");
  if (!state.available) {
    $("calib-unavailable").textContent = `Calibrate: ${state.reason}`;
    $("calib-unavailable").hidden = false;
    $("calib-panel").hidden = true;
    return;
  }
  $("calib-unavailable").hidden = true;
  $("calib-panel").hidden = false;
  fillSelect($("calib-recording"), state.recordings, false);
  if ($("calib-recording").value === "" && state.recordings.length) $("calib-recording").value = state.recordings[0].id;
  if (state.ground_tool) {
    fillSelect($("calib-ground"), state.recordings, true);
    $("calib-ground").disabled = false;
    if (!$("calib-ground").dataset.chosen && state.recordings.some((r) => r.id === "ground")) {
      $("calib-ground").value = "ground";
      $("calib-ground").dataset.chosen = "1";
    }
  } else {
    $("calib-ground").disabled = true;
  }
  $("calib-wand").textContent = `wand '${state.wand.name}': markers at ${state.wand.markers_mm.join(", ")} mm (${state.wand.length_mm} mm end to end); cameras ${state.cameras.join(", ")}`;
  $("calib-world").textContent = `world: ${state.world}`;
  const running = CALIB_RUNNING.includes(state.stage);
  $("calibrate").disabled = running || state.recordings.length === 0;
  const total = state.frames_total ? ` of ${state.frames_total}` : "";
  const words = {
    idle: state.recordings.length ? "choose the dance and press Calibrate" : "no recording yet: record a wand dance with ● Record",
    detecting: `detecting the dance: ${state.frames_done}${total} frames`,
    detecting_ground: `detecting the ground frame: ${state.frames_done}${total} frames`,
    calibrating: "calibrating…",
    done: `calibrated from ${state.recording}`,
    failed: `failed: ${state.error}`,
  };
  $("calib-state").textContent = words[state.stage] ?? state.stage;
  $("calib-state").dataset.stage = state.stage;
  drawCoverage(state.coverage);
  if (running) studio.coverageHistory.push(Number($("calib-coverage").dataset.filled));
  if (state.stage === "done" && state.result && calibResultShown !== state.result) {
    calibResultShown = state.result;
    showCalibration(state);
  }
  if (state.stage !== "done") $("calib-result").hidden = true;
  if (running || active) calibTimer = setTimeout(pollCalibration, running ? 250 : 2000);
}

// Each camera's image as a grid of cells, a cell brighter the more wand markers fell in it.
function drawCoverage(coverage) {
  const box = $("calib-coverage");
  let filled = 0;
  coverage.forEach((c, index) => {
    let figure = box.children[index];
    if (!figure) {
      figure = document.createElement("figure");
      figure.append(document.createElement("canvas"), document.createElement("figcaption"));
      box.append(figure);
    }
    const canvas = figure.firstChild;
    canvas.width = 240;
    canvas.height = Math.round((240 * c.height_px) / Math.max(c.width_px, 1));
    canvas.dataset.camera = c.camera;
    const context = canvas.getContext("2d");
    context.fillStyle = "#000";
    context.fillRect(0, 0, canvas.width, canvas.height);
    const w = canvas.width / c.columns;
    const h = canvas.height / c.rows;
    const most = Math.max(...c.counts, 1);
    let cells = 0;
    c.counts.forEach((count, k) => {
      if (count > 0) {
        cells += 1;
        const level = 0.25 + (0.75 * count) / most;
        context.fillStyle = `rgba(63, 191, 111, ${level})`;
        context.fillRect((k % c.columns) * w, Math.floor(k / c.columns) * h, w, h);
      }
    });
    context.strokeStyle = "#3a434e";
    for (let i = 0; i <= c.columns; i += 1) context.strokeRect(i * w, 0, 0, canvas.height);
    for (let j = 0; j <= c.rows; j += 1) context.strokeRect(0, j * h, canvas.width, 0);
    canvas.dataset.filled = cells;
    figure.lastChild.textContent = `${c.camera}: ${c.views} wand views, ${cells} of ${c.counts.length} cells`;
    filled += cells;
  });
  while (box.children.length > coverage.length) box.lastChild.remove();
  box.dataset.filled = filled;
}

function showCalibration(state) {
  const result = state.result;
  $("calib-result").hidden = false;
  $("calib-length").textContent = `wand length ${result.length_mean_mm.toFixed(3)} mm (${result.length_error_percent >= 0 ? "+" : ""}${result.length_error_percent.toFixed(3)} % of ${result.length_mm} mm), error rms ${result.length_error_rms_mm.toFixed(4)} mm, max ${result.length_error_max_mm.toFixed(4)} mm; ${result.frames_used} of ${result.frames} frames used`;
  const table = $("calib-cameras");
  table.replaceChildren();
  const head = table.insertRow();
  for (const h of ["camera", "frames", "dropped", "RMS (px)", "centre ± (mm)", "rotation ± (°)"]) {
    const th = document.createElement("th");
    th.textContent = h;
    head.append(th);
  }
  for (const c of result.cameras) {
    const row = table.insertRow();
    row.dataset.camera = c.name;
    row.dataset.rmsPx = c.rms_px;
    for (const v of [c.name, c.frames, c.dropped, c.rms_px.toFixed(4), c.centre_std_mm.toFixed(3), c.rotation_std_deg.toFixed(4)]) row.insertCell().textContent = v;
  }
  $("calib-world-result").textContent = result.world;
  $("calib-warning").textContent = result.warning ?? "";
  $("calib-lines").textContent = result.lines.join("\n");
  $("calib-saved").textContent = "";
  showSavePath();
  drawCalibratedRig(result.rig);
}

// The calibrated rig in 3-D: its cameras' frusta (as the live view draws them) and the world
// axes, framed on them; a renderer of its own, made when first needed.
function drawCalibratedRig(cameras) {
  const box = $("calib-scene");
  if (!calib3) {
    const renderer3 = new THREE.WebGLRenderer({ antialias: false });
    renderer3.setPixelRatio(1);
    box.append(renderer3.domElement);
    const camera3 = new THREE.PerspectiveCamera(45, 1, 1, 100000);
    const controls = new OrbitControls(camera3, renderer3.domElement);
    calib3 = { renderer: renderer3, camera: camera3, controls, scene: null };
    controls.addEventListener("change", () => renderCalibration());
  }
  const scene3 = new THREE.Scene();
  scene3.background = new THREE.Color(0x0c0e11);
  const box3 = new THREE.Box3().expandByPoint(new THREE.Vector3(0, 0, 0));
  const names = [];
  cameras.forEach((camera, i) => {
    const { frustum, position, corners } = cameraFrustum(camera, palette[i % palette.length]);
    scene3.add(frustum);
    const name = label(camera.name, 1, `#${palette[i % palette.length].toString(16).padStart(6, "0")}`);
    name.position.copy(position);
    names.push(name);
    scene3.add(name);
    box3.expandByPoint(position);
    for (const p of corners) box3.expandByPoint(p);
  });
  const size = box3.getSize(new THREE.Vector3()).length();
  // Text a 30th of the rig across: readable from where the rig is framed.
  for (const name of names) name.scale.multiplyScalar(size / 30);
  scene3.add(new THREE.AxesHelper(size / 6));
  scene3.add(label("world", size / 30));
  calib3.scene = scene3;
  const width = box.clientWidth || 640;
  const height = box.clientHeight || 420;
  calib3.renderer.setSize(width, height, false);
  calib3.renderer.domElement.style.width = "100%";
  calib3.renderer.domElement.style.height = "100%";
  const centre = box3.getCenter(new THREE.Vector3());
  const mean = new THREE.Vector3();
  for (const camera of cameras) mean.add(new THREE.Vector3(...camera.position_mm));
  mean.divideScalar(Math.max(cameras.length, 1));
  // From behind the cameras, raised: the frusta in depth.
  const direction = mean.clone().sub(centre);
  if (direction.lengthSq() < 1e-6) direction.set(0, -1, 1);
  direction.normalize();
  const up = new THREE.Vector3();
  for (const camera of cameras) up.sub(new THREE.Vector3(camera.rotation[0][1], camera.rotation[1][1], camera.rotation[2][1]));
  if (up.lengthSq() > 0) calib3.camera.up.copy(up.normalize());
  calib3.camera.aspect = width / height;
  const distance = (0.6 * size) / Math.sin(THREE.MathUtils.degToRad(22.5));
  calib3.camera.position.copy(centre.clone().addScaledVector(direction.addScaledVector(calib3.camera.up, 0.5).normalize(), distance));
  calib3.camera.near = Math.max(distance / 100, 1);
  calib3.camera.far = distance * 20;
  calib3.camera.updateProjectionMatrix();
  calib3.controls.target.copy(centre);
  calib3.controls.update();
  renderCalibration();
}

function renderCalibration() {
  if (!calib3?.scene) return;
  calib3.renderer.render(calib3.scene, calib3.camera);
  studio.calibrationRenders += 1;
}

function showSavePath() {
  const out = studio.calibration?.out ?? "";
  $("calib-path").textContent = `→ ${out}/${$("calib-name").value}`;
  $("calib-confirm").hidden = true;
  $("calib-overwrite").hidden = true;
}

async function saveRig(overwrite) {
  try {
    const saved = await post("/api/calibrate/save", { name: $("calib-name").value, overwrite });
    $("calib-confirm").hidden = true;
    if (saved.saved) {
      $("calib-saved").textContent = `saved ${saved.path}`;
      $("calib-saved").dataset.path = saved.path;
      $("calib-overwrite").hidden = true;
    } else {
      $("calib-saved").textContent = saved.message;
      $("calib-overwrite").hidden = false;
    }
    showError("");
  } catch (error) {
    showError(error.message);
  }
}

$("calib-form").addEventListener("submit", async (event) => {
  event.preventDefault();
  try {
    studio.coverageHistory = [];
    calibResultShown = null;
    await post("/api/calibrate/start", { recording: $("calib-recording").value, ground: $("calib-ground").value || null });
    showError("");
  } catch (error) {
    showError(error.message);
  }
  pollCalibration();
});
$("calib-ground").addEventListener("change", () => {
  $("calib-ground").dataset.chosen = "1";
});
$("calib-name").addEventListener("input", showSavePath);
// Saving asks first: the path shown, then Confirm; an existing file only with Overwrite.
$("calib-save-form").addEventListener("submit", (event) => {
  event.preventDefault();
  $("calib-saved").textContent = `save the rig to ${studio.calibration?.out}/${$("calib-name").value}?`;
  $("calib-confirm").hidden = false;
  $("calib-overwrite").hidden = true;
});
$("calib-confirm").addEventListener("click", () => saveRig(false));
$("calib-overwrite").addEventListener("click", () => saveRig(true));

// ---- start ----
// The page asks first whether its token is this studio's (`/api/session` answers without it):
// opened from a bookmark or a second tab it says how to open it, and opens nothing that the
// server would refuse (a refused WebSocket or request is an error in the console).
async function start() {
  let session;
  try {
    session = await fetch(`/api/session?token=${encodeURIComponent(token)}`).then((r) => r.json());
  } catch (error) {
    showError(`cannot reach the studio: ${error.message}`);
    return;
  }
  if (!session.token_ok) {
    studio.tokenRefused = true;
    document.body.classList.add("no-token");
    $("no-token-message").textContent = session.message.replace("127.0.0.1:PORT", location.host);
    $("no-token").hidden = false;
    return;
  }
  studio.tokenRefused = false;
  resizeScene();
  loadScene()
    .catch((error) => showError(error.message))
    .finally(() => {
      connect();
      requestAnimationFrame(render);
    });
  pollStatus();
  setInterval(pollStatus, 1000);
  openTabOfLink();
}
start();
