// The .pbake container (see penumbra/core/pbake.h for the layout).
#include "penumbra/core/pbake.h"


#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <system_error>

#include "penumbra/core/file.h"
#include "penumbra/core/hash.h"
#include "penumbra/core/log.h"
#include "penumbra/core/random.h"
#include "penumbra/core/version.h"

namespace penumbra {

static_assert(std::endian::native == std::endian::little,
              "the .pbake format and ByteWriter/ByteReader assume a little-endian host");

namespace {

constexpr unsigned char kMagic[8] = {0x89, 'P', 'B', 'A', 'K', 'E', '\r', '\n'};
constexpr std::size_t kHeaderSize = 64;
constexpr std::size_t kEntrySize = 64;
constexpr std::uint64_t kAlignment = 16;

constexpr std::uint64_t align_up(std::uint64_t x) { return (x + kAlignment - 1) & ~(kAlignment - 1); }

std::string hex32(std::uint32_t v) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08x", v);
  return text;
}

// ---- little-endian fields in a byte buffer ---------------------------------------------------

void put32(unsigned char* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}
void put64(unsigned char* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}
std::uint32_t get32(const unsigned char* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}
std::uint64_t get64(const unsigned char* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}

// ---- reading ---------------------------------------------------------------------------------

Error corrupted(const std::string& name, const std::string& what) {
  return make_error(ErrorCode::InvalidInput, name + ": " + what + "; the file is corrupted, re-bake it");
}

// Reads `size` bytes at `offset`.
Status read_at(const std::filesystem::path& path, std::uint64_t offset, unsigned char* out, std::size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    return make_error(ErrorCode::Io, path.string() + ": cannot open for reading (" + std::strerror(errno) + ")");
  }
  bool ok = std::fseek(f, static_cast<long>(offset), SEEK_SET) == 0 && std::fread(out, 1, size, f) == size;
  std::fclose(f);
  if (!ok) return make_error(ErrorCode::Io, path.string() + ": read failed; check the disk and permissions");
  return {};
}

Result<std::uint64_t> file_size_of(const std::filesystem::path& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) {
    return make_error(ErrorCode::NotFound, path.string() + ": no such file (looked for " +
                                               std::filesystem::absolute(path, ec).string() + "); bake the scene first");
  }
  if (!std::filesystem::is_regular_file(status)) {
    return make_error(ErrorCode::InvalidInput, path.string() + ": not a regular file (" +
                                                   (std::filesystem::is_directory(status) ? "a folder" : "a device or pipe") +
                                                   "); give the .pbake file itself");
  }
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) return make_error(ErrorCode::Io, path.string() + ": cannot read its size (" + ec.message() + ")");
  return size;
}

// Checks the magic, format version, header checksum and recorded size of the first 64 bytes.
Status check_header(const std::string& name, const unsigned char* h, std::uint64_t actual_size) {
  const std::size_t have = static_cast<std::size_t>(std::min<std::uint64_t>(actual_size, kHeaderSize));
  if (std::memcmp(h, kMagic, std::min<std::size_t>(have, sizeof kMagic)) != 0) {
    if (have >= 7 && std::memcmp(h, kMagic, 6) == 0 && h[6] == '\n') {
      return make_error(ErrorCode::InvalidInput, name + ": line endings were converted (CR LF became LF), as by a "
                                                        "text-mode transfer; copy the file in binary mode");
    }
    if (have >= 1 && h[0] == 0x09 && std::memcmp(h + 1, kMagic + 1, std::min<std::size_t>(have, 8) - 1) == 0) {
      return make_error(ErrorCode::InvalidInput,
                        name + ": the high bit of each byte was stripped by a 7-bit transfer; copy the file in binary mode");
    }
    return make_error(ErrorCode::InvalidInput, name + ": not a .pbake file (it does not start with the .pbake "
                                                      "signature); give a file written by 'penumbra bake'");
  }
  if (have < kHeaderSize) {
    return corrupted(name, "truncated: " + std::to_string(actual_size) + " bytes, shorter than the 64-byte header");
  }
  const std::uint32_t version = get32(h + 8);
  if (version != kPbakeFormatVersion) {
    return make_error(ErrorCode::Unsupported, name + ": format version " + std::to_string(version) +
                                                  ", but this SDK reads version " +
                                                  std::to_string(kPbakeFormatVersion) + "; re-bake it with this SDK");
  }
  const std::uint32_t stored = get32(h + 60), computed = crc32(h, 60);
  if (stored != computed) {
    return corrupted(name, "header checksum mismatch (stored " + hex32(stored) + ", computed " + hex32(computed) + ")");
  }
  const std::uint64_t recorded = get64(h + 24);
  if (actual_size < recorded) {
    return corrupted(name, "truncated: " + std::to_string(actual_size) + " bytes, but the header records " +
                               std::to_string(recorded) + " (an interrupted copy?)");
  }
  if (actual_size > recorded) {
    return corrupted(name, std::to_string(actual_size - recorded) + " unexpected bytes after the end recorded in the header");
  }
  return {};
}

