#!/usr/bin/env bash
# scripts/make_patient.sh on a generated ellipsoid: a liver-sized surface in millimetres, LPS,
# centred far from the origin (as a segmentation exports it). Checks the outputs exist and are
# valid (direct_sim loads the scenario and runs 1 s with the controller in process), the
# markers lie at least 9 mm inside the ellipsoid (10 mm asked, 1 mm for the faceting), the
# mesh sizes and the frame; then bad inputs exit with 2 and a message.
# Usage: make_patient_test.sh BIN_DIR SOURCE_DIR; exit code 77 (skipped) without gmsh.
set -euo pipefail
bin="$1"
src="$2"
python=/usr/bin/python3
if ! "$python" -c "import gmsh" 2>/dev/null; then
  echo "make_patient_test: SKIP: no gmsh module for $python (apt-get install python3-gmsh)"
  exit 77
fi
work="$(mktemp -d /tmp/nsim_make_patient_test.XXXXXX)"
trap 'rm -rf "$work"' EXIT
fail() { echo "make_patient_test: FAIL: $*" >&2; exit 1; }

# the ellipsoid: semi-axes 95 x 55 x 78 mm (RAS), centre (120, -35, 410) mm in LPS
"$python" - "$work/liver.stl" <<'PY'
import math, struct, sys
a, b, c = 95.0, 55.0, 78.0
centre = (120.0, -35.0, 410.0)
nu, nv = 64, 32
def point(i, j):
    th, ph = math.pi * i / nv, 2 * math.pi * j / nu
    return (centre[0] + a * math.sin(th) * math.cos(ph),
            centre[1] + b * math.sin(th) * math.sin(ph), centre[2] + c * math.cos(th))
tris = []
for i in range(nv):
    for j in range(nu):
        p00, p10, p11, p01 = point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1)
        if i > 0:
            tris.append((p00, p10, p01))
        if i < nv - 1:
            tris.append((p10, p11, p01))
with open(sys.argv[1], "wb") as f:
    f.write(b"ellipsoid".ljust(80, b" "))
    f.write(struct.pack("<I", len(tris)))
    for t in tris:
        f.write(struct.pack("<12fH", 0, 0, 0, *t[0], *t[1], *t[2], 0))
PY

out="$work/patient"
timeout -s KILL 180 "$src/scripts/make_patient.sh" --liver "$work/liver.stl" --nodes 1500 \
  --units mm --lps --out "$out" > "$work/make_patient.log" 2>&1 \
  || { cat "$work/make_patient.log"; fail "make_patient.sh exit $?"; }
for f in scenario.yaml liver.msh liver_model.msh skin.msh quality.txt; do
  [ -s "$out/$f" ] || fail "no $out/$f"
done
grep -q '^\$MeshFormat' "$out/liver.msh" || fail "liver.msh is not a Gmsh file"
head -2 "$out/liver.msh" | grep -q '^4.1 0 8' || fail "liver.msh is not MSH 4.1 ASCII"
grep -q 'radius ratio: min' "$out/quality.txt" || fail "quality.txt has no radius ratio"
grep -q 'inverted 0' "$out/quality.txt" || fail "an inverted tetrahedron: $(cat "$out/quality.txt")"

# sizes, frame and markers, from the files
"$python" - "$out" <<'PY' || fail "checks of the outputs"
import re, sys
out = sys.argv[1]
def nodes(path):
    lines = open(path).read().split("\n")
    return int(lines[lines.index("$Nodes") + 1].split()[1])
n_liver, n_model = nodes(out + "/liver.msh"), nodes(out + "/liver_model.msh")
print("liver.msh %d nodes, liver_model.msh %d nodes" % (n_liver, n_model))
assert 1200 <= n_liver <= 1800, n_liver
assert abs(n_model - n_liver) > 0.1 * n_liver, "the model mesh has the patient's size"
text = open(out + "/scenario.yaml").read()
for section in ("shared", "patient", "breathing", "needle", "robot", "insertion", "safety",
                "run", "view", "dds", "inverse", "controller", "prediction"):
    assert re.search("^" + section + ":", text, re.M), "no section " + section
