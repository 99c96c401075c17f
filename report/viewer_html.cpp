// OUTDIR/viewer.html: the interactive WebGL2 view of one scan (docs/report.md,
// "The viewer"). One self-contained file: its script and its data (the
// shaders, m, M or its preview, the APO texture, the views) are inline, so
// it opens from file://, in a copied folder, on a machine without the tool.
#include "report/report.h"

#include <fmt/format.h>

namespace apo {
namespace {

using Json = nlohmann::json;

// Inline script and style only; images beside the page for the fallback.
constexpr const char* kViewerSecurityPolicy =
    "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src 'self' file: data:";

std::string base64(const void* data, std::size_t size) {
  static constexpr char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (std::size_t i = 0; i < size; i += 3) {
    const std::uint32_t b0 = bytes[i], b1 = i + 1 < size ? bytes[i + 1] : 0, b2 = i + 2 < size ? bytes[i + 2] : 0;
    const std::uint32_t triple = (b0 << 16) | (b1 << 8) | b2;
    out += kDigits[(triple >> 18) & 63];
    out += kDigits[(triple >> 12) & 63];
    out += i + 1 < size ? kDigits[(triple >> 6) & 63] : '=';
    out += i + 2 < size ? kDigits[triple & 63] : '=';
  }
  return out;
}

template <typename T>
std::string base64Of(const std::vector<T>& values) {
  return base64(values.data(), values.size() * sizeof(T));
}

Json geometryJson(const ViewerGeometry& g) {
  if (g.positions.empty()) return nullptr;
  Json out{{"description", g.description},
           {"vertices", g.positions.size() / 3},
           {"positions", base64Of(g.positions)},
           {"normals", base64Of(g.normals)}};
  if (g.isMesh()) out["indices"] = base64Of(g.indices);
  else out["radii"] = base64Of(g.radii);
  return out;
}

Json vec3Json(const Vec3f& v) { return Json::array({v.x(), v.y(), v.z()}); }

Json viewsJson(const std::vector<Camera>& views) {
  Json out = Json::array();
  for (const Camera& c : views)
    out.push_back({{"eye", vec3Json(c.eye)},
                   {"target", vec3Json(c.target)},
                   {"up", vec3Json(c.up)},
                   {"fov", c.fovYDegrees},
                   {"near", c.nearPlane},
                   {"far", c.farPlane},
                   {"label", c.label},
                   {"sees_scanned_side", c.seesScannedSide ? Json(*c.seesScannedSide) : Json(nullptr)}});
  return out;
}

Json escapedPaths(const std::vector<std::string>& paths) {
  Json out = Json::array();
  for (const std::string& path : paths) out.push_back(urlPathEscape(path));
  return out;
}

Json sceneJson(const ViewerScene& scene, std::string_view scanName, const std::vector<std::string>& staticImages) {
  const ViewerShaders& s = scene.shaders;
  Json uniforms = Json::array();
  for (const ViewerUniform& u : scene.apoUniforms) uniforms.push_back({{"name", u.name}, {"type", u.type}, {"values", u.values}});
  return {{"name", std::string(scanName)},
          {"shaders", {{"mesh_vertex", s.meshVertex}, {"mesh_fragment", s.meshFragment}, {"apo_fragment", s.apoFragment},
                       {"point_vertex", s.pointVertex}, {"point_fragment", s.pointFragment},
                       {"screen_vertex", s.screenVertex}, {"heat_fragment", s.heatFragment}}},
          {"apo", {{"width", scene.textureWidth}, {"height", scene.textureHeight}, {"texels", base64Of(scene.texture)},
                   {"uniforms", uniforms}}},
          {"coarse", geometryJson(scene.coarse)},
          {"detail", geometryJson(scene.detail)},
          {"views", viewsJson(scene.views)},
          {"images", escapedPaths(staticImages)},
          {"mipmapping", scene.mipmapping},
          {"filtering", scene.filtering},
          {"heat_map_degrees", scene.heatMapDegrees},
          {"radius", scene.boundingRadius}};
}

// JSON inside <script>: "<" only occurs within JSON strings, where \u003c
// means the same, so no "</script>" or "<!--" can end or bend the element.
std::string scriptSafe(const std::string& json) {
  std::string out;
  out.reserve(json.size());
  for (char c : json) {
    if (c == '<') out += "\\u003c";
    else out += c;
  }
  return out;
}

constexpr const char* kViewerStyle = R"(
* { box-sizing: border-box; }
body { font: 14px/1.4 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; color: #1d1d1f;
       background: #f6f6f4; margin: 0; padding: 12px 16px; }
h1 { font-size: 18px; margin: 0 0 8px; overflow-wrap: anywhere; }
#viewer { display: grid; grid-template-columns: minmax(0, 1024px) 290px; gap: 14px; align-items: start; }
canvas { width: 100%; height: auto; aspect-ratio: 4 / 3; background: #fff; border: 1px solid #d0d0cc; touch-action: none;
         cursor: grab; }
fieldset { border: 1px solid #d0d0cc; margin: 0 0 10px; padding: 6px 10px 8px; }
legend { font-weight: 600; }
#views button { font: 12px monospace; margin: 2px; padding: 2px 5px; }
#views button.unscanned { color: #8a3b1e; }
#views button.current { outline: 2px solid #3b528b; }
label { display: block; }
#readout { font: 12px monospace; white-space: pre-wrap; }
.hint { color: #555; font-size: 12px; }
#fallback figure { display: inline-block; margin: 4px; }
#fallback img { width: 256px; height: 256px; border: 1px solid #d0d0cc; }
.warning { background: #fff4d6; border: 1px solid #8a5a00; padding: 8px 12px; }
)";

// The viewer's script: reads the scene, builds the programs from the
// shaders it carries, draws on demand, and exposes window.apoViewer for the
// tests (setView, normals, timeFrames).
constexpr const char* kViewerScript = R"JS(
'use strict';
(function () {
const scene = JSON.parse(document.getElementById('apo-scene').textContent);
const canvas = document.getElementById('canvas');

function bytesOf(b64) {
  const s = atob(b64), out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; ++i) out[i] = s.charCodeAt(i);
  return out;
}
const floatsOf = b64 => { const b = bytesOf(b64); return new Float32Array(b.buffer, 0, b.length >> 2); };
const uintsOf = b64 => { const b = bytesOf(b64); return new Uint32Array(b.buffer, 0, b.length >> 2); };

// No WebGL2 (or what the passes need): the report's static views, and why.
function fallBack(why) {
  document.getElementById('viewer').hidden = true;
  document.getElementById('fallback').hidden = false;
  document.getElementById('why').textContent = why;
  const grid = document.getElementById('fallback-images');
  scene.images.forEach((src, i) => {
    const figure = document.createElement('figure'), image = document.createElement('img');
    const caption = document.createElement('figcaption');
    image.src = src;
    image.alt = 'view ' + i + ', m with the APO';
    caption.textContent = 'View ' + i + ' (' + scene.views[i].label + ')';
    figure.append(image, caption);
    grid.append(figure);
  });
  window.apoViewer = { ready: false, error: why };
}

// ---- vectors and the OSMesa passes' matrices (render/passes.cpp) ----------
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const length = a => Math.sqrt(dot(a, a));
const normalize = a => scale(a, 1 / length(a));
// Rodrigues: v turned by `angle` radians about the unit axis k.
function rotate(v, k, angle) {
  const c = Math.cos(angle), s = Math.sin(angle);
  return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
}
// Column-major 4x4 of perspective(camera) * lookAt(camera), as passes.cpp.
function viewProjection(c, aspect) {
  const f = normalize(sub(c.target, c.eye)), s = normalize(cross(f, c.up)), u = cross(s, f);
  const view = [s[0], s[1], s[2], -dot(s, c.eye), u[0], u[1], u[2], -dot(u, c.eye),
                -f[0], -f[1], -f[2], dot(f, c.eye), 0, 0, 0, 1];  // row-major
  const t = 1 / Math.tan(0.5 * c.fov * Math.PI / 180);
  const proj = [t / aspect, 0, 0, 0, 0, t, 0, 0, 0, 0, (c.far + c.near) / (c.near - c.far),
                2 * c.far * c.near / (c.near - c.far), 0, 0, -1, 0];  // row-major
  const out = new Float32Array(16);
  for (let row = 0; row < 4; ++row)
    for (let col = 0; col < 4; ++col) {
      let sum = 0;
      for (let k = 0; k < 4; ++k) sum += proj[row * 4 + k] * view[k * 4 + col];
      out[col * 4 + row] = sum;
    }
  return out;
}
// Screen pixels one world unit covers at distance 1 (passes.cpp).
const pixelsPerWorldUnitAtOne = (c, height) => height / (2 * Math.tan(0.5 * c.fov * Math.PI / 180));

// ---- GL ---------------------------------------------------------------------
const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
if (!gl) { fallBack('This browser offers no WebGL2 (or it is turned off), so the report shows its static views.'); return; }
if (!gl.getExtension('EXT_color_buffer_float')) {
  fallBack('This browser\'s WebGL2 cannot render to float textures (EXT_color_buffer_float), which the normal buffers need.');
  return;
}
const maxTexture = gl.getParameter(gl.MAX_TEXTURE_SIZE);
if (scene.apo.width > maxTexture || scene.apo.height > maxTexture) {
  fallBack('The APO texture (' + scene.apo.width + ' x ' + scene.apo.height + ') is larger than this browser\'s ' +
           'largest texture (' + maxTexture + ').');
  return;
}

function program(vertexSource, fragmentSource, name) {
  const compile = (type, source, stage) => {
    const shader = gl.createShader(type);
    gl.shaderSource(shader, source);
    gl.compileShader(shader);
    if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS))
      throw new Error(name + ' ' + stage + ' shader: ' + gl.getShaderInfoLog(shader));
    return shader;
  };
  const p = gl.createProgram();
  gl.attachShader(p, compile(gl.VERTEX_SHADER, vertexSource, 'vertex'));
  gl.attachShader(p, compile(gl.FRAGMENT_SHADER, fragmentSource, 'fragment'));
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(name + ' link: ' + gl.getProgramInfoLog(p));
  return p;
}

function upload(geometry) {
  if (!geometry) return null;
  const vao = gl.createVertexArray();
  gl.bindVertexArray(vao);
  const attribute = (index, data, width) => {
    gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
    gl.enableVertexAttribArray(index);
    gl.vertexAttribPointer(index, width, gl.FLOAT, false, 0, 0);
  };
  attribute(0, floatsOf(geometry.positions), 3);
  attribute(1, floatsOf(geometry.normals), 3);
  let count = geometry.vertices, isMesh = 'indices' in geometry;
  if (isMesh) {
    const indices = uintsOf(geometry.indices);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    count = indices.length;
  } else {
    attribute(2, floatsOf(geometry.radii), 1);
  }
  gl.bindVertexArray(null);
  return { vao, count, isMesh, description: geometry.description };
}

let programs, coarse, detail;
try {
  const s = scene.shaders;
  programs = {
    mesh: program(s.mesh_vertex, s.mesh_fragment, 'mesh'),
    apo: program(s.mesh_vertex, s.apo_fragment, 'APO'),
    points: program(s.point_vertex, s.point_fragment, 'points'),
    heat: program(s.screen_vertex, s.heat_fragment, 'heat map'),
  };
  coarse = upload(scene.coarse);
  detail = upload(scene.detail);
} catch (e) {
  console.error(String(e));
  fallBack('The viewer could not set up WebGL2: ' + e.message);
  return;
}

const apoTexture = gl.createTexture();
gl.activeTexture(gl.TEXTURE0);
gl.bindTexture(gl.TEXTURE_2D, apoTexture);
gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8UI, scene.apo.width, scene.apo.height, 0, gl.RGBA_INTEGER, gl.UNSIGNED_BYTE,
              bytesOf(scene.apo.texels));

// A target as the OSMesa context's: shaded RGBA8, normal and coverage RGBA32F, depth.
function makeTarget(width, height) {
  const framebuffer = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
  const attach = (format, attachment) => {
    const texture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.texStorage2D(gl.TEXTURE_2D, 1, format, width, height);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, attachment, gl.TEXTURE_2D, texture, 0);
    return texture;
  };
  const shaded = attach(gl.RGBA8, gl.COLOR_ATTACHMENT0), normals = attach(gl.RGBA32F, gl.COLOR_ATTACHMENT1);
  const depth = gl.createRenderbuffer();
  gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
  gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, width, height);
  gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
  gl.drawBuffers([gl.COLOR_ATTACHMENT0, gl.COLOR_ATTACHMENT1]);
  const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  if (status !== gl.FRAMEBUFFER_COMPLETE) throw new Error('framebuffer incomplete: ' + status);
  return { framebuffer, shaded, normals, width, height };
}
const targets = new Map();
function target(key, width, height) {
  const found = targets.get(key);
  if (found && found.width === width && found.height === height) return found;
  const made = makeTarget(width, height);
  targets.set(key, made);
  return made;
}

function setUniform(p, u) {
  const at = gl.getUniformLocation(p, u.name);
  if (u.type === '1i') gl.uniform1i(at, u.values[0]);
  else if (u.type === '1ui') gl.uniform1ui(at, u.values[0]);
  else if (u.type === '1f') gl.uniform1f(at, u.values[0]);
  else if (u.type === '3f') gl.uniform3f(at, u.values[0], u.values[1], u.values[2]);
}

// ---- state ------------------------------------------------------------------
const state = {
  camera: null, viewIndex: 0, mode: 'apo',
  filtering: scene.filtering, mipmapping: scene.mipmapping,
  headlight: true, lightAzimuth: 30, lightElevation: 30,
  frameTimes: [], moving: false,
};
const copyView = v => ({ eye: v.eye.slice(), target: v.target.slice(), up: v.up.slice(), fov: v.fov, near: v.near, far: v.far });

// The light as a world direction, from its angles about the camera's axes.
function lightDirection(c) {
  if (state.headlight) return [0, 0, 0];
  const back = normalize(sub(c.eye, c.target)), side = normalize(cross(c.up, back)), up = cross(back, side);
  const a = state.lightAzimuth * Math.PI / 180, e = state.lightElevation * Math.PI / 180;
  return normalize(add(add(scale(back, Math.cos(e) * Math.cos(a)), scale(side, Math.cos(e) * Math.sin(a))), scale(up, Math.sin(e))));
}

// One pass into `t`: 'apo' (m with the APO), 'coarse' (m alone), 'detail' (M).
function drawPass(pass, c, t) {
  gl.bindFramebuffer(gl.FRAMEBUFFER, t.framebuffer);
  gl.viewport(0, 0, t.width, t.height);
  gl.clearBufferfv(gl.COLOR, 0, [1, 1, 1, 1]);
  gl.clearBufferfv(gl.COLOR, 1, [0, 0, 0, 0]);
  gl.clearBufferfv(gl.DEPTH, 0, [1]);
  gl.enable(gl.DEPTH_TEST);
  const geometry = pass === 'detail' ? detail : coarse;
  const p = pass === 'apo' ? programs.apo : geometry.isMesh ? programs.mesh : programs.points;
  gl.useProgram(p);
  gl.uniformMatrix4fv(gl.getUniformLocation(p, 'viewProjection'), false, viewProjection(c, t.width / t.height));
  gl.uniform3fv(gl.getUniformLocation(p, 'eye'), c.eye);
  gl.uniform3fv(gl.getUniformLocation(p, 'light'), lightDirection(c));
  gl.uniform1f(gl.getUniformLocation(p, 'pixelsPerWorldUnitAtOne'), pixelsPerWorldUnitAtOne(c, t.height));
  if (pass === 'apo') {
    scene.apo.uniforms.forEach(u => setUniform(p, u));
    gl.uniform1i(gl.getUniformLocation(p, 'apoTexture'), 0);
    gl.uniform1i(gl.getUniformLocation(p, 'mipmapping'), state.mipmapping ? 1 : 0);
    // While the camera moves, unfiltered (a quarter of the time in a software
    // WebGL); the frame drawn once it rests is as set.
    gl.uniform1i(gl.getUniformLocation(p, 'filtering'), state.filtering && !state.moving ? 1 : 0);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, apoTexture);
  }
  gl.bindVertexArray(geometry.vao);
  if (geometry.isMesh) gl.drawElements(gl.TRIANGLES, geometry.count, gl.UNSIGNED_INT, 0);
  else gl.drawArrays(gl.POINTS, 0, geometry.count);
  gl.bindVertexArray(null);
}

