#!/usr/bin/env node
// SPDX-License-Identifier: BSD-3-Clause
// Write a ROS 2 bag in MCAP from a frame dump with Foxglove's MCAP and ROS 2 serialization
// libraries (@mcap/core, @foxglove/rosmsg2-serialization; pinned in package.json), for the tests
// of `plumb import`: the ROS 2 counterpart of tests/cli/bag_from_dump.py, with the same topics,
// frames and layouts: the first FRAMES LiDAR frames as sensor_msgs/msg/PointCloud2 on /points
// (frame "lidar"), imu.csv as sensor_msgs/msg/Imu on /imu (frame "imu"), odom.csv as
// nav_msgs/msg/Odometry on /odom and the extrinsics as tf2_msgs/msg/TFMessage on /tf_static; with
// --wheels also wheels.csv as sensor_msgs/msg/JointState on /joint_states (joints "caster",
// "wheel_left", "wheel_right": the wheel angles [rad], the caster at 0).
//
// Layouts of the clouds: "pcd" sends the PCD records as they are; "unusual" reorders the fields,
// pads point_step, stores x y z as float64 and splits the points in two rows with padding at each
// row's end; "unusual-be" is "unusual" with big-endian point data; "velodyne" is
// velodyne_pointcloud's PointXYZIRT (x y z, padding, intensity float32, ring uint16, time float32
// [s], point_step 32); "ouster" is ouster_ros's point (x y z, padding, intensity float32, t uint32
// [ns], reflectivity uint16, ring uint16, ambient uint16, range uint32, point_step 48) with a NaN
// point after every 7th one.
//
// usage: node mcap_from_dump.cjs DUMP OUT.mcap [--compression none|lz4|zstd] [--layout L]
//                               [--frames N] [--no-tf-static] [--unchunked] [--no-summary]
//                               [--cdr-be] [--wheels]
// --cdr-be writes the clouds in big-endian CDR (the rest stays little-endian, as ROS 2 writes).
// The node_modules come from NODE_PATH (scripts/setup.sh installs them in ~/.cache/plumb/mcap-writer).
'use strict';
const fs = require('fs');
const path = require('path');
const { McapWriter } = require('@mcap/core');
const { MessageWriter } = require('@foxglove/rosmsg2-serialization');
const { parse } = require('@foxglove/rosmsg');
const { CdrWriter, EncapsulationKind } = require('@foxglove/cdr');
const lz4 = require('lz4js');
const zstd = require('@foxglove/wasm-zstd');

const SEP = '\n' + '='.repeat(80) + '\n';
const HEADER = 'MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n';
const VECTOR3 = 'MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n';
const QUATERNION = 'MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n';
const POINT = 'MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n';
const DEFINITIONS = {
  'sensor_msgs/msg/PointCloud2': ['std_msgs/Header header\nuint32 height\nuint32 width\n' +
    'sensor_msgs/PointField[] fields\nbool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\n' +
    'bool is_dense\n', HEADER,
    'MSG: sensor_msgs/PointField\nuint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\n' +
    'uint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n'],
  'sensor_msgs/msg/Imu': ['std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n' +
    'float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n' +
    'float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n' +
    'float64[9] linear_acceleration_covariance\n', HEADER, QUATERNION, VECTOR3],
  'nav_msgs/msg/Odometry': ['std_msgs/Header header\nstring child_frame_id\n' +
    'geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n', HEADER,
    'MSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance\n',
    'MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n', POINT,
    QUATERNION, 'MSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\nfloat64[36] covariance\n',
    'MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n', VECTOR3],
  'sensor_msgs/msg/JointState': ['std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n' +
    'float64[] effort\n', HEADER],
  'tf2_msgs/msg/TFMessage': ['geometry_msgs/TransformStamped[] transforms\n',
    'MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\n' +
    'geometry_msgs/Transform transform\n', HEADER,
    'MSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n',
    VECTOR3, QUATERNION],
};
const PCD_TO_ROS = { I1: 1, U1: 2, I2: 3, U2: 4, I4: 5, U4: 6, F4: 7, F8: 8 };

