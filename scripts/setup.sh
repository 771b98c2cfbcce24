#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Install what plumb needs with apt, only what is missing (idempotent).
#   scripts/setup.sh            build + test dependencies (also of the Python module: pybind11, numpy,
#                               pytest; matplotlib for the plotting example; ROS 1 rosbag and message
#                               packages, which the tests use to write bags for `plumb import`; Node.js
#                               and the pinned MCAP writer of tests/cli/mcap_writer, installed with
#                               `npm ci` into ~/.cache/plumb/mcap-writer, for the ROS 2 bags)
#   scripts/setup.sh --fuzz     also clang + libFuzzer (CI's fuzz step)
#   scripts/setup.sh --peers    also the benchmark peers: PCL, Open3D, nanoflann
set -euo pipefail

packages=(cmake g++ make libeigen3-dev libgtest-dev libgmock-dev libbenchmark-dev liblzf-dev zlib1g-dev
          libcli11-dev nlohmann-json3-dev ccache python3
          python3-dev pybind11-dev python3-numpy python3-pytest python3-matplotlib libxml2-utils time
          libbz2-dev liblz4-dev libzstd-dev
          python3-rosbag python3-sensor-msgs python3-nav-msgs python3-tf2-msgs python3-geometry-msgs nodejs)
# npm from apt only when no npm is there (Node installed otherwise brings its own).
if ! command -v npm >/dev/null 2>&1; then packages+=(npm); fi
for arg in "$@"; do
  case "$arg" in
    --fuzz) packages+=(clang libclang-rt-14-dev) ;;
    --peers) packages+=(libnanoflann-dev libpcl-dev libopen3d-dev python3-open3d) ;;
    *) echo "setup.sh: unknown option $arg" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all dependencies present"
else
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  echo "setup: done"
fi

# The MCAP writer of the import tests: its pinned node_modules, reinstalled when the lock changes.
writer_src="$(cd "$(dirname "$0")/.." && pwd)/tests/cli/mcap_writer"
writer_dir="${HOME}/.cache/plumb/mcap-writer"
if ! cmp -s "$writer_src/package-lock.json" "$writer_dir/package-lock.json" || [ ! -d "$writer_dir/node_modules" ]; then
  echo "setup: installing the MCAP writer's node modules in $writer_dir"
  mkdir -p "$writer_dir"
  cp "$writer_src/package.json" "$writer_src/package-lock.json" "$writer_dir/"
  (cd "$writer_dir" && npm ci --no-audit --no-fund --loglevel=error)
fi
