// GPU layout of ambient occlusion fields for the renderer's per-pixel pass: every baked caster's
// current transform, settings and field, and the cap-occlusion table, in one storage buffer of
// vec4s (std430: a `vec4 data[]` array), so that a fragment shader can evaluate what
// accumulate_open() (ao_field.h) evaluates on the CPU. evaluate_packed() below is the reference
// the shader ports: it reads nothing but the buffer.
//
// Layout (all indices in vec4s; integers are stored as exact floats, so the buffer holds at most
// 2^24 vec4s):
//   data[0]                  (caster count, table offset T, table size K + 1 = 129, 0)
//   data[1 + 7 i + 0..2]     caster i's world-to-local matrix rows: local = (dot(row0, (x, 1)),
//                            dot(row1, (x, 1)), dot(row2, (x, 1))); the normal n_local =
//                            normalize(rows' xyz times n)
//   data[1 + 7 i + 3]        (centre.xyz, r_far), local units
//   data[1 + 7 i + 4]        (1 / ((1 - fade_start) r_far), inside_occlusion, inside_exponent,
//                            representation: 0 radial fit, 1 grid)
//   data[1 + 7 i + 5]        (resolution or grid_size, offset F of the field's data, 0, 0)
//   data[1 + 7 i + 6]        (world-space centre.xyz, world-space reach r_far x scale): the pass
//                            skips the caster beyond it
//   radial fit, texel j      data[F + 2 j] = (a, b, c, r0), data[F + 2 j + 1] = (C0.xyz, 0); texel
//                            order as AOFieldData::texels (face, row v, column u)
//   grid, vertex j           data[F + j] = (Omega, Omega Upsilon.xyz); order as AOFieldData::nodes
//   table                    value (i, j) of the 129 x 129 cap-occlusion table (omega index i,
//                            cos-beta index j) is component (q % 4) of data[T + q / 4], q = 129 i + j
// The caster records come first, so a frame in which only transforms changed uploads
// data[0 .. 1 + 7 count) again and nothing else.
//
// The shader's steps per pixel (x, n in world space), for each caster i: skip when
// |x - world centre| >= reach; transform to local; then steps 1-5 of evaluate_local (ao_field.h),
// with the table lookup done on the buffer as cap_occlusion_table does (bilinear, clamped); then
// open *= 1 - A. The pixel's ambient term is multiplied by open (1 - combined occlusion).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"

namespace penumbra {

// One caster for pack_ao_fields_gpu: its baked field and its entity's current world matrix
// (rotation, translation, uniform scale).
struct AOFieldGpuCaster {
  const AOFieldData* field = nullptr;
  glm::mat4 world{1.0f};
};

struct AOFieldGpuBuffer {
  std::vector<glm::vec4> data;  // the storage buffer's contents, in the layout above
  std::uint32_t casters = 0;
  std::uint64_t bytes() const { return data.size() * sizeof(glm::vec4); }
};

// Packs `casters` (skipping null or invalid fields) into the layout above. InvalidArgument, naming
// the caster's position in the list and the fix, for a singular or non-finite world matrix, and
// OutOfBudget when the buffer would pass 2^24 vec4s. Cost: O(total texels); the result is the
// fields' bytes x ~1.15 plus 66 KB of table. Thread-safe.
Result<AOFieldGpuBuffer> pack_ao_fields_gpu(std::span<const AOFieldGpuCaster> casters);


// The combined occlusion 1 - prod (1 - A_i) at world point x with unit world normal n, read from
// the buffer alone, step by step as the shader does (see above). Agrees with accumulate_open on
// the packed casters to float rounding (ao_field_gpu_test). 0 for an empty or malformed buffer.
// Cost: O(casters). Thread-safe.
float evaluate_packed(const AOFieldGpuBuffer& buffer, glm::vec3 x, glm::vec3 n);

}  // namespace penumbra