function args() {
  const a = { compression: 'none', layout: 'pcd', frames: 1e9, tf: true, chunked: true, summary: true, cdrBe: false, wheels: false };
  const rest = process.argv.slice(2);
  const positional = [];
  for (let i = 0; i < rest.length; ++i) {
    const o = rest[i];
    if (o === '--compression') a.compression = rest[++i];
    else if (o === '--layout') a.layout = rest[++i];
    else if (o === '--frames') a.frames = Number(rest[++i]);
    else if (o === '--no-tf-static') a.tf = false;
    else if (o === '--unchunked') a.chunked = false;
    else if (o === '--no-summary') a.summary = false;
    else if (o === '--cdr-be') a.cdrBe = true;
    else if (o === '--wheels') a.wheels = true;
    else if (o.startsWith('--')) throw new Error('unknown option ' + o);
    else positional.push(o);
  }
  if (positional.length !== 2) throw new Error('usage: mcap_from_dump.cjs DUMP OUT.mcap [options]');
  if (!['none', 'lz4', 'zstd'].includes(a.compression)) throw new Error('--compression none|lz4|zstd');
  if (!['pcd', 'unusual', 'unusual-be', 'velodyne', 'ouster'].includes(a.layout)) {
    throw new Error('--layout pcd|unusual|unusual-be|velodyne|ouster');
  }
  [a.dump, a.out] = positional;
  return a;
}

function rosTime(stamp) {
  const ns = Math.round(stamp * 1e9);
  const sec = Math.floor(ns / 1e9);
  return { sec, nanosec: ns - sec * 1e9, ns: BigInt(ns) };
}

function rows(file) {
  return fs.readFileSync(file, 'utf8').split('\n').slice(1).filter((l) => l && !l.startsWith('#'))
    .map((l) => l.split(',').map(Number));
}

function csvRows(file) {
  return fs.readFileSync(file, 'utf8').split('\n').slice(1).filter((l) => l).map((l) => l.split(','));
}

// A binary PCD: field names, kinds ("F4", ...), the records and the number of points.
function readPcd(file) {
  const buf = fs.readFileSync(file);
  const head = {};
  let pos = 0;
  for (;;) {
    const end = buf.indexOf(10, pos);
    const line = buf.toString('ascii', pos, end).trim();
    pos = end + 1;
    if (line.startsWith('#')) continue;
    const [key, ...value] = line.split(/\s+/);
    head[key] = value;
    if (key === 'DATA') break;
  }
  if (head.DATA[0] !== 'binary') throw new Error(file + ': only binary PCD is sent');
  const kinds = head.TYPE.map((t, i) => t + head.SIZE[i]);
  const n = Number(head.POINTS[0]);
  const step = head.SIZE.reduce((s, v) => s + Number(v), 0);
  return { names: head.FIELDS, kinds, data: buf.subarray(pos, pos + n * step), n, step };
}

function read(view, kind, at) {
  switch (kind) {
    case 'F4': return view.getFloat32(at, true);
    case 'F8': return view.getFloat64(at, true);
    case 'U2': return view.getUint16(at, true);
    case 'U1': return view.getUint8(at);
    case 'I4': return view.getInt32(at, true);
    case 'U4': return view.getUint32(at, true);
    default: throw new Error('PCD kind ' + kind);
  }
}

