// Decompresses a LAZ file with laz-perf (the LAZperf C++ decoder compiled to
// WASM, pinned in package-lock.json) and prints what it found as JSON, for
// the LAZ decoder's cross-check (tests/ingest/laz_reader_test.cpp) and its
// speed figure: the point count, the record length, the SHA-256 of all the
// decompressed point records end to end (the bytes an uncompressed LAS file
// would hold after its header and VLRs) and the seconds the decoding took
// (the best of --repeat runs; opening the file included, reading it from
// disk and hashing not).
// Usage: node tests/ingest/lazperf_decode.mjs FILE.laz [--repeat N]
// Exit 0 with the JSON; exit 3 with {"error": ...} when laz-perf refuses.
import {createLazPerf} from 'laz-perf';
import {createHash} from 'node:crypto';
import {readFileSync} from 'node:fs';

const file = process.argv[2];
const repeatAt = process.argv.indexOf('--repeat');
const repeats = repeatAt > 0 ? Number(process.argv[repeatAt + 1]) : 1;

// One full decompression into a fresh buffer; laz-perf reads the whole file
// from WASM memory and hands back one record per getPoint.
function decode(lazPerf, filePointer, fileLength) {
  const laszip = new lazPerf.LASZip();
  try {
    laszip.open(filePointer, fileLength);
    const count = laszip.getCount();
    const recordLength = laszip.getPointLength();
    const records = new Uint8Array(count * recordLength);
    const pointPointer = lazPerf._malloc(recordLength);
    try {
      for (let i = 0; i < count; ++i) {
        laszip.getPoint(pointPointer);
        records.set(lazPerf.HEAPU8.subarray(pointPointer, pointPointer + recordLength), i * recordLength);
      }
    } finally {
      lazPerf._free(pointPointer);
    }
    return {count, recordLength, records};
  } finally {
    laszip.delete();
  }
}

try {
  const bytes = readFileSync(file);
  const lazPerf = await createLazPerf();
  const filePointer = lazPerf._malloc(bytes.length);
  lazPerf.HEAPU8.set(bytes, filePointer);
  let best = Infinity;
  let result;
  for (let run = 0; run < repeats; ++run) {
    const start = process.hrtime.bigint();
    result = decode(lazPerf, filePointer, bytes.length);
    best = Math.min(best, Number(process.hrtime.bigint() - start) / 1e9);
  }
  lazPerf._free(filePointer);
  process.stdout.write(JSON.stringify({
    points: result.count,
    recordLength: result.recordLength,
    sha256: createHash('sha256').update(result.records).digest('hex'),
    seconds: best,
  }));
} catch (error) {
  process.stdout.write(JSON.stringify({error: String(error?.message ?? error)}));
  process.exit(3);
}
