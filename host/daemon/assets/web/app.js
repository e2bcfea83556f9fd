// The robot-host web view.
//
// Polls /api/state every POLL_MS and draws, on one canvas:
// - with a geo-referenced image: the image fitted to the canvas (scaled to fit, centred), and,
//   once the map is geo-referenced, the map over it through `pixel_from_map`;
// - without an image: the map in its own frame (x to the right, y up) fitted to the canvas.
// The map is the occupancy grid (from /api/map.png, placed by its origin and resolution), the
// landmarks, the trajectory, the pose with its 95 % uncertainty ellipse, and the goal.
// A click on the image POSTs that pixel to /api/goal and shows the answer or the error.
// A daemon serving beyond loopback wants its token for the goal (and, if so configured, for
// every /api/ request): the page asks for it once, keeps it in the browser's storage and
// sends it as `Authorization: Bearer TOKEN`.
//
// Frames: "map" is the SLAM map frame in metres; "image" is the image's pixels, column and row
// from its top-left outer corner; "canvas" is CSS pixels from the canvas's top-left corner.
// Affine maps use the canvas's convention: {a, b, c, d, e, f} takes (x, y) to
// (a·x + c·y + e, b·x + d·y + f).

'use strict';

const POLL_MS = 500;
// 95 % quantile of the χ² distribution with 2 degrees of freedom.
const CHI2_95_2DOF = 5.991;
// Blank border around the map when it is drawn in its own frame, CSS pixels.
const MAP_MARGIN_PX = 24;
// Occupancy-grid pixel values (see host::grid::map_export).
const UNKNOWN_PIXEL = 205;
const FREE_PIXEL_MIN = 230;

const COLOURS = {
  trajectory: '#1e5ac8',
  landmark: '#ff9800',
  landmarkEdge: '#4e2a00',
  pose: '#e53935',
  poseEllipse: 'rgba(229, 57, 53, 0.18)',
  goal: '#d500f9',
  scale: '#1f2328',
};

const FIX_QUALITY = { 0: 'no fix', 1: 'GPS', 2: 'DGPS', 4: 'RTK fixed', 5: 'RTK float' };

const canvas = document.getElementById('view');
const context = canvas.getContext('2d');

// What the page knows: the last state, the loaded pictures, and the frames of the last drawing.
const view = {
  state: null,
  image: null,
  imageLoading: false,
  grid: null,
  gridLoading: null,
  canvasFromImage: null,
  canvasFromMap: null,
  askingToken: false,
};

// ---- Affine maps ------------------------------------------------------------------------

function affine(a, b, c, d, e, f) {
  return { a, b, c, d, e, f };
}

function apply(m, [x, y]) {
  return [m.a * x + m.c * y + m.e, m.b * x + m.d * y + m.f];
}

// outer ∘ inner: first inner, then outer.
function compose(outer, inner) {
  return affine(
    outer.a * inner.a + outer.c * inner.b,
    outer.b * inner.a + outer.d * inner.b,
    outer.a * inner.c + outer.c * inner.d,
    outer.b * inner.c + outer.d * inner.d,
    outer.a * inner.e + outer.c * inner.f + outer.e,
    outer.b * inner.e + outer.d * inner.f + outer.f,
  );
}

function invert(m) {
  const det = m.a * m.d - m.b * m.c;
  return affine(
    m.d / det, -m.b / det, -m.c / det, m.a / det,
    (m.c * m.f - m.d * m.e) / det, (m.b * m.e - m.a * m.f) / det,
  );
}

// The state's `pixel_from_map` [a, b, c, d, e, f] means col = a + b·x + c·y, row = d + e·x + f·y.
function imageFromMap(pixelFromMap) {
  const [a, b, c, d, e, f] = pixelFromMap;
  return affine(b, e, c, f, a, d);
}

// The occupancy grid's PNG pixels → map: row 0 is the top of the grid (its highest y).
function mapFromGridPixels(grid) {
  const r = grid.resolution_m;
  const [x0, y0] = grid.origin_m;
  return affine(r, 0, 0, -r, x0, y0 + r * grid.size_cells[1]);
}

// ---- Frames -----------------------------------------------------------------------------