// The current mode drawn on the canvas.
function drawFrame(c) {
  const w = canvas.width, h = canvas.height;
  if (state.mode === 'heat') {
    const apo = target('apo', w, h), reference = target('reference', w, h);
    drawPass('apo', c, apo);
    drawPass('detail', c, reference);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, w, h);
    gl.disable(gl.DEPTH_TEST);
    gl.useProgram(programs.heat);
    gl.activeTexture(gl.TEXTURE1);
    gl.bindTexture(gl.TEXTURE_2D, apo.normals);
    gl.activeTexture(gl.TEXTURE2);
    gl.bindTexture(gl.TEXTURE_2D, reference.normals);
    gl.uniform1i(gl.getUniformLocation(programs.heat, 'apoNormals'), 1);
    gl.uniform1i(gl.getUniformLocation(programs.heat, 'referenceNormals'), 2);
    gl.uniform1f(gl.getUniformLocation(programs.heat, 'heatMapDegrees'), scene.heat_map_degrees);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    return;
  }
  const t = target('screen', w, h);
  drawPass(state.mode, c, t);
  gl.bindFramebuffer(gl.READ_FRAMEBUFFER, t.framebuffer);
  gl.readBuffer(gl.COLOR_ATTACHMENT0);
  gl.bindFramebuffer(gl.DRAW_FRAMEBUFFER, null);
  gl.blitFramebuffer(0, 0, w, h, 0, 0, w, h, gl.COLOR_BUFFER_BIT, gl.NEAREST);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
}

