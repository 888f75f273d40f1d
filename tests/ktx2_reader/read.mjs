// Reads KTX2 files with ktx-parse and prints, for each, what the tests compare (one JSON object per file, in
// the order given): the header fields, the data format descriptor, the key/value data (text values as text,
// others as base64), the levels' bytes (base64), and the ktx-parse constants the fields are checked against.
// Usage: node read.mjs FILE...
import { readFileSync } from 'node:fs';
import * as ktx from 'ktx-parse';

const constantNames = Object.keys(ktx).filter(
  (name) => /^(VK_FORMAT_R(16|32)(G(16|32))?(B(16|32)A(16|32))?_SFLOAT|KHR_DF_|KHR_SUPERCOMPRESSION_NONE)/.test(name),
);
const constants = Object.fromEntries(constantNames.map((name) => [name, ktx[name]]));
const base64 = (bytes) => Buffer.from(bytes.buffer, bytes.byteOffset, bytes.byteLength).toString('base64');

const out = process.argv.slice(2).map((path) => {
  const container = ktx.read(new Uint8Array(readFileSync(path)));
  const keyValue = {};
  for (const [key, value] of Object.entries(container.keyValue)) {
    keyValue[key] = typeof value === 'string' ? value : { base64: base64(value) };
  }
  return {
    vkFormat: container.vkFormat,
    typeSize: container.typeSize,
    pixelWidth: container.pixelWidth,
    pixelHeight: container.pixelHeight,
    pixelDepth: container.pixelDepth,
    layerCount: container.layerCount,
    faceCount: container.faceCount,
    levelCount: container.levelCount,
    supercompressionScheme: container.supercompressionScheme,
    dataFormatDescriptor: container.dataFormatDescriptor,
    keyValue,
    levels: container.levels.map((level) => ({
      data: base64(level.levelData),
      uncompressedByteLength: level.uncompressedByteLength,
    })),
  };
});
process.stdout.write(JSON.stringify({ files: out, constants }));
