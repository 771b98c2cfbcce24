#!/usr/bin/env node
// SPDX-License-Identifier: BSD-3-Clause
// Reference per-element bounding boxes (and parse+mesh time) from web-ifc for plumb's IFC tests.
//
//   npm install --prefix /tmp/webifc web-ifc        # outside the repository
//   WEBIFC_DIR=/tmp/webifc node scripts/ifc_golden/webifc_bbox.cjs MODEL.ifc [OUT.json] [--time N]
//
// Output: {"file", "webifc_version", "elements": {"<express id>": {"type", "bbox": [[minx,miny,minz],[maxx,maxy,maxz]]}}}
// in the IFC world frame in metres (web-ifc meshes are Y-up: IFC (x, y, z) = web-ifc (x, -z, y)).
// Only walls, slabs, doors, windows, beams and columns are written. With --time N it prints the
// median of N OpenModel + StreamAllMeshes runs in milliseconds instead.
const fs = require('fs');
const path = require('path');
const dir = process.env.WEBIFC_DIR || '/tmp/webifc';
const WebIFC = require(path.join(dir, 'node_modules', 'web-ifc'));

const KEEP = ['IFCWALL', 'IFCWALLSTANDARDCASE', 'IFCSLAB', 'IFCDOOR', 'IFCWINDOW', 'IFCBEAM', 'IFCCOLUMN'];

async function main() {
  const args = process.argv.slice(2);
  const model = args[0];
  const timeIdx = args.indexOf('--time');
  const data = new Uint8Array(fs.readFileSync(model));
  const api = new WebIFC.IfcAPI();
  await api.Init();
  if (timeIdx >= 0) {
    const n = parseInt(args[timeIdx + 1] || '5', 10);
    const times = [];
    for (let r = 0; r < n; ++r) {
      const t0 = process.hrtime.bigint();
      const id = api.OpenModel(data);
      let tris = 0;
      api.StreamAllMeshes(id, (mesh) => {
        for (let i = 0; i < mesh.geometries.size(); ++i) {
          const g = api.GetGeometry(id, mesh.geometries.get(i).geometryExpressID);
          tris += g.GetIndexDataSize() / 3;
        }
      });
      api.CloseModel(id);
      times.push(Number(process.hrtime.bigint() - t0) / 1e6);
    }
    times.sort((a, b) => a - b);
    console.log(JSON.stringify({file: model, runs: n, median_ms: times[Math.floor(n / 2)], all_ms: times}));
    return;
  }
  const id = api.OpenModel(data);
  const typeOf = {};
  for (const name of KEEP) {
    const code = WebIFC[name];
    if (code === undefined) continue;
    const ids = api.GetLineIDsWithType(id, code);
    for (let i = 0; i < ids.size(); ++i) typeOf[ids.get(i)] = name;
  }
  const elements = {};
  api.StreamAllMeshes(id, (mesh) => {
    const type = typeOf[mesh.expressID];
    if (!type) return;
    const lo = [Infinity, Infinity, Infinity];
    const hi = [-Infinity, -Infinity, -Infinity];
    for (let i = 0; i < mesh.geometries.size(); ++i) {
      const pg = mesh.geometries.get(i);
      const g = api.GetGeometry(id, pg.geometryExpressID);
      const v = api.GetVertexArray(g.GetVertexData(), g.GetVertexDataSize());
      const m = pg.flatTransformation;  // column-major 4x4
      for (let k = 0; k + 5 < v.length; k += 6) {
        const x = v[k], y = v[k + 1], z = v[k + 2];
        const wx = m[0] * x + m[4] * y + m[8] * z + m[12];
        const wy = m[1] * x + m[5] * y + m[9] * z + m[13];
        const wz = m[2] * x + m[6] * y + m[10] * z + m[14];
        const p = [wx, -wz, wy];  // Y-up -> IFC Z-up
        for (let c = 0; c < 3; ++c) {
          lo[c] = Math.min(lo[c], p[c]);
          hi[c] = Math.max(hi[c], p[c]);
        }
      }
    }
    if (lo[0] <= hi[0]) {
      const r = (x) => Math.round(x * 1e6) / 1e6;
      elements[mesh.expressID] = {type, bbox: [lo.map(r), hi.map(r)]};
    }
  });
  api.CloseModel(id);
  let version = 'unknown';
  try {
    version = JSON.parse(fs.readFileSync(path.join(dir, 'node_modules', 'web-ifc', 'package.json'))).version;
  } catch (e) { /* keep unknown */ }
  const out = JSON.stringify({file: path.basename(model), webifc_version: version, elements}, null, 1);
  if (args[1] && !args[1].startsWith('--')) fs.writeFileSync(args[1], out + '\n'); else console.log(out);
}
main().catch((e) => { console.error(e); process.exit(1); });
