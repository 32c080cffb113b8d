# penumbra render --offline and penumbra compare: the CPU frame, its modes, the reference's error,
# determinism across thread counts, and clear failures on bad input.
source "$(dirname "$0")/lib.sh"
size="--width 48 --height 40"
expect_exit 0 "$PENUMBRA" render builtin:cornell --offline reference --spp 64 $size --view indirect \
  -o "$scratch/ref.exr" --std-error "$scratch/ref_se.exr"
expect_output "reference, spp 64"; expect_output "standard error"
for mode in mc irradiance-filter; do
  expect_exit 0 "$PENUMBRA" render builtin:cornell --offline $mode --spp 4 $size --view indirect -o "$scratch/$mode.exr"
  expect_output "$mode, spp 4"
  expect_exit 0 "$PENUMBRA" compare "$scratch/$mode.exr" "$scratch/ref.exr" --reference-error "$scratch/ref_se.exr" \
    -o "$scratch/$mode-diff.png"
  expect_output "relative RMSE"; expect_output "SSIM"; expect_output "reference's error    0\."
  [ -s "$scratch/$mode-diff.png" ] || fail "no difference map for $mode"
done
# Byte-identical EXR at 1 and 2 threads.
expect_exit 0 "$PENUMBRA" render builtin:cornell --offline irradiance-filter --spp 4 $size -o "$scratch/t1.exr" --threads 1
expect_exit 0 "$PENUMBRA" render builtin:cornell --offline irradiance-filter --spp 4 $size -o "$scratch/t2.exr" --threads 2
cmp -s "$scratch/t1.exr" "$scratch/t2.exr" || fail "the offline image differs between 1 and 2 threads"
# A PNG of the lit view, and a time budget that picks the ray count.
expect_exit 0 "$PENUMBRA" render builtin:courtyard --offline mc --seconds 0.5 $size -o "$scratch/court.png"
expect_output "spp "
[ -s "$scratch/court.png" ] || fail "no PNG written"
# Bad input: an unknown mode, options without --offline, --std-error outside the reference,
# unreadable and mismatched images.
expect_exit 2 "$PENUMBRA" render builtin:cornell --offline path-tracer -o "$scratch/x.exr"; expect_output "irradiance-filter"
expect_exit 2 "$PENUMBRA" render builtin:cornell --spp 4 -o "$scratch/x.exr"; expect_output "--offline"
expect_exit 2 "$PENUMBRA" render builtin:cornell --offline mc --std-error "$scratch/e.exr" -o "$scratch/x.exr"
expect_output "reference"
expect_exit 2 "$PENUMBRA" render builtin:cornell --offline mc --view ao -o "$scratch/x.exr"; expect_output "lit, direct"
echo "not an image" >"$scratch/bad.exr"
expect_exit 1 "$PENUMBRA" compare "$scratch/bad.exr" "$scratch/ref.exr"; expect_output "bad.exr"
expect_exit 0 "$PENUMBRA" render builtin:cornell --offline mc --spp 2 --width 16 --height 16 -o "$scratch/small.exr"
expect_exit 1 "$PENUMBRA" compare "$scratch/small.exr" "$scratch/ref.exr"; expect_output "one size"
expect_exit 2 "$PENUMBRA" compare "$scratch/small.exr"; expect_output "REFERENCE.exr"
finish
