// weft::write_file_atomically, the writer behind every cache and checkpoint: two processes
// writing one path, a process killed mid-write, a full disk (a file-size limit) and a
// folder that cannot be written never leave a mixed, half or stray file behind. And
// weft::read_input_file / check_input_file, the reader behind every input path: a FIFO, a
// folder or a device is a named error, never a wait.
#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <future>
#include <iterator>
#include <random>
#include <span>
#include <string>
#include <thread>
#include <vector>
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

import weft.core;

namespace fs = std::filesystem;

namespace {

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("weft-test-files-" + std::to_string(std::random_device{}()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  [[nodiscard]] int stray_files() const {
    int n = 0;
    for (const auto& e : fs::directory_iterator(path)) n += e.path().extension() == ".tmp";
    return n;
  }
};

std::vector<std::byte> filled(std::size_t size, unsigned char value) { return std::vector<std::byte>(size, std::byte{value}); }

std::vector<std::byte> read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::vector<char> chars((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::byte> out(chars.size());
  for (std::size_t i = 0; i < chars.size(); ++i) out[i] = std::byte(chars[i]);
  return out;
}

// Runs `body` in a child process and returns its exit code (-signal when killed).
template <class F>
int in_child(F body) {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(body());
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

}  // namespace

TEST_CASE("write_file_atomically writes every part, replaces the old file and leaves no temporary") {
  TempDir dir;
  const auto file = dir.path / "a.bin";
  const auto head = filled(3, 1), body = filled(5, 2);
  REQUIRE(weft::write_file_atomically(file, {std::span<const std::byte>(head), std::span<const std::byte>(body)}, "test file"));
  auto bytes = read_all(file);
  REQUIRE(bytes.size() == 8);
  CHECK(bytes[2] == std::byte{1});
  CHECK(bytes[3] == std::byte{2});
  REQUIRE(weft::write_file_atomically(file, {std::span<const std::byte>(head)}, "test file"));
  CHECK(read_all(file).size() == 3);
  CHECK(dir.stray_files() == 0);
}

TEST_CASE("two processes writing one path at once: the file is always one writer's whole bytes") {
  TempDir dir;
  const auto file = dir.path / "shared.bin";
  constexpr std::size_t size = 1 << 18;
  const auto writer = [&](unsigned char value) {
    const auto bytes = filled(size, value);
    for (int i = 0; i < 40; ++i)
      if (!weft::write_file_atomically(file, {std::span<const std::byte>(bytes)}, "test file")) return 1;
    return 0;
  };
  const pid_t a = ::fork();
  if (a == 0) ::_exit(writer(0xAA));
  const pid_t b = ::fork();
  if (b == 0) ::_exit(writer(0xBB));
  // Meanwhile: every read sees one writer's whole file.
  int mixed = 0, reads = 0;
  for (int status = 0; ::waitpid(a, &status, WNOHANG) == 0 || ::waitpid(b, &status, WNOHANG) == 0;) {
    if (!fs::exists(file)) continue;
    const auto bytes = read_all(file);
    ++reads;
    if (bytes.size() != size || std::count(bytes.begin(), bytes.end(), bytes.front()) != std::ptrdiff_t(size)) ++mixed;
  }
  int status_a = 0, status_b = 0;
  ::waitpid(a, &status_a, 0);
  ::waitpid(b, &status_b, 0);
  CHECK(mixed == 0);
  MESSAGE(reads << " reads while two processes wrote");
  const auto last = read_all(file);
  REQUIRE(last.size() == size);
  CHECK(std::count(last.begin(), last.end(), last.front()) == std::ptrdiff_t(size));
  CHECK(dir.stray_files() == 0);
}

TEST_CASE("a process killed mid-write leaves the old file whole (and at most its own temporary)") {
  TempDir dir;
  const auto file = dir.path / "big.bin";
  const auto old = filled(1000, 7);
  REQUIRE(weft::write_file_atomically(file, {std::span<const std::byte>(old)}, "test file"));
  for (int delay_ms : {0, 2, 10, 40}) {
    const pid_t child = ::fork();
    if (child == 0) {
      const auto bytes = filled(std::size_t(64) << 20, 9);  // 64 MiB: usually still writing when killed
      (void)weft::write_file_atomically(file, {std::span<const std::byte>(bytes)}, "test file");
      ::_exit(0);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    const auto now = read_all(file);
    const bool whole_old = now == old;
    const bool whole_new = now.size() == (std::size_t(64) << 20) && now.front() == std::byte{9} && now.back() == std::byte{9};
    CHECK_MESSAGE((whole_old || whole_new), "after " << delay_ms << " ms: " << now.size() << " bytes");
    for (const auto& e : fs::directory_iterator(dir.path))
      if (e.path().extension() == ".tmp") fs::remove(e.path());
  }
}

TEST_CASE("a full disk (a file-size limit) and an unwritable folder are errors, with nothing left behind") {
  TempDir dir;
  const auto file = dir.path / "limited.bin";
  const auto old = filled(100, 3);
  REQUIRE(weft::write_file_atomically(file, {std::span<const std::byte>(old)}, "test file"));
  const int code = in_child([&] {
    std::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    const auto bytes = filled(1 << 20, 5);
    auto r = weft::write_file_atomically(file, {std::span<const std::byte>(bytes)}, "test file");
    if (r) return 1;
    if (r.error().kind != weft::ErrorKind::Io) return 2;
    if (r.error().message.find("cannot write test file") == std::string::npos) return 3;
    return 0;
  });
  CHECK(code == 0);
  CHECK(read_all(file) == old);
  CHECK(dir.stray_files() == 0);

  // A "folder" that is a regular file: nothing can be created inside (even as root).
  std::ofstream(dir.path / "not-a-folder") << "x";
  auto r = weft::write_file_atomically(dir.path / "not-a-folder" / "x.bin", {std::span<const std::byte>(old)}, "cache entry");
  REQUIRE_FALSE(r);
  CHECK(r.error().kind == weft::ErrorKind::Io);
  CHECK(r.error().message.find("cannot write cache entry") != std::string::npos);
  CHECK(r.error().message.find("Not a directory") != std::string::npos);
}

TEST_CASE("issue 33: a read-only file, a FIFO, a device or a folder at the path is refused and left as it was") {
  TempDir dir;
  const auto bytes = filled(64, 7);
  // Read-only: no write bit for anyone. Root's rename ignores the bits; the writer does not.
  const auto ro = dir.path / "ro.bin";
  std::ofstream(ro) << "precious";
  fs::permissions(ro, fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read);
  auto r = weft::write_file_atomically(ro, {std::span<const std::byte>(bytes)}, "image");
  REQUIRE_FALSE(r);
  CHECK(r.error().message.find("cannot write image '" + ro.string() + "': the file is read-only") != std::string::npos);
  std::ifstream in(ro);
  std::string kept;
  std::getline(in, kept);
  CHECK(kept == "precious");
  // A FIFO (rename would have replaced it with a regular file; opening it would wait).
  const auto fifo = dir.path / "fifo.png";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  r = weft::write_file_atomically(fifo, {std::span<const std::byte>(bytes)}, "image");
  REQUIRE_FALSE(r);
  CHECK(r.error().message.find("it is a FIFO, not a regular file") != std::string::npos);
  CHECK(fs::is_fifo(fifo));
  // A link to a device: refused, the link and /dev/null untouched.
  const auto null_link = dir.path / "null.png";
  fs::create_symlink("/dev/null", null_link);
  r = weft::write_file_atomically(null_link, {std::span<const std::byte>(bytes)}, "image");
  REQUIRE_FALSE(r);
  CHECK(r.error().message.find("'" + null_link.string() + "': it is a character device") != std::string::npos);
  CHECK(fs::is_symlink(null_link));
  CHECK(fs::is_character_file("/dev/null"));
  // A folder.
  fs::create_directories(dir.path / "folder.png");
  r = weft::write_file_atomically(dir.path / "folder.png", {std::span<const std::byte>(bytes)}, "image");
  REQUIRE_FALSE(r);
  CHECK(r.error().message.find("it is a folder") != std::string::npos);
  // A link loop.
  fs::create_symlink("loop.png", dir.path / "loop.png");
  r = weft::write_file_atomically(dir.path / "loop.png", {std::span<const std::byte>(bytes)}, "image");
  REQUIRE_FALSE(r);
  CHECK(dir.stray_files() == 0);
}

TEST_CASE("issue 33: a symlink is written through: its target gets the bytes and the link stays a link") {
  TempDir dir;
  fs::create_directories(dir.path / "renders");
  const auto target = dir.path / "renders" / "out.bin";
  std::ofstream(target) << "old";
  const auto link = dir.path / "latest.bin";
  fs::create_symlink("renders/out.bin", link);
  const auto bytes = filled(16, 9);
  REQUIRE(weft::write_file_atomically(link, {std::span<const std::byte>(bytes)}, "image"));
  CHECK(fs::is_symlink(link));
  CHECK(read_all(target) == bytes);
  CHECK(dir.stray_files() == 0);
}

// ---- read_input_file / check_input_file (issue 33: a FIFO as a scene, mesh or photo blocked forever)

namespace {

// Runs `read` on a thread and waits up to 10 s. When it is still waiting (on a FIFO nobody
// writes), a writer opens the FIFO and closes it, which ends the reader's wait with an empty
// read, so a regression fails the test instead of hanging it.
template <class F>
auto without_waiting(F read, const fs::path& fifo) {
  std::packaged_task<decltype(read())()> task(read);
  auto result = task.get_future();
  std::thread thread(std::move(task));
  const bool finished = result.wait_for(std::chrono::seconds(10)) == std::future_status::ready;
  if (!finished && !fifo.empty()) {
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
  }
  thread.join();
  CHECK_MESSAGE(finished, "the read waited for more than 10 s");
  return result.get();
}

std::string message_of(const weft::Error& e) { return e.message; }

}  // namespace

TEST_CASE("read_input_file reads a regular file, an empty one, and names a missing one") {
  TempDir dir;
  const fs::path file = dir.path / "a.bin", empty = dir.path / "empty.bin";
  std::ofstream(file, std::ios::binary) << "weft";
  std::ofstream{empty};
  auto bytes = weft::read_input_file(file, "test file");
  REQUIRE(bytes);
  CHECK(std::string(bytes->begin(), bytes->end()) == "weft");
  auto none = weft::read_input_file(empty, "test file");
  REQUIRE(none);
  CHECK(none->empty());
  CHECK(weft::check_input_file(file, "test file"));
  CHECK(weft::check_input_file(empty, "test file"));
  auto missing = weft::read_input_file(dir.path / "absent.bin", "test file");
  REQUIRE_FALSE(missing);
  CHECK(missing.error().kind == weft::ErrorKind::NotFound);
  CHECK(message_of(missing.error()) == "test file '" + (dir.path / "absent.bin").string() + "' not found");
  CHECK(weft::check_input_file(dir.path / "absent.bin", "test file").error().kind == weft::ErrorKind::NotFound);
}

TEST_CASE("read_input_file and check_input_file refuse a FIFO, a folder and a device without waiting") {
  TempDir dir;
  const fs::path fifo = dir.path / "scene.json";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  const auto expect = [](const weft::Error& e, const fs::path& path, const std::string& kind) {
    CHECK(e.kind == weft::ErrorKind::Io);
    CHECK_MESSAGE(message_of(e) == "scene file '" + path.string() + "' is " + kind + ", not a regular file", e.message);
  };
  {
    auto r = without_waiting([&] { return weft::read_input_file(fifo, "scene file"); }, fifo);
    REQUIRE_FALSE(r);
    expect(r.error(), fifo, "a FIFO");
    auto c = without_waiting([&] { return weft::check_input_file(fifo, "scene file"); }, fifo);
    REQUIRE_FALSE(c);
    expect(c.error(), fifo, "a FIFO");
  }
  {
    auto r = weft::read_input_file(dir.path, "scene file");
    REQUIRE_FALSE(r);
    expect(r.error(), dir.path, "a folder");
  }
  if (fs::exists("/dev/zero")) {  // never ends: read to the end it would fill the memory
    auto r = without_waiting([&] { return weft::read_input_file("/dev/zero", "scene file"); }, {});
    REQUIRE_FALSE(r);
    expect(r.error(), "/dev/zero", "a character device");
    // Through a symbolic link with an innocent name, too.
    fs::create_symlink("/dev/zero", dir.path / "mesh.obj");
    auto c = weft::check_input_file(dir.path / "mesh.obj", "scene file");
    REQUIRE_FALSE(c);
    expect(c.error(), dir.path / "mesh.obj", "a character device");
  }
}
