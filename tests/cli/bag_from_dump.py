#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Write a ROS 1 bag from a frame dump with ROS's own rosbag (Debian python3-rosbag), for the tests
of `plumb import`: the first FRAMES LiDAR frames as sensor_msgs/PointCloud2 on /points (frame
"lidar"), imu.csv as sensor_msgs/Imu on /imu (frame "imu"), odom.csv as nav_msgs/Odometry on /odom
and the extrinsics as tf2_msgs/TFMessage on /tf_static (base_link -> lidar, base_link -> imu); with
--wheels also wheels.csv as sensor_msgs/JointState on /joint_states (joints "caster", "wheel_left",
"wheel_right": the wheel angles [rad], the caster at 0).

Layouts of the clouds: "pcd" sends the PCD records as they are (fields x y z intensity ring time
label, packed); "unusual" reorders the fields, pads point_step, stores x y z as float64 and splits
the points in two rows with padding at each row's end; "unusual-be" is "unusual" big-endian;
"velodyne" is velodyne_pointcloud's PointXYZIRT (x y z, 4 bytes padding, intensity float32, ring
uint16, time float32 [s], point_step 32); "ouster" is ouster_ros's point (x y z, padding, intensity
float32, t uint32 [ns], reflectivity uint16, ring uint16, ambient uint16, range uint32, point_step
48) with a NaN point after every 7th one, as an organised cloud holds for missing returns;
"notime" is x y z intensity ring without a time field.

usage: bag_from_dump.py DUMP OUT.bag [--compression none|bz2|lz4] [--layout L] [--frames N]
                        [--no-tf-static] [--wheels]
