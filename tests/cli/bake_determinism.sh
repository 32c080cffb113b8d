# Bakes are bit-identical at 1 and 2 threads and as shards baked by separate processes and merged;
# an unchanged scene is not re-baked; info reads the file.
source "$(dirname "$0")/lib.sh"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/t1.pbake" --preset draft --threads 1 --seed 7
expect_output "vertex-ao"; expect_output "probe-grid"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/only.pbake" --preset draft --only probe-grid
expect_exit 0 "$PENUMBRA" info "$scratch/only.pbake"
expect_output "PRBG"; grep -q VXAO <<<"$out" && fail "--only probe-grid also baked vertex-ao"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/t2.pbake" --preset draft --threads 2 --seed 7
cmp "$scratch/t1.pbake" "$scratch/t2.pbake" || fail "bakes at 1 and 2 threads differ"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/s0.pbake" --preset draft --threads 1 --seed 7 --shard 0/2
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/s1.pbake" --preset draft --threads 2 --seed 7 --shard 1/2
expect_exit 0 "$PENUMBRA" merge "$scratch/s1.pbake" "$scratch/s0.pbake" -o "$scratch/merged.pbake"
cmp "$scratch/t1.pbake" "$scratch/merged.pbake" || fail "the merge of two processes' shards differs from the single bake"
# The indirect transport's plan carries its settings as bytes: every process must write the same
# ones (at the default preset, where stray padding bytes made the parts refuse to merge).
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/it.pbake" --only indirect-transport --seed 7
for i in 0 1; do
  expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/it$i.pbake" --only indirect-transport --seed 7 --shard $i/2
done
expect_exit 0 "$PENUMBRA" merge "$scratch/it0.pbake" "$scratch/it1.pbake" -o "$scratch/it_merged.pbake"
cmp "$scratch/it.pbake" "$scratch/it_merged.pbake" || fail "the indirect transport's merged shards differ from its single bake"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/t3.pbake" --preset draft --threads 2 --seed 8
cmp -s "$scratch/t1.pbake" "$scratch/t3.pbake" && fail "a different seed gave the same bake"
expect_exit 0 "$PENUMBRA" bake builtin:courtyard -o "$scratch/t1.pbake" --preset draft --threads 2 --seed 7
expect_output "up to date"
expect_exit 0 "$PENUMBRA" info "$scratch/t1.pbake"
expect_output "input hash"; expect_output "VXAO"; expect_output "PRBG"
finish
