// Training checkpoints: little-endian "WEFTBTCK", version, the fingerprint of the data and
// options that produced them, the position (epoch, step, stage), the loss sums of the epoch
// in progress, then the parameters, batch-norm statistics and (fine-tuning) latents, Adam's
// step count and moments, early stopping's state and best model, and an FNV-1a checksum of everything before it. Written to a temporary renamed over the file, so
// an interrupted write never leaves a half checkpoint.
module;
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <string>
#include <system_error>
#include <vector>
module weft.btf.training;

namespace weft::btf::training_detail {
namespace {

constexpr char kMagic[8] = {'W', 'E', 'F', 'T', 'B', 'T', 'C', 'K'};
constexpr std::uint32_t kVersion = 2;  // 2: Adam moments and early stopping's best model

struct Writer {
  std::vector<std::byte> bytes;
  void raw(const void* p, std::size_t n) {
    const auto* b = static_cast<const std::byte*>(p);
    bytes.insert(bytes.end(), b, b + n);
  }
  template <class T>
  void value(const T& v) { raw(&v, sizeof v); }
  void floats(const Floats& v) {
    value(std::uint64_t(v.size()));
    raw(v.data(), v.size() * sizeof(float));
  }
};

struct Reader {
  std::span<const std::byte> bytes;
  std::size_t at = 0;
  bool raw(void* p, std::size_t n) {
    if (n > bytes.size() - at) return false;
    if (n > 0) std::memcpy(p, bytes.data() + at, n);  // an empty array's data() may be null
    at += n;
    return true;
  }
  template <class T>
  bool value(T& v) { return raw(&v, sizeof v); }
  bool floats(Floats& v) {
    std::uint64_t n = 0;
    if (!value(n) || n > (bytes.size() - at) / sizeof(float)) return false;
    v.resize(n);
    return raw(v.data(), n * sizeof(float));
  }
};

}  // namespace

Result<void> save_checkpoint(const std::filesystem::path& file, const TrainState& s) {
  Writer w;
  w.raw(kMagic, sizeof kMagic);
  w.value(kVersion);
  w.value(s.fingerprint);
  w.value(std::uint64_t(s.epoch));
  w.value(std::uint64_t(s.step));
  w.value(std::uint8_t(s.finetuning));
  w.value(s.elapsed_s);
  w.value(s.epoch_loss);
  w.value(s.epoch_count);
  w.value(s.last_epoch_loss);
  w.floats(s.parameters);
  w.floats(s.running_mean);
  w.floats(s.running_var);
  w.floats(s.latents);
  w.value(s.adam_steps);
  w.floats(s.moment1);
  w.floats(s.moment2);
  w.floats(s.latent_moment1);
  w.floats(s.latent_moment2);
  w.value(s.best_rmse);
  w.value(s.last_rmse);
  w.value(s.best_epoch);
  w.value(s.stale);
  w.value(std::uint8_t(s.best_finetuning));
  w.floats(s.best_parameters);
  w.floats(s.best_running_mean);
  w.floats(s.best_running_var);
  w.floats(s.best_latents);
  w.value(hash_bytes(w.bytes));
  return write_file_atomically(file, {std::span<const std::byte>(w.bytes)}, "checkpoint");
}

Result<TrainState> load_checkpoint(const std::filesystem::path& file) {
  auto chars = read_input_file(file, "checkpoint");
  if (!chars) return std::unexpected(chars.error());
  std::vector<std::byte> data(chars->size());
  if (!chars->empty()) std::memcpy(data.data(), chars->data(), chars->size());  // memcpy(null, ..., 0) is UB
  if (data.size() < sizeof kMagic + sizeof(std::uint64_t) || std::memcmp(data.data(), kMagic, sizeof kMagic) != 0)
    return fail(ErrorKind::Parse, "checkpoint {}: not a weft training checkpoint (magic WEFTBTCK missing)", file.string());
  const std::size_t body = data.size() - sizeof(std::uint64_t);
  std::uint64_t stored = 0;
  std::memcpy(&stored, data.data() + body, sizeof stored);
  if (stored != hash_bytes(std::span<const std::byte>(data).first(body)))
    return fail(ErrorKind::Parse, "checkpoint {}: checksum mismatch (truncated or corrupt)", file.string());
  Reader r{std::span<const std::byte>(data).first(body), sizeof kMagic};
  std::uint32_t version = 0;
  TrainState s;
  std::uint64_t epoch = 0, step = 0;
  std::uint8_t finetuning = 0, best_finetuning = 0;
  if (!r.value(version)) return fail(ErrorKind::Parse, "checkpoint {}: truncated header", file.string());
  if (version != kVersion)
    return fail(ErrorKind::Parse, "checkpoint {}: version {} (this build reads {})", file.string(), version, kVersion);
  const bool ok = r.value(s.fingerprint) && r.value(epoch) && r.value(step) && r.value(finetuning) &&
                  r.value(s.elapsed_s) && r.value(s.epoch_loss) && r.value(s.epoch_count) &&
                  r.value(s.last_epoch_loss) && r.floats(s.parameters) && r.floats(s.running_mean) &&
                  r.floats(s.running_var) && r.floats(s.latents) && r.value(s.adam_steps) && r.floats(s.moment1) &&
                  r.floats(s.moment2) && r.floats(s.latent_moment1) && r.floats(s.latent_moment2) &&
                  r.value(s.best_rmse) && r.value(s.last_rmse) && r.value(s.best_epoch) && r.value(s.stale) &&
                  r.value(best_finetuning) && r.floats(s.best_parameters) && r.floats(s.best_running_mean) &&
                  r.floats(s.best_running_var) && r.floats(s.best_latents) && r.at == body;
  if (!ok) return fail(ErrorKind::Parse, "checkpoint {}: sections do not fit the file", file.string());
  s.epoch = std::size_t(epoch);
  s.step = std::size_t(step);
  s.finetuning = finetuning != 0;
  s.best_finetuning = best_finetuning != 0;
  return s;
}

}  // namespace weft::btf::training_detail