// Parses and checks the chunk table (canonical layout: each payload at the next 16-byte aligned
// offset, the file ending with the last payload).
Result<BakeFileInfo> parse_info(const std::string& name, const unsigned char* h, const unsigned char* table) {
  BakeFileInfo info;
  info.format_version = get32(h + 8);
  info.input_hash = get64(h + 16);
  info.file_size = get64(h + 24);
  const char* sdk = reinterpret_cast<const char*>(h + 32);
  info.sdk_version.assign(sdk, strnlen(sdk, kPbakeMaxSdkVersion));
  const std::uint32_t count = get32(h + 12);

  const std::uint32_t stored = get32(h + 56), computed = crc32(table, std::size_t{count} * kEntrySize);
  if (stored != computed) {
    return corrupted(name, "chunk table checksum mismatch (stored " + hex32(stored) + ", computed " + hex32(computed) + ")");
  }
  std::uint64_t expected_offset = align_up(kHeaderSize + std::uint64_t{count} * kEntrySize);
  std::uint64_t end = kHeaderSize + std::uint64_t{count} * kEntrySize;
  for (std::uint32_t i = 0; i < count; ++i) {
    const unsigned char* e = table + std::size_t{i} * kEntrySize;
    BakeChunkInfo c;
    c.type = get32(e);
    c.version = get32(e + 4);
    c.offset = get64(e + 8);
    c.size = get64(e + 16);
    c.crc = get32(e + 24);
    const std::uint32_t label_length = get32(e + 28);
    const std::string where = "chunk " + std::to_string(i) + " '" + fourcc_to_string(c.type) + "'";
    if (label_length > kPbakeMaxLabel) return corrupted(name, where + ": label length " + std::to_string(label_length) + " exceeds 32");
    c.label.assign(reinterpret_cast<const char*>(e + 32), label_length);
    if (c.offset != expected_offset) {
      return corrupted(name, where + ": payload offset " + std::to_string(c.offset) + ", expected " +
                                 std::to_string(expected_offset));
    }
    if (c.size > info.file_size || c.offset > info.file_size - c.size) {
      return corrupted(name, where + ": payload of " + std::to_string(c.size) + " bytes at offset " +
                                 std::to_string(c.offset) + " runs past the end of the " +
                                 std::to_string(info.file_size) + "-byte file");
    }
    end = c.offset + c.size;
    expected_offset = align_up(end);
    info.chunks.push_back(std::move(c));
  }
  if (end != info.file_size) {
    return corrupted(name, "the chunks end at byte " + std::to_string(end) + " but the file is " +
                               std::to_string(info.file_size) + " bytes");
  }
  return info;
}

