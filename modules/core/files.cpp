// write_file_atomically: how every weft writer of a file a reader may meet half-done (baked
// caches, checkpoints, images) puts it on disk. The bytes go to a temporary file unique to
// this process and call, are flushed to the disk (fsync), and the temporary is renamed over
// the target, which POSIX makes atomic: a reader sees the old file or the whole new one,
// never a mix of two writers (two processes baking one cache key wrote the same
// "file.tmp" before) and never half a file (a process killed mid-write leaves only its
// temporary). A failure (no space, no permission) removes the temporary and says why. A
// symlink is written through (its target is replaced, the link stays); a folder, FIFO, device or
// read-only file at the path is refused before anything is written (issue 33).
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
#include <vector>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
module weft.core;

namespace weft {

namespace {

// "a FIFO" for what stat() says a path is, when that is not a regular file.
const char* not_regular(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISREG(mode)) return nullptr;
  return "not a file";
}

// The file a write to `path` lands in: `path`, or the file its chain of symlinks names (a link
// out.png -> renders/out.png updates renders/out.png; before, the rename replaced the link).
Result<std::filesystem::path> through_links(const std::filesystem::path& path, std::string_view what) {
  std::filesystem::path at = path;
  for (int hops = 0; hops < 40; ++hops) {
    struct stat st {};
    if (::lstat(at.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return at;
    std::error_code ec;
    const std::filesystem::path target = std::filesystem::read_symlink(at, ec);
    if (ec) return at;
    at = target.is_absolute() ? target : at.parent_path() / target;
  }
  return fail(ErrorKind::Io, "cannot write {} '{}': {}", what, path.string(), std::strerror(ELOOP));
}

}  // namespace

Result<void> write_file_atomically(const std::filesystem::path& requested, std::initializer_list<std::span<const std::byte>> parts,
                                   std::string_view what) {
  if (requested.empty() || !requested.has_filename())
    return fail(ErrorKind::InvalidArgument, "cannot write {} to '{}': not a file path", what, requested.string());
  auto resolved = through_links(requested, what);
  if (!resolved) return std::unexpected(resolved.error());
  const std::filesystem::path& path = *resolved;
  // What is there already: a regular file that may be written is replaced; anything else is
  // refused before a byte is written (issue 33). A FIFO or a device (`-o` through a link to
  // /dev/null or /dev/full) would have been replaced by a regular file; a read-only file is
  // the user's "keep this" (root's rename ignores the permission bits, so they are checked
  // here: no write bit for anyone, or none for this user).
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (const char* kind = not_regular(st.st_mode))
      return fail(ErrorKind::Io, "cannot write {} '{}': it is {}, not a regular file", what, requested.string(), kind);
    if ((st.st_mode & 0222) == 0 || ::access(path.c_str(), W_OK) != 0)
      return fail(ErrorKind::Io, "cannot write {} '{}': the file is read-only (weft does not replace it; make it writable or "
                  "choose another path)", what, requested.string());
  }
  static std::atomic<unsigned> counter{0};
  std::filesystem::path tmp = path;
  tmp += weft::format(".{}-{}.tmp", ::getpid(), counter++);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return fail(ErrorKind::Io, "cannot write {} '{}': {}", what, requested.string(), std::strerror(errno));
  const auto give_up = [&](int error) -> Result<void> {
    ::close(fd);
    ::unlink(tmp.c_str());
    return fail(ErrorKind::Io, "cannot write {} '{}': {}", what, requested.string(), std::strerror(error));
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
    return fail(ErrorKind::Io, "cannot write {} '{}': {}", what, requested.string(), std::strerror(error));
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    ::unlink(tmp.c_str());
    return fail(ErrorKind::Io, "cannot write {} '{}': {}", what, requested.string(), std::strerror(error));
  }
  return {};
}

namespace {

Result<struct stat> classify(const std::filesystem::path& path, std::string_view what) {
  if (path.empty()) return fail(ErrorKind::NotFound, "{} '' not found (an empty path)", what);
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int error = errno;
    if (error == ENOENT || error == ENOTDIR) return fail(ErrorKind::NotFound, "{} '{}' not found", what, path.string());
    return fail(ErrorKind::Io, "cannot open {} '{}': {}", what, path.string(), std::strerror(error));
  }
  if (const char* kind = not_regular(st.st_mode))
    return fail(ErrorKind::Io, "{} '{}' is {}, not a regular file", what, path.string(), kind);
  return st;
}

// Opens the regular file `path` without waiting and reads it to the end into `out` (or
// only through it, when `out` is null).
Result<void> read_regular(const std::filesystem::path& path, std::string_view what, std::vector<unsigned char>* out,
                          std::size_t size_hint) {
  int fd = -1;
  do fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    const int error = errno;
    if (error == ENOENT) return fail(ErrorKind::NotFound, "{} '{}' not found", what, path.string());
    return fail(ErrorKind::Io, "cannot open {} '{}': {}", what, path.string(), std::strerror(error));
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || not_regular(st.st_mode) != nullptr) {
    const char* kind = not_regular(st.st_mode);
    ::close(fd);
    return fail(ErrorKind::Io, "{} '{}' is {}, not a regular file", what, path.string(), kind ? kind : "not readable");
  }
  if (out) out->reserve(size_hint ? size_hint : std::size_t(st.st_size));
  unsigned char chunk[1 << 16];
  for (;;) {
    const ::ssize_t n = ::read(fd, chunk, sizeof chunk);
    if (n == 0) break;
    if (n < 0) {
      const int error = errno;
      if (error == EINTR) continue;
      ::close(fd);
      if (error == EAGAIN || error == EWOULDBLOCK)
        return fail(ErrorKind::Io, "{} '{}' cannot be read without waiting (not a regular file on disk)", what, path.string());
      if (error == EISDIR) return fail(ErrorKind::Io, "{} '{}' is a folder, not a regular file", what, path.string());
      return fail(ErrorKind::Io, "cannot read {} '{}': {}", what, path.string(), std::strerror(error));
    }
    if (out) out->insert(out->end(), chunk, chunk + n);
  }
  ::close(fd);
  return {};
}

}  // namespace

Result<std::vector<unsigned char>> read_input_file(const std::filesystem::path& path, std::string_view what) {
  auto st = classify(path, what);
  if (!st) return std::unexpected(st.error());
  std::vector<unsigned char> bytes;
  if (auto ok = read_regular(path, what, &bytes, std::size_t(st->st_size)); !ok) return std::unexpected(ok.error());
  return bytes;
}

Result<void> check_input_file(const std::filesystem::path& path, std::string_view what) {
  auto st = classify(path, what);
  if (!st) return std::unexpected(st.error());
  if (st->st_size > 0) return {};
  return read_regular(path, what, nullptr, 0);
}

}  // namespace weft