// A frame's time includes the rasteriser's work: reading one pixel waits for it.
function timedFrame() {
  const start = performance.now();
  drawFrame(state.camera);
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
  return performance.now() - start;
}
const median = values => { const s = values.slice().sort((a, b) => a - b); return s[s.length >> 1]; };

let pending = false;
function redraw() {
  if (pending) return;
  pending = true;
  requestAnimationFrame(() => {
    pending = false;
    state.frameTimes.push(timedFrame());
    if (state.frameTimes.length > 15) state.frameTimes.shift();
    showReadout();
  });
}

function showReadout() {
  const c = state.camera, where = state.viewIndex >= 0 ? 'view ' + state.viewIndex + ' (' + scene.views[state.viewIndex].label + ')' : 'free camera';
  const geometry = state.mode === 'detail' ? detail : coarse;
  document.getElementById('readout').textContent =
      'frame: ' + median(state.frameTimes).toFixed(1) + ' ms (median of the last ' + state.frameTimes.length + ')\n' +
      canvas.width + ' x ' + canvas.height + ' px, ' + where + '\n' +
      'distance ' + length(sub(c.eye, c.target)).toPrecision(4) + '\n' +
      (state.moving && state.filtering ? '(unfiltered while moving) ' : '') +
      (state.mode === 'heat' ? 'heat map: APO against M, 0 (dark) to ' + scene.heat_map_degrees + '+ degrees (yellow); grey: one of the two only'
                             : state.mode === 'apo' ? 'm with the APO' : geometry.description);
}

