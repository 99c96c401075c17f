// Reads a LAS file with @loaders.gl/las (an independent reader, pinned in
// package-lock.json) and prints what it found as JSON, for the LAS reader's
// cross-check (tests/ingest/las_reader_test.cpp). World coordinates in
// double; colours as loaders.gl turns 16-bit channels into bytes.
// Usage: node tests/ingest/loadersgl_las.mjs FILE.las
// Exit 0 with the JSON; exit 3 with {"error": ...} when loaders.gl refuses.
import {parse} from '@loaders.gl/core';
import {LASLoader} from '@loaders.gl/las';
import {readFileSync} from 'node:fs';

const bytes = readFileSync(process.argv[2]);
try {
  const las = await parse(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength), LASLoader, {
    las: {fp64: true, skip: 1, colorDepth: 'auto'},
    worker: false,
  });
  const attribute = (name) => (las.attributes[name] ? Array.from(las.attributes[name].value) : null);
  const rgba = attribute('COLOR_0');
  process.stdout.write(JSON.stringify({
    points: las.header.vertexCount,
    positions: attribute('POSITION'),
    intensity: attribute('intensity'),
    classification: attribute('classification'),
    colors: rgba ? rgba.filter((_, i) => i % 4 !== 3) : null,
  }));
} catch (error) {
  process.stdout.write(JSON.stringify({error: String(error)}));
  process.exit(3);
}