// Header and table of a file whose first bytes are in `h` (all of them when `whole` is set).
Result<BakeFileInfo> read_info_from(const std::filesystem::path& path, std::vector<unsigned char>& bytes,
                                    std::uint64_t actual_size, bool whole) {
  const std::string name = path.string();
  PENUMBRA_TRY(check_header(name, bytes.data(), actual_size));
  const std::uint64_t count = get32(bytes.data() + 12);
  if (count > (actual_size - kHeaderSize) / kEntrySize) {
    return corrupted(name, "the header lists " + std::to_string(count) + " chunks, more than the file can hold");
  }
  const std::size_t table_end = kHeaderSize + static_cast<std::size_t>(count) * kEntrySize;
  if (!whole) {
    bytes.resize(table_end);
    PENUMBRA_TRY(read_at(path, kHeaderSize, bytes.data() + kHeaderSize, table_end - kHeaderSize));
  }
  return parse_info(name, bytes.data(), bytes.data() + kHeaderSize);
}

// ---- writing ---------------------------------------------------------------------------------

// Writes everything to the open temporary file.
Status write_contents(int fd, const std::filesystem::path& target, const BakeFile& file, const CancelToken* cancel) {
  const std::size_t count = file.chunks.size();
  std::vector<unsigned char> head(kHeaderSize + count * kEntrySize, 0);
  std::uint64_t offset = align_up(head.size());
  std::uint64_t end = head.size();
  for (std::size_t i = 0; i < count; ++i) {
    const BakeChunk& c = file.chunks[i];
    unsigned char* e = head.data() + kHeaderSize + i * kEntrySize;
    put32(e, c.type);
    put32(e + 4, c.version);
    put64(e + 8, offset);
    put64(e + 16, c.payload.size());
    put32(e + 24, crc32(c.payload.data(), c.payload.size()));
    put32(e + 28, static_cast<std::uint32_t>(c.label.size()));
    std::memcpy(e + 32, c.label.data(), c.label.size());
    end = offset + c.payload.size();
    offset = align_up(end);
  }
  unsigned char* h = head.data();
  std::memcpy(h, kMagic, sizeof kMagic);
  put32(h + 8, kPbakeFormatVersion);
  put32(h + 12, static_cast<std::uint32_t>(count));
  put64(h + 16, file.input_hash);
  put64(h + 24, end);
  const std::string sdk = file.sdk_version.empty() ? std::string(sdk_version()) : file.sdk_version;
  std::memcpy(h + 32, sdk.data(), sdk.size());
  put32(h + 56, crc32(h + kHeaderSize, count * kEntrySize));
  put32(h + 60, crc32(h, 60));

  const std::filesystem::path& p = target;
  PENUMBRA_TRY(write_all(fd, head.data(), head.size(), p));
  std::uint64_t written = head.size();
  static constexpr unsigned char kZeros[kAlignment] = {};
  for (std::size_t i = 0; i < count; ++i) {
    if (cancel != nullptr && cancel->cancelled()) {
      return make_error(ErrorCode::Cancelled, p.string() + ": write cancelled by the host; the previous file is kept");
    }
    PENUMBRA_TRY(write_all(fd, kZeros, static_cast<std::size_t>(align_up(written) - written), p));
    written = align_up(written);
    const BakeChunk& c = file.chunks[i];
    PENUMBRA_TRY(write_all(fd, c.payload.data(), c.payload.size(), p));
    written += c.payload.size();
  }
  return {};
}

}  // namespace

std::string fourcc_to_string(std::uint32_t type) {
  std::string s(4, '?');
  for (std::size_t i = 0; i < 4; ++i) {
    const auto c = static_cast<unsigned char>(type >> (8 * i));
    if (c >= 0x20 && c < 0x7f) s[i] = static_cast<char>(c);
  }
  return s;
}

const BakeChunk* BakeFile::find(std::uint32_t type) const {
  for (const BakeChunk& c : chunks) {
    if (c.type == type) return &c;
  }
  return nullptr;
}

