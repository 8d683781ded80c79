// BTF files: the UBO2003 (Bonn) and UTIA image sets, one image per (light, view) pair named
// by its angles, and weft's own .btfraw cache. Nothing from a file is trusted: names are
// parsed strictly, the light x view grid must be complete, image sizes must agree, the crop
// must fit, samples must be finite and >= 0, and .btfraw sizes and checksums are checked
// before any payload is used.
module;
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <regex>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include <weft/try.h>
module weft.btf;
import weft.cluster;

namespace fs = std::filesystem;

namespace weft::btf {
namespace {

enum class Layout : std::uint8_t { Ubo2003, Utia };

std::string_view layout_name(Layout layout) { return layout == Layout::Ubo2003 ? "UBO2003" : "UTIA"; }

// "00008 tl000 pl000 tv030 pv030.jpg" (the index is optional) / "tl000_pl000_tv000_pv000.png".
const std::regex& pattern(Layout layout) {
  static const std::regex ubo(R"(^(?:\d+ )?tl(\d{1,3}) pl(\d{1,3}) tv(\d{1,3}) pv(\d{1,3})\.(jpe?g|png|exr|hdr)$)",
                              std::regex::icase);
  static const std::regex utia(R"(^tl(\d{1,3})_pl(\d{1,3})_tv(\d{1,3})_pv(\d{1,3})\.(png|exr)$)", std::regex::icase);
  return layout == Layout::Ubo2003 ? ubo : utia;
}

struct Angles {  // integer degrees, as in the file names
  int theta = 0, phi = 0;
  auto operator<=>(const Angles&) const = default;
};

struct Entry {
  Angles light, view;
  fs::path path;
};

// Image files of the layout in `folder` and its immediate subfolders (the per-view folders).
Result<std::vector<Entry>> scan(const fs::path& folder, Layout layout) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec))
    return fail(ErrorKind::NotFound, "BTF folder '{}' does not exist or is not a folder", folder.string());
  std::vector<fs::path> files;
  auto add_files = [&](const fs::path& dir) -> Result<void> {
    std::error_code e;
    for (fs::directory_iterator it(dir, e), end; !e && it != end; it.increment(e))
      if (it->is_regular_file(e)) files.push_back(it->path());
    if (e) return fail(ErrorKind::Io, "cannot list '{}': {}", dir.string(), e.message());
    return {};
  };
  WEFT_TRY_VOID(add_files(folder));
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_directory(ec))
      WEFT_TRY_VOID(add_files(it->path()));
  std::vector<Entry> entries;
  for (const auto& f : files) {
    std::smatch m;
    const std::string name = f.filename().string();
    if (!std::regex_match(name, m, pattern(layout))) continue;
    Entry e{{std::stoi(m[1].str()), std::stoi(m[2].str())}, {std::stoi(m[3].str()), std::stoi(m[4].str())}, f};
    for (Angles a : {e.light, e.view})
      if (a.theta > 90 || a.phi >= 360)
        return fail(ErrorKind::Parse, "{}: angles θ {}°, φ {}° out of range (θ <= 90, φ < 360)", f.string(), a.theta, a.phi);
    entries.push_back(std::move(e));
  }
  return entries;
}

Direction to_direction(Angles a) {
  constexpr float k = std::numbers::pi_v<float> / 180.0f;
  return {float(a.theta) * k, float(a.phi) * k};
}

// CIE XYZ (D65) -> linear sRGB (IEC 61966-2-1).
vec3 xyz_to_linear_srgb(vec3 c) {
  return {3.2404542f * c.x - 1.5371385f * c.y - 0.4985314f * c.z, -0.9692660f * c.x + 1.8760108f * c.y + 0.0415560f * c.z,
          0.0556434f * c.x - 0.2040259f * c.y + 1.0572252f * c.z};
}

