#!/usr/bin/env bash
# Regenerates every mesh in configs/meshes/ from its committed gmsh script and reports the node
# and tetrahedron counts. Headless; reproducible with the same gmsh version (4.8.4, Debian).
# Usage: scripts/make_meshes.sh
#        scripts/make_meshes.sh --large DIR   only the ~30000-node liver (liver_30000.msh, 6.5 MB,
#                                             not committed; the scaling benchmark's), into DIR
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
dir="${root}/configs/meshes"
large=""
case "${1:-}" in
  --large) large="${2:?make_meshes.sh: --large needs a directory}"; mkdir -p "$large" ;;
  "") ;;
  *) echo "make_meshes.sh: unknown argument $1 (usage: make_meshes.sh [--large DIR])" >&2; exit 2 ;;
esac

if ! command -v gmsh >/dev/null 2>&1; then
  echo "make_meshes.sh: gmsh not found; install it (apt-get install gmsh)" >&2
  exit 2
fi
version="$(gmsh --version 2>&1 | tail -n 1)"
if [[ "${version}" != "4.8.4" ]]; then
  echo "make_meshes.sh: warning: gmsh ${version}, the committed meshes were made with 4.8.4;" \
       "node counts may differ" >&2
fi

# counts "<nodes> <tets>" of an ASCII .msh file (format 2.2 or 4.1)
count() {
  awk '
    /^\$MeshFormat/ { getline; version = $1 }
    /^\$Nodes/ { getline; nodes = (version + 0 >= 4) ? $2 : $1 }
    /^\$Elements/ { in_elements = 1; getline; block = 0; next }
    /^\$EndElements/ { in_elements = 0 }
    in_elements && version + 0 < 4 && $2 == 4 { tets++ }
    in_elements && version + 0 >= 4 {
      if (block == 0) { type = $3; block = $4; if (type == 4) tets += $4 } else { block-- }
    }
    END { printf "%d %d\n", nodes, tets }' "$1"
}

# mesh <geo> <output> <format> [gmsh options...]; the output goes to $to (default: configs/meshes)
mesh() {
  local geo="$1" out="$2" format="$3" to="${to:-$dir}"
  shift 3
  gmsh -3 "${dir}/${geo}" -o "${to}/${out}" -format "${format}" "$@" >"${to}/.${out}.log" 2>&1 || {
    echo "make_meshes.sh: gmsh failed on ${geo}; log:" >&2
    cat "${to}/.${out}.log" >&2
    exit 1
  }
  if grep -qE '^(Warning|Error)' "${to}/.${out}.log"; then
    grep -E '^(Warning|Error)' "${to}/.${out}.log" >&2
  fi
  rm -f "${to}/.${out}.log"
  read -r nodes tets < <(count "${to}/${out}")
  printf '%-20s %6d nodes %7d tets\n' "${out}" "${nodes}" "${tets}"
}

if [ -n "$large" ]; then
  # the same liver, 30097 nodes (about 15 s of gmsh)
  to="$large" mesh liver.geo liver_30000.msh msh41 -setnumber lc 3.5
  exit 0
fi

# the liver at three resolutions (lc = maximum element size in mm)
mesh liver.geo liver_700.msh msh41 -setnumber lc 14.5
mesh liver.geo liver_2660.msh msh41 -setnumber lc 8.53
mesh liver.geo liver_10000.msh msh41 -setnumber lc 5.18
# the controller's model of the liver (inverse.mesh): the same surface meshed separately, with
# another element size and other 2D / 3D algorithms (Frontal-Delaunay, HXT), so the inverse
# simulation does not share the patient's nodes (no "inverse crime")
mesh liver.geo liver_model_2000.msh msh41 -setnumber lc 9.5 -setnumber Mesh.Algorithm 6 \
  -setnumber Mesh.Algorithm3D 10
# the skin patch, written in the older format 2.2 (both formats are read)
mesh skin_patch.geo skin_patch.msh msh22