std::uint64_t BakeFile::bytes() const {
  std::uint64_t total = sdk_version.capacity();
  for (const BakeChunk& c : chunks) total += sizeof(BakeChunk) + c.payload.capacity() + c.label.capacity();
  return total;
}

Status write_bake_file(const std::filesystem::path& path, const BakeFile& file, const CancelToken* cancel) {
  const std::string name = path.string();
  // Validate before touching the disk.
  if (file.format_version != kPbakeFormatVersion) {
    return make_error(ErrorCode::InvalidArgument, name + ": cannot write format version " +
                                                      std::to_string(file.format_version) + "; this SDK writes version " +
                                                      std::to_string(kPbakeFormatVersion));
  }
  if (file.sdk_version.size() >= kPbakeMaxSdkVersion) {
    return make_error(ErrorCode::InvalidArgument, name + ": SDK version string '" + file.sdk_version +
                                                      "' is longer than 23 bytes");
  }
  if (file.chunks.size() > 0xFFFFFFFFu) {
    return make_error(ErrorCode::InvalidArgument, name + ": too many chunks");
  }
  for (std::size_t i = 0; i < file.chunks.size(); ++i) {
    const BakeChunk& c = file.chunks[i];
    if (c.label.size() > kPbakeMaxLabel) {
      return make_error(ErrorCode::InvalidArgument, name + ": chunk " + std::to_string(i) + " '" +
                                                        fourcc_to_string(c.type) + "': label '" + c.label +
                                                        "' is longer than 32 bytes; shorten it");
    }
  }

  return write_atomically(path, [&](int fd) { return write_contents(fd, path, file, cancel); });
}

Result<BakeFileInfo> read_bake_info(const std::filesystem::path& path) {
  auto size = file_size_of(path);
  if (!size) return size.error();
  std::vector<unsigned char> bytes(kHeaderSize, 0);
  PENUMBRA_TRY(read_at(path, 0, bytes.data(), static_cast<std::size_t>(std::min<std::uint64_t>(*size, kHeaderSize))));
  return read_info_from(path, bytes, *size, false);
}

Result<BakeFile> read_bake_file(const std::filesystem::path& path) {
  auto size = file_size_of(path);
  if (!size) return size.error();
  if (*size > std::uint64_t{1} << 40) {
    return make_error(ErrorCode::InvalidInput, path.string() + ": " + std::to_string(*size) + " bytes is too large for a bake file");
  }
  std::vector<unsigned char> bytes(static_cast<std::size_t>(std::max<std::uint64_t>(*size, kHeaderSize)), 0);
  PENUMBRA_TRY(read_at(path, 0, bytes.data(), static_cast<std::size_t>(*size)));
  auto info = read_info_from(path, bytes, *size, true);
  if (!info) return info.error();

  const std::string name = path.string();
  BakeFile file;
  file.format_version = info->format_version;
  file.input_hash = info->input_hash;
  file.sdk_version = info->sdk_version;
  std::uint64_t previous_end = kHeaderSize + info->chunks.size() * kEntrySize;
  for (std::size_t i = 0; i < info->chunks.size(); ++i) {
    const BakeChunkInfo& c = info->chunks[i];
    const std::string where = "chunk " + std::to_string(i) + " '" + fourcc_to_string(c.type) + "'";
    // The padding before each payload is zero (every byte of the file is checked).
    for (std::uint64_t b = previous_end; b < c.offset; ++b) {
      if (bytes[b] != 0) return corrupted(name, where + ": non-zero padding at byte " + std::to_string(b));
    }
    const unsigned char* payload = bytes.data() + c.offset;
    const std::uint32_t computed = crc32(payload, static_cast<std::size_t>(c.size));
    if (computed != c.crc) {
      return corrupted(name, where + ": checksum mismatch (stored " + hex32(c.crc) + ", computed " + hex32(computed) + ")");
    }
    BakeChunk chunk;
    chunk.type = c.type;
    chunk.version = c.version;
    chunk.label = c.label;
    chunk.payload.resize(static_cast<std::size_t>(c.size));
    if (!chunk.payload.empty()) std::memcpy(chunk.payload.data(), payload, chunk.payload.size());
    file.chunks.push_back(std::move(chunk));
    previous_end = c.offset + c.size;
  }
  return file;
}