function setView(i) {
  state.viewIndex = i;
  state.camera = copyView(scene.views[i]);
  state.moving = false;
  document.querySelectorAll('#views button').forEach((b, k) => b.classList.toggle('current', k === i));
  redraw();
}

// ---- interaction ------------------------------------------------------------
function freeCamera() {
  if (state.viewIndex < 0) return;
  state.viewIndex = -1;
  document.querySelectorAll('#views button').forEach(b => b.classList.remove('current'));
}
// Near and far planes around the object, wherever the eye has moved.
function fitPlanes(c) {
  const d = length(sub(c.eye, c.target)), r = scene.radius;
  c.near = Math.max(d - 1.5 * r, 1e-3 * r);
  c.far = d + 1.5 * r;
}
function orbit(dx, dy) {
  const c = state.camera, up = normalize(c.up);
  let back = rotate(sub(c.eye, c.target), up, -dx * 0.008);  // about the screen's vertical
  const side = normalize(cross(up, back));
  back = rotate(back, side, -dy * 0.008);                     // about its horizontal
  c.up = normalize(rotate(up, side, -dy * 0.008));
  c.eye = add(c.target, back);
}
function pan(dx, dy) {
  const c = state.camera, back = sub(c.eye, c.target), d = length(back);
  const side = normalize(cross(c.up, back)), up = normalize(cross(back, side));
  // Pointer moves are in CSS pixels: the canvas may be shown smaller than its 1024 x 768.
  const perPixel = 2 * d * Math.tan(0.5 * c.fov * Math.PI / 180) / canvas.clientHeight;
  const move = add(scale(side, -dx * perPixel), scale(up, dy * perPixel));
  c.eye = add(c.eye, move);
  c.target = add(c.target, move);
}
function zoom(factor) {
  const c = state.camera;
  c.eye = add(c.target, scale(sub(c.eye, c.target), factor));
  fitPlanes(c);
}

