// The reference mode's data: the raw BTF packed for btf_reference.glsl, cropped to what one
// storage buffer holds.
module;
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <weft/try.h>
module weft.pass.neural_btf;

namespace weft::passes {

namespace {
// Besides the device's storage-buffer range: a 100 x 100 twill (787 MB) is three copies in host
// memory while it uploads (data, packed words, the device's), so past 1 GiB it is cropped.
constexpr std::uint64_t kReferenceBytesCap = std::uint64_t(1) << 30;
}  // namespace

Result<PackedBtfReference> pack_reference(const btf::Btf& data, std::uint64_t max_bytes) {
  WEFT_TRY_VOID(btf::validate(data, "the reference mode's BTF"));
  const std::uint64_t header = 16 + 16 * std::uint64_t(data.lights.size() + data.views.size());
  const std::uint64_t per_texel = std::uint64_t(data.abrdf_floats()) * 4;
  const std::uint64_t fit = max_bytes > header ? (max_bytes - header) / per_texel : 0;
  if (fit == 0)
    return fail(ErrorKind::Unsupported, "the reference mode's BTF: one texel ({} bytes) does not fit in {} bytes",
                header + per_texel, max_bytes);
  PackedBtfReference packed;
  packed.crop = {0, 0, data.width, data.height};
  if (data.texels() > fit) {  // the largest top-left crop of the same aspect ratio that fits
    const double s = std::sqrt(double(fit) / double(data.texels()));
    std::uint32_t w = std::clamp<std::uint32_t>(std::uint32_t(double(data.width) * s), 1, data.width);
    std::uint32_t h = std::clamp<std::uint32_t>(std::uint32_t(std::min<std::uint64_t>(fit / w, data.height)), 1, data.height);
    packed.crop = {0, 0, w, h};
    packed.cropped = true;
  }
  const btf::Crop& c = packed.crop;
  const std::size_t floats = data.abrdf_floats();
  auto& words = packed.words;
  words.reserve(std::size_t(header / 4) + std::size_t(c.width) * c.height * floats);
  words.push_back(std::uint32_t(data.lights.size()));
  words.push_back(std::uint32_t(data.views.size()));
  words.push_back(c.width);
  words.push_back(c.height);
  auto push = [&](float v) { words.push_back(std::bit_cast<std::uint32_t>(v)); };
  for (const auto* set : {&data.lights, &data.views})
    for (const btf::Direction& d : *set) {
      const vec3 v = btf::to_vector(d);  // the vectors interpolation_weights compares against
      push(v.x), push(v.y), push(v.z), push(0.0f);
    }
  for (std::uint32_t y = 0; y < c.height; ++y)
    for (std::uint32_t x = 0; x < c.width; ++x)
      for (float v : data.abrdf(std::size_t(c.y + y) * data.width + c.x + x)) push(v);
  return packed;
}

Result<GpuBtfReference> upload_reference(gpu::Device& device, const btf::Btf& data, std::string_view label) {
  const std::uint64_t range = device.adapter_info().limits.max_storage_buffer_range;
  WEFT_TRY(auto packed, pack_reference(data, std::min(range > 0 ? range : kReferenceBytesCap, kReferenceBytesCap)));
  WEFT_TRY(auto buffer, device.create_buffer_with_data({.label = std::string(label), .size = packed.words.size() * 4,
                                                  .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
                                                 std::as_bytes(std::span(packed.words))));
  return GpuBtfReference{std::move(buffer), packed.crop, packed.cropped};
}

}  // namespace weft::passes