// The image scaled to fit the canvas and centred.
function fitImage(width, height, image) {
  const scale = Math.min(width / image.width, height / image.height);
  const left = (width - scale * image.width) / 2;
  const top = (height - scale * image.height) / 2;
  return affine(scale, 0, 0, scale, left, top);
}

// The map's content in its own frame, y up, scaled to fit the canvas and centred.
function fitMap(width, height, state) {
  const points = mapPoints(state);
  if (points.length === 0) points.push([-5, -5], [5, 5]);
  let [minX, minY, maxX, maxY] = [Infinity, Infinity, -Infinity, -Infinity];
  for (const [x, y] of points) {
    minX = Math.min(minX, x); maxX = Math.max(maxX, x);
    minY = Math.min(minY, y); maxY = Math.max(maxY, y);
  }
  const spanX = Math.max(maxX - minX, 1);
  const spanY = Math.max(maxY - minY, 1);
  const scale = Math.max(
    Math.min((width - 2 * MAP_MARGIN_PX) / spanX, (height - 2 * MAP_MARGIN_PX) / spanY),
    1e-6,
  );
  const left = (width - scale * spanX) / 2 - scale * minX;
  const top = (height - scale * spanY) / 2 + scale * (minY + spanY);
  return affine(scale, 0, 0, -scale, left, top);
}

// Every point of the map worth keeping in view, in the map frame.
function mapPoints(state) {
  const points = [...state.trajectory_m];
  for (const landmark of state.landmarks) points.push([landmark.x_m, landmark.y_m]);
  if (state.grid) {
    const m = mapFromGridPixels(state.grid);
    const [w, h] = state.grid.size_cells;
    points.push(apply(m, [0, 0]), apply(m, [w, h]));
  }
  if (state.goal) points.push([state.goal.x_m, state.goal.y_m]);
  if (state.trajectory_m.length > 0 || state.landmarks.length > 0) {
    points.push([state.pose.x_m, state.pose.y_m]);
  }
  return points.filter(([x, y]) => Number.isFinite(x) && Number.isFinite(y));
}

// ---- Drawing ----------------------------------------------------------------------------

function draw() {
  const ratio = window.devicePixelRatio || 1;
  const width = canvas.clientWidth;
  const height = canvas.clientHeight;
  if (canvas.width !== Math.round(width * ratio) || canvas.height !== Math.round(height * ratio)) {
    canvas.width = Math.round(width * ratio);
    canvas.height = Math.round(height * ratio);
  }
  const device = affine(ratio, 0, 0, ratio, 0, 0);
  setTransform(device);
  context.clearRect(0, 0, width, height);

  const state = view.state;
  view.canvasFromImage = null;
  view.canvasFromMap = null;
  if (state && state.image && view.image) {
    view.canvasFromImage = fitImage(width, height, view.image);
    if (state.pixel_from_map) {
      view.canvasFromMap = compose(view.canvasFromImage, imageFromMap(state.pixel_from_map));
    }
    const [left, top] = apply(view.canvasFromImage, [0, 0]);
    const scale = view.canvasFromImage.a;
    context.drawImage(view.image, left, top, scale * view.image.width, scale * view.image.height);
  } else if (state && !state.image) {
    view.canvasFromMap = fitMap(width, height, state);
  }
  updateNote(state);
  if (!state || !view.canvasFromMap) return;

  const toCanvas = (point) => apply(view.canvasFromMap, point);
  drawGrid(device);
  setTransform(device);
  drawTrajectory(state.trajectory_m.map(toCanvas));
  for (const landmark of state.landmarks) drawLandmark(toCanvas([landmark.x_m, landmark.y_m]));
  drawPose(state.pose);
  if (state.goal) drawGoal(goalOnCanvas(state.goal));
  drawScaleBar(width, height);
}

function setTransform(m) {
  context.setTransform(m.a, m.b, m.c, m.d, m.e, m.f);
}

function drawGrid(device) {
  if (!view.grid || !view.state.grid) return;
  const canvasFromGrid = compose(view.canvasFromMap, mapFromGridPixels(view.grid.placement));
  setTransform(compose(device, canvasFromGrid));
  context.imageSmoothingEnabled = false;
  context.drawImage(view.grid.picture, 0, 0);
  context.imageSmoothingEnabled = true;
}