// The camera is moving until a quarter second without a move.
let restTimer = 0;
function moved() {
  state.moving = true;
  clearTimeout(restTimer);
  restTimer = setTimeout(() => { state.moving = false; redraw(); }, 250);
  redraw();
}

let dragging = null;
canvas.addEventListener('contextmenu', e => e.preventDefault());
canvas.addEventListener('pointerdown', e => {
  dragging = { x: e.clientX, y: e.clientY, panning: e.shiftKey || e.button !== 0 };
  try { canvas.setPointerCapture(e.pointerId); } catch (error) { /* a pointer the page did not see go down */ }
});
canvas.addEventListener('pointermove', e => {
  if (!dragging) return;
  const dx = e.clientX - dragging.x, dy = e.clientY - dragging.y;
  dragging.x = e.clientX;
  dragging.y = e.clientY;
  freeCamera();
  if (dragging.panning) pan(dx, dy);
  else orbit(dx, dy);
  fitPlanes(state.camera);
  moved();
});
canvas.addEventListener('pointerup', () => { dragging = null; });
canvas.addEventListener('wheel', e => {
  e.preventDefault();
  freeCamera();
  zoom(Math.exp(e.deltaY * 0.001));
  moved();
}, { passive: false });

function buildControls() {
  const views = document.getElementById('views');
  scene.views.forEach((v, i) => {
    const b = document.createElement('button');
    b.type = 'button';
    b.textContent = i + ' ' + v.label;
    b.title = 'view ' + i + ' (' + v.label + ')' + (v.sees_scanned_side === false ? ': the unscanned side, back faces tinted' :
                                                      v.sees_scanned_side ? ': the scanned side' : '');
    if (v.sees_scanned_side === false) b.classList.add('unscanned');
    b.addEventListener('click', () => setView(i));
    views.append(b);
  });
  document.querySelectorAll('input[name=mode]').forEach(input => {
    const needsDetail = input.value === 'detail' || input.value === 'heat';
    if (needsDetail && !detail) input.disabled = true;
    input.addEventListener('change', () => { state.mode = input.value; state.frameTimes = []; redraw(); });
  });
  document.getElementById('detail-label').textContent = detail ? detail.description : 'M (not in this run)';
  const bind = (id, key, parse) => {
    const input = document.getElementById(id);
    if (input.type === 'checkbox') input.checked = state[key];
    else input.value = state[key];
    input.addEventListener('input', () => { state[key] = parse(input); redraw(); });
  };
  bind('filtering', 'filtering', i => i.checked);
  bind('mipmapping', 'mipmapping', i => i.checked);
  bind('headlight', 'headlight', i => i.checked);
  bind('azimuth', 'lightAzimuth', i => Number(i.value));
  bind('elevation', 'lightElevation', i => Number(i.value));
}