function cloudMessage(stamp, pcd, layout) {
  const t = rosTime(stamp);
  const msg = { header: { stamp: { sec: t.sec, nanosec: t.nanosec }, frame_id: 'lidar' }, fields: [], is_dense: true };
  if (layout === 'pcd') {
    let offset = 0;
    pcd.names.forEach((name, i) => {
      msg.fields.push({ name, offset, datatype: PCD_TO_ROS[pcd.kinds[i]], count: 1 });
      offset += Number(pcd.kinds[i].slice(1));
    });
    Object.assign(msg, { height: 1, width: pcd.n, point_step: offset, row_step: offset * pcd.n, is_bigendian: false,
      data: new Uint8Array(pcd.data.buffer, pcd.data.byteOffset, pcd.data.length) });
    return msg;
  }
  // name, ROS type, offset: reordered, with gaps, x y z widened to float64.
  const fields = [['time', 7, 0], ['ring', 4, 8], ['z', 8, 12], ['intensity', 7, 20], ['x', 8, 24], ['y', 8, 32]];
  const pointStep = 48, rowPad = 16;
  const height = pcd.n % 2 === 0 ? 2 : 1, width = pcd.n / height;
  const rowStep = pointStep * width + rowPad;
  const out = new Uint8Array(rowStep * height).fill(0);
  const dst = new DataView(out.buffer);
  const src = new DataView(pcd.data.buffer, pcd.data.byteOffset, pcd.data.length);
  const little = layout !== 'unusual-be';
  const srcOffset = {};
  let o = 0;
  pcd.names.forEach((name, i) => { srcOffset[name] = [o, pcd.kinds[i]]; o += Number(pcd.kinds[i].slice(1)); });
  for (let r = 0; r < height; ++r) {
    for (let c = 0; c < width; ++c) {
      const p = r * width + c, at = r * rowStep + c * pointStep;
      for (const [name, type, offset] of fields) {
        const v = read(src, srcOffset[name][1], p * pcd.step + srcOffset[name][0]);
        if (type === 7) dst.setFloat32(at + offset, v, little);
        else if (type === 8) dst.setFloat64(at + offset, v, little);
        else dst.setUint16(at + offset, v, little);
      }
    }
    out.fill(0xab, r * rowStep + pointStep * width, (r + 1) * rowStep);
  }
  for (const [name, datatype, offset] of fields) msg.fields.push({ name, offset, datatype, count: 1 });
  Object.assign(msg, { height, width, point_step: pointStep, row_step: rowStep, is_bigendian: !little, data: out });
  return msg;
}

// name, ROS type, offset; point_step of the drivers' layouts.
const DRIVER_LAYOUTS = {
  velodyne: [[['x', 7, 0], ['y', 7, 4], ['z', 7, 8], ['intensity', 7, 16], ['ring', 4, 20], ['time', 7, 24]], 32],
  ouster: [[['x', 7, 0], ['y', 7, 4], ['z', 7, 8], ['intensity', 7, 16], ['t', 6, 20], ['reflectivity', 4, 24],
    ['ring', 4, 26], ['ambient', 4, 28], ['range', 6, 32]], 48],
};

function driverCloudMessage(stamp, pcd, layout) {
  const [fields, pointStep] = DRIVER_LAYOUTS[layout];
  const src = new DataView(pcd.data.buffer, pcd.data.byteOffset, pcd.data.length);
  const srcOffset = {};
  let o = 0;
  pcd.names.forEach((name, i) => { srcOffset[name] = [o, pcd.kinds[i]]; o += Number(pcd.kinds[i].slice(1)); });
  const value = (name, p) => read(src, srcOffset[name][1], p * pcd.step + srcOffset[name][0]);
  const keep = [];  // source point, or -1 for a NaN point (ouster: after every 7th)
  for (let i = 0; i < pcd.n; ++i) {
    if (layout === 'ouster' && i > 0 && i % 7 === 0) keep.push(-1);
    keep.push(i);
  }
  const out = new Uint8Array(pointStep * keep.length);
  const dst = new DataView(out.buffer);
  const offset = Object.fromEntries(fields.map(([name, , off]) => [name, off]));
  keep.forEach((p, k) => {
    const at = k * pointStep;
    if (p < 0) {
      for (const name of ['x', 'y', 'z']) dst.setFloat32(at + offset[name], NaN, true);
      return;
    }
    for (const name of ['x', 'y', 'z', 'intensity']) dst.setFloat32(at + offset[name], value(name, p), true);
    dst.setUint16(at + offset.ring, value('ring', p), true);
    if (layout === 'velodyne') {
      dst.setFloat32(at + offset.time, value('time', p), true);
    } else {
      dst.setUint32(at + offset.t, Math.round(value('time', p) * 1e9), true);
      dst.setUint16(at + offset.reflectivity, Math.min(Math.trunc(value('intensity', p)), 65535), true);
      const x = value('x', p), y = value('y', p), z = value('z', p);
      dst.setUint32(at + offset.range, Math.trunc(Math.sqrt(x * x + y * y + z * z) * 1000), true);
    }
  });
  const t = rosTime(stamp);
  return { header: { stamp: { sec: t.sec, nanosec: t.nanosec }, frame_id: 'lidar' },
    fields: fields.map(([name, datatype, off]) => ({ name, offset: off, datatype, count: 1 })),
    height: 1, width: keep.length, is_bigendian: false, point_step: pointStep, row_step: pointStep * keep.length,
    data: out, is_dense: layout !== 'ouster' };
}

