#!/usr/bin/env node
// SPDX-License-Identifier: BSD-3-Clause
// Reference per-element surface areas from web-ifc: a check, beyond bounding boxes, that openings
// (IfcRelVoidsElement) were cut out of their walls.
//
//   WEBIFC_DIR=/tmp/webifc node scripts/ifc_golden/webifc_area.cjs MODEL.ifc [OUT.json]
//
// Output: {"file", "webifc_version", "elements": {"<express id>": {"type", "area", "triangles"}}}, area
// in square metres of the element's triangles (transformed to the IFC world frame), for walls,
// slabs, doors, windows, beams and columns.
const fs = require('fs');
const path = require('path');
const dir = process.env.WEBIFC_DIR || '/tmp/webifc';
const WebIFC = require(path.join(dir, 'node_modules', 'web-ifc'));

const KEEP = ['IFCWALL', 'IFCWALLSTANDARDCASE', 'IFCSLAB', 'IFCDOOR', 'IFCWINDOW', 'IFCBEAM', 'IFCCOLUMN'];

async function main() {
  const args = process.argv.slice(2);
  const model = args[0];
  const api = new WebIFC.IfcAPI();
  await api.Init();
  const id = api.OpenModel(new Uint8Array(fs.readFileSync(model)));
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
    let area = 0;
    let triangles = 0;
    for (let i = 0; i < mesh.geometries.size(); ++i) {
      const pg = mesh.geometries.get(i);
      const g = api.GetGeometry(id, pg.geometryExpressID);
      const v = api.GetVertexArray(g.GetVertexData(), g.GetVertexDataSize());
      const idx = api.GetIndexArray(g.GetIndexData(), g.GetIndexDataSize());
      const m = pg.flatTransformation;  // column-major 4x4
      const P = (k) => {
        const x = v[6 * k], y = v[6 * k + 1], z = v[6 * k + 2];
        return [m[0] * x + m[4] * y + m[8] * z + m[12], m[1] * x + m[5] * y + m[9] * z + m[13],
                m[2] * x + m[6] * y + m[10] * z + m[14]];
      };
      for (let t = 0; t + 2 < idx.length; t += 3) {
        const a = P(idx[t]), b = P(idx[t + 1]), c = P(idx[t + 2]);
        const u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        const w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        const n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
        area += 0.5 * Math.hypot(n[0], n[1], n[2]);
        ++triangles;
      }
    }
    elements[mesh.expressID] = {type, area: Math.round(area * 1e6) / 1e6, triangles};
  });
  api.CloseModel(id);
  let version = 'unknown';
  try {
    version = JSON.parse(fs.readFileSync(path.join(dir, 'node_modules', 'web-ifc', 'package.json'))).version;
  } catch (e) { /* keep unknown */ }
  const out = JSON.stringify({file: path.basename(model), webifc_version: version, elements}, null, 1);
  if (args[1]) fs.writeFileSync(args[1], out + '\n'); else console.log(out);
}
main().catch((e) => { console.error(e); process.exit(1); });
