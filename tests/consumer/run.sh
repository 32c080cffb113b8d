# Installs the built SDK into a scratch prefix, configures and builds tests/consumer against it with
# find_package(penumbra) (linking penumbra::runtime only), bakes the courtyard with the tool, runs the
# consumer on that bake, and checks that the executable depends on neither Embree nor tinygltf.
set -eu
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
cmake --install "$BUILD_DIR" --prefix "$scratch/prefix" > "$scratch/install.log"
cmake -S "$SOURCE_DIR/tests/consumer" -B "$scratch/build" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$scratch/prefix" > "$scratch/configure.log" || { cat "$scratch/configure.log"; exit 1; }
cmake --build "$scratch/build" -j 2 > "$scratch/build.log" || { cat "$scratch/build.log"; exit 1; }
"$PENUMBRA" bake builtin:courtyard --preset draft -o "$scratch/courtyard.pbake" > "$scratch/bake.log" \
  || { cat "$scratch/bake.log"; exit 1; }
"$scratch/build/consumer" "$scratch/courtyard.pbake"
needed=$(readelf -d "$scratch/build/consumer" | grep NEEDED || true)
if grep -qi "embree\|tinygltf" <<<"$needed"; then
  echo "the runtime-only consumer depends on the bake layer's libraries:"
  echo "$needed"
  exit 1
fi
if nm -C "$scratch/build/consumer" | grep -q "rtcNewDevice\|tinygltf::"; then
  echo "the runtime-only consumer contains Embree or tinygltf symbols"
  exit 1
fi
echo "consumer: links neither Embree nor tinygltf ($(grep -c NEEDED <<<"$needed") shared libraries needed)"