std::string lower_extension(const fs::path& p) {
  std::string e = p.extension().string();
  std::ranges::transform(e, e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

// One image as linear RGB, checked: 8-bit files are sRGB-decoded; float files must hold
// finite, non-negative samples (the error names the file and pixel).
Result<image::Image> read_rgb(const fs::path& path, Layout layout) {
  const std::string ext = lower_extension(path);
  image::Image img;
  const bool is_float = ext == ".exr" || ext == ".hdr";
  if (is_float) {
    WEFT_TRY(auto loaded, ext == ".exr" ? image::load_exr(path) : image::load_hdr(path));
    img = std::move(loaded);
    for (std::size_t i = 0; i < img.pixels.size(); ++i)
      if (!std::isfinite(img.pixels[i]) || img.pixels[i] < 0.0f) {
        const std::size_t pixel = i / img.channels;
        return fail(ErrorKind::Parse, "{}: sample {} (not finite and >= 0) at pixel ({}, {}), channel {}", path.string(),
                    img.pixels[i], pixel % img.width, pixel / img.width, i % img.channels);
      }
  } else {
    WEFT_TRY(auto loaded, image::load_ldr(path));
    img = image::from_srgb8(loaded);
  }
  image::Image rgb = image::Image::filled(img.width, img.height, 3);
  const bool gray = img.channels <= 2;
  for (std::size_t p = 0; p < std::size_t(img.width) * img.height; ++p) {
    const float* src = img.pixels.data() + p * img.channels;
    vec3 c = gray ? vec3(src[0]) : vec3(src[0], src[1], src[2]);
    if (is_float && layout == Layout::Utia && !gray) c = glm::max(xyz_to_linear_srgb(c), vec3(0.0f));
    rgb.pixels[p * 3] = c.r, rgb.pixels[p * 3 + 1] = c.g, rgb.pixels[p * 3 + 2] = c.b;
  }
  return rgb;
}

std::string pair_name(Layout layout, Angles l, Angles v) {
  return layout == Layout::Ubo2003
             ? weft::format("tl{:03} pl{:03} tv{:03} pv{:03}", l.theta, l.phi, v.theta, v.phi)
             : weft::format("tl{:03}_pl{:03}_tv{:03}_pv{:03}", l.theta, l.phi, v.theta, v.phi);
}

Result<Btf> load_image_set(const fs::path& folder, Layout layout, const Crop& crop) {
  auto context = [&](Error e) { return with_context(weft::format("loading {} BTF '{}'", layout_name(layout), folder.string()), std::move(e)); };
  auto entries = scan(folder, layout);
  if (!entries) return context(entries.error());
  if (entries->empty())
    return fail(ErrorKind::NotFound, "no {} BTF images (named like '{}') in '{}'", layout_name(layout),
                layout == Layout::Ubo2003 ? "00000 tl000 pl000 tv000 pv000.jpg" : "tl000_pl000_tv000_pv000.png",
                folder.string());
  std::vector<Angles> light_angles, view_angles;
  for (const auto& e : *entries) light_angles.push_back(e.light), view_angles.push_back(e.view);
  for (auto* v : {&light_angles, &view_angles}) {
    std::ranges::sort(*v);
    v->erase(std::unique(v->begin(), v->end()), v->end());
  }
  const std::size_t L = light_angles.size(), V = view_angles.size();
  std::vector<const Entry*> grid(L * V, nullptr);
  for (const auto& e : *entries) {
    const auto l = std::size_t(std::ranges::lower_bound(light_angles, e.light) - light_angles.begin());
    const auto v = std::size_t(std::ranges::lower_bound(view_angles, e.view) - view_angles.begin());
    if (grid[l * V + v])
      return context(Error{ErrorKind::Parse, weft::format("two images for {}: '{}' and '{}'", pair_name(layout, e.light, e.view),
                                                          grid[l * V + v]->path.string(), e.path.string())});
    grid[l * V + v] = &e;
  }
  for (std::size_t i = 0; i < grid.size(); ++i)
    if (!grid[i])
      return context(Error{ErrorKind::Parse,
                           weft::format("the image for {} is missing ({} lights x {} views need {} images, found {})",
                                        pair_name(layout, light_angles[i / V], view_angles[i % V]), L, V, L * V,
                                        entries->size())});

  auto first = read_rgb(grid[0]->path, layout);
  if (!first) return context(first.error());
  const std::uint32_t iw = first->width, ih = first->height;
  const std::uint32_t cw = crop.width ? crop.width : (crop.x < iw ? iw - crop.x : 0);
  const std::uint32_t ch = crop.height ? crop.height : (crop.y < ih ? ih - crop.y : 0);
  if (cw == 0 || ch == 0 || std::uint64_t(crop.x) + cw > iw || std::uint64_t(crop.y) + ch > ih)
    return context(Error{ErrorKind::InvalidArgument, weft::format("crop ({}, {}) size {} x {} does not fit the {} x {} images",
                                                                  crop.x, crop.y, crop.width, crop.height, iw, ih)});
  Btf btf{cw, ch, {}, {}, {}};
  for (auto a : light_angles) btf.lights.push_back(to_direction(a));
  for (auto a : view_angles) btf.views.push_back(to_direction(a));
  btf.rgb.assign(btf.texels() * btf.abrdf_floats(), 0.0f);
  if (L * V > 500)
    log::info(weft::format("loading {} BTF '{}': {} images, {} x {} texels", layout_name(layout), folder.string(), L * V, cw, ch));

  std::vector<std::optional<Error>> errors(L * V);
  cluster::parallel_each(L * V, 0, [&](std::size_t i) {
    auto img = i == 0 ? Result<image::Image>(*first) : read_rgb(grid[i]->path, layout);
    if (!img) {
      errors[i] = img.error();
      return;
    }
    if (img->width != iw || img->height != ih) {
      errors[i] = Error{ErrorKind::Parse, weft::format("'{}' is {} x {}, the other images {} x {}", grid[i]->path.string(),
                                                       img->width, img->height, iw, ih)};
      return;
    }
    for (std::uint32_t y = 0; y < ch; ++y)
      for (std::uint32_t x = 0; x < cw; ++x) {
        const float* src = img->pixels.data() + (std::size_t(crop.y + y) * iw + crop.x + x) * 3;
        float* dst = btf.rgb.data() + ((std::size_t(y) * cw + x) * L * V + i) * 3;
        dst[0] = src[0], dst[1] = src[1], dst[2] = src[2];
      }
  });
  for (auto& e : errors)
    if (e) return context(std::move(*e));
  WEFT_TRY_VOID(validate(btf, folder.string()));
  return btf;
}

// ---- .btfraw ------------------------------------------------------------------------------

constexpr char kMagic[8] = {'W', 'E', 'F', 'T', 'B', 'T', 'F', 'R'};
constexpr std::size_t kFixedHeader = 48;  // magic, version, header size, 4 sizes, floats, payload checksum
static_assert(std::endian::native == std::endian::little, ".btfraw is little-endian; so is every supported host");

template <class T>
void put(std::vector<std::byte>& out, const T& v) {
  const auto* p = reinterpret_cast<const std::byte*>(&v);
  out.insert(out.end(), p, p + sizeof v);
}
template <class T>
T get(const std::byte* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

Result<Btf> load_raw(const fs::path& file, const Crop& crop_rect) {
  const std::string name = file.string();
  WEFT_TRY_VOID(check_input_file(file, "BTF file"));
  std::ifstream in(file, std::ios::binary);
  if (!in) return fail(ErrorKind::NotFound, "cannot open BTF file '{}'", name);
  std::error_code ec;
  const std::uint64_t file_size = fs::file_size(file, ec);
  if (ec) return fail(ErrorKind::Io, "cannot read the size of '{}': {}", name, ec.message());
  std::vector<std::byte> fixed(kFixedHeader);
  if (file_size < kFixedHeader + 8 || !in.read(reinterpret_cast<char*>(fixed.data()), kFixedHeader))
    return fail(ErrorKind::Parse, "'{}' is too short ({} bytes) for a .btfraw header", name, file_size);
  if (std::memcmp(fixed.data(), kMagic, 8) != 0)
    return fail(ErrorKind::Parse, "'{}' is not a .btfraw file (magic bytes differ)", name);
  const auto version = get<std::uint32_t>(fixed.data() + 8), header_size = get<std::uint32_t>(fixed.data() + 12);
  if (version != kBtfRawVersion)
    return fail(ErrorKind::Unsupported, "'{}' is .btfraw version {}, this build reads version {}", name, version, kBtfRawVersion);
  const auto width = get<std::uint32_t>(fixed.data() + 16), height = get<std::uint32_t>(fixed.data() + 20);
  const auto lights = get<std::uint32_t>(fixed.data() + 24), views = get<std::uint32_t>(fixed.data() + 28);
  const auto floats = get<std::uint64_t>(fixed.data() + 32), payload_sum = get<std::uint64_t>(fixed.data() + 40);
  const std::uint64_t expected_header = kFixedHeader + (std::uint64_t(lights) + views) * 8 + 8;
  if (header_size != expected_header)
    return fail(ErrorKind::Parse, "'{}': header size {} does not match {} lights and {} views (expected {})", name, header_size,
                lights, views, expected_header);
  const std::uint64_t expected_floats = std::uint64_t(width) * height * lights * views * 3;
  if (floats != expected_floats || header_size + floats * 4 != file_size)
    return fail(ErrorKind::Parse, "'{}': {} x {} texels x {} x {} directions need {} floats; the header says {} and the file "
                "holds {} bytes after a {}-byte header (truncated or corrupt)", name, width, height, lights, views,
                expected_floats, floats, file_size >= header_size ? file_size - header_size : 0, header_size);
  std::vector<std::byte> header(header_size);
  std::memcpy(header.data(), fixed.data(), kFixedHeader);
  if (!in.read(reinterpret_cast<char*>(header.data() + kFixedHeader), std::streamsize(header_size - kFixedHeader)))
    return fail(ErrorKind::Parse, "'{}': truncated header", name);
  if (get<std::uint64_t>(header.data() + header_size - 8) != hash_bytes(std::span(header.data(), header_size - 8)))
    return fail(ErrorKind::Parse, "'{}': header checksum mismatch (corrupt header)", name);
  Btf btf{width, height, {}, {}, {}};
  for (std::uint32_t i = 0; i < lights + views; ++i) {
    const Direction d{get<float>(header.data() + kFixedHeader + i * 8), get<float>(header.data() + kFixedHeader + i * 8 + 4)};
    (i < lights ? btf.lights : btf.views).push_back(d);
  }
  btf.rgb.resize(floats);
  if (!in.read(reinterpret_cast<char*>(btf.rgb.data()), std::streamsize(floats * 4)))
    return fail(ErrorKind::Parse, "'{}': truncated samples", name);
  if (hash_bytes(std::as_bytes(std::span(btf.rgb))) != payload_sum)
    return fail(ErrorKind::Parse, "'{}': sample checksum mismatch (corrupt samples)", name);
  WEFT_TRY_VOID(validate(btf, name));
  if (crop_rect.x == 0 && crop_rect.y == 0 && crop_rect.width == 0 && crop_rect.height == 0) return btf;
  auto cropped = crop(btf, crop_rect);
  if (!cropped) return with_context(name, cropped.error());
  return cropped;
}

}  // namespace

Result<Btf> load_ubo2003(const fs::path& folder, const Crop& crop) { return load_image_set(folder, Layout::Ubo2003, crop); }
Result<Btf> load_utia(const fs::path& folder, const Crop& crop) { return load_image_set(folder, Layout::Utia, crop); }

Result<Btf> load_btf(const fs::path& path, const Crop& crop) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    WEFT_TRY(auto utia, scan(path, Layout::Utia));
    WEFT_TRY(auto ubo, scan(path, Layout::Ubo2003));
    if (utia.empty() && ubo.empty())
      return fail(ErrorKind::NotFound,
                  "'{}' holds no BTF images (UBO2003: '00000 tl000 pl000 tv000 pv000.jpg', UTIA: "
                  "'tl000_pl000_tv000_pv000.png', in the folder or its per-view subfolders)", path.string());
    return utia.size() >= ubo.size() ? load_utia(path, crop) : load_ubo2003(path, crop);
  }
  if (!fs::exists(path, ec)) return fail(ErrorKind::NotFound, "BTF '{}' does not exist", path.string());
  if (lower_extension(path) != ".btfraw")
    return fail(ErrorKind::Unsupported, "'{}' is neither a .btfraw file nor a folder of BTF images", path.string());
  return load_raw(path, crop);
}