"""
import argparse
import csv
import json
import math
import os

import numpy as np
import rosbag
import genpy
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu, JointState, PointCloud2, PointField
from tf2_msgs.msg import TFMessage

PCD_TO_ROS = {('I', 1): PointField.INT8, ('U', 1): PointField.UINT8, ('I', 2): PointField.INT16,
              ('U', 2): PointField.UINT16, ('I', 4): PointField.INT32, ('U', 4): PointField.UINT32,
              ('F', 4): PointField.FLOAT32, ('F', 8): PointField.FLOAT64}
NUMPY = {('I', 1): 'i1', ('U', 1): 'u1', ('I', 2): 'i2', ('U', 2): 'u2', ('I', 4): 'i4', ('U', 4): 'u4',
         ('F', 4): 'f4', ('F', 8): 'f8'}


def ros_time(stamp):
    ns = int(round(stamp * 1e9))
    return genpy.Time(ns // 1000000000, ns % 1000000000)


def read_pcd(path):
    """(field names, (type, size) per field, raw record bytes, number of points) of a binary PCD."""
    with open(path, 'rb') as f:
        head = {}
        while True:
            line = f.readline().decode('ascii').strip()
            if line.startswith('#'):
                continue
            key, _, value = line.partition(' ')
            head[key] = value.split()
            if key == 'DATA':
                break
        assert head['DATA'] == ['binary'], path + ': only binary PCD is sent'
        names = head['FIELDS']
        kinds = [(t, int(s)) for t, s in zip(head['TYPE'], head['SIZE'])]
        n = int(head['POINTS'][0])
        data = f.read(n * sum(s for _, s in kinds))
        return names, kinds, data, n


def cloud_msg(stamp, names, kinds, data, n, layout):
    msg = PointCloud2()
    msg.header.stamp = ros_time(stamp)
    msg.header.frame_id = 'lidar'
    if layout == 'pcd':
        offset = 0
        for name, kind in zip(names, kinds):
            msg.fields.append(PointField(name=name, offset=offset, datatype=PCD_TO_ROS[kind], count=1))
            offset += kind[1]
        msg.height, msg.width = 1, n
        msg.point_step, msg.row_step = offset, offset * n
        msg.data = data
        msg.is_bigendian = False
    else:
        src = np.frombuffer(data, dtype=np.dtype([(nm, NUMPY[k]) for nm, k in zip(names, kinds)]), count=n)
        e = '>' if layout == 'unusual-be' else '<'
        # name, numpy type, ROS type, offset: reordered, with gaps, x y z widened to float64.
        layout_fields = [('time', 'f4', PointField.FLOAT32, 0), ('ring', 'u2', PointField.UINT16, 8),
                         ('z', 'f8', PointField.FLOAT64, 12), ('intensity', 'f4', PointField.FLOAT32, 20),
                         ('x', 'f8', PointField.FLOAT64, 24), ('y', 'f8', PointField.FLOAT64, 32)]
        point_step = 48
        dtype = np.dtype({'names': [f[0] for f in layout_fields], 'formats': [e + f[1] for f in layout_fields],
                          'offsets': [f[3] for f in layout_fields], 'itemsize': point_step})
        height = 2 if n % 2 == 0 else 1
        width = n // height
        row_pad = 16
        rows = []
        for r in range(height):
            out = np.zeros(width, dtype=dtype)
            for name in dtype.names:
                out[name] = src[name][r * width:(r + 1) * width]
            rows.append(out.tobytes() + b'\xab' * row_pad)
        for name, _, ros_type, offset in layout_fields:
            msg.fields.append(PointField(name=name, offset=offset, datatype=ros_type, count=1))
        msg.height, msg.width = height, width
        msg.point_step, msg.row_step = point_step, point_step * width + row_pad
        msg.data = b''.join(rows)
        msg.is_bigendian = layout == 'unusual-be'
    msg.is_dense = layout != 'ouster'
    return msg


# name, numpy type, ROS type, offset, point_step of the drivers' layouts.
DRIVER_LAYOUTS = {
    'velodyne': ([('x', 'f4', PointField.FLOAT32, 0), ('y', 'f4', PointField.FLOAT32, 4),
                  ('z', 'f4', PointField.FLOAT32, 8), ('intensity', 'f4', PointField.FLOAT32, 16),
                  ('ring', 'u2', PointField.UINT16, 20), ('time', 'f4', PointField.FLOAT32, 24)], 32),
    'ouster': ([('x', 'f4', PointField.FLOAT32, 0), ('y', 'f4', PointField.FLOAT32, 4),
                ('z', 'f4', PointField.FLOAT32, 8), ('intensity', 'f4', PointField.FLOAT32, 16),
                ('t', 'u4', PointField.UINT32, 20), ('reflectivity', 'u2', PointField.UINT16, 24),
                ('ring', 'u2', PointField.UINT16, 26), ('ambient', 'u2', PointField.UINT16, 28),
                ('range', 'u4', PointField.UINT32, 32)], 48),
    'notime': ([('x', 'f4', PointField.FLOAT32, 0), ('y', 'f4', PointField.FLOAT32, 4),
                ('z', 'f4', PointField.FLOAT32, 8), ('intensity', 'f4', PointField.FLOAT32, 12),
                ('ring', 'u2', PointField.UINT16, 16)], 18),
}


def driver_cloud_msg(stamp, names, kinds, data, n, layout):
    src = np.frombuffer(data, dtype=np.dtype([(nm, NUMPY[k]) for nm, k in zip(names, kinds)]), count=n)
    fields, point_step = DRIVER_LAYOUTS[layout]
    dtype = np.dtype({'names': [f[0] for f in fields], 'formats': ['<' + f[1] for f in fields],
                      'offsets': [f[3] for f in fields], 'itemsize': point_step})
    keep = np.arange(n)
    if layout == 'ouster':  # a NaN point after every 7th one
        keep = np.insert(keep, np.arange(7, n, 7), -1)
    out = np.zeros(len(keep), dtype=dtype)
    valid = keep >= 0
    for name in ('x', 'y', 'z', 'intensity', 'ring'):
        out[name][valid] = src[name][keep[valid]]
    for name in ('x', 'y', 'z'):
        out[name][~valid] = np.nan
    if layout == 'velodyne':
        out['time'][valid] = src['time'][keep[valid]]
    elif layout == 'ouster':
        out['t'][valid] = np.round(src['time'][keep[valid]].astype(np.float64) * 1e9).astype(np.uint32)
        out['reflectivity'][valid] = np.minimum(src['intensity'][keep[valid]], 65535).astype(np.uint16)
        out['range'][valid] = (np.sqrt(out['x'][valid].astype(np.float64) ** 2 + out['y'][valid] ** 2 +
                                       out['z'][valid] ** 2) * 1000).astype(np.uint32)
    msg = PointCloud2()
    msg.header.stamp = ros_time(stamp)
    msg.header.frame_id = 'lidar'
    for name, _, ros_type, offset in fields:
        msg.fields.append(PointField(name=name, offset=offset, datatype=ros_type, count=1))
    msg.height, msg.width = 1, len(keep)
    msg.point_step, msg.row_step = point_step, point_step * len(keep)
    msg.data = out.tobytes()
    msg.is_bigendian = False
    msg.is_dense = layout != 'ouster'
    return msg


def quaternion(R):
    """x y z w of a rotation matrix (Shepperd's method)."""
    t = R[0][0] + R[1][1] + R[2][2]
    if t > 0:
        s = math.sqrt(t + 1.0) * 2
        return ((R[2][1] - R[1][2]) / s, (R[0][2] - R[2][0]) / s, (R[1][0] - R[0][1]) / s, 0.25 * s)
    i = max(range(3), key=lambda k: R[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = math.sqrt(1.0 + R[i][i] - R[j][j] - R[k][k]) * 2
    q = [0.0, 0.0, 0.0]
    q[i] = 0.25 * s
    q[j] = (R[j][i] + R[i][j]) / s
    q[k] = (R[k][i] + R[i][k]) / s
    return (q[0], q[1], q[2], (R[k][j] - R[j][k]) / s)


def transform(stamp, parent, child, T16):
    tf = TransformStamped()
    tf.header.stamp = ros_time(stamp)
    tf.header.frame_id = parent
    tf.child_frame_id = child
    R = [T16[0:3], T16[4:7], T16[8:11]]
    tf.transform.translation.x, tf.transform.translation.y, tf.transform.translation.z = T16[3], T16[7], T16[11]
    r = tf.transform.rotation
    r.x, r.y, r.z, r.w = quaternion(R)
    return tf


def rows(path):
    with open(path) as f:
        return [[float(v) for v in row] for row in list(csv.reader(f))[1:] if row and not row[0].startswith('#')]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('dump')
    ap.add_argument('bag')
    ap.add_argument('--compression', default='none', choices=['none', 'bz2', 'lz4'])
    ap.add_argument('--layout', default='pcd', choices=['pcd', 'unusual', 'unusual-be'] + sorted(DRIVER_LAYOUTS))
    ap.add_argument('--frames', type=int, default=1000000)
    ap.add_argument('--no-tf-static', action='store_true')
    ap.add_argument('--wheels', action='store_true')
    a = ap.parse_args()
    meta = json.load(open(os.path.join(a.dump, 'meta.json')))
    messages = []  # (stamp, order, topic, message)
    for stamp, wx, wy, wz, ax, ay, az in rows(os.path.join(a.dump, 'imu.csv')):
        m = Imu()
        m.header.stamp = ros_time(stamp)
        m.header.frame_id = 'imu'
        m.orientation.w = 1.0
        m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = wx, wy, wz
        m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z = ax, ay, az
        messages.append((stamp, 1, '/imu', m))
    for stamp, x, y, theta in rows(os.path.join(a.dump, 'odom.csv')):
        m = Odometry()
        m.header.stamp = ros_time(stamp)
        m.header.frame_id = 'odom'
        m.child_frame_id = 'base_link'
        m.pose.pose.position.x, m.pose.pose.position.y = x, y
        m.pose.pose.orientation.z, m.pose.pose.orientation.w = math.sin(theta / 2), math.cos(theta / 2)
        messages.append((stamp, 2, '/odom', m))
    if a.wheels:
        for stamp, left, right in rows(os.path.join(a.dump, 'wheels.csv')):
            m = JointState()
            m.header.stamp = ros_time(stamp)
            m.name = ['caster', 'wheel_left', 'wheel_right']
            m.position = [0.0, left, right]
            messages.append((stamp, 4, '/joint_states', m))
    frames = [r for r in csv.reader(open(os.path.join(a.dump, 'frames.csv')))][1:1 + a.frames]
    first = float(frames[0][1])
    tf = TFMessage(transforms=[transform(first, 'base_link', 'lidar', meta['T_base_lidar']),
                               transform(first, 'base_link', 'imu', meta['T_base_imu'])])
    if not a.no_tf_static:
        messages.append((first, 0, '/tf_static', tf))
    make = driver_cloud_msg if a.layout in DRIVER_LAYOUTS else cloud_msg
    for _, stamp, name in frames:
        names, kinds, data, n = read_pcd(os.path.join(a.dump, name))
        messages.append((float(stamp), 3, '/points', make(float(stamp), names, kinds, data, n, a.layout)))
    messages.sort(key=lambda m: (m[0], m[1]))
    with rosbag.Bag(a.bag, 'w', compression=a.compression) as bag:
        for stamp, _, topic, msg in messages:
            bag.write(topic, msg, t=ros_time(stamp))


if __name__ == '__main__':
    main()