// ---- for the tests and benchmarks -------------------------------------------
function base64OfBytes(bytes) {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}
window.apoViewer = {
  ready: true,
  views: scene.views.length,
  setView,
  setFiltering(on) {
    state.filtering = on;
    document.getElementById('filtering').checked = on;
    redraw();
  },
  setMode(mode) {
    state.mode = mode;
    document.querySelectorAll('input[name=mode]').forEach(input => { input.checked = input.value === mode; });
    redraw();
  },
  // The normal buffer of `pass` ('apo', 'coarse', 'detail') at view i, drawn
  // at size x size under the headlight, with `options` ({filtering,
  // mipmapping}) in place of the page's switches: base64 of float32 RGBA
  // rows, bottom row first (GL's order).
  normals(i, size, pass, options) {
    const saved = Object.assign({}, state);
    Object.assign(state, { headlight: true, moving: false }, options || {});
    try {
      const t = target('probe', size, size);
      drawPass(pass || 'apo', copyView(scene.views[i]), t);
      gl.bindFramebuffer(gl.READ_FRAMEBUFFER, t.framebuffer);
      gl.readBuffer(gl.COLOR_ATTACHMENT1);
      const out = new Float32Array(4 * size * size);
      gl.readPixels(0, 0, size, size, gl.RGBA, gl.FLOAT, out);
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      return base64OfBytes(new Uint8Array(out.buffer));
    } finally {
      Object.assign(state, saved);
    }
  },
  // The median time of `frames` frames of the current mode and camera.
  timeFrames(frames) {
    const times = [];
    for (let k = 0; k < frames; ++k) times.push(timedFrame());
    return median(times);
  },
  camera() { return copyView(state.camera); },
  glError() { return gl.getError(); },
};

