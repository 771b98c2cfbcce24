# SPDX-License-Identifier: BSD-3-Clause
"""A PCD file split with plain Python, the reference the readers are compared with."""

import pathlib


def pcd_header_and_data(path):
    """(header dict, data bytes) of a PCD file, split at the DATA line."""
    raw = pathlib.Path(path).read_bytes()
    header, pos = {}, 0
    while True:
        end = raw.index(b"\n", pos)
        line = raw[pos:end].decode().strip()
        pos = end + 1
        if line and not line.startswith("#"):
            key, *values = line.split()
            header[key] = values
            if key == "DATA":
                return header, raw[pos:]