function drawTrajectory(points) {
  if (points.length < 2) return;
  context.beginPath();
  context.moveTo(...points[0]);
  for (const point of points.slice(1)) context.lineTo(...point);
  context.strokeStyle = COLOURS.trajectory;
  context.lineWidth = 2.5;
  context.lineJoin = 'round';
  context.stroke();
}

function drawLandmark([x, y]) {
  context.beginPath();
  context.arc(x, y, 5, 0, 2 * Math.PI);
  context.fillStyle = COLOURS.landmark;
  context.fill();
  context.strokeStyle = COLOURS.landmarkEdge;
  context.lineWidth = 1;
  context.stroke();
}

// The 95 % ellipse of the position, drawn as a polygon in the map frame so that any affine
// map to the canvas draws it right, and a triangle along the heading.
function drawPose(pose) {
  const centre = [pose.x_m, pose.y_m];
  const outline = ellipseOutline(centre, pose.position_cov_m2);
  if (outline) {
    context.beginPath();
    outline.forEach((point, i) => {
      const [x, y] = apply(view.canvasFromMap, point);
      if (i === 0) context.moveTo(x, y); else context.lineTo(x, y);
    });
    context.closePath();
    context.fillStyle = COLOURS.poseEllipse;
    context.fill();
    context.strokeStyle = COLOURS.pose;
    context.lineWidth = 1.5;
    context.stroke();
  }
  const [px, py] = apply(view.canvasFromMap, centre);
  const ahead = apply(view.canvasFromMap, [
    pose.x_m + Math.cos(pose.theta_rad), pose.y_m + Math.sin(pose.theta_rad),
  ]);
  const length = Math.hypot(ahead[0] - px, ahead[1] - py) || 1;
  const [ux, uy] = [(ahead[0] - px) / length, (ahead[1] - py) / length];
  context.beginPath();
  context.moveTo(px + 14 * ux, py + 14 * uy);
  context.lineTo(px - 7 * ux - 7 * uy, py - 7 * uy + 7 * ux);
  context.lineTo(px - 7 * ux + 7 * uy, py - 7 * uy - 7 * ux);
  context.closePath();
  context.fillStyle = COLOURS.pose;
  context.fill();
  context.strokeStyle = '#ffffff';
  context.lineWidth = 1;
  context.stroke();
}

// The semi-axes (metres) and the angle (radians, from the map's x axis) of the 95 % ellipse of
// the covariance [xx, xy, yy], or null if it is not a covariance.
function ellipseAxes([xx, xy, yy]) {
  if (![xx, xy, yy].every(Number.isFinite)) return null;
  const mean = (xx + yy) / 2;
  const spread = Math.hypot((xx - yy) / 2, xy);
  const major = mean + spread;
  const minor = mean - spread;
  if (minor < 0) return null;
  return {
    major_m: Math.sqrt(CHI2_95_2DOF * major),
    minor_m: Math.sqrt(CHI2_95_2DOF * minor),
    angle_rad: 0.5 * Math.atan2(2 * xy, xx - yy),
  };
}

function ellipseOutline([cx, cy], covariance) {
  const axes = ellipseAxes(covariance);
  if (!axes || axes.major_m === 0) return null;
  const [c, s] = [Math.cos(axes.angle_rad), Math.sin(axes.angle_rad)];
  const points = [];
  for (let i = 0; i < 64; i += 1) {
    const t = (2 * Math.PI * i) / 64;
    const [u, v] = [axes.major_m * Math.cos(t), axes.minor_m * Math.sin(t)];
    points.push([cx + c * u - s * v, cy + s * u + c * v]);
  }
  return points;
}

function goalOnCanvas(goal) {
  if (goal.pixel && view.canvasFromImage) return apply(view.canvasFromImage, goal.pixel);
  return apply(view.canvasFromMap, [goal.x_m, goal.y_m]);
}

function drawGoal([x, y]) {
  context.strokeStyle = COLOURS.goal;
  context.lineWidth = 3;
  context.beginPath();
  context.arc(x, y, 9, 0, 2 * Math.PI);
  context.moveTo(x - 15, y); context.lineTo(x - 4, y);
  context.moveTo(x + 4, y); context.lineTo(x + 15, y);
  context.moveTo(x, y - 15); context.lineTo(x, y - 4);
  context.moveTo(x, y + 4); context.lineTo(x, y + 15);
  context.stroke();
}

