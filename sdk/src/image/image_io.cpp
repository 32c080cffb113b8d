// write_image: PNG through stb_image_write, OpenEXR (32-bit float RGBA) through OpenEXR; both
// written to a temporary file that is renamed over the destination. read_exr: OpenEXR, checked.
#include "penumbra/image/image.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>

#include "stb_image_write.h"  // implementation in Debian's libstb

namespace penumbra {
namespace {

bool ends_with(const std::string& s, std::string_view suffix) {
  if (s.size() < suffix.size()) return false;
  for (std::size_t i = 0; i < suffix.size(); ++i) {
    const char c = s[s.size() - suffix.size() + i];
    if (std::tolower(static_cast<unsigned char>(c)) != suffix[i]) return false;
  }
  return true;
}

Status write_exr(const Image& image, const std::string& path) {
  try {
    const int w = static_cast<int>(image.width), h = static_cast<int>(image.height);
    Imf::Header header(w, h);
    for (const char* c : {"R", "G", "B", "A"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    Imf::OutputFile file(path.c_str(), header);
    Imf::FrameBuffer fb;
    const std::size_t xs = 4 * sizeof(float), ys = xs * image.width;
    char* base = const_cast<char*>(reinterpret_cast<const char*>(image.rgba32f.data()));
    const char* names[4] = {"R", "G", "B", "A"};
    for (std::size_t c = 0; c < 4; ++c) fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
    file.setFrameBuffer(fb);
    file.writePixels(h);
  } catch (const std::exception& e) {
    return make_error(ErrorCode::Io, path + ": cannot write OpenEXR: " + e.what());
  }
  return {};
}

}  // namespace

glm::vec3 display_colour(glm::vec3 radiance, float exposure, bool encode_srgb) {
  glm::vec3 out;
  for (int c = 0; c < 3; ++c) {
    const float v = radiance[c] * exposure;
    const float x = v > 0.0f ? v : 0.0f;  // NaN and negatives: 0
    float t = std::clamp((x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f), 0.0f, 1.0f);
    if (encode_srgb) t = t <= 0.0031308f ? 12.92f * t : 1.055f * std::pow(t, 1.0f / 2.4f) - 0.055f;
    out[c] = std::clamp(t, 0.0f, 1.0f);
  }
  return out;
}

Status write_image(const Image& image, const std::string& path) {
  const bool png = ends_with(path, ".png"), exr = ends_with(path, ".exr");
  if (!png && !exr) {
    return make_error(ErrorCode::InvalidArgument, path + ": unknown image type; use a .png or .exr file name");
  }
  const std::size_t pixels = std::size_t{image.width} * image.height;
  if (pixels == 0) return make_error(ErrorCode::InvalidArgument, path + ": the image is empty");
  if (png && image.rgba8.size() != pixels * 4) {
    return make_error(ErrorCode::InvalidArgument, path + ": PNG needs an 8-bit image; render without linear_float or write .exr");
  }
  if (exr && image.rgba32f.size() != pixels * 4) {
    return make_error(ErrorCode::InvalidArgument, path + ": OpenEXR needs a float image; render with linear_float or write .png");
  }
  // Atomic: write "<path>.tmp<ext>", then rename.
  const std::string tmp = path + (png ? ".tmp.png" : ".tmp.exr");
  Status written;
  if (png) {
    const int stride = static_cast<int>(image.width * 4);
    if (!stbi_write_png(tmp.c_str(), static_cast<int>(image.width), static_cast<int>(image.height), 4,
                        image.rgba8.data(), stride)) {
      written = make_error(ErrorCode::Io, path + ": cannot write the PNG; check that the directory exists and is writable");
    }
  } else {
    written = write_exr(image, tmp);
  }
  std::error_code ec;
  if (!written.ok()) {
    std::filesystem::remove(tmp, ec);
    return written;
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return make_error(ErrorCode::Io, path + ": cannot replace the file (" + ec.message() + ")");
  }
  return {};
}

Result<Image> read_exr(const std::string& path) {
  constexpr std::int64_t kMaxSide = 16384, kMaxPixels = std::int64_t{1} << 26;
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    const std::int64_t w = std::int64_t(window.max.x) - window.min.x + 1, h = std::int64_t(window.max.y) - window.min.y + 1;
    if (w < 1 || h < 1 || w > kMaxSide || h > kMaxSide || w * h > kMaxPixels)
      return make_error(ErrorCode::InvalidInput, path + ": the image's data window is " + std::to_string(w) + "x" +
                                                     std::to_string(h) + "; an image of 1..16384 pixels per side and "
                                                     "at most 2^26 pixels is expected");
    const Imf::ChannelList& channels = file.header().channels();
    for (const char* c : {"R", "G", "B"})
      if (!channels.findChannel(c))
        return make_error(ErrorCode::InvalidInput, path + ": the image has no " + std::string(c) +
                                                       " channel; write R, G and B (an RGB or RGBA OpenEXR)");
    for (auto it = channels.begin(); it != channels.end(); ++it)
      if (it.channel().xSampling != 1 || it.channel().ySampling != 1)
        return make_error(ErrorCode::InvalidInput, path + ": channel " + std::string(it.name()) +
                                                       " is subsampled; write full-resolution channels");
    Image image;
    image.width = static_cast<std::uint32_t>(w);
    image.height = static_cast<std::uint32_t>(h);
    image.rgba32f.assign(std::size_t(w * h) * 4, 1.0f);  // A stays 1 when the file has none
    Imf::FrameBuffer fb;
    const char* names[4] = {"R", "G", "B", "A"};
    for (std::size_t c = 0; c < 4; ++c) {
      // Slice::Make places the data window's corner at the buffer's start without out-of-range pointers.
      fb.insert(names[c], Imf::Slice::Make(Imf::FLOAT, image.rgba32f.data() + c, window, 4 * sizeof(float),
                                           std::size_t(w) * 4 * sizeof(float), 1, 1, c == 3 ? 1.0 : 0.0));
    }
    file.setFrameBuffer(fb);
    file.readPixels(window.min.y, window.max.y);
    return image;
  } catch (const std::exception& e) {
    return make_error(ErrorCode::InvalidInput, path + ": cannot read it as OpenEXR (" + e.what() +
                                                   "); write the image again, as a scanline or tiled OpenEXR");
  }
}

}  // namespace penumbra