// A PointCloud2 in big-endian CDR, written field by field (MessageWriter writes little-endian).
function cloudBigEndian(m) {
  const w = new CdrWriter({ kind: EncapsulationKind.CDR_BE, size: m.data.length + 4096 });
  w.int32(m.header.stamp.sec).uint32(m.header.stamp.nanosec).string(m.header.frame_id);
  w.uint32(m.height).uint32(m.width).sequenceLength(m.fields.length);
  for (const f of m.fields) w.string(f.name).uint32(f.offset).uint8(f.datatype).uint32(f.count);
  w.uint8(m.is_bigendian ? 1 : 0).uint32(m.point_step).uint32(m.row_step).uint8Array(m.data, true);
  w.uint8(m.is_dense ? 1 : 0);
  return w.data;
}

// x y z w of a rotation matrix (rows of a 4x4 row-major transform), Shepperd's method.
function quaternion(T) {
  const R = [[T[0], T[1], T[2]], [T[4], T[5], T[6]], [T[8], T[9], T[10]]];
  const t = R[0][0] + R[1][1] + R[2][2];
  if (t > 0) {
    const s = Math.sqrt(t + 1.0) * 2;
    return [(R[2][1] - R[1][2]) / s, (R[0][2] - R[2][0]) / s, (R[1][0] - R[0][1]) / s, 0.25 * s];
  }
  const i = [0, 1, 2].reduce((a, b) => (R[b][b] > R[a][a] ? b : a), 0);
  const j = (i + 1) % 3, k = (i + 2) % 3;
  const s = Math.sqrt(1.0 + R[i][i] - R[j][j] - R[k][k]) * 2;
  const q = [0, 0, 0];
  q[i] = 0.25 * s;
  q[j] = (R[j][i] + R[i][j]) / s;
  q[k] = (R[k][i] + R[i][k]) / s;
  return [q[0], q[1], q[2], (R[k][j] - R[j][k]) / s];
}

function transform(stamp, parent, child, T) {
  const t = rosTime(stamp);
  const [x, y, z, w] = quaternion(T);
  return { header: { stamp: { sec: t.sec, nanosec: t.nanosec }, frame_id: parent }, child_frame_id: child,
    transform: { translation: { x: T[3], y: T[7], z: T[11] }, rotation: { x, y, z, w } } };
}

