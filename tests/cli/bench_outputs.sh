# penumbra bench prints a table with its ratios and writes NAME.csv and NAME.png.
source "$(dirname "$0")/lib.sh"
for name in ecs rays ao-noise probe-grid ao-field pose-ao render-ao shards image-accuracy irradiance-filter \
    indirect-transport characters; do
  expect_exit 0 "$PENUMBRA" bench "$name" --quick --out "$scratch"
  expect_output "goal"
  [ -s "$scratch/$name.csv" ] || fail "$name.csv missing or empty"
  [ "$(head -c 8 "$scratch/$name.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] || fail "$name.png is not a PNG"
  [ "$(wc -l < "$scratch/$name.csv")" -ge 3 ] || fail "$name.csv has fewer than two data rows"
done
finish