Result<void> save_btf(const Btf& btf, const fs::path& file) {
  if (btf.rgb.size() != btf.texels() * btf.abrdf_floats())
    return fail(ErrorKind::InvalidArgument, "saving '{}': BTF holds {} floats, not {} x {} texels x {} x {} directions x 3",
                file.string(), btf.rgb.size(), btf.width, btf.height, btf.lights.size(), btf.views.size());
  std::vector<std::byte> header;
  header.insert(header.end(), reinterpret_cast<const std::byte*>(kMagic), reinterpret_cast<const std::byte*>(kMagic) + 8);
  put(header, kBtfRawVersion);
  put(header, static_cast<std::uint32_t>(kFixedHeader + (btf.lights.size() + btf.views.size()) * 8 + 8));
  put(header, btf.width), put(header, btf.height);
  put(header, static_cast<std::uint32_t>(btf.lights.size())), put(header, static_cast<std::uint32_t>(btf.views.size()));
  put(header, static_cast<std::uint64_t>(btf.rgb.size()));
  put(header, hash_bytes(std::as_bytes(std::span(btf.rgb))));
  for (const auto* set : {&btf.lights, &btf.views})
    for (auto d : *set) put(header, d.theta), put(header, d.phi);
  put(header, hash_bytes(header));
  return write_file_atomically(file, {std::span<const std::byte>(header), std::as_bytes(std::span(btf.rgb))}, "BTF");
}

}  // namespace weft::btf
