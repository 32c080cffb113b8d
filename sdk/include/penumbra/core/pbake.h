// The .pbake container: baked lighting data as typed, versioned, checksummed chunks.
//
// Layout (all integers little-endian; the SDK supports little-endian hosts only):
//   0   header, 64 bytes:
//         magic "\x89PBAKE\r\n" (the 0x89 and CR LF catch 7-bit and text-mode transfers),
//         u32 format version, u32 chunk count, u64 input hash, u64 file size,
//         char[24] SDK version (NUL-padded), u32 CRC-32 of the chunk table,
//         u32 CRC-32 of header bytes 0..59
//   64  chunk table, 64 bytes per chunk:
//         u32 type (fourcc), u32 chunk version, u64 offset, u64 size, u32 CRC-32 of the payload,
//         u32 label length, char[32] label (NUL-padded)
//   then the payloads, each at a 16-byte aligned offset, in table order, zero padding between.
// Every byte is covered by a check, so truncation and any bit flip are reported, never
// misread. Writes are atomic: the file is written to a temporary name in the same directory,
// flushed to disk and renamed over the target, so a failed or cancelled write leaves the
// previous file as it was.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "penumbra/core/jobs.h"
#include "penumbra/core/result.h"

namespace penumbra {

inline constexpr std::uint32_t kPbakeFormatVersion = 1;
inline constexpr std::size_t kPbakeMaxLabel = 32;    // bytes
inline constexpr std::size_t kPbakeMaxSdkVersion = 24;  // bytes, including a terminating NUL

// The chunk type code of four ASCII characters, first character in the lowest byte:
// fourcc("PRBG"). `code` must have exactly 4 characters.
constexpr std::uint32_t fourcc(const char (&code)[5]) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(code[0])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(code[1])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(code[2])) << 16 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(code[3])) << 24;
}
// "PRBG" back from the code; non-printable bytes become '?'.
std::string fourcc_to_string(std::uint32_t type);

// The chunk that marks a part of a sharded bake (penumbra/bake/shard.h), which only `penumbra
// merge` reads: a part holds work items, not lighting data.
inline constexpr std::uint32_t kShardManifestChunk = fourcc("SHRD");

// One baker's output: its type, the version of its payload layout, a short label (at most
// kPbakeMaxLabel bytes, e.g. the entity or probe-volume name) and the serialised data.
struct BakeChunk {
  std::uint32_t type = 0;
  std::uint32_t version = 0;
  std::string label;
  std::vector<std::byte> payload;
};

// A whole bake. format_version and sdk_version describe the file that was read; on write,
// format_version must be kPbakeFormatVersion and an empty sdk_version means this SDK's.
struct BakeFile {
  std::uint32_t format_version = kPbakeFormatVersion;
  std::uint64_t input_hash = 0;  // hash of everything the bake read (scene, settings, seed)
  std::string sdk_version;
  std::vector<BakeChunk> chunks;

  // The first chunk of `type`, or nullptr.
  const BakeChunk* find(std::uint32_t type) const;
  // Bytes held in memory by the chunks' payloads and labels.
  std::uint64_t bytes() const;
};

// The first check of every chunk reader: InvalidArgument when `chunk` is not of `type`, Unsupported
// when its layout version is not `version` (naming both and asking for a re-bake). `context`
// names the chunk in the message, e.g. "chunk 'PRBG' (probe-grid:hall)".
Status check_chunk(const BakeChunk& chunk, std::uint32_t type, std::uint32_t version, std::string_view context);

// What the header and chunk table say, without reading the payloads.
struct BakeChunkInfo {
  std::uint32_t type = 0;
  std::uint32_t version = 0;
  std::string label;
  std::uint64_t offset = 0;
  std::uint64_t size = 0;
  std::uint32_t crc = 0;
};
struct BakeFileInfo {
  std::uint32_t format_version = 0;
  std::uint64_t input_hash = 0;
  std::string sdk_version;
  std::uint64_t file_size = 0;
  std::vector<BakeChunkInfo> chunks;
};

