#include "penumbra/core/pbake.h"

#include <gtest/gtest.h>

#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>

#include "penumbra/core/hash.h"
#include "penumbra/core/version.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards.
class PbakeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("penumbra_pbake_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::permissions(dir_, fs::perms::owner_all, ec);
    fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

std::vector<std::byte> bytes_of_text(std::string_view s) {
  std::vector<std::byte> out(s.size());
  std::memcpy(out.data(), s.data(), s.size());
  return out;
}

BakeFile sample_file() {
  BakeFile f;
  f.input_hash = 0x0123456789abcdefull;
  f.chunks.push_back({fourcc("VXAO"), 1, "courtyard", bytes_of_text("seventeen bytes!!")});
  f.chunks.push_back({fourcc("PRBG"), 3, "", {}});
  f.chunks.push_back({fourcc("PRBG"), 2, "probe volume 2", bytes_of_text("0123456789abcdef")});
  return f;
}

std::vector<char> slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void spit(const fs::path& p, const std::vector<char>& data, std::size_t size) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(data.data(), static_cast<std::streamsize>(size));
}

// Only `expected` remains in the directory: no temporary file was left behind.
void expect_only(const fs::path& dir, const std::vector<std::string>& expected) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, expected);
}

TEST_F(PbakeTest, RoundTrip) {
  const fs::path path = dir_ / "scene.pbake";
  const BakeFile in = sample_file();
  ASSERT_TRUE(write_bake_file(path, in).ok());
  auto out = read_bake_file(path);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_EQ(out->format_version, kPbakeFormatVersion);
  EXPECT_EQ(out->input_hash, in.input_hash);
  EXPECT_EQ(out->sdk_version, sdk_version());
  ASSERT_EQ(out->chunks.size(), in.chunks.size());
  for (std::size_t i = 0; i < in.chunks.size(); ++i) {
    EXPECT_EQ(out->chunks[i].type, in.chunks[i].type);
    EXPECT_EQ(out->chunks[i].version, in.chunks[i].version);
    EXPECT_EQ(out->chunks[i].label, in.chunks[i].label);
    EXPECT_EQ(out->chunks[i].payload, in.chunks[i].payload);
  }
  ASSERT_NE(out->find(fourcc("PRBG")), nullptr);
  EXPECT_EQ(out->find(fourcc("PRBG"))->version, 3u);  // the first of its type
  EXPECT_EQ(out->find(fourcc("NONE")), nullptr);
  EXPECT_GE(out->bytes(), 33u);

  auto info = read_bake_info(path);
  ASSERT_TRUE(info.ok()) << info.error().message;
  EXPECT_EQ(info->input_hash, in.input_hash);
  EXPECT_EQ(info->file_size, fs::file_size(path));
  ASSERT_EQ(info->chunks.size(), 3u);
  for (const BakeChunkInfo& c : info->chunks) EXPECT_EQ(c.offset % 16, 0u);
  EXPECT_EQ(info->chunks[2].label, "probe volume 2");
  EXPECT_EQ(info->chunks[2].size, 16u);

  // The file starts with the documented little-endian header.
  const std::vector<char> raw = slurp(path);
  EXPECT_EQ(std::memcmp(raw.data(), "\x89PBAKE\r\n", 8), 0);
  EXPECT_EQ(static_cast<unsigned char>(raw[8]), kPbakeFormatVersion);
  EXPECT_EQ(raw[12], 3);
  EXPECT_EQ(static_cast<unsigned char>(raw[16]), 0xefu);  // input hash, lowest byte first
  expect_only(dir_, {"scene.pbake"});
}

TEST_F(PbakeTest, FourccText) {
  EXPECT_EQ(fourcc("PRBG"), 0x47425250u);
  EXPECT_EQ(fourcc_to_string(fourcc("VXAO")), "VXAO");
  EXPECT_EQ(fourcc_to_string(0x00414141u), "AAA?");
}

TEST_F(PbakeTest, EveryTruncationIsRejected) {
  const fs::path good = dir_ / "good.pbake", cut = dir_ / "cut.pbake";
  ASSERT_TRUE(write_bake_file(good, sample_file()).ok());
  const std::vector<char> raw = slurp(good);
  for (std::size_t n = 0; n < raw.size(); ++n) {
    spit(cut, raw, n);
    auto file = read_bake_file(cut);
    ASSERT_FALSE(file.ok()) << "length " << n;
    EXPECT_EQ(file.error().code, ErrorCode::InvalidInput) << n;
    EXPECT_NE(file.error().message.find("cut.pbake"), std::string::npos) << file.error().message;
    EXPECT_FALSE(read_bake_info(cut).ok()) << "length " << n;
  }
  // Appended bytes are rejected too.
  std::vector<char> longer = raw;
  longer.push_back(0);
  spit(cut, longer, longer.size());
  EXPECT_FALSE(read_bake_file(cut).ok());
}