// A bar of a round length in metres, bottom left.
function drawScaleBar(width, height) {
  const [x0, y0] = apply(view.canvasFromMap, [0, 0]);
  const [x1, y1] = apply(view.canvasFromMap, [1, 0]);
  const pxPerM = Math.hypot(x1 - x0, y1 - y0);
  if (!(pxPerM > 0)) return;
  const wanted = 120 / pxPerM;
  const magnitude = 10 ** Math.floor(Math.log10(wanted));
  const lengthM = [5, 2, 1].map((k) => k * magnitude).find((m) => m <= wanted) || magnitude;
  const lengthPx = lengthM * pxPerM;
  const [left, bottom] = [16, height - 16];
  context.fillStyle = 'rgba(255, 255, 255, 0.8)';
  context.fillRect(left - 6, bottom - 24, lengthPx + 12, 30);
  context.strokeStyle = COLOURS.scale;
  context.lineWidth = 2;
  context.beginPath();
  context.moveTo(left, bottom - 6); context.lineTo(left, bottom);
  context.lineTo(left + lengthPx, bottom); context.lineTo(left + lengthPx, bottom - 6);
  context.stroke();
  context.fillStyle = COLOURS.scale;
  context.font = '12px system-ui, sans-serif';
  context.fillText(`${lengthM} m`, left, bottom - 10);
}

function updateNote(state) {
  let note = '';
  if (!state) note = 'Waiting for the daemon…';
  else if (state.image && !view.image) note = 'Loading the geo-referenced image…';
  else if (state.image && !state.pixel_from_map) {
    note = 'The map is not geo-referenced yet: the image is shown without it.';
  } else if (!state.image) {
    note = 'No geo-referenced image: the map is drawn in its own frame (x right, y up).';
  }
  document.getElementById('view-note').textContent = note;
  document.getElementById('goal-hint').hidden = !state || !state.image;
}

// ---- Access -----------------------------------------------------------------------------

const TOKEN_KEY = 'robot-host-token';

// fetch() with the stored token; on 401 asks for the token once and tries again.
async function api(path, options = {}) {
  const send = () => {
    const token = window.localStorage.getItem(TOKEN_KEY);
    const headers = { ...(options.headers || {}) };
    if (token) headers.Authorization = `Bearer ${token}`;
    return fetch(path, { ...options, headers });
  };
  const response = await send();
  if (response.status !== 401 || view.askingToken) return response;
  view.askingToken = true;
  try {
    const token = window.prompt(
      'This daemon needs its access token (printed when it started, or [web] token in its configuration):');
    if (!token) return response;
    window.localStorage.setItem(TOKEN_KEY, token.trim());
    return await send();
  } finally {
    view.askingToken = false;
  }
}

// ---- Pictures ---------------------------------------------------------------------------

// An image from the API, fetched with the token, as an <img> once decoded.
async function loadPicture(path) {
  const response = await api(path, { cache: 'no-store' });
  if (!response.ok) throw new Error(`HTTP ${response.status}`);
  const url = URL.createObjectURL(await response.blob());
  const picture = new Image();
  try {
    await new Promise((resolve, reject) => {
      picture.onload = resolve;
      picture.onerror = () => reject(new Error('not an image'));
      picture.src = url;
    });
  } finally {
    URL.revokeObjectURL(url);
  }
  return picture;
}

function ensureImage(state) {
  if (!state.image || view.image || view.imageLoading) return;
  view.imageLoading = true;
  loadPicture('/api/image.png').then((picture) => {
    view.image = picture;
    view.imageLoading = false;
    draw();
  }, () => {
    document.getElementById('view-note').textContent = 'Cannot load the image; retrying…';
    setTimeout(() => { view.imageLoading = false; }, 5000);
  });
}

function ensureGrid(state) {
  if (!state.grid) {
    view.grid = null;
    return;
  }
  const revision = state.grid.revision;
  if ((view.grid && view.grid.revision === revision) || view.gridLoading === revision) return;
  view.gridLoading = revision;
  const placement = state.grid;
  loadPicture(`/api/map.png?revision=${encodeURIComponent(revision)}`).then((picture) => {
    view.grid = { revision, placement, picture: withoutUnknownCells(picture) };
    view.gridLoading = null;
    draw();
  }, () => { view.gridLoading = null; });
}