// Writes `file` to `path` atomically (temporary file <path>.tmp-<pid>-<n>, fsync, rename, fsync
// of the directory). Fails with InvalidArgument (a label or version string too long, a wrong
// format_version), Io (the directory cannot be written, the disk is full) or Cancelled (`cancel`
// was set; checked before each chunk); on any failure the temporary file is removed and an
// existing file at `path` is untouched. Cost: one pass over the payloads (CRC-32) plus the
// write. Thread-safe for distinct paths.
Status write_bake_file(const std::filesystem::path& path, const BakeFile& file,
                       const CancelToken* cancel = nullptr);

// Reads and verifies a whole file: magic, header and table checksums, format version, sizes,
// alignment, every payload's CRC-32 and the zero padding. Errors (InvalidInput, NotFound, Io,
// Unsupported for another format version) name the file and the element, e.g.
//   "courtyard.pbake: chunk 2 'PRBG': checksum mismatch (stored 0x1234abcd, computed
//    0x9f00e1c2); the file is corrupted, re-bake it".
Result<BakeFile> read_bake_file(const std::filesystem::path& path);

// Reads and verifies the header and the chunk table only (cheap: for `penumbra info` and the
// "inputs unchanged, skip the bake" check). Payload checksums are not verified.
Result<BakeFileInfo> read_bake_info(const std::filesystem::path& path);

// Serialises a chunk payload: values are appended little-endian, byte for byte. T must be
// trivially copyable without padding (arithmetic types, glm vectors and matrices of them).
class ByteWriter {
 public:
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void write(const T& value) { write_bytes(&value, sizeof(T)); }
  // The elements only; the reader must know the count.
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void write_array(std::span<const T> values) { write_bytes(values.data(), values.size_bytes()); }
  // A u64 element count, then the elements (read back with ByteReader::read_vector).
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void write_vector(std::span<const T> values) {
    write(static_cast<std::uint64_t>(values.size()));
    write_array(values);
  }
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void write_vector(const std::vector<T>& values) { write_vector(std::span<const T>(values)); }
  // A u32 byte count, then the characters.
  void write_string(std::string_view s);
  void write_bytes(const void* data, std::size_t size);

  std::size_t size() const { return data_.size(); }
  // Hands the bytes over (the writer is empty afterwards).
  std::vector<std::byte> take() { return std::move(data_); }

 private:
  std::vector<std::byte> data_;
};

// Reads a chunk payload written by ByteWriter with bounds checks: a read past the end fails with
// InvalidInput naming `context` (e.g. "chunk 'VXAO'"), the offset and the sizes, and leaves the
// output unchanged. Not thread-safe; the payload must outlive the reader.
class ByteReader {
 public:
  ByteReader(std::span<const std::byte> data, std::string context);

  template <class T>
    requires std::is_trivially_copyable_v<T>
  Status read(T& value) { return read_bytes(&value, sizeof(T), "a value"); }
  template <class T>
    requires std::is_trivially_copyable_v<T>
  Status read_array(std::span<T> out) { return read_bytes(out.data(), out.size_bytes(), "an array"); }
  // Reads a u64 count (at most `max_count`, and no more than the bytes left allow) and the
  // elements.
  template <class T>
    requires std::is_trivially_copyable_v<T>
  Status read_vector(std::vector<T>& out, std::uint64_t max_count = UINT64_MAX) {
    std::uint64_t count = 0;
    PENUMBRA_TRY(read_count(count, sizeof(T), max_count));
    std::vector<T> values(static_cast<std::size_t>(count));
    PENUMBRA_TRY(read_array(std::span<T>(values)));
    out = std::move(values);
    return {};
  }
  Status read_string(std::string& out, std::size_t max_size = 4096);
  Status read_bytes(void* out, std::size_t size, std::string_view what = "bytes");

  // Succeeds when every byte was consumed; trailing bytes mean a layout mismatch.
  Status finish() const;
  std::size_t offset() const { return offset_; }
  std::size_t remaining() const { return data_.size() - offset_; }
  const std::string& context() const { return context_; }

 private:
  Status read_count(std::uint64_t& count, std::size_t element_size, std::uint64_t max_count);

  std::span<const std::byte> data_;
  std::size_t offset_ = 0;
  std::string context_;
};

}  // namespace penumbra
