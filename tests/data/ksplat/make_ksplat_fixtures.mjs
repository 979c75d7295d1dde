// Writes the .ksplat fixtures of tests/data/ksplat/ with GaussianSplats3D's own converter (its PlyLoader and
// SplatBuffer, the code its create-ksplat utility calls), from the shipped PLY scenes:
//
//   guitar_256_l0.ksplat, _l1, _l2   tests/data/interop/guitar_256.ply (256 Gaussians, SH degree 0) at
//                                    compression levels 0, 1 and 2
//   guitar_sh3_1024_l0_sh1.ksplat    the first 1,024 Gaussians of tests/data/guitar_sh3.ply, level 0, SH degree 1
//   guitar_sh3_1024_l1_sh2.ksplat    the same, level 1, SH degree 2, in sections of 400 Gaussians (3 sections)
//   guitar_sh3_1024_l2_sh2.ksplat    the same, level 2 (SH rest as 8 bits), SH degree 2
//
// Every Gaussian is kept (minimum alpha 0, where the package's default 1 drops those of alpha byte 0), so the
// counts equal the source's. Buckets: the package's defaults (block size 5, 256 Gaussians a bucket), which leave
// partially filled buckets in every file of level 1 or 2. The package writes SH degree 2 at most from a PLY.
// The licence of the fixtures is the sample's (samples/guitar.ply: README "Sample data").
//
//   npm install --prefix .ksplat_node @mkkellogg/gaussian-splats-3d@0.4.7 three@0.170.0
//   node tests/data/ksplat/make_ksplat_fixtures.mjs .ksplat_node [OUT_DIR]    # OUT_DIR: tests/data/ksplat
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const here = path.dirname(new URL(import.meta.url).pathname);
const root = path.resolve(here, '..', '..', '..');
const prefix = path.resolve(process.argv[2] || '.ksplat_node');
const out = path.resolve(process.argv[3] || here);
const pkg = path.join(prefix, 'node_modules', '@mkkellogg', 'gaussian-splats-3d');
const entry = JSON.parse(fs.readFileSync(path.join(pkg, 'package.json'), 'utf8')).module;
// The loaders defer their work with window.setTimeout, the one browser global they use on this path.
globalThis.window ??= { setTimeout };
const { PlyLoader } = await import(pathToFileURL(path.join(pkg, entry)).href);

// The first `count` vertices of a binary PLY with one element, as a new PLY (header count rewritten).
function firstVertices(bytes, count) {
  const end = bytes.indexOf('end_header\n') + 'end_header\n'.length;
  const header = bytes.subarray(0, end).toString('latin1');
  const total = Number(/element vertex (\d+)/.exec(header)[1]);
  const stride = (bytes.length - end) / total;
  const newHeader = Buffer.from(header.replace(/element vertex \d+/, `element vertex ${count}`), 'latin1');
  return Buffer.concat([newHeader, bytes.subarray(end, end + stride * count)]);
}

const guitar256 = fs.readFileSync(path.join(root, 'tests/data/interop/guitar_256.ply'));
const guitarSh3 = firstVertices(fs.readFileSync(path.join(root, 'tests/data/guitar_sh3.ply')), 1024);
const fixtures = [
  ['guitar_256_l0.ksplat', guitar256, 0, 0, 0],
  ['guitar_256_l1.ksplat', guitar256, 1, 0, 0],
  ['guitar_256_l2.ksplat', guitar256, 2, 0, 0],
  ['guitar_sh3_1024_l0_sh1.ksplat', guitarSh3, 0, 1, 0],
  ['guitar_sh3_1024_l1_sh2.ksplat', guitarSh3, 1, 2, 400],
  ['guitar_sh3_1024_l2_sh2.ksplat', guitarSh3, 2, 2, 0],
];
for (const [name, ply, level, shDegree, sectionSize] of fixtures) {
  const data = ply.buffer.slice(ply.byteOffset, ply.byteOffset + ply.length);
  // minimumAlpha, compressionLevel, optimizeSplatData (sections and buckets), SH degree, section size
  const splatBuffer = await PlyLoader.loadFromFileData(data, 0, level, true, shDegree, sectionSize);
  fs.writeFileSync(path.join(out, name), Buffer.from(splatBuffer.bufferData));
  console.log(`${name}: ${splatBuffer.getSplatCount()} Gaussians, ${splatBuffer.bufferData.byteLength} bytes`);
}
