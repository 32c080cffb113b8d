// Writing files so that a failure never destroys what is on disk: everything goes to a temporary
// file in the destination's directory, which is synced and then renamed over the destination (an
// atomic replace on POSIX file systems), and the directory is synced after the rename.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string_view>

#include "penumbra/core/result.h"

namespace penumbra {

// Calls `write` with an open descriptor of a fresh temporary file (<path>.tmp-<pid>-<n>, mode
// 0644) and, when it succeeds, syncs and renames the file over `path`. On any failure (write's own
// error, or Io naming the path and the fix) the temporary file is removed and an existing file at
// `path` is untouched. A symbolic link at `path` is replaced by the file, not followed. Thread-safe
// for distinct paths.
Status write_atomically(const std::filesystem::path& path, const std::function<Status(int fd)>& write);

// write_atomically with `bytes` as the whole file.
Status write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

// Writes all of [data, data + size) to `fd`, retrying interrupted writes. Io names `path`.
Status write_all(int fd, const void* data, std::size_t size, const std::filesystem::path& path);

}  // namespace penumbra