TEST_F(PbakeTest, EverySingleBitFlipIsRejected) {
  const fs::path good = dir_ / "good.pbake", bad = dir_ / "bad.pbake";
  ASSERT_TRUE(write_bake_file(good, sample_file()).ok());
  std::vector<char> raw = slurp(good);
  for (std::size_t bit = 0; bit < raw.size() * 8; ++bit) {
    raw[bit / 8] = static_cast<char>(raw[bit / 8] ^ (1 << (bit % 8)));
    spit(bad, raw, raw.size());
    raw[bit / 8] = static_cast<char>(raw[bit / 8] ^ (1 << (bit % 8)));
    auto file = read_bake_file(bad);
    ASSERT_FALSE(file.ok()) << "byte " << bit / 8 << " bit " << bit % 8;
  }
}

TEST_F(PbakeTest, ErrorsNameTheFileTheChunkAndTheFix) {
  const fs::path path = dir_ / "courtyard.pbake";
  ASSERT_TRUE(write_bake_file(path, sample_file()).ok());
  auto info = read_bake_info(path);
  ASSERT_TRUE(info.ok());
  std::vector<char> raw = slurp(path);

  // A flipped payload byte of chunk 2.
  std::vector<char> flipped = raw;
  flipped[info->chunks[2].offset + 3] ^= 0x10;
  spit(path, flipped, flipped.size());
  auto file = read_bake_file(path);
  ASSERT_FALSE(file.ok());
  const std::string& m = file.error().message;
  EXPECT_NE(m.find("courtyard.pbake: chunk 2 'PRBG': checksum mismatch (stored 0x"), std::string::npos) << m;
  EXPECT_NE(m.find("re-bake"), std::string::npos) << m;
  EXPECT_TRUE(read_bake_info(path).ok());  // the table is intact; info does not read payloads

  // Another format version, with a valid header checksum.
  std::vector<char> future = raw;
  future[8] = 2;
  const std::uint32_t crc = crc32(future.data(), 60);
  std::memcpy(future.data() + 60, &crc, 4);
  spit(path, future, future.size());
  file = read_bake_file(path);
  ASSERT_FALSE(file.ok());
  EXPECT_EQ(file.error().code, ErrorCode::Unsupported);
  EXPECT_NE(file.error().message.find("format version 2"), std::string::npos) << file.error().message;
  EXPECT_NE(file.error().message.find("reads version 1"), std::string::npos) << file.error().message;

  // CR LF turned into LF by a text-mode copy.
  std::vector<char> text = raw;
  text.erase(text.begin() + 6);
  spit(path, text, text.size());
  file = read_bake_file(path);
  ASSERT_FALSE(file.ok());
  EXPECT_NE(file.error().message.find("binary mode"), std::string::npos) << file.error().message;

  // Not a bake file at all, and no file.
  spit(path, std::vector<char>(100, 'x'), 100);
  EXPECT_NE(read_bake_file(path).error().message.find("not a .pbake file"), std::string::npos);
  EXPECT_EQ(read_bake_file(dir_ / "missing.pbake").error().code, ErrorCode::NotFound);
  EXPECT_EQ(read_bake_info(dir_).error().code, ErrorCode::InvalidInput);
}

TEST_F(PbakeTest, InvalidChunksAreRefusedBeforeWriting) {
  const fs::path path = dir_ / "scene.pbake";
  BakeFile f = sample_file();
  f.chunks[1].label = std::string(33, 'x');
  Status s = write_bake_file(path, f);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(s.error().message.find("chunk 1 'PRBG'"), std::string::npos) << s.error().message;
  f = sample_file();
  f.format_version = 7;
  EXPECT_EQ(write_bake_file(path, f).error().code, ErrorCode::InvalidArgument);
  expect_only(dir_, {});
}

// The file that an interrupted write must leave alone.
struct OldFile {
  fs::path path;
  std::vector<char> bytes;
  explicit OldFile(const fs::path& p) : path(p) {
    BakeFile f;
    f.input_hash = 42;
    f.chunks.push_back({fourcc("OLD!"), 1, "previous bake", bytes_of_text("the good old data")});
    EXPECT_TRUE(write_bake_file(p, f).ok());
    bytes = slurp(p);
  }
  void expect_intact() const {
    EXPECT_EQ(slurp(path), bytes);
    auto f = read_bake_file(path);
    ASSERT_TRUE(f.ok());
    EXPECT_EQ(f->input_hash, 42u);
  }
};

BakeFile big_file() {
  BakeFile f;
  f.input_hash = 7;
  for (int i = 0; i < 4; ++i) f.chunks.push_back({fourcc("BIG "), 1, "", std::vector<std::byte>(256 * 1024)});
  return f;
}

TEST_F(PbakeTest, CancelledWriteKeepsTheOldFile) {
  const OldFile old(dir_ / "scene.pbake");
  CancelToken cancel;
  cancel.cancel();
  Status s = write_bake_file(old.path, big_file(), &cancel);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::Cancelled);
  old.expect_intact();
  expect_only(dir_, {"scene.pbake"});
}

