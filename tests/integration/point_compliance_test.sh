#!/usr/bin/env bash
# point_compliance on the coarse scenario (685-node patient liver, the 2001-node model) with the
# 2656-node liver as a second patient mesh. Checked against the scaling of a point load in 3D
# elasticity: the discrete compliance of a point held in a mesh of element size h grows like
# 1 / h, so the 2656-node liver's mean lateral compliance over the 685-node one's must be the
# ratio of their sizes, (2656 / 685)^(1/3) = 1.57, within 20 %; every compliance is positive;
# bad input exits 2 naming it.
# Usage: point_compliance_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src="${1:?usage: point_compliance_test.sh SOURCE_DIR BUILD_DIR}"
bin="${2:?usage: point_compliance_test.sh SOURCE_DIR BUILD_DIR}/bench/point_compliance"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }

"$bin" --config "$src/configs/scenarios/liver_test_coarse.yaml" \
  --patient-meshes "$src/configs/meshes/liver_2660.msh" > "$work/out.txt"
cat "$work/out.txt"
coarse="$(awk '/^# patient .*liver_700.msh .*lateral/ {print $(NF - 2)}' "$work/out.txt")"
fine="$(awk '/^# patient .*liver_2660.msh .*lateral/ {print $(NF - 2)}' "$work/out.txt")"
rows="$(grep -vc '^#\|^depth' "$work/out.txt")"
[[ -n "$coarse" && -n "$fine" ]] || fail "no mean lateral compliance for both patient meshes"
(( rows >= 10 )) || fail "only $rows depths along the path inside every liver"
awk -v c="$coarse" -v f="$fine" 'BEGIN {
  r = f / c; e = (2656 / 685) ^ (1 / 3); printf "fine / coarse %.3f, h ratio %.3f\n", r, e
  exit !(r > 0.8 * e && r < 1.2 * e) }' || fail "compliance ratio off the 1 / h scaling"
awk '!/^#|^depth/ { for (i = 2; i <= NF; ++i) if (!($i > 0)) bad = 1 } END { exit bad }' \
  "$work/out.txt" || fail "a compliance is not positive"

set +e
"$bin" --config "$src/configs/scenarios/liver_test_coarse.yaml" --patient-meshes "$work/missing.msh" \
  > /dev/null 2> "$work/err.txt"
code=$?
set -e
[[ $code -eq 2 ]] || fail "a missing mesh exits $code, not 2"
grep -q "missing.msh" "$work/err.txt" || fail "the message does not name the missing mesh"

(( fails == 0 )) && echo "point_compliance_test: ok"
exit $(( fails > 0 ))
