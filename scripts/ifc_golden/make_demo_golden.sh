#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Regenerate the committed demo building and its web-ifc reference boxes after a change to the
# generator (tests/bim/demo_building_test.cpp fails until both are regenerated):
#
#   scripts/ifc_golden/make_demo_golden.sh [BUILD_DIR]     # BUILD_DIR holds examples/plumb (default build)
#
# Needs node and web-ifc outside the repository (npm install --prefix /tmp/webifc web-ifc; set
# WEBIFC_DIR when it is elsewhere).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build}"
plumb="$build/examples/plumb"
[[ -x "$plumb" ]] || { echo "no plumb binary at $plumb (build target plumb_cli)" >&2; exit 1; }
model="$root/examples/data/demo_office.ifc"
"$plumb" make-demo-building -o "$model"
WEBIFC_DIR="${WEBIFC_DIR:-/tmp/webifc}" node "$root/scripts/ifc_golden/webifc_bbox.cjs" "$model" \
  "$root/tests/bim/golden/demo_office_webifc_bbox.json"
WEBIFC_DIR="${WEBIFC_DIR:-/tmp/webifc}" node "$root/scripts/ifc_golden/webifc_area.cjs" "$model" \
  "$root/tests/bim/golden/demo_office_webifc_area.json"
echo "wrote $model and tests/bim/golden/demo_office_webifc_{bbox,area}.json"