async function main() {
  const a = args();
  const meta = JSON.parse(fs.readFileSync(path.join(a.dump, 'meta.json'), 'utf8'));
  const messages = [];  // [stamp, order, topic, message]
  const zero9 = new Array(9).fill(0), zero36 = new Array(36).fill(0);
  for (const [stamp, wx, wy, wz, ax, ay, az] of rows(path.join(a.dump, 'imu.csv'))) {
    const t = rosTime(stamp);
    messages.push([stamp, 1, '/imu', { header: { stamp: { sec: t.sec, nanosec: t.nanosec }, frame_id: 'imu' },
      orientation: { x: 0, y: 0, z: 0, w: 1 }, orientation_covariance: zero9,
      angular_velocity: { x: wx, y: wy, z: wz }, angular_velocity_covariance: zero9,
      linear_acceleration: { x: ax, y: ay, z: az }, linear_acceleration_covariance: zero9 }]);
  }
  for (const [stamp, x, y, theta] of rows(path.join(a.dump, 'odom.csv'))) {
    const t = rosTime(stamp);
    messages.push([stamp, 2, '/odom', { header: { stamp: { sec: t.sec, nanosec: t.nanosec }, frame_id: 'odom' },
      child_frame_id: 'base_link',
      pose: { pose: { position: { x, y, z: 0 }, orientation: { x: 0, y: 0, z: Math.sin(theta / 2), w: Math.cos(theta / 2) } },
        covariance: zero36 },
      twist: { twist: { linear: { x: 0, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0 } }, covariance: zero36 } }]);
  }
  if (a.wheels) {
    for (const [stamp, left, right] of rows(path.join(a.dump, 'wheels.csv'))) {
      const t = rosTime(stamp);
      messages.push([stamp, 4, '/joint_states', { header: { stamp: { sec: t.sec, nanosec: t.nanosec }, frame_id: '' },
        name: ['caster', 'wheel_left', 'wheel_right'], position: [0, left, right], velocity: [], effort: [] }]);
    }
  }
  const frames = csvRows(path.join(a.dump, 'frames.csv')).slice(0, a.frames);
  const first = Number(frames[0][1]);
  if (a.tf) {
    messages.push([first, 0, '/tf_static', { transforms: [transform(first, 'base_link', 'lidar', meta.T_base_lidar),
      transform(first, 'base_link', 'imu', meta.T_base_imu)] }]);
  }
  for (const [, stamp, name] of frames) {
    const make = DRIVER_LAYOUTS[a.layout] ? driverCloudMessage : cloudMessage;
    messages.push([Number(stamp), 3, '/points', make(Number(stamp), readPcd(path.join(a.dump, name)), a.layout)]);
  }
  messages.sort((p, q) => p[0] - q[0] || p[1] - q[1]);

  await zstd.isLoaded;
  const compressChunk = a.compression === 'lz4' ? (d) => ({ compression: 'lz4', compressedData: lz4.compress(d) })
    : a.compression === 'zstd' ? (d) => ({ compression: 'zstd', compressedData: zstd.compress(d, 3) })
      : undefined;
  const parts = [];
  let size = 0n;
  const writable = { position: () => size, write: async (b) => { parts.push(Buffer.from(b)); size += BigInt(b.byteLength); } };
  const writer = new McapWriter({ writable, useChunks: a.chunked, compressChunk, chunkSize: 512 * 1024,
    useStatistics: a.summary, useSummaryOffsets: a.summary, useChunkIndex: a.summary, useMessageIndex: a.summary,
    repeatSchemas: a.summary, repeatChannels: a.summary, useAttachmentIndex: a.summary, useMetadataIndex: a.summary });
  await writer.start({ profile: 'ros2', library: 'plumb tests/cli/mcap_writer' });
  const channels = {}, serializers = {};
  const types = { '/imu': 'sensor_msgs/msg/Imu', '/odom': 'nav_msgs/msg/Odometry', '/tf_static': 'tf2_msgs/msg/TFMessage',
    '/points': 'sensor_msgs/msg/PointCloud2' };
  if (a.wheels) types['/joint_states'] = 'sensor_msgs/msg/JointState';
  for (const [topic, type] of Object.entries(types)) {
    const text = DEFINITIONS[type].join(SEP);
    serializers[topic] = new MessageWriter(parse(text, { ros2: true }));
    const schemaId = await writer.registerSchema({ name: type, encoding: 'ros2msg', data: Buffer.from(text) });
    channels[topic] = await writer.registerChannel({ topic, schemaId, messageEncoding: 'cdr', metadata: new Map() });
  }
  let sequence = 0;
  for (const [stamp, , topic, msg] of messages) {
    const data = topic === '/points' && a.cdrBe ? cloudBigEndian(msg) : serializers[topic].writeMessage(msg);
    const t = rosTime(stamp).ns;
    await writer.addMessage({ channelId: channels[topic], sequence: sequence++, logTime: t, publishTime: t, data });
  }
  await writer.end();
  fs.writeFileSync(a.out, Buffer.concat(parts));
}

main().catch((e) => { console.error('mcap_from_dump: ' + (e.stack || e)); process.exit(1); });
