// write_file_atomically: how every weft writer of a file a reader may meet half-done (baked
// caches, checkpoints, images) puts it on disk. The bytes go to a temporary file unique to
// this process and call, are flushed to the disk (fsync), and the temporary is renamed over
// the target, which POSIX makes atomic: a reader sees the old file or the whole new one,
// never a mix of two writers (two processes baking one cache key wrote the same
// "file.tmp" before) and never half a file (a process killed mid-write leaves only its
// temporary). A failure (no space, no permission) removes the temporary and says why.
module;
#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstring>
#include <expected>
#include <filesystem>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <fcntl.h>
#include <unistd.h>
module weft.core;

namespace weft {

Result<void> write_file_atomically(const std::filesystem::path& path, std::initializer_list<std::span<const std::byte>> parts,
                                   std::string_view what) {
  if (path.empty() || !path.has_filename())
    return fail(ErrorKind::InvalidArgument, "cannot write {} to '{}': not a file path", what, path.string());
  static std::atomic<unsigned> counter{0};
  std::filesystem::path tmp = path;
  tmp += weft::format(".{}-{}.tmp", ::getpid(), counter++);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return fail(ErrorKind::Io, "cannot write {} '{}': {}", what, path.string(), std::strerror(errno));
  const auto give_up = [&](int error) -> Result<void> {
    ::close(fd);
    ::unlink(tmp.c_str());
    return fail(ErrorKind::Io, "cannot write {} '{}': {}", what, path.string(), std::strerror(error));
  };
  for (std::span<const std::byte> part : parts) {
    while (!part.empty()) {
      const ::ssize_t n = ::write(fd, part.data(), part.size());
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return give_up(n < 0 ? errno : ENOSPC);
      part = part.subspan(std::size_t(n));
    }
  }
  if (::fsync(fd) != 0) return give_up(errno);
  if (::close(fd) != 0) {
    const int error = errno;
    ::unlink(tmp.c_str());
    return fail(ErrorKind::Io, "cannot write {} '{}': {}", what, path.string(), std::strerror(error));
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    ::unlink(tmp.c_str());
    return fail(ErrorKind::Io, "cannot write {} '{}': {}", what, path.string(), std::strerror(error));
  }
  return {};
}

}  // namespace weft