buildControls();
setView(0);
})();
)JS";

constexpr const char* kViewerBody = R"(
<div id="viewer">
<canvas id="canvas" width="1024" height="768"></canvas>
<div id="controls">
<fieldset><legend>Show</legend>
<label><input type="radio" name="mode" value="apo" checked> m with the APO</label>
<label><input type="radio" name="mode" value="coarse"> m alone (its own normals)</label>
<label><input type="radio" name="mode" value="detail"> <span id="detail-label">M</span></label>
<label><input type="radio" name="mode" value="heat"> heat map: APO against M</label>
</fieldset>
<fieldset><legend>Views</legend><div id="views"></div>
<p class="hint">Drag: orbit. Shift-drag or right-drag: pan. Wheel: zoom. A view's button resets to it; in red, a
one-sided scan's views of its unscanned side (back faces tinted).</p></fieldset>
<fieldset><legend>APO</legend>
<label><input type="checkbox" id="filtering"> trilinear filtering (paper 5.3)</label>
<label><input type="checkbox" id="mipmapping"> mip-mapping (paper 5.2)</label>
</fieldset>
<fieldset><legend>Light</legend>
<label><input type="checkbox" id="headlight"> headlight (as the static images)</label>
<label>azimuth <input type="range" id="azimuth" min="-180" max="180" step="1"></label>
<label>elevation <input type="range" id="elevation" min="-90" max="90" step="1"></label>
</fieldset>
<div id="readout"></div>
</div>
</div>
<div id="fallback" hidden>
<p class="warning" id="why"></p>
<div id="fallback-images"></div>
</div>
<noscript><p class="warning">Scripts are off, so the interactive view cannot run: the report shows the static views.</p></noscript>
)";

}  // namespace

std::string viewerHtml(const ViewerScene& scene, std::string_view scanName, const std::vector<std::string>& staticImages) {
  const std::string title = htmlEscape(fmt::format("{}: interactive view", scanName));
  std::string html = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  html += fmt::format("<meta http-equiv=\"Content-Security-Policy\" content=\"{}\">\n", kViewerSecurityPolicy);
  html += "<title>" + title + "</title>\n<style>" + std::string(kViewerStyle) + "</style>\n</head>\n<body>\n";
  html += "<h1>" + title + "</h1>\n";
  html += kViewerBody;
  html += "<script type=\"application/json\" id=\"apo-scene\">" + scriptSafe(sceneJson(scene, scanName, staticImages).dump(-1, ' ', false, Json::error_handler_t::replace)) +
          "</script>\n";
  html += "<script>" + std::string(kViewerScript) + "</script>\n</body>\n</html>\n";
  return html;
}

}  // namespace apo
