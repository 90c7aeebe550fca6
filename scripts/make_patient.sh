#!/usr/bin/env bash
# A patient-specific scene from a liver segmentation: tetrahedralizes the surfaces with gmsh
# (Debian's python3-gmsh), reports the mesh quality and writes a scenario that scripts/run.sh
# runs. The work is done by scripts/make_patient.py (its --help lists every option).
#
#   scripts/make_patient.sh --liver LIVER.stl|obj [--skin SKIN.stl|obj] --nodes N --out DIR
#       [--model-nodes M] [--units mm|m] [--lps] [--entry X,Y,Z] [--target X,Y,Z]
#       [--plan PLAN.yaml] [--markers 5] [--marker-margin 0.01] [--seed 1]
#   scripts/run.sh DIR/scenario.yaml
#
# The segmentation: one closed surface, in millimetres (--units mm, the default, as 3D Slicer
# exports) or metres (--units m), any origin (it is recentred on its bounding-box centre), RAS
# axes (+x patient right, +y anterior, +z superior) or LPS (--lps flips x and y; Slicer writes
# LPS by default). The scenario's world frame: origin at the liver's bounding-box centre, RAS,
# metres; --entry, --target and a plan (entry: [x, y, z], target: [x, y, z]) are in it, or in
# the segmentation's coordinates with "frame: input" in the plan.
#
# Writes DIR/scenario.yaml (configs/scenarios/liver_breathing.yaml with the patient's
# geometry), DIR/liver.msh (about N nodes), DIR/liver_model.msh (the controller's model: a
# separate mesh of the same surface, M nodes), DIR/skin.msh (without --skin,
# configs/meshes/skin_patch.msh, placed over the entry by the scenario's skin pose) and
# DIR/quality.txt. Exit codes: 0 success, 2 bad input or gmsh missing, 1 meshing failed.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
python=/usr/bin/python3  # Debian's interpreter: python3-gmsh and python3-numpy are its modules
if [ ! -x "$python" ] || ! "$python" -c "import gmsh, numpy" 2>/dev/null; then
  echo "make_patient: needs /usr/bin/python3 with gmsh and numpy (apt-get install python3-gmsh" \
       "python3-numpy, or scripts/setup.sh)" >&2
  exit 2
fi
code=0
"$python" "$root/scripts/make_patient.py" "$@" || code=$?
if [ "$code" -gt 2 ]; then  # gmsh aborts the interpreter on some meshing errors
  echo "make_patient: meshing failed (the interpreter exited with $code; gmsh's error above)" >&2
  exit 1
fi
exit "$code"
