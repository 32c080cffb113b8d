// The light models shared by every integrator and baker: KHR_lights_punctual directional, point
// and spot lights (inverse square, the recommended range window, the smooth spot cone) and
// one-sided Lambertian rect lights (area sampling over a scrambled Sobol' net).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "penumbra/bake/integrators.h"
#include "penumbra/core/sampling.h"

namespace penumbra {

// Calls fn(l, e) for each visible light sample at point p: l is the unit direction towards the
// sample and e its irradiance on a surface facing it (W/m^2, no cosine at the receiver). Shadow
// rays leave from `origin` (p, or p offset off its surface). When `n` is non-zero only samples in
// the hemisphere around n are taken, which saves the shadow rays of the others. A rect light gives
// `rect_samples` samples, each weighted by 1/rect_samples, and draws one scramble from rng.
template <class Fn>
void for_each_light_sample(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 p, glm::vec3 origin,
                           glm::vec3 n, std::uint32_t rect_samples, Rng& rng, Fn&& fn) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const bool hemisphere = n != glm::vec3(0.0f);
  const auto faces = [&](glm::vec3 l) { return !hemisphere || glm::dot(n, l) > 0.0f; };
  for (const WorldLight& wl : lights) {
    const Light& light = wl.light;
    const glm::vec3 power = light.color * light.intensity;
    switch (light.type) {
      case Light::Type::Directional: {
        // Illuminance, if the way towards the light is free.
        const glm::vec3 l = -wl.direction;
        if (faces(l) && !scene.occluded(Ray{origin, 0.0f, l, kInf})) fn(l, power);
        break;
      }
      case Light::Type::Point:
      case Light::Type::Spot: {
        // Intensity / d^2, windowed by range (KHR_lights_punctual's recommended falloff).
        const glm::vec3 d = wl.position - p;
        const float dist2 = glm::dot(d, d);
        if (!(dist2 > 0.0f)) break;
        const float dist = std::sqrt(dist2);
        const glm::vec3 l = d / dist;
        if (!faces(l)) break;
        const float falloff = punctual_window(light, wl.direction, l, dist) / dist2;
        // The shadow ray's direction is the segment itself: t = 1 reaches the light.
        if (falloff > 0.0f && !scene.occluded(Ray{origin, 0.0f, wl.position - origin, 1.0f})) fn(l, power * falloff);
        break;
      }
      case Light::Type::Rect: {
        // Area sampling: E = L \int cos_l / d^2 dA, over a scrambled Sobol' net on the rect.
        const float area = 4.0f * glm::length(glm::cross(wl.half_x, wl.half_y));
        const glm::vec3 weight = power * (area / float(rect_samples));
        const std::uint32_t scramble = rng.next_u32();
        for (std::uint32_t k = 0; k < rect_samples; ++k) {
          const glm::vec2 u = sobol_2d(k, scramble);
          const glm::vec3 q = wl.position + (2.0f * u.x - 1.0f) * wl.half_x + (2.0f * u.y - 1.0f) * wl.half_y;
          const glm::vec3 d = q - p;
          const float dist2 = glm::dot(d, d);
          if (!(dist2 > 0.0f)) continue;
          const glm::vec3 l = d / std::sqrt(dist2);
          const float cl = -glm::dot(wl.direction, l);  // one-sided: emits towards `direction`
          if (!(cl > 0.0f) || !faces(l)) continue;     // also skips NaN
          if (!scene.occluded(Ray{origin, 0.0f, q - origin, 1.0f})) fn(l, weight * (cl / dist2));
        }
        break;
      }
    }
  }
}

}  // namespace penumbra
