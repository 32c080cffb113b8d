// Irradiance caching with gradients and neighbour clamping (offline/irradiance_cache.h).
#include "penumbra/offline/irradiance_cache.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "penumbra/core/colour.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/sampling.h"

namespace penumbra {
namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::uint32_t kTile = 8;  // pixels per side of a screen tile of the record look-up

std::uint32_t rings(std::uint32_t rays) {
  return std::max<std::uint32_t>(2, static_cast<std::uint32_t>(std::lround(std::sqrt(double(rays) / kPi))));
}
std::uint32_t sectors(std::uint32_t rays) {
  return std::max<std::uint32_t>(3, static_cast<std::uint32_t>(std::lround(double(rays) / rings(rays))));
}

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

std::uint32_t cache_record_rays(std::uint32_t rays) { return rings(rays) * sectors(rays); }

CacheRecord make_cache_record(glm::vec3 x, glm::vec3 n, std::uint32_t rays, Rng& rng, const IncidentFn& incident,
                              std::uint32_t* nonfinite) {
  const std::uint32_t m = rings(rays), sec = sectors(rays);
  glm::vec3 t, b;
  orthonormal_basis(n, t, b);
  const auto rho = [&](float phi) { return std::cos(phi) * t + std::sin(phi) * b; };  // e_rho in world space
  const auto along = [&](float phi) { return -std::sin(phi) * t + std::cos(phi) * b; };  // e_phi
  std::vector<glm::vec3> radiance(std::size_t(m) * sec);
  std::vector<float> dist(std::size_t(m) * sec);
  CacheRecord r;
  r.position = x;
  r.normal = n;
  double inverse_distance = 0.0;
  glm::dvec3 sum(0.0);
  for (std::uint32_t j = 0; j < m; ++j) {
    for (std::uint32_t k = 0; k < sec; ++k) {
      // Stratum (j, k): rings of equal projected solid angle, jittered inside.
      const float sin2 = (float(j) + rng.next_float()) / float(m);
      const float phi = 2.0f * kPi * (float(k) + rng.next_float()) / float(sec);
      const float sin_t = std::sqrt(sin2), cos_t = std::sqrt(std::max(0.0f, 1.0f - sin2));
      const glm::vec3 dir = sin_t * rho(phi) + cos_t * n;
      IncidentSample s = incident(x, n, dir, rng);
      if (!finite(s.value) || std::isnan(s.distance)) {
        if (nonfinite) ++*nonfinite;
        s = {glm::vec3(0.0f), kInf};
      }
      const std::size_t at = std::size_t(j) * sec + k;
      radiance[at] = s.value / kPi;
      dist[at] = s.distance > 0.0f ? s.distance : 1e-30f;
      sum += glm::dvec3(s.value);
      if (std::isfinite(dist[at])) inverse_distance += 1.0 / double(dist[at]);
      // Rotation: dE/dn = \int L (u . w) dw = pi / (M N) sum L tan(theta) e_rho, at the stratum's centre.
      const float sin2_c = (float(j) + 0.5f) / float(m);
      const float tan_c = std::sqrt(sin2_c / std::max(1.0f - sin2_c, 1e-6f));
      const glm::vec3 e = rho(2.0f * kPi * (float(k) + 0.5f) / float(sec));
      for (int c = 0; c < 3; ++c) r.rotational[c] += (kPi / float(m * sec)) * radiance[at][c] * tan_c * e;
    }
  }
  r.irradiance = glm::vec3(sum / double(m * sec));
  r.radius = inverse_distance > 0.0 ? float(double(m * sec) / inverse_distance) : kInf;
  // Translation (Ward & Heckbert 1992): moving x along the surface moves each strata boundary by
  // 1 / (the nearer distance seen on its two sides), trading one stratum's radiance for the other's.
  for (std::uint32_t k = 0; k < sec; ++k) {
    const glm::vec3 e = rho(2.0f * kPi * (float(k) + 0.5f) / float(sec));
    for (std::uint32_t j = 1; j < m; ++j) {
      const std::size_t a = std::size_t(j) * sec + k, below = std::size_t(j - 1) * sec + k;
      const float d = std::min(dist[a], dist[below]);
      if (!std::isfinite(d)) continue;
      const float sin_b = std::sqrt(float(j) / float(m)), cos2_b = 1.0f - float(j) / float(m);
      const float scale = (2.0f * kPi / float(sec)) * sin_b * cos2_b / d;
      for (int c = 0; c < 3; ++c) r.translational[c] += scale * (radiance[a][c] - radiance[below][c]) * e;
    }
    const glm::vec3 v = along(2.0f * kPi * float(k) / float(sec));
    const std::uint32_t prev = (k + sec - 1) % sec;
    for (std::uint32_t j = 0; j < m; ++j) {
      const std::size_t a = std::size_t(j) * sec + k, side = std::size_t(j) * sec + prev;
      const float d = std::min(dist[a], dist[side]);
      if (!std::isfinite(d)) continue;
      const float scale = (std::sqrt(float(j + 1) / float(m)) - std::sqrt(float(j) / float(m))) / d;
      for (int c = 0; c < 3; ++c) r.translational[c] += scale * (radiance[a][c] - radiance[side][c]) * v;
    }
  }
  return r;
}

float cache_weight(const CacheRecord& record, glm::vec3 x, glm::vec3 n, float accuracy) {
  const glm::vec3 d = x - record.position;
  const float distance = glm::length(d);
  // A record in front of x (x lies behind its surface) sees what x does not.
  if (glm::dot(d, 0.5f * (n + record.normal)) < -0.05f * distance) return 0.0f;
  const float eps = (std::isfinite(record.radius) ? distance / record.radius : 0.0f) +
                    std::sqrt(std::max(0.0f, 1.0f - glm::dot(n, record.normal)));
  if (!(eps < accuracy)) return 0.0f;
  return 1.0f / std::max(eps, 1e-6f) - 1.0f / accuracy;
}

glm::vec3 cache_extrapolate(const CacheRecord& record, glm::vec3 x, glm::vec3 n) {
  const glm::vec3 dx = x - record.position, dn = n - record.normal;
  glm::vec3 e;
  for (int c = 0; c < 3; ++c)
    e[c] = std::max(0.0f, record.irradiance[c] + glm::dot(record.translational[c], dx) + glm::dot(record.rotational[c], dn));
  return e;
}

Status irradiance_cache(std::span<const CachePixel> pixels, std::uint32_t width, std::uint32_t height,
                        const IrradianceCacheSettings& s, const IncidentFn& incident, std::span<glm::vec3> out,
                        IrradianceCacheStats& stats, JobContext& jobs) {
  const std::size_t count = std::size_t(width) * height;
  if (pixels.size() != count || out.size() != count)
    return make_error(ErrorCode::InvalidArgument, "irradiance_cache: size the pixels and the output as the image");
  if (!(s.accuracy > 0.0f) || !std::isfinite(s.accuracy) || s.rays < 6 || !(s.min_radius > 0.0f) ||
      !(s.max_radius >= s.min_radius) || !std::isfinite(s.max_radius))
    return make_error(ErrorCode::InvalidArgument,
                      "irradiance_cache: accuracy must be positive, rays at least 6, 0 < min_radius <= max_radius");
  const std::uint32_t tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
  std::vector<std::vector<std::uint32_t>> tiles(std::size_t(tiles_x) * tiles_y);
  std::vector<CacheRecord> records;
  const auto tile_of = [&](std::size_t p) { return (p / width / kTile) * tiles_x + (p % width) / kTile; };
  const auto covered = [&](std::size_t p) {
    for (const std::uint32_t r : tiles[tile_of(p)])
      if (cache_weight(records[r], pixels[p].position, pixels[p].normal, s.accuracy) > 0.0f) return true;
    return false;
  };

  std::vector<std::uint32_t> levels;
  for (std::uint32_t spacing = 32; spacing >= 1; spacing /= 2) levels.push_back(spacing);
  std::uint64_t units = 0;
  for (const std::uint32_t sp : levels) units += std::uint64_t((width + sp - 1) / sp) * ((height + sp - 1) / sp);
  jobs.begin_stage("irradiance cache", units);
  for (const std::uint32_t sp : levels) {
    // The level's lattice pixels; those no record covers get one (in parallel, each from its own stream).
    std::vector<std::size_t> lattice;
    for (std::uint32_t y = 0; y < height; y += sp)
      for (std::uint32_t x = 0; x < width; x += sp) lattice.push_back(std::size_t(y) * width + x);
    std::vector<std::optional<CacheRecord>> made(lattice.size());
    std::vector<std::uint32_t> bad(lattice.size(), 0);
    PENUMBRA_TRY(jobs.parallel_for(lattice.size(), 16, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const std::size_t p = lattice[i];
        if (!pixels[p].surface || covered(p)) continue;
        Rng rng = Rng::stream(mix64(s.seed + 0x1cu), p);
        made[i] = make_cache_record(pixels[p].position, pixels[p].normal, s.rays, rng, incident, &bad[i]);
      }
    }));
    // In pixel order: clamp each new record's radius, then insert it where it may be looked up.
    for (std::size_t i = 0; i < lattice.size(); ++i) {
      stats.nonfinite += bad[i];
      if (!made[i]) continue;
      CacheRecord& r = *made[i];
      const std::size_t p = lattice[i];
      const float fp = pixels[p].footprint;
      const float lo = s.min_radius * fp / s.accuracy, hi = s.max_radius * fp / s.accuracy;
      r.radius = std::min(r.radius, hi);
      // Neighbour clamping (Křivánek et al. 2006): no record's radius exceeds a neighbour's plus
      // their distance; the neighbours are the records whose influence reaches its tile.
      for (const std::uint32_t j : tiles[tile_of(p)])
        r.radius = std::min(r.radius, records[j].radius + glm::distance(r.position, records[j].position));
      const auto px = static_cast<std::int64_t>(p % width), py = static_cast<std::int64_t>(p / width);
      // Gradient limit: the translation cannot extrapolate the luminance below zero within R.
      glm::vec3 grad(0.0f);
      for (int c = 0; c < 3; ++c) grad += kLuminanceWeights[c] * r.translational[c];
      const float g = glm::length(grad);
      if (g > 0.0f) r.radius = std::min(r.radius, luminance(r.irradiance) / g);
      r.radius = std::max(r.radius, lo);
      // Insert into the tiles its influence (a R pixels around it) touches.
      const float influence = std::min(s.accuracy * r.radius / fp, s.max_radius);
      const auto ir = static_cast<std::int64_t>(std::ceil(influence));
      const auto index = static_cast<std::uint32_t>(records.size());
      for (std::int64_t ty = std::max<std::int64_t>(0, (py - ir) / kTile);
           ty <= std::min<std::int64_t>(tiles_y - 1, (py + ir) / kTile); ++ty)
        for (std::int64_t tx = std::max<std::int64_t>(0, (px - ir) / kTile);
             tx <= std::min<std::int64_t>(tiles_x - 1, (px + ir) / kTile); ++tx)
          tiles[std::size_t(ty) * tiles_x + std::size_t(tx)].push_back(index);
      records.push_back(r);
    }
  }
  stats.records += records.size();
  stats.rays += records.size() * std::uint64_t(cache_record_rays(s.rays));

  // Interpolation: every surface pixel is covered (the last level gave each uncovered one a record).
  jobs.begin_stage("cache interpolation", count);
  return jobs.parallel_for(count, 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t p = begin; p < end; ++p) {
      out[p] = glm::vec3(0.0f);
      if (!pixels[p].surface) continue;
      glm::dvec3 sum(0.0);
      double weight = 0.0;
      for (const std::uint32_t r : tiles[tile_of(p)]) {
        const float w = cache_weight(records[r], pixels[p].position, pixels[p].normal, s.accuracy);
        if (w <= 0.0f) continue;
        sum += double(w) * glm::dvec3(cache_extrapolate(records[r], pixels[p].position, pixels[p].normal));
        weight += w;
      }
      if (weight > 0.0) out[p] = glm::vec3(sum / weight);
    }
  });
}

}  // namespace penumbra