// ---- ByteWriter / ByteReader -----------------------------------------------------------------

void ByteWriter::write_bytes(const void* data, std::size_t size) {
  const auto* p = static_cast<const std::byte*>(data);
  data_.insert(data_.end(), p, p + size);
}

void ByteWriter::write_string(std::string_view s) {
  write(static_cast<std::uint32_t>(s.size()));
  write_bytes(s.data(), s.size());
}

ByteReader::ByteReader(std::span<const std::byte> data, std::string context)
    : data_(data), context_(std::move(context)) {}

Status ByteReader::read_bytes(void* out, std::size_t size, std::string_view what) {
  if (size > remaining()) {
    return make_error(ErrorCode::InvalidInput, context_ + ": truncated: reading " + std::string(what) + " of " +
                                                   std::to_string(size) + " bytes at offset " + std::to_string(offset_) +
                                                   " of a " + std::to_string(data_.size()) +
                                                   "-byte payload; the data is corrupted or from another version, re-bake it");
  }
  if (size > 0) std::memcpy(out, data_.data() + offset_, size);
  offset_ += size;
  return {};
}

Status ByteReader::read_count(std::uint64_t& count, std::size_t element_size, std::uint64_t max_count) {
  const std::size_t at = offset_;
  std::uint64_t n = 0;
  PENUMBRA_TRY(read_bytes(&n, sizeof n, "an element count"));
  if (n > max_count || n > remaining() / element_size) {
    offset_ = at;
    return make_error(ErrorCode::InvalidInput, context_ + ": element count " + std::to_string(n) + " at offset " +
                                                   std::to_string(at) + " exceeds " +
                                                   (n > max_count ? "the limit of " + std::to_string(max_count)
                                                                  : "the " + std::to_string(remaining()) + " bytes left") +
                                                   "; the data is corrupted, re-bake it");
  }
  count = n;
  return {};
}

Status ByteReader::read_string(std::string& out, std::size_t max_size) {
  const std::size_t at = offset_;
  std::uint32_t n = 0;
  PENUMBRA_TRY(read_bytes(&n, sizeof n, "a string length"));
  if (n > max_size || n > remaining()) {
    offset_ = at;
    return make_error(ErrorCode::InvalidInput, context_ + ": string of " + std::to_string(n) + " bytes at offset " +
                                                   std::to_string(at) + " is longer than allowed or than the payload; "
                                                   "the data is corrupted, re-bake it");
  }
  out.assign(reinterpret_cast<const char*>(data_.data() + offset_), n);
  offset_ += n;
  return {};
}

Status ByteReader::finish() const {
  if (remaining() != 0) {
    return make_error(ErrorCode::InvalidInput, context_ + ": " + std::to_string(remaining()) +
                                                   " unexpected bytes after the data (at offset " + std::to_string(offset_) +
                                                   "); the chunk was written by another version, re-bake it");
  }
  return {};
}

Status check_chunk(const BakeChunk& chunk, std::uint32_t type, std::uint32_t version, std::string_view context) {
  const std::string where(context);
  if (chunk.type != type)
    return make_error(ErrorCode::InvalidArgument,
                      where + ": this chunk is '" + fourcc_to_string(chunk.type) + "', not '" + fourcc_to_string(type) + "'");
  if (chunk.version != version)
    return make_error(ErrorCode::Unsupported, where + ": version " + std::to_string(chunk.version) +
                                                  ", this SDK reads version " + std::to_string(version) +
                                                  "; re-bake with this SDK");
  return {};
}

}  // namespace penumbra
