// Writes OUT.html: a page that compiles and links the APO pass's WebGL2
// shaders (render.h webglApoShaders) in the browser, draws one triangle
// with a one-texel APO bound, and puts the outcome in document.title: "ok",
// or the stage that failed and the browser's log. tests/render/
// webgl_shaders_check.py opens it in headless Chromium.
#include "render/render.h"

#include "core/file_io.h"

#include <nlohmann/json.hpp>

#include <cstdio>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: write_webgl_shaders OUT.html\n");
    return 1;
  }
  const apo::ShaderSources sources = apo::webglApoShaders();
  const std::string page = R"(<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>pending</title></head><body>
<canvas id="c" width="64" height="64"></canvas>
<script>
const vertexSource = )" + nlohmann::json(sources.vertex).dump() + R"(;
const fragmentSource = )" + nlohmann::json(sources.fragment).dump() + R"(;
function run() {
  const gl = document.getElementById('c').getContext('webgl2');
  if (!gl) return 'no WebGL2';
  const compile = (type, source, name) => {
    const shader = gl.createShader(type);
    gl.shaderSource(shader, source);
    gl.compileShader(shader);
    if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw name + ': ' + gl.getShaderInfoLog(shader);
    return shader;
  };
  const program = gl.createProgram();
  gl.attachShader(program, compile(gl.VERTEX_SHADER, vertexSource, 'vertex shader'));
  gl.attachShader(program, compile(gl.FRAGMENT_SHADER, fragmentSource, 'fragment shader'));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw 'link: ' + gl.getProgramInfoLog(program);
  // One draw with a one-texel texture bound: the program runs, not only compiles.
  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8UI, 1, 1, 0, gl.RGBA_INTEGER, gl.UNSIGNED_BYTE, new Uint8Array([0, 0, 0, 0]));
  gl.useProgram(program);
  const buffer = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 0, 0, 0, 1, 1, -1, 0, 0, 0, 1, 0, 1, 0, 0, 0, 1]), gl.STATIC_DRAW);
  gl.enableVertexAttribArray(0);
  gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 24, 0);
  gl.enableVertexAttribArray(1);
  gl.vertexAttribPointer(1, 3, gl.FLOAT, false, 24, 12);
  gl.uniformMatrix4fv(gl.getUniformLocation(program, 'viewProjection'), false,
                      new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]));
  gl.uniform1f(gl.getUniformLocation(program, 'unitScale'), 0.5);
  gl.uniform3f(gl.getUniformLocation(program, 'unitOffset'), 0.5, 0.5, 0.5);
  gl.uniform1ui(gl.getUniformLocation(program, 'widthMask'), 0);
  gl.drawArrays(gl.TRIANGLES, 0, 3);
  const error = gl.getError();
  return error === gl.NO_ERROR ? 'ok' : 'draw: GL error ' + error;
}
try { document.title = run(); } catch (e) { document.title = String(e); }
</script></body></html>
)";
  const apo::Status written = apo::writeFileAtomically(argv[1], page);
  if (!written.ok()) {
    std::fprintf(stderr, "%s\n", written.error().message.c_str());
    return 1;
  }
  return 0;
}