assert re.search(r"^\s+mesh: liver\.msh", text, re.M) and "mesh: liver_model.msh" in text
block = text.split("markers:", 1)[1].split("target:", 1)[0]
markers = [[float(v) for v in m] for m in re.findall(r"- \[([^,]+), ([^,]+), ([^\]]+)\]", block)]
assert len(markers) == 5, markers
# a point at distance >= d from the surface of an ellipsoid with semi-axes (a, b, c) lies in the
# ellipsoid with semi-axes (a - d, b - d, c - d) (compare the support functions); the world
# frame is centred on the bounding box, i.e. on the ellipsoid's centre
a, b, c, d = 0.095, 0.055, 0.078, 0.009
for m in markers:
    value = (m[0] / (a - d)) ** 2 + (m[1] / (b - d)) ** 2 + (m[2] / (c - d)) ** 2
    assert value <= 1, "marker %s is not 9 mm inside the ellipsoid (%.3f)" % (m, value)
spread = min(sum((p - q) ** 2 for p, q in zip(m1, m2)) ** 0.5
             for i, m1 in enumerate(markers) for m2 in markers[i + 1:])
assert spread > 0.02, "markers closer than 2 cm: %.3f m" % spread
entry = [float(v) for v in re.search(r"entry: \[([^\]]+)\]", text).group(1).split(",")]
assert entry[1] > b, "the entry %s is not anterior of the liver" % entry
PY

# the scenario loads and runs: 1 s, the controller in process
timeout -s KILL 120 "$bin/direct_sim" run --config "$out/scenario.yaml" --in-process --duration 1 \
  --no-video --quiet --out "$work/run/direct" > "$work/run.log" 2>&1 \
  || { cat "$work/run.log"; fail "direct_sim run on the scenario"; }
[ -f "$work/run/direct/summary.json" ] || fail "direct_sim wrote no summary"

# the same input gives the same scene
timeout -s KILL 180 "$src/scripts/make_patient.sh" --liver "$work/liver.stl" --nodes 1500 \
  --units mm --lps --out "$work/again" > /dev/null 2>&1 || fail "second make_patient.sh"
diff <(grep -v 'make_patient.sh on' "$out/scenario.yaml") \
     <(grep -v 'make_patient.sh on' "$work/again/scenario.yaml") > /dev/null \
  || fail "two runs on the same input wrote different scenarios"

# a plan in the segmentation's own frame (mm, LPS): 20 mm left and 10 mm posterior of the
# centre is x = -0.02, y = -0.01 in the world frame (RAS, m)
printf 'frame: input   # mm, LPS\ntarget: [140, -25, 410]\n' > "$work/plan.yaml"
timeout -s KILL 180 "$src/scripts/make_patient.sh" --liver "$work/liver.stl" --nodes 600 \
  --lps --plan "$work/plan.yaml" --out "$work/planned" > "$work/planned.log" 2>&1 \
  || { cat "$work/planned.log"; fail "make_patient.sh --plan"; }
grep -q '^  target: \[-0.02, -0.01, 0.0\]' "$work/planned/scenario.yaml" \
  || fail "plan target not in the world frame: $(grep 'target:' "$work/planned/scenario.yaml")"

# bad inputs: exit 2 and a message naming the problem
expect_error() {  # expect_error TEXT ARGS...
  local text="$1" code=0
  shift
  "$src/scripts/make_patient.sh" "$@" > "$work/error.log" 2>&1 || code=$?
  [ "$code" -eq 2 ] || fail "exit $code (expected 2) for: $*"
  grep -q -- "$text" "$work/error.log" || fail "no '$text' in: $(cat "$work/error.log")"
}
expect_error "no such file" --liver "$work/missing.stl" --nodes 1500 --out "$work/bad"
expect_error "wrong --units" --liver "$work/liver.stl" --units m --nodes 1500 --out "$work/bad"
expect_error "must differ" --liver "$work/liver.stl" --nodes 1500 --model-nodes 1500 \
  --out "$work/bad"
printf 'solid one\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n%b\n' \
  'endloop\nendfacet\nendsolid' > "$work/open.stl"
expect_error "fewer than 4 triangles" --liver "$work/open.stl" --nodes 1500 --out "$work/bad"
"$python" - "$work/liver.stl" "$work/holed.stl" <<'PY'
import struct, sys
data = open(sys.argv[1], "rb").read()
count = struct.unpack_from("<I", data, 80)[0]
open(sys.argv[2], "wb").write(data[:80] + struct.pack("<I", count - 1) + data[134:])
PY
expect_error "not closed" --liver "$work/holed.stl" --nodes 1500 --out "$work/bad"
expect_error "expected X,Y,Z" --liver "$work/liver.stl" --nodes 1500 --target 1,2 --out "$work/bad"
echo "make_patient_test: OK"