// The grid with unknown cells transparent and free cells faint, so the image shows through.
function withoutUnknownCells(picture) {
  const copy = document.createElement('canvas');
  copy.width = picture.naturalWidth;
  copy.height = picture.naturalHeight;
  const copyContext = copy.getContext('2d');
  copyContext.drawImage(picture, 0, 0);
  const pixels = copyContext.getImageData(0, 0, copy.width, copy.height);
  const data = pixels.data;
  for (let i = 0; i < data.length; i += 4) {
    if (data[i] === UNKNOWN_PIXEL) data[i + 3] = 0;
    else if (data[i] >= FREE_PIXEL_MIN) data[i + 3] = 110;
  }
  copyContext.putImageData(pixels, 0, 0);
  return copy;
}

// ---- Camera ------------------------------------------------------------------------------

// Fetches the camera's frame when /api/state says a new one is there, then draws it.
function ensureCameraFrame(state) {
  const panel = document.getElementById('camera-panel');
  panel.hidden = !state.camera;
  if (!state.camera || state.camera.frame === 0) return;
  const frame = state.camera.frame;
  if ((view.camera && view.camera.frame === frame) || view.cameraLoading) return;
  view.cameraLoading = true;
  const status = state.camera;
  loadPicture(`/api/camera.jpg?frame=${frame}`).then((picture) => {
    view.camera = { frame, status, picture };
    view.cameraLoading = false;
    drawCamera();
  }, () => { view.cameraLoading = false; });
}

// The frame, each feature's 3σ search ellipse about its predicted pixel, the features
// started in it and the corners found moving (where they are, and a line from where they were).
function drawCamera() {
  const camera = view.camera;
  if (!camera) return;
  const element = document.getElementById('camera');
  const { picture, status } = camera;
  element.width = picture.naturalWidth;
  element.height = picture.naturalHeight;
  const context = element.getContext('2d');
  context.drawImage(picture, 0, 0);
  // The camera method's pixel (0, 0) is the centre of the top-left pixel.
  context.translate(0.5, 0.5);
  context.lineWidth = 1.5;
  context.strokeStyle = '#ffd21f';
  // ellipseAxes draws the 95 % ellipse; the search region is the 3σ one.
  const toThreeSigma = 9 / CHI2_95_2DOF;
  for (const feature of status.features) {
    const [xx, xy, yy] = feature.covariance_px2.map((v) => v * toThreeSigma);
    const axes = ellipseAxes([xx, xy, yy]);
    if (!axes) continue;
    context.beginPath();
    context.ellipse(feature.pixel[0], feature.pixel[1], axes.major_m, axes.minor_m,
      axes.angle_rad, 0, 2 * Math.PI);
    context.stroke();
  }
  context.strokeStyle = '#3ce070';
  for (const [x, y] of status.added) {
    context.strokeRect(x - 3, y - 3, 6, 6);
  }
  context.strokeStyle = '#2f7dff';
  context.fillStyle = '#2f7dff';
  for (const [[x, y], [px, py]] of status.moving) {
    context.beginPath();
    context.moveTo(px, py);
    context.lineTo(x, y);
    context.stroke();
    context.fillRect(x - 2, y - 2, 4, 4);
  }
  const scale = status.scale_from_gps ? `, ${status.scale_from_gps.toFixed(3)} m per map unit from GPS` : '';
  document.getElementById('camera-note').textContent = status.tracking
    ? `${status.source}: frame ${status.frame}, ${status.features.length} features looked for, `
      + `${status.measured} measured; ${status.local_maps} local maps, `
      + `${status.places_recognised} places recognised, ${status.rejected_as_moving} rejected as moving${scale}; `
      + `${status.frames_skipped} frames skipped, ${status.frames_refused} refused`
    : `${status.source}: frame ${status.frame} (shown and recorded; the camera method runs with slam.method = "camera"), `
      + `${status.frames_refused} refused`;
}

// ---- Panels -----------------------------------------------------------------------------

function setText(id, text) {
  document.getElementById(id).textContent = text;
}

function fixed(value, digits) {
  return value === null || value === undefined || !Number.isFinite(value)
    ? '–' : value.toFixed(digits);
}

