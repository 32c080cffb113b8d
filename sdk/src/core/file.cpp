// Atomic file writes (penumbra/core/file.h).
#include "penumbra/core/file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <string>

#include "penumbra/core/log.h"
#include "penumbra/core/random.h"

namespace penumbra {

namespace {

Error io_error(const std::string& what, const std::filesystem::path& path, int err) {
  return make_error(ErrorCode::Io, path.string() + ": " + what + " (" + std::strerror(err) +
                                       "); check that the directory exists, is writable and has free space");
}

}  // namespace

Status write_all(int fd, const void* data, std::size_t size, const std::filesystem::path& path) {
  const auto* p = static_cast<const unsigned char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd, p, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return io_error("write failed", path, errno);
    }
    p += n;
    size -= static_cast<std::size_t>(n);
  }
  return {};
}

Status write_atomically(const std::filesystem::path& path, const std::function<Status(int fd)>& write) {
  // A temporary name in the same directory (so that rename is atomic) that no other writer uses.
  static std::atomic<std::uint64_t> counter{0};
  const std::uint64_t unique =
      mix64((static_cast<std::uint64_t>(::getpid()) << 32) ^ counter.fetch_add(1) ^ reinterpret_cast<std::uintptr_t>(&write));
  std::filesystem::path temp = path;
  temp += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(unique & 0xFFFFFFFFu);

  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return io_error("cannot create the temporary file " + temp.filename().string(), path, errno);
  Status status = write(fd);
  if (status.ok() && ::fsync(fd) != 0) status = io_error("fsync failed", path, errno);
  if (::close(fd) != 0 && status.ok()) status = io_error("close failed", path, errno);
  if (status.ok() && ::rename(temp.c_str(), path.c_str()) != 0)
    status = io_error("cannot replace the file with the temporary " + temp.filename().string(), path, errno);
  if (!status.ok()) {
    ::unlink(temp.c_str());
    return status;
  }
  // Make the rename itself durable.
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0 || ::fsync(dfd) != 0) log(LogLevel::Warning, path.string() + ": could not sync the directory after writing");
  if (dfd >= 0) ::close(dfd);
  return {};
}

Status write_file_atomically(const std::filesystem::path& path, std::string_view bytes) {
  return write_atomically(path, [&](int fd) { return write_all(fd, bytes.data(), bytes.size(), path); });
}

}  // namespace penumbra
