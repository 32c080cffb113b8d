# Bakes are bit-identical at 1 and 2 threads; an unchanged scene is not re-baked; info reads the file.
source "$(dirname "$0")/lib.sh"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/t1.pbake" --preset draft --threads 1 --seed 7
expect_output "vertex-ao"; expect_output "probe-grid"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/only.pbake" --preset draft --only probe-grid
expect_exit 0 "$PENUMBRA" info "$scratch/only.pbake"
expect_output "PRBG"; grep -q VXAO <<<"$out" && fail "--only probe-grid also baked vertex-ao"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/t2.pbake" --preset draft --threads 2 --seed 7
cmp "$scratch/t1.pbake" "$scratch/t2.pbake" || fail "bakes at 1 and 2 threads differ"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/t3.pbake" --preset draft --threads 2 --seed 8
cmp -s "$scratch/t1.pbake" "$scratch/t3.pbake" && fail "a different seed gave the same bake"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/t1.pbake" --preset draft --threads 2 --seed 7
expect_output "up to date"
expect_exit 0 "$PENUMBRA" info "$scratch/t1.pbake"
expect_output "input hash"; expect_output "VXAO"; expect_output "PRBG"
finish