TEST_F(PbakeTest, WriteFailingMidwayKeepsTheOldFile) {
  const OldFile old(dir_ / "scene.pbake");
  // Limit the size of files this process may write: the write of the 1 MiB file fails after
  // 64 KiB with EFBIG, like a full disk (SIGXFSZ ignored so that write() returns the error).
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  rlimit limited = saved;
  limited.rlim_cur = 64 * 1024;
  auto previous = std::signal(SIGXFSZ, SIG_IGN);
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limited), 0);
  Status s = write_bake_file(old.path, big_file());
  setrlimit(RLIMIT_FSIZE, &saved);
  std::signal(SIGXFSZ, previous);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::Io);
  EXPECT_NE(s.error().message.find("scene.pbake: write failed"), std::string::npos) << s.error().message;
  old.expect_intact();
  expect_only(dir_, {"scene.pbake"});
}

TEST_F(PbakeTest, RenameFailureRemovesTheTemporaryFile) {
  // The target is a non-empty directory: the temporary file is written but cannot replace it.
  const fs::path target = dir_ / "taken.pbake";
  fs::create_directories(target / "inside");
  Status s = write_bake_file(target, sample_file());
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::Io);
  expect_only(dir_, {"taken.pbake"});
  EXPECT_TRUE(fs::is_directory(target / "inside"));
}

TEST_F(PbakeTest, UnwritableDirectoryFailsAndKeepsTheOldFile) {
  // A directory that does not exist.
  Status s = write_bake_file(dir_ / "no" / "such" / "dir" / "scene.pbake", sample_file());
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::Io);
  EXPECT_NE(s.error().message.find("writable"), std::string::npos) << s.error().message;

  // A read-only directory holding the previous file (root ignores permissions, so this part
  // only runs where the permission actually takes effect).
  const OldFile old(dir_ / "scene.pbake");
  fs::permissions(dir_, fs::perms::owner_read | fs::perms::owner_exec);
  if (::access(dir_.c_str(), W_OK) != 0) {
    s = write_bake_file(old.path, big_file());
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().code, ErrorCode::Io);
    old.expect_intact();
  }
  fs::permissions(dir_, fs::perms::owner_all);
  expect_only(dir_, {"scene.pbake"});
}

TEST(ByteStream, RoundTripAndBoundsChecks) {
  ByteWriter w;
  w.write(std::uint32_t{0xdeadbeef});
  w.write(-2.5f);
  w.write_vector(std::vector<double>{1.0, 2.0, 3.0});
  w.write_string("probe grid");
  const std::uint16_t raw[2] = {7, 9};
  w.write_array(std::span<const std::uint16_t>(raw));
  const std::vector<std::byte> data = w.take();
  EXPECT_EQ(data.size(), 4u + 4u + 8u + 24u + 4u + 10u + 4u);
  EXPECT_EQ(data[0], std::byte{0xef});  // little-endian

  ByteReader r(data, "chunk 'TEST'");
  std::uint32_t u = 0;
  float f = 0;
  std::vector<double> v;
  std::string s;
  std::uint16_t back[2] = {};
  ASSERT_TRUE(r.read(u).ok());
  ASSERT_TRUE(r.read(f).ok());
  ASSERT_TRUE(r.read_vector(v).ok());
  ASSERT_TRUE(r.read_string(s).ok());
  ASSERT_TRUE(r.read_array(std::span<std::uint16_t>(back)).ok());
  EXPECT_TRUE(r.finish().ok());
  EXPECT_EQ(u, 0xdeadbeefu);
  EXPECT_EQ(f, -2.5f);
  EXPECT_EQ(v, (std::vector<double>{1.0, 2.0, 3.0}));
  EXPECT_EQ(s, "probe grid");
  EXPECT_EQ(back[1], 9);

  // Reading past the end fails cleanly and names the context; the output is untouched.
  ByteReader short_reader(std::span<const std::byte>(data).first(6), "chunk 'TEST'");
  ASSERT_TRUE(short_reader.read(u).ok());
  std::uint32_t untouched = 5;
  Status bad = short_reader.read(untouched);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(untouched, 5u);
  EXPECT_NE(bad.error().message.find("chunk 'TEST': truncated"), std::string::npos) << bad.error().message;
  EXPECT_FALSE(short_reader.finish().ok());

  // A corrupted count larger than the payload is refused before allocating.
  ByteWriter huge;
  huge.write(std::uint64_t{1} << 60);
  const std::vector<std::byte> hdata = huge.take();
  ByteReader hr(hdata, "chunk 'HUGE'");
  EXPECT_FALSE(hr.read_vector(v).ok());
  EXPECT_EQ(v.size(), 3u);
  // And a count above the caller's limit.
  ByteWriter limited;
  limited.write_vector(std::vector<float>(10, 1.0f));
  const std::vector<std::byte> ldata = limited.take();
  ByteReader lr(ldata, "chunk 'LIM'");
  std::vector<float> fl;
  EXPECT_FALSE(lr.read_vector(fl, 5).ok());
}

}  // namespace
}  // namespace penumbra