function updatePanels(state) {
  const pose = state.pose;
  setText('pose-x', fixed(pose.x_m, 2));
  setText('pose-y', fixed(pose.y_m, 2));
  setText('pose-heading', fixed((pose.theta_rad * 180) / Math.PI, 1));
  setText('pose-lat', fixed(pose.lat_deg, 7));
  setText('pose-lon', fixed(pose.lon_deg, 7));
  const axes = ellipseAxes(pose.position_cov_m2);
  // The camera method gives no metric covariance: no ellipse then.
  setText('pose-ellipse', axes && axes.major_m > 0
    ? `${axes.major_m.toFixed(2)} × ${axes.minor_m.toFixed(2)}` : '–');

  const tracking = state.tracking;
  const trackingElement = document.getElementById('tracking');
  trackingElement.textContent = !tracking ? '–'
    : tracking.lost ? `tracking lost (${tracking.lost_scans} scans so far)`
      : `on the map (${tracking.lost_scans} scans lost so far)`;
  trackingElement.classList.toggle('lost', Boolean(tracking && tracking.lost));

  const counters = state.counters;
  setText('telegrams', String(counters.telegrams));
  setText('telegram-crc-errors', String(counters.telegram_crc_errors));
  setText('frames', String(counters.frames));
  setText('crc-errors', String(counters.crc_errors));
  setText('frames-lost', String(counters.frames_lost));
  setText('reconnects', String(counters.reconnects));
  setText('board-restarts', String(counters.board_restarts));
  setText('clock', counters.clock_synchronised ? 'synchronised' : 'not synchronised');
  setText('gps-fix', FIX_QUALITY[counters.gps_fix_quality] || `quality ${counters.gps_fix_quality}`);
  setText('gps-satellites', String(counters.gps_satellites));
  setText('gps-fixes', String(counters.gps_fixes));

  showGoal(state.goal);
}

function showGoal(goal) {
  document.getElementById('goal').hidden = !goal;
  if (!goal) return;
  setText('goal-x', fixed(goal.x_m, 2));
  setText('goal-y', fixed(goal.y_m, 2));
  setText('goal-lat', fixed(goal.lat_deg, 7));
  setText('goal-lon', fixed(goal.lon_deg, 7));
}

function showGoalError(message) {
  const element = document.getElementById('goal-error');
  element.textContent = message;
  element.hidden = !message;
}

function setLinkStatus(live, message) {
  const element = document.getElementById('link-status');
  element.textContent = message;
  element.className = `status ${live ? 'live' : 'down'}`;
}

// ---- The daemon -------------------------------------------------------------------------

async function poll() {
  try {
    const response = await api('/api/state', { cache: 'no-store' });
    if (!response.ok) throw new Error(`HTTP ${response.status}`);
    view.state = await response.json();
    setLinkStatus(true, 'live');
    ensureImage(view.state);
    ensureGrid(view.state);
    ensureCameraFrame(view.state);
    updatePanels(view.state);
    draw();
  } catch (error) {
    setLinkStatus(false, `daemon unreachable: ${error.message}`);
  } finally {
    setTimeout(poll, POLL_MS);
  }
}

async function setGoal(request) {
  showGoalError('');
  try {
    const response = await api('/api/goal', {
      method: 'POST',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify(request),
    });
    const answer = await response.json()
      .catch(() => ({ error: `the daemon answered HTTP ${response.status}` }));
    if (!response.ok) {
      showGoalError(`Goal refused: ${answer.error || `HTTP ${response.status}`}`);
      return;
    }
    if (view.state) view.state.goal = answer;
    showGoal(answer);
    draw();
  } catch (error) {
    showGoalError(`Cannot reach the daemon: ${error.message}`);
  }
}

canvas.addEventListener('click', (event) => {
  if (!view.canvasFromImage) {
    showGoalError('Goals are set by clicking the geo-referenced image, and none is shown.');
    return;
  }
  const bounds = canvas.getBoundingClientRect();
  const onCanvas = [event.clientX - bounds.left, event.clientY - bounds.top];
  const [pixelX, pixelY] = apply(invert(view.canvasFromImage), onCanvas);
  setGoal({ pixel_x: pixelX, pixel_y: pixelY });
});

new ResizeObserver(draw).observe(canvas);
poll();
