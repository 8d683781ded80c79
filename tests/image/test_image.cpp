// Tests of weft.image: file round trips (PNG exact, Radiance within RGBE precision, EXR
// float exact and half within half precision, tiled EXR), the sRGB transfer, the error
// paths a user hits, and the metrics against analytic results and a brute-force SSIM.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <string_view>
#include <vector>
#include <sys/stat.h>
#include <unistd.h>

#include <tinyexr.h>  // declarations only: to write a tiled EXR, which weft.image never writes
#include <cstdio>  // before jpeglib.h, which uses FILE
#include <jpeglib.h>  // to write a CMYK JPEG, which weft.image never writes

import weft.image;
import weft.core;

namespace fs = std::filesystem;
using weft::ErrorKind;
using weft::image::Image;
using weft::image::Image8;

namespace {

// A fresh folder under the system temp dir, removed with everything in it.
struct TempDir {
  fs::path path;
  TempDir() {
    static std::atomic<int> counter{0};
    std::random_device rd;
    path = fs::temp_directory_path() /
           ("weft-test-image-" + std::to_string(rd()) + "-" + std::to_string(counter++));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  fs::path operator/(const std::string& name) const { return path / name; }
  // Files whose name ends in ".tmp": a finished save must leave none.
  [[nodiscard]] int tmp_files() const {
    int n = 0;
    for (const auto& e : fs::directory_iterator(path)) n += e.path().extension() == ".tmp";
    return n;
  }
};

std::vector<std::uint8_t> read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_all(const fs::path& p, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

// Every 8-bit value shows up somewhere, different in every channel.
Image8 pattern8(std::uint32_t w, std::uint32_t h, std::uint32_t c) {
  Image8 img = Image8::filled(w, h, c);
  for (std::size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = static_cast<std::uint8_t>((i * 37 + 11) % 256);
  return img;
}

// Smooth structure plus detail, values in [lo, hi].
Image pattern(std::uint32_t w, std::uint32_t h, std::uint32_t c, float lo = 0.0f, float hi = 1.0f) {
  Image img = Image::filled(w, h, c);
  for (std::uint32_t y = 0; y < h; ++y) {
    for (std::uint32_t x = 0; x < w; ++x) {
      for (std::uint32_t k = 0; k < c; ++k) {
        const double t = 0.5 + 0.25 * std::sin(0.7 * x + 1.3 * k) + 0.25 * std::cos(0.45 * y * (k + 1) + 0.2 * x);
        img.at(x, y, k) = static_cast<float>(lo + (hi - lo) * t);
      }
    }
  }
  return img;
}

Image add_noise(Image img, double sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  for (float& v : img.pixels) v = static_cast<float>(v + noise(rng));
  return img;
}

// The error's kind, or Internal when there is no error (so the CHECK fails clearly).
template <class T>
ErrorKind kind_of(const weft::Result<T>& r) {
  return r ? ErrorKind::Internal : r.error().kind;
}

template <class T>
bool message_has(const weft::Result<T>& r, const std::string& text) {
  return !r && r.error().message.find(text) != std::string::npos;
}

// Straight-from-the-paper SSIM on luminance: every 11x11 (or shrunk) window, means and
// (co)variances by two passes about the window mean. Slow, independent of metrics.cpp.
double reference_ssim(const Image& a, const Image& b, double L = 1.0) {
  auto lum = [](const Image& img, std::uint32_t x, std::uint32_t y) {
    if (img.channels >= 3) return 0.2126 * img.at(x, y, 0) + 0.7152 * img.at(x, y, 1) + 0.0722 * img.at(x, y, 2);
    return static_cast<double>(img.at(x, y, 0));
  };
  const std::uint32_t wx = std::min(11u, a.width), wy = std::min(11u, a.height);
  auto gauss = [](std::uint32_t n) {
    std::vector<double> g(n);
    double s = 0;
    for (std::uint32_t i = 0; i < n; ++i) {
      const double d = i - (n - 1) / 2.0;
      s += g[i] = std::exp(-d * d / (2 * 1.5 * 1.5));
    }
    for (double& v : g) v /= s;
    return g;
  };
  const auto gx = gauss(wx), gy = gauss(wy);
  const double c1 = (0.01 * L) * (0.01 * L), c2 = (0.03 * L) * (0.03 * L);
  double total = 0;
  int count = 0;
  for (std::uint32_t oy = 0; oy + wy <= a.height; ++oy) {
    for (std::uint32_t ox = 0; ox + wx <= a.width; ++ox) {
      double ma = 0, mb = 0;
      for (std::uint32_t j = 0; j < wy; ++j)
        for (std::uint32_t i = 0; i < wx; ++i) {
          ma += gx[i] * gy[j] * lum(a, ox + i, oy + j);
          mb += gx[i] * gy[j] * lum(b, ox + i, oy + j);
        }
      double va = 0, vb = 0, cov = 0;
      for (std::uint32_t j = 0; j < wy; ++j)
        for (std::uint32_t i = 0; i < wx; ++i) {
          const double da = lum(a, ox + i, oy + j) - ma, db = lum(b, ox + i, oy + j) - mb;
          va += gx[i] * gy[j] * da * da;
          vb += gx[i] * gy[j] * db * db;
          cov += gx[i] * gy[j] * da * db;
        }
      total += ((2 * ma * mb + c1) * (2 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
      ++count;
    }
  }
  return total / count;
}

// SSIM's luminance term for window means mu_a, mu_b.
double luminance_term(double mu_a, double mu_b, double L = 1.0) {
  const double c1 = (0.01 * L) * (0.01 * L);
  return (2 * mu_a * mu_b + c1) / (mu_a * mu_a + mu_b * mu_b + c1);
}

}  // namespace

// ---- the Image type ------------------------------------------------------------------------

TEST_CASE("Image::at indexes row-major, top row first, channels interleaved") {
  Image img = Image::filled(3, 2, 4, 0.0f);
  REQUIRE(img.pixels.size() == 24);
  img.at(2, 1, 3) = 7.0f;
  img.at(1, 0, 2) = 5.0f;
  CHECK(img.pixels[(1 * 3 + 2) * 4 + 3] == 7.0f);
  CHECK(img.pixels[(0 * 3 + 1) * 4 + 2] == 5.0f);
  CHECK(std::count(img.pixels.begin(), img.pixels.end(), 0.0f) == 22);

  Image8 img8 = Image8::filled(2, 2, 1, 9);
  img8.at(1, 1, 0) = 200;
  CHECK(img8.pixels == std::vector<std::uint8_t>{9, 9, 9, 200});
}

TEST_CASE("validate rejects zero size, channel counts outside 1..4 and wrong pixel counts") {
  CHECK(weft::image::validate(Image::filled(2, 2, 3)));
  CHECK(weft::image::validate(Image8::filled(1, 1, 1)));
  CHECK(kind_of(weft::image::validate(Image::filled(0, 2, 3))) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::validate(Image::filled(2, 0, 3))) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::validate(Image::filled(2, 2, 0))) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::validate(Image::filled(2, 2, 5))) == ErrorKind::InvalidArgument);
  Image short_pixels = Image::filled(2, 2, 3);
  short_pixels.pixels.pop_back();
  const auto r = weft::image::validate(short_pixels);
  CHECK(kind_of(r) == ErrorKind::InvalidArgument);
  CHECK(message_has(r, "12"));
  CHECK(message_has(r, "11"));
  Image8 bad8 = Image8::filled(2, 2, 2);
  bad8.pixels.push_back(0);
  CHECK(kind_of(weft::image::validate(bad8)) == ErrorKind::InvalidArgument);
}

// ---- round trips -----------------------------------------------------------------------------

TEST_CASE("PNG round trip is exact for 1 to 4 channels") {
  TempDir dir;
  for (std::uint32_t c = 1; c <= 4; ++c) {
    CAPTURE(c);
    const Image8 img = pattern8(7, 5, c);
    const fs::path p = dir / ("rt" + std::to_string(c) + ".png");
    REQUIRE(weft::image::save_png(p, img));
    const auto back = weft::image::load_png(p);
    REQUIRE(back);
    CHECK(back->width == 7);
    CHECK(back->height == 5);
    CHECK(back->channels == c);
    CHECK(back->pixels == img.pixels);
    const auto any = weft::image::load_ldr(p);
    REQUIRE(any);
    CHECK(any->pixels == img.pixels);
  }
  // A 1x1 image is still an image.
  const fs::path one = dir / "one.png";
  REQUIRE(weft::image::save_png(one, Image8{1, 1, 3, {1, 2, 250}}));
  const auto back = weft::image::load_png(one);
  REQUIRE(back);
  CHECK(back->pixels == std::vector<std::uint8_t>{1, 2, 250});
  CHECK(dir.tmp_files() == 0);
}

TEST_CASE("decode_ldr reads encoded bytes in memory as load_ldr reads the file; bad bytes name the label") {
  TempDir dir;
  const Image8 img = pattern8(6, 3, 3);
  const fs::path p = dir / "bytes.png";
  REQUIRE(weft::image::save_png(p, img));
  const auto bytes = read_all(p);
  const auto decoded = weft::image::decode_ldr(bytes, "glTF 'a.glb' image 2");
  REQUIRE(decoded);
  CHECK(decoded->width == 6);
  CHECK(decoded->height == 3);
  CHECK(decoded->pixels == img.pixels);
  const std::vector<std::uint8_t> garbage = {1, 2, 3, 4, 5};
  for (const auto& bad : {garbage, std::vector<std::uint8_t>{}, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 40)}) {
    const auto refused = weft::image::decode_ldr(bad, "glTF 'a.glb' image 2");
    REQUIRE_FALSE(refused);
    CHECK(refused.error().kind == weft::ErrorKind::Parse);
    CHECK_MESSAGE(refused.error().message.find("glTF 'a.glb' image 2") != std::string::npos, refused.error().message);
  }
}

TEST_CASE("Radiance HDR round trip stays within RGBE precision") {
  TempDir dir;
  // Values over nine decades, different per channel.
  Image img = Image::filled(9, 4, 3);
  for (std::size_t i = 0; i < img.pixels.size(); ++i) {
    img.pixels[i] = static_cast<float>(std::pow(10.0, -4.0 + 9.0 * static_cast<double>(i) / img.pixels.size()) *
                                       (1.0 + 0.3 * std::sin(i * 1.7)));
  }
  const fs::path p = dir / "rt.hdr";
  REQUIRE(weft::image::save_hdr(p, img));
  const auto back = weft::image::load_hdr(p);
  REQUIRE(back);
  REQUIRE(back->width == 9);
  REQUIRE(back->height == 4);
  REQUIRE(back->channels == 3);
  // RGBE shares one exponent per pixel with an 8-bit mantissa: error < max(r,g,b) / 128.
  for (std::uint32_t y = 0; y < 4; ++y) {
    for (std::uint32_t x = 0; x < 9; ++x) {
      const float m = std::max({img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)});
      for (std::uint32_t c = 0; c < 3; ++c) {
        CAPTURE(x);
        CAPTURE(y);
        CHECK(std::abs(back->at(x, y, c) - img.at(x, y, c)) <= m / 128.0f);
      }
      // The largest channel is within 1%.
      const float mb = std::max({back->at(x, y, 0), back->at(x, y, 1), back->at(x, y, 2)});
      CHECK(mb == doctest::Approx(m).epsilon(0.01));
    }
  }
}

TEST_CASE("Radiance HDR: gray is written as RGB, NaN and negatives as 0") {
  TempDir dir;
  const Image gray{3, 1, 1, {0.25f, std::numeric_limits<float>::quiet_NaN(), -4.0f}};
  const fs::path p = dir / "gray.hdr";
  REQUIRE(weft::image::save_hdr(p, gray));
  const auto back = weft::image::load_hdr(p);
  REQUIRE(back);
  REQUIRE(back->channels == 3);
  for (std::uint32_t c = 0; c < 3; ++c) {
    CHECK(back->at(0, 0, c) == doctest::Approx(0.25).epsilon(0.01));
    CHECK(back->at(1, 0, c) == 0.0f);
    CHECK(back->at(2, 0, c) == 0.0f);
  }
}

TEST_CASE("EXR float32 round trip is bit-exact for 1 to 4 channels, including NaN, inf and extremes") {
  TempDir dir;
  for (std::uint32_t c = 1; c <= 4; ++c) {
    CAPTURE(c);
    Image img = pattern(6, 5, c, -3.0f, 40.0f);
    img.at(0, 0, 0) = std::numeric_limits<float>::quiet_NaN();
    img.at(1, 0, c - 1) = std::numeric_limits<float>::infinity();
    img.at(2, 0, 0) = 1e30f;
    img.at(3, 0, c - 1) = FLT_MAX;
    img.at(4, 0, 0) = std::numeric_limits<float>::denorm_min();
    img.at(5, 0, c - 1) = -0.0f;
    const fs::path p = dir / ("rt" + std::to_string(c) + ".exr");
    REQUIRE(weft::image::save_exr(p, img));
    const auto back = weft::image::load_exr(p);
    REQUIRE(back);
    CHECK(back->width == 6);
    CHECK(back->height == 5);
    REQUIRE(back->channels == c);
    REQUIRE(back->pixels.size() == img.pixels.size());
    CHECK(std::memcmp(back->pixels.data(), img.pixels.data(), img.pixels.size() * sizeof(float)) == 0);
  }
}

TEST_CASE("EXR half round trip is within half precision") {
  TempDir dir;
  Image img = pattern(8, 3, 4, 0.001f, 1000.0f);
  img.at(0, 0, 0) = 65504.0f;  // largest half
  img.at(1, 0, 0) = 0.5f;      // exact in half
  img.at(2, 0, 0) = 1e6f;      // overflows half
  const fs::path p = dir / "half.exr";
  REQUIRE(weft::image::save_exr(p, img, weft::image::ExrPixelType::Half));
  const auto back = weft::image::load_exr(p);
  REQUIRE(back);
  REQUIRE(back->pixels.size() == img.pixels.size());
  CHECK(back->at(0, 0, 0) == 65504.0f);
  CHECK(back->at(1, 0, 0) == 0.5f);
  CHECK(std::isinf(back->at(2, 0, 0)));
  for (std::size_t i = 0; i < img.pixels.size(); ++i) {
    if (i == 0 || i == 4 || i == 8) continue;  // the three set above
    CAPTURE(i);
    CHECK(std::abs(back->pixels[i] - img.pixels[i]) <= img.pixels[i] * (1.0f / 2048.0f));
  }
  // Half files are smaller than float ones.
  const fs::path pf = dir / "float.exr";
  REQUIRE(weft::image::save_exr(pf, img));
  CHECK(fs::file_size(p) < fs::file_size(pf));
}

TEST_CASE("a tiled EXR (written by tinyexr directly) reads back in place") {
  // 6x5 in 4x4 tiles: the right and bottom tiles are partial.
  const int w = 6, h = 5, ts = 4, nx = 2, ny = 2;
  auto value = [](int x, int y) { return static_cast<float>(x + 10 * y) + 0.25f; };
  std::vector<std::vector<float>> planes(nx * ny, std::vector<float>(ts * ts, -1.0f));
  std::vector<unsigned char*> plane_ptrs(nx * ny);
  std::vector<EXRTile> tiles(nx * ny);
  for (int t = 0; t < nx * ny; ++t) {
    const int tx = t % nx, ty = t / nx;
    EXRTile& tile = tiles[t];
    std::memset(&tile, 0, sizeof tile);
    tile.offset_x = tx;
    tile.offset_y = ty;
    tile.width = std::min(ts, w - tx * ts);
    tile.height = std::min(ts, h - ty * ts);
    for (int j = 0; j < tile.height; ++j)
      for (int i = 0; i < tile.width; ++i) planes[t][j * ts + i] = value(tx * ts + i, ty * ts + j);
    plane_ptrs[t] = reinterpret_cast<unsigned char*>(planes[t].data());
    tile.images = &plane_ptrs[t];
  }
  EXRChannelInfo channel;
  std::memset(&channel, 0, sizeof channel);
  std::strcpy(channel.name, "Y");
  channel.x_sampling = channel.y_sampling = 1;
  int pixel_type = TINYEXR_PIXELTYPE_FLOAT, stored_type = TINYEXR_PIXELTYPE_FLOAT;
  EXRHeader header;
  InitEXRHeader(&header);
  header.num_channels = 1;
  header.channels = &channel;
  header.pixel_types = &pixel_type;
  header.requested_pixel_types = &stored_type;
  header.compression_type = TINYEXR_COMPRESSIONTYPE_ZIP;
  header.tiled = 1;
  header.tile_size_x = ts;
  header.tile_size_y = ts;
  header.tile_level_mode = TINYEXR_TILE_ONE_LEVEL;
  header.data_window.max_x = w - 1;  // tinyexr counts tiles from the data window
  header.data_window.max_y = h - 1;
  EXRImage image;
  InitEXRImage(&image);
  image.width = w;
  image.height = h;
  image.num_channels = 1;
  image.tiles = tiles.data();
  image.num_tiles = nx * ny;
  unsigned char* memory = nullptr;
  const char* err = nullptr;
  const std::size_t size = SaveEXRImageToMemory(&image, &header, &memory, &err);
  if (err != nullptr) FreeEXRErrorMessage(err);
  REQUIRE(size > 0);
  std::vector<std::uint8_t> bytes(memory, memory + size);
  std::free(memory);

  TempDir dir;
  write_all(dir / "tiled.exr", bytes);
  const auto back = weft::image::load_exr(dir / "tiled.exr");
  REQUIRE(back);
  REQUIRE(back->width == 6);
  REQUIRE(back->height == 5);
  REQUIRE(back->channels == 1);
  for (std::uint32_t y = 0; y < 5; ++y)
    for (std::uint32_t x = 0; x < 6; ++x) CHECK(back->at(x, y, 0) == value(static_cast<int>(x), static_cast<int>(y)));
}

TEST_CASE("save_image and load_float_image dispatch on the extension") {
  TempDir dir;
  const Image img = pattern(5, 4, 3);
  // .png: sRGB-encoded, with exposure.
  REQUIRE(weft::image::save_image(dir / "a.png", img, 0.5f));
  const auto png = weft::image::load_png(dir / "a.png");
  REQUIRE(png);
  CHECK(png->pixels == weft::image::to_srgb8(img, 0.5f).pixels);
  const auto png_float = weft::image::load_float_image(dir / "a.png");
  REQUIRE(png_float);
  CHECK(png_float->pixels == weft::image::from_srgb8(*png).pixels);
  // .EXR (upper case) is float32 and exact; exposure does not apply.
  REQUIRE(weft::image::save_image(dir / "b.EXR", img, 4.0f));
  const auto exr = weft::image::load_float_image(dir / "b.EXR");
  REQUIRE(exr);
  CHECK(exr->pixels == img.pixels);
  // .hdr is Radiance.
  REQUIRE(weft::image::save_image(dir / "c.hdr", img));
  const auto hdr = weft::image::load_float_image(dir / "c.hdr");
  REQUIRE(hdr);
  CHECK(*weft::image::max_abs_diff(*hdr, img) < 1.0 / 128.0);
  // 8-bit images: .png as is, .exr through from_srgb8.
  const Image8 img8 = pattern8(3, 3, 4);
  REQUIRE(weft::image::save_image(dir / "d.png", img8));
  CHECK(weft::image::load_png(dir / "d.png")->pixels == img8.pixels);
  REQUIRE(weft::image::save_image(dir / "e.exr", img8));
  CHECK(weft::image::load_exr(dir / "e.exr")->pixels == weft::image::from_srgb8(img8).pixels);
  // Unknown extensions are refused, naming the extension.
  const auto tiff = weft::image::save_image(dir / "f.tiff", img);
  CHECK(kind_of(tiff) == ErrorKind::Unsupported);
  CHECK(message_has(tiff, ".tiff"));
  CHECK(kind_of(weft::image::load_float_image(dir / "a.bmp")) == ErrorKind::Unsupported);
  CHECK(!fs::exists(dir / "f.tiff"));
  CHECK(dir.tmp_files() == 0);
}

// ---- sRGB --------------------------------------------------------------------------------------

TEST_CASE("sRGB transfer matches known values") {
  using weft::image::linear_to_srgb;
  using weft::image::srgb_to_linear;
  // 0.5 linear is 188/255.
  CHECK(linear_to_srgb(0.5f) == doctest::Approx(0.735357).epsilon(1e-6));
  CHECK(weft::image::to_srgb8(Image{1, 1, 1, {0.5f}}).pixels[0] == 188);
  CHECK(weft::image::to_srgb8(Image{1, 1, 1, {0.2158605f}}).pixels[0] == 128);  // code 128 decoded
  CHECK(srgb_to_linear(0.5f) == doctest::Approx(0.214041).epsilon(1e-5));
  // The linear segment below 0.0031308, and continuity at the boundary.
  CHECK(linear_to_srgb(0.001f) == doctest::Approx(0.01292).epsilon(1e-6));
  CHECK(linear_to_srgb(0.0031308f) == doctest::Approx(0.04045).epsilon(1e-4));
  CHECK(std::abs(linear_to_srgb(std::nextafter(0.0031308f, 0.0f)) - linear_to_srgb(std::nextafter(0.0031308f, 1.0f))) <
        1e-6f);
  CHECK(weft::image::to_srgb8(Image{1, 1, 1, {0.0031308f}}).pixels[0] == 10);  // 0.04045 * 255 = 10.3
  CHECK(srgb_to_linear(0.04045f) == doctest::Approx(0.04045 / 12.92).epsilon(1e-6));
  CHECK(linear_to_srgb(0.0f) == 0.0f);
  CHECK(linear_to_srgb(1.0f) == doctest::Approx(1.0).epsilon(1e-7));
  CHECK(srgb_to_linear(1.0f) == doctest::Approx(1.0).epsilon(1e-7));
  // Clamped, NaN -> 0.
  CHECK(linear_to_srgb(-2.0f) == 0.0f);
  CHECK(linear_to_srgb(7.0f) == doctest::Approx(1.0).epsilon(1e-7));
  CHECK(linear_to_srgb(std::numeric_limits<float>::quiet_NaN()) == 0.0f);
  CHECK(srgb_to_linear(std::numeric_limits<float>::quiet_NaN()) == 0.0f);
}

TEST_CASE("every 8-bit code survives from_srgb8 then to_srgb8, colour and alpha") {
  Image8 all = Image8::filled(256, 1, 4);
  for (std::uint32_t x = 0; x < 256; ++x)
    for (std::uint32_t c = 0; c < 4; ++c) all.at(x, 0, c) = static_cast<std::uint8_t>(c % 2 ? 255 - x : x);
  const Image linear = weft::image::from_srgb8(all);
  REQUIRE(linear.pixels.size() == all.pixels.size());
  CHECK(weft::image::to_srgb8(linear).pixels == all.pixels);
  // Linear values increase strictly with the code, and alpha is code/255.
  for (std::uint32_t x = 1; x < 256; ++x) CHECK(linear.at(x, 0, 0) > linear.at(x - 1, 0, 0));
  CHECK(linear.at(0, 0, 3) == doctest::Approx(1.0));
  CHECK(linear.at(128, 0, 3) == doctest::Approx(127.0 / 255.0));
  CHECK(linear.at(128, 0, 2) == doctest::Approx(weft::image::srgb_to_linear(128.0f / 255.0f)));
}

TEST_CASE("to_srgb8 clamps, maps NaN to 0, scales colour by exposure and leaves alpha linear") {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const Image8 gray = weft::image::to_srgb8(Image{6, 1, 1, {-1.0f, 2.0f, nan, inf, -inf, 0.0f}});
  CHECK(gray.pixels == std::vector<std::uint8_t>{0, 255, 0, 255, 0, 0});
  // RGBA: exposure 2 makes colour 0.25 into 0.5 -> 188; alpha 0.5 -> 128 regardless.
  const Image8 rgba = weft::image::to_srgb8(Image{1, 1, 4, {0.25f, 0.25f, nan, 0.5f}}, 2.0f);
  CHECK(rgba.pixels == std::vector<std::uint8_t>{188, 188, 0, 128});
  // Gray+alpha: the second channel is alpha.
  const Image8 ga = weft::image::to_srgb8(Image{1, 1, 2, {0.5f, 0.5f}});
  CHECK(ga.pixels == std::vector<std::uint8_t>{188, 128});
  // Exposure 0 of infinity is NaN, so 0.
  CHECK(weft::image::to_srgb8(Image{1, 1, 1, {inf}}, 0.0f).pixels[0] == 0);
  // Invalid images convert to empty ones.
  CHECK(weft::image::to_srgb8(Image{2, 2, 3, {1.0f}}).pixels.empty());
  CHECK(weft::image::from_srgb8(Image8{2, 2, 7, {}}).pixels.empty());
}

TEST_CASE("luminance uses Rec.709 weights and passes gray through") {
  const Image rgb{2, 1, 3, {1.0f, 0.0f, 0.0f, 0.2f, 0.4f, 0.8f}};
  const Image l = weft::image::luminance(rgb);
  REQUIRE(l.channels == 1);
  REQUIRE(l.pixels.size() == 2);
  CHECK(l.pixels[0] == doctest::Approx(0.2126));
  CHECK(l.pixels[1] == doctest::Approx(0.2126 * 0.2 + 0.7152 * 0.4 + 0.0722 * 0.8));
  const Image rgba{1, 1, 4, {0.0f, 1.0f, 0.0f, 0.3f}};
  CHECK(weft::image::luminance(rgba).pixels[0] == doctest::Approx(0.7152));
  const Image ga{1, 1, 2, {0.6f, 0.1f}};
  CHECK(weft::image::luminance(ga).pixels[0] == 0.6f);
  const Image white = Image::filled(3, 3, 3, 1.0f);
  for (float v : weft::image::luminance(white).pixels) CHECK(v == doctest::Approx(1.0).epsilon(1e-6));
  CHECK(weft::image::luminance(Image{}).pixels.empty());
}

// ---- error paths ---------------------------------------------------------------------------------

TEST_CASE("a missing file is NotFound naming the path") {
  TempDir dir;
  const fs::path missing = dir / "missing.png";
  for (const auto& r : {weft::image::load_png(missing), weft::image::load_ldr(missing)}) {
    CHECK(kind_of(r) == ErrorKind::NotFound);
    CHECK(message_has(r, missing.string()));
  }
  const auto hdr = weft::image::load_hdr(dir / "missing.hdr");
  CHECK(kind_of(hdr) == ErrorKind::NotFound);
  CHECK(message_has(hdr, "missing.hdr"));
  const auto exr = weft::image::load_float_image(dir / "missing.exr");
  CHECK(kind_of(exr) == ErrorKind::NotFound);
  CHECK(message_has(exr, "missing.exr"));
  // A folder is not an image.
  CHECK(kind_of(weft::image::load_png(dir.path)) == ErrorKind::Io);
}

TEST_CASE("issue 33: an image path that is a FIFO or a device is an Io error saying so, never a wait") {
  TempDir dir;
  ::alarm(30);  // a reader waiting on the FIFO ends the test run (SIGALRM) instead of hanging it
  for (const char* name : {"photo.png", "photo.jpg", "sky.hdr", "sky.exr"}) {
    const fs::path fifo = dir / name;
    REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
    const auto ldr = weft::image::load_ldr(fifo);
    CHECK(kind_of(ldr) == ErrorKind::Io);
    CHECK(message_has(ldr, "image file '" + fifo.string() + "' is a FIFO, not a regular file"));
    const auto any = weft::image::load_float_image(fifo);
    CHECK(kind_of(any) == ErrorKind::Io);
    CHECK(message_has(any, "is a FIFO"));
  }
  CHECK(message_has(weft::image::load_exr("/dev/zero"), "image file '/dev/zero' is a character device, not a regular file"));
  CHECK(message_has(weft::image::load_png(dir.path), "is a folder, not a regular file"));
  ::alarm(0);
}

TEST_CASE("a truncated PNG is a Parse error naming the path and the decoder's reason") {
  TempDir dir;
  REQUIRE(weft::image::save_png(dir / "full.png", pattern8(16, 16, 3)));
  auto bytes = read_all(dir / "full.png");
  REQUIRE(bytes.size() > 40);
  bytes.resize(40);
  const fs::path cut = dir / "cut.png";
  write_all(cut, bytes);
  const auto r = weft::image::load_png(cut);
  REQUIRE(!r);
  CHECK(r.error().kind == ErrorKind::Parse);
  CHECK(message_has(r, cut.string()));
  // "cannot decode PNG '<path>': <reason>" with a non-empty reason.
  const std::string& m = r.error().message;
  const auto colon = m.rfind("': ");
  REQUIRE(colon != std::string::npos);
  CHECK(m.size() > colon + 3);
  CHECK(kind_of(weft::image::load_ldr(cut)) == ErrorKind::Parse);
  CHECK(kind_of(weft::image::load_float_image(cut)) == ErrorKind::Parse);
}

TEST_CASE("garbage bytes are Parse errors for every format") {
  TempDir dir;
  std::vector<std::uint8_t> garbage(300);
  std::mt19937 rng(7);
  for (auto& b : garbage) b = static_cast<std::uint8_t>(rng());
  for (const char* name : {"g.hdr", "g.exr", "g.png", "g.jpg"}) {
    CAPTURE(name);
    write_all(dir / name, garbage);
    const auto r = weft::image::load_float_image(dir / name);
    CHECK(kind_of(r) == ErrorKind::Parse);
    CHECK(message_has(r, name));
  }
  CHECK(kind_of(weft::image::load_png(dir / "g.png")) == ErrorKind::Parse);
  CHECK(kind_of(weft::image::load_hdr(dir / "g.hdr")) == ErrorKind::Parse);
  CHECK(kind_of(weft::image::load_exr(dir / "g.exr")) == ErrorKind::Parse);
  // An empty file too.
  write_all(dir / "empty.exr", {});
  CHECK(kind_of(weft::image::load_exr(dir / "empty.exr")) == ErrorKind::Parse);
  // A real file of another format is not a Radiance, EXR or PNG file.
  REQUIRE(weft::image::save_png(dir / "real.png", pattern8(4, 4, 3)));
  REQUIRE(weft::image::save_exr(dir / "real.exr", pattern(4, 4, 3)));
  CHECK(kind_of(weft::image::load_hdr(dir / "real.png")) == ErrorKind::Parse);
  CHECK(kind_of(weft::image::load_exr(dir / "real.png")) == ErrorKind::Parse);
  CHECK(kind_of(weft::image::load_png(dir / "real.exr")) == ErrorKind::Parse);
  // A truncated EXR: header intact, pixel data cut.
  auto exr = read_all(dir / "real.exr");
  exr.resize(exr.size() - 20);
  write_all(dir / "cut.exr", exr);
  CHECK(kind_of(weft::image::load_exr(dir / "cut.exr")) == ErrorKind::Parse);
}

TEST_CASE("an unwritable path is an Io error naming the path, leaving no file behind") {
  TempDir dir;
  const Image img = pattern(4, 4, 3);
  const Image8 img8 = pattern8(4, 4, 3);
  const fs::path nowhere = "/nonexistent_dir/x.png";
  const auto r = weft::image::save_png(nowhere, img8);
  CHECK(kind_of(r) == ErrorKind::Io);
  CHECK(message_has(r, nowhere.string()));
  CHECK(kind_of(weft::image::save_hdr("/nonexistent_dir/x.hdr", img)) == ErrorKind::Io);
  CHECK(kind_of(weft::image::save_exr("/nonexistent_dir/x.exr", img)) == ErrorKind::Io);
  CHECK(kind_of(weft::image::save_image(dir / "no" / "such" / "dir.exr", img)) == ErrorKind::Io);
  // Writing onto a folder fails and leaves the folder and no .tmp.
  fs::create_directory(dir / "folder.png");
  const auto onto_dir = weft::image::save_png(dir / "folder.png", img8);
  CHECK(kind_of(onto_dir) == ErrorKind::Io);
  CHECK(message_has(onto_dir, "folder.png"));
  CHECK(fs::is_directory(dir / "folder.png"));
  CHECK(dir.tmp_files() == 0);
}

TEST_CASE("saving a bad image is InvalidArgument and keeps an existing file intact") {
  TempDir dir;
  const fs::path p = dir / "keep.png";
  REQUIRE(weft::image::save_png(p, pattern8(3, 3, 3)));
  const auto before = read_all(p);
  const Image8 wrong_count{3, 3, 3, std::vector<std::uint8_t>(26)};
  CHECK(kind_of(weft::image::save_png(p, wrong_count)) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::save_png(p, Image8{0, 3, 3, {}})) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::save_png(p, Image8{1, 1, 5, std::vector<std::uint8_t>(5)})) ==
        ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::save_image(p, Image{2, 2, 3, {}})) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::save_exr(dir / "x.exr", Image{1, 1, 0, {}})) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::save_hdr(dir / "x.hdr", Image{2, 1, 1, {1.0f}})) == ErrorKind::InvalidArgument);
  CHECK(read_all(p) == before);
  CHECK(!fs::exists(dir / "x.exr"));
  CHECK(!fs::exists(dir / "x.hdr"));
  // Saving again over an existing file replaces it.
  REQUIRE(weft::image::save_png(p, pattern8(2, 2, 1)));
  CHECK(weft::image::load_png(p)->width == 2);
  CHECK(dir.tmp_files() == 0);
}

// ---- metrics ---------------------------------------------------------------------------------

TEST_CASE("metrics refuse mismatched sizes, naming both") {
  const Image a = Image::filled(4, 4, 3), b = Image::filled(5, 4, 3), c = Image::filled(4, 4, 1);
  for (const auto& r : {weft::image::rmse(a, b), weft::image::psnr(a, b), weft::image::ssim(a, b),
                        weft::image::max_abs_diff(a, b)}) {
    CHECK(kind_of(r) == ErrorKind::InvalidArgument);
    CHECK(message_has(r, "4x4x3"));
    CHECK(message_has(r, "5x4x3"));
  }
  const auto channels = weft::image::rmse(a, c);
  CHECK(kind_of(channels) == ErrorKind::InvalidArgument);
  CHECK(message_has(channels, "4x4x1"));
  CHECK(kind_of(weft::image::ssim(Image{}, Image{})) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::rmse(Image{2, 2, 1, {1.0f}}, Image{2, 2, 1, {1.0f}})) == ErrorKind::InvalidArgument);
}

TEST_CASE("metrics refuse NaN and infinity, naming the pixel") {
  Image a = pattern(5, 5, 3), b = a;
  b.at(3, 2, 1) = std::numeric_limits<float>::quiet_NaN();
  for (const auto& r : {weft::image::rmse(a, b), weft::image::psnr(a, b), weft::image::ssim(a, b),
                        weft::image::max_abs_diff(a, b)}) {
    CHECK(kind_of(r) == ErrorKind::InvalidArgument);
    CHECK(message_has(r, "(3, 2)"));
    CHECK(message_has(r, "image b"));
  }
  a.at(0, 4, 0) = -std::numeric_limits<float>::infinity();
  const auto r = weft::image::rmse(a, a);
  CHECK(kind_of(r) == ErrorKind::InvalidArgument);
  CHECK(message_has(r, "(0, 4)"));
  // Bad parameters.
  CHECK(kind_of(weft::image::psnr(a, a, 0.0)) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::ssim(b, b, -1.0)) == ErrorKind::InvalidArgument);
  CHECK(kind_of(weft::image::ssim(b, b, std::numeric_limits<double>::quiet_NaN())) == ErrorKind::InvalidArgument);
}

TEST_CASE("RMSE and max |a-b| of a constant offset c are c") {
  const Image a = pattern(13, 7, 3);
  for (const float c : {0.001f, 0.1f, 0.5f, 3.0f}) {
    CAPTURE(c);
    Image b = a;
    for (std::size_t i = 0; i < b.pixels.size(); ++i) b.pixels[i] = a.pixels[i] + (i % 2 ? c : -c);
    CHECK(*weft::image::rmse(a, b) == doctest::Approx(c).epsilon(1e-4));
    CHECK(*weft::image::max_abs_diff(a, b) == doctest::Approx(c).epsilon(1e-4));
  }
  CHECK(*weft::image::rmse(a, a) == 0.0);
  CHECK(*weft::image::max_abs_diff(a, a) == 0.0);
  // One sample off by d among n samples: RMSE is d / sqrt(n), max is d.
  Image b = a;
  b.at(4, 3, 2) += 2.0f;
  CHECK(*weft::image::rmse(a, b) == doctest::Approx(2.0 / std::sqrt(13.0 * 7 * 3)).epsilon(1e-5));
  CHECK(*weft::image::max_abs_diff(a, b) == doctest::Approx(2.0).epsilon(1e-6));
}

TEST_CASE("PSNR: identical is +inf, an offset of 0.1 with peak 1 is 20 dB") {
  const Image a = Image::filled(8, 8, 3, 0.25f), b = Image::filled(8, 8, 3, 0.35f);
  const auto same = weft::image::psnr(a, a);
  REQUIRE(same);
  CHECK(std::isinf(*same));
  CHECK(*same > 0);
  CHECK(*weft::image::psnr(a, b) == doctest::Approx(20.0).epsilon(1e-5));
  // Peak 10 adds 20 dB; RMSE 0.01 is 40 dB.
  CHECK(*weft::image::psnr(a, b, 10.0) == doctest::Approx(40.0).epsilon(1e-5));
  const Image c = Image::filled(8, 8, 3, 0.26f);
  CHECK(*weft::image::psnr(a, c) == doctest::Approx(40.0).epsilon(1e-4));
}

TEST_CASE("SSIM: identical is 1, symmetric, and falls as noise grows") {
  const Image a = pattern(32, 24, 3);
  CHECK(*weft::image::ssim(a, a) == doctest::Approx(1.0).epsilon(1e-12));
  const Image n1 = add_noise(a, 0.01, 1), n2 = add_noise(a, 0.05, 2), n3 = add_noise(a, 0.2, 3);
  const double s1 = *weft::image::ssim(a, n1), s2 = *weft::image::ssim(a, n2), s3 = *weft::image::ssim(a, n3);
  CHECK(s1 < 1.0);
  CHECK(s1 > s2);
  CHECK(s2 > s3);
  CHECK(s3 > -1.0);
  CHECK(*weft::image::ssim(n2, a) == s2);  // exactly symmetric
  CHECK(*weft::image::ssim(n3, n1) == *weft::image::ssim(n1, n3));
}

TEST_CASE("SSIM agrees with a brute-force per-window reference") {
  // Sizes around the window: larger, exactly 11, and shrunk windows (odd and even).
  const std::uint32_t sizes[][2] = {{29, 17}, {11, 11}, {12, 30}, {5, 3}, {8, 20}, {2, 2}};
  unsigned seed = 10;
  for (const auto& s : sizes) {
    CAPTURE(s[0]);
    CAPTURE(s[1]);
    const Image a = add_noise(pattern(s[0], s[1], 3), 0.05, seed++);
    const Image b = add_noise(a, 0.08, seed++);
    CHECK(*weft::image::ssim(a, b) == doctest::Approx(reference_ssim(a, b)).epsilon(1e-10));
    CHECK(*weft::image::ssim(a, b, 2.0) == doctest::Approx(reference_ssim(a, b, 2.0)).epsilon(1e-10));
  }
}

TEST_CASE("SSIM of an image and a constant-shifted copy is the luminance term") {
  // A constant image: no structure, so SSIM is exactly the luminance term.
  const Image flat = Image::filled(16, 16, 1, 0.5f), flat_up = Image::filled(16, 16, 1, 0.6f);
  CHECK(*weft::image::ssim(flat, flat_up) == doctest::Approx(luminance_term(0.5, 0.6f)).epsilon(1e-12));
  // With structure the contrast-structure term stays 1; window means wander a little
  // around 0.5, and the luminance term barely moves with them.
  Image a = pattern(40, 40, 1, 0.45f, 0.55f);
  Image b = a;
  for (float& v : b.pixels) v += 0.1f;
  const double expected = luminance_term(0.5, 0.6);
  CHECK(*weft::image::ssim(a, b) == doctest::Approx(expected).epsilon(2e-3));
  CHECK(*weft::image::ssim(a, b) < 1.0 - 0.5 * (1.0 - expected));
}

TEST_CASE("SSIM on images smaller than the window: the window shrinks to the image") {
  // 1x1: a one-pixel window, no variance, SSIM is the luminance term.
  const Image p{1, 1, 1, {0.5f}}, q{1, 1, 1, {0.6f}};
  CHECK(*weft::image::ssim(p, q) == doctest::Approx(luminance_term(0.5, 0.6f)).epsilon(1e-12));
  CHECK(*weft::image::ssim(p, p) == doctest::Approx(1.0).epsilon(1e-15));
  // 1 x 20 and 3 x 3 work and behave.
  const Image line = pattern(1, 20, 3), line_noisy = add_noise(line, 0.1, 5);
  const double s = *weft::image::ssim(line, line_noisy);
  CHECK(s < 1.0);
  CHECK(s > -1.0);
  CHECK(s == doctest::Approx(reference_ssim(line, line_noisy)).epsilon(1e-10));
  CHECK(*weft::image::ssim(pattern(3, 3, 4), pattern(3, 3, 4)) == doctest::Approx(1.0).epsilon(1e-12));
}

TEST_CASE("metrics stay finite and right at extremes: zeros, 1e30, FLT_MAX") {
  const Image zero = Image::filled(12, 12, 3, 0.0f), huge = Image::filled(12, 12, 3, 1e30f);
  CHECK(*weft::image::rmse(zero, zero) == 0.0);
  CHECK(*weft::image::ssim(zero, zero) == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(std::isinf(*weft::image::psnr(zero, zero)));
  CHECK(*weft::image::rmse(zero, huge) == doctest::Approx(1e30).epsilon(1e-6));
  CHECK(*weft::image::psnr(zero, huge) == doctest::Approx(-600.0).epsilon(1e-6));
  CHECK(*weft::image::ssim(huge, huge) == doctest::Approx(1.0).epsilon(1e-12));
  const double far = *weft::image::ssim(zero, huge);
  CHECK(std::isfinite(far));
  CHECK(far >= 0.0);
  CHECK(far < 1e-50);  // C1 / (1e60 + C1)
  // FLT_MAX against -FLT_MAX: the difference overflows float but not the metrics.
  const Image top = Image::filled(4, 4, 1, FLT_MAX), bottom = Image::filled(4, 4, 1, -FLT_MAX);
  CHECK(*weft::image::rmse(top, bottom) == doctest::Approx(2.0 * FLT_MAX).epsilon(1e-6));
  CHECK(*weft::image::max_abs_diff(top, bottom) == doctest::Approx(2.0 * FLT_MAX).epsilon(1e-6));
  CHECK(std::isfinite(*weft::image::psnr(top, bottom)));
  const double opposite = *weft::image::ssim(top, bottom);
  CHECK(std::isfinite(opposite));
  CHECK(opposite == doctest::Approx(-1.0).epsilon(1e-9));  // (2 mu_a mu_b) / (mu_a^2 + mu_b^2)
  // Structure a few float steps tall riding on a mean of 1e30: E[x^2] - E[x]^2 taken
  // naively would lose it (double keeps 16 digits, the structure sits at digit 8).
  const float step = std::nextafter(1e30f, 2e30f) - 1e30f;
  Image big = Image::filled(24, 24, 1), big_other = Image::filled(24, 24, 1);
  std::mt19937 rng(9);
  for (std::size_t i = 0; i < big.pixels.size(); ++i) {
    big.pixels[i] = 1e30f + step * static_cast<float>(rng() % 8);
    big_other.pixels[i] = 1e30f + step * static_cast<float>(rng() % 8);
  }
  const double L = 1e23;
  const double s = *weft::image::ssim(big, big_other, L);
  CHECK(s == doctest::Approx(reference_ssim(big, big_other, L)).epsilon(1e-6));
  CHECK(std::abs(s) < 0.5);  // independent noise: little structure in common
  CHECK(*weft::image::ssim(big, big, L) == doctest::Approx(1.0).epsilon(1e-12));
}

TEST_CASE("every truncation of a PNG, EXR and HDR file fails cleanly") {
  // Under the sanitizers this also proves the decoders stay inside the buffer.
  TempDir dir;
  REQUIRE(weft::image::save_png(dir / "a.png", pattern8(9, 7, 4)));
  REQUIRE(weft::image::save_exr(dir / "a.exr", pattern(9, 7, 3)));
  REQUIRE(weft::image::save_exr(dir / "h.exr", pattern(9, 7, 2), weft::image::ExrPixelType::Half));
  REQUIRE(weft::image::save_hdr(dir / "a.hdr", pattern(9, 7, 3)));
  for (const std::string name : {"a.png", "a.exr", "h.exr", "a.hdr"}) {
    const auto full = read_all(dir / name);
    const auto original = weft::image::load_float_image(dir / name);
    REQUIRE(original);
    int refused = 0, decoded = 0;
    // Every cut in the header and at the end, every 5th byte in between.
    for (std::size_t n = 1; n < full.size(); n += (n < 128 || n + 16 >= full.size()) ? 1 : 5) {
      write_all(dir / ("cut-" + name), {full.begin(), full.begin() + static_cast<std::ptrdiff_t>(n)});
      const auto r = weft::image::load_float_image(dir / ("cut-" + name));
      if (r) {
        // Only a file cut after its pixel data (e.g. a PNG without IEND) may still decode.
        ++decoded;
        CHECK(r->pixels == original->pixels);
      } else {
        ++refused;
        CHECK(r.error().kind == ErrorKind::Parse);
      }
    }
    CHECK(refused > decoded);
    MESSAGE(name << ": " << full.size() << " bytes, " << refused << " prefixes refused, " << decoded << " decoded");
  }
}

TEST_CASE("randomly corrupted PNG, HDR and EXR files decode or fail with Parse/Unsupported") {
  // Three random bytes overwritten per try; under the sanitizers this is a small fuzz run.
  TempDir dir;
  REQUIRE(weft::image::save_png(dir / "a.png", pattern8(9, 7, 3)));
  REQUIRE(weft::image::save_hdr(dir / "a.hdr", pattern(9, 7, 3)));
  REQUIRE(weft::image::save_exr(dir / "a.exr", pattern(9, 7, 3)));
  std::mt19937 rng(1);
  for (const std::string name : {"a.png", "a.hdr", "a.exr"}) {
    const auto full = read_all(dir / name);
    int failed = 0;
    for (int t = 0; t < 150; ++t) {
      auto bytes = full;
      for (int k = 0; k < 3; ++k) bytes[rng() % bytes.size()] = static_cast<std::uint8_t>(rng());
      write_all(dir / ("bad-" + name), bytes);
      const auto r = weft::image::load_float_image(dir / ("bad-" + name));
      if (r) {
        CAPTURE(name);
        CHECK(weft::image::validate(*r));  // whatever decodes is a well-formed image
      } else {
        ++failed;
        const bool expected_kind = r.error().kind == ErrorKind::Parse || r.error().kind == ErrorKind::Unsupported;
        CHECK(expected_kind);
      }
    }
    CHECK(failed > 0);
  }
}

// ---- what fuzzing found in the codecs weft builds on (issue 21) ------------------------------

namespace {
std::size_t find_bytes(const std::vector<std::uint8_t>& haystack, std::string_view needle) {
  const auto it = std::search(haystack.begin(), haystack.end(), needle.begin(), needle.end(),
                              [](std::uint8_t a, char b) { return a == static_cast<std::uint8_t>(b); });
  return it == haystack.end() ? std::string::npos : static_cast<std::size_t>(it - haystack.begin());
}
}  // namespace

TEST_CASE("a JPEG Huffman table with more than 256 codes is refused before stb_image writes past its table") {
  TempDir dir;
  const fs::path p = dir / "ok.jpg";
  REQUIRE(weft::image::save_jpeg(p, pattern8(16, 16, 3)));
  auto bytes = read_all(p);
  REQUIRE(weft::image::decode_ldr(bytes, "ok.jpg"));
  const std::size_t dht = find_bytes(bytes, std::string_view("\xFF\xC4", 2));
  REQUIRE(dht != std::string::npos);
  // The first table's 16 counts follow the marker, the length and the class/id byte; making
  // the last count 255 takes the table past 256 codes.
  bytes[dht + 5 + 15] = 255;
  const auto refused = weft::image::decode_ldr(bytes, "bad.jpg");
  REQUIRE_FALSE(refused);
  CHECK_MESSAGE(refused.error().message.find("Huffman table") != std::string::npos, refused.error().message);
  CHECK_MESSAGE(refused.error().message.find("at most 256") != std::string::npos, refused.error().message);
  // stb skips 0xFF fill bytes before SOI as before any marker; so must the check.
  bytes.insert(bytes.begin(), {0xFF, 0xFF});
  const auto filled = weft::image::decode_ldr(bytes, "filled.jpg");
  REQUIRE_FALSE(filled);
  CHECK_MESSAGE(filled.error().message.find("Huffman table") != std::string::npos, filled.error().message);
}

TEST_CASE("a PNG with a zero-length IDAT chunk decodes to the same pixels as without it") {
  TempDir dir;
  const fs::path p = dir / "ok.png";
  const Image8 img = pattern8(5, 4, 4);
  REQUIRE(weft::image::save_png(p, img));
  auto bytes = read_all(p);
  const std::size_t idat = find_bytes(bytes, "IDAT");
  REQUIRE(idat != std::string::npos);
  // length 0, "IDAT", CRC-32 of "IDAT" (0x35AF061E), inserted before the real IDAT chunk.
  const std::vector<std::uint8_t> empty_idat = {0, 0, 0, 0, 'I', 'D', 'A', 'T', 0x35, 0xAF, 0x06, 0x1E};
  bytes.insert(bytes.begin() + static_cast<std::ptrdiff_t>(idat - 4), empty_idat.begin(), empty_idat.end());
  const auto decoded = weft::image::decode_ldr(bytes, "empty_idat.png");
  REQUIRE(decoded);
  CHECK(decoded->pixels == img.pixels);
}

TEST_CASE("a Radiance file whose header ends in a NUL line and whose RLE stops short fails instead of hanging") {
  TempDir dir;
  const std::string header = std::string("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n") + '\0' + "\n-Y 1 +X 8\n";
  SUBCASE("scanline header, then nothing") {
    std::vector<std::uint8_t> bytes(header.begin(), header.end());
    for (std::uint8_t b : {2, 2, 0, 8}) bytes.push_back(b);
    write_all(dir / "cut.hdr", bytes);
    const auto r = weft::image::load_hdr(dir / "cut.hdr");
    REQUIRE_FALSE(r);
    CHECK_MESSAGE(r.error().message.find("truncated") != std::string::npos, r.error().message);
  }
  SUBCASE("a run of length zero") {
    std::vector<std::uint8_t> bytes(header.begin(), header.end());
    for (std::uint8_t b : {2, 2, 0, 8, 0, 0, 0}) bytes.push_back(b);
    write_all(dir / "zero.hdr", bytes);
    const auto r = weft::image::load_hdr(dir / "zero.hdr");
    REQUIRE_FALSE(r);
    CHECK_MESSAGE(r.error().message.find("zero-length run") != std::string::npos, r.error().message);
  }
}

namespace {
// A valid EXR of `image` whose data window has one field (0 min_x, 1 min_y, 2 max_x, 3 max_y)
// set to `value`; returns its bytes.
std::vector<std::uint8_t> exr_with_window_field(const TempDir& dir, const Image& image, int field, std::int32_t value) {
  const fs::path p = dir / "ok.exr";
  REQUIRE(weft::image::save_exr(p, image));
  auto bytes = read_all(p);
  // The attribute: "dataWindow\0box2i\0", its size (16), then min_x, min_y, max_x, max_y.
  const std::size_t at = find_bytes(bytes, std::string_view("dataWindow\0box2i\0", 17));
  REQUIRE(at != std::string::npos);
  std::memcpy(bytes.data() + at + 17 + 4 + 4 * field, &value, 4);
  write_all(dir / "bad.exr", bytes);
  return bytes;
}
}  // namespace

TEST_CASE("an EXR data window near INT_MIN is refused before tinyexr overflows computing its width") {
  TempDir dir;
  exr_with_window_field(dir, pattern(4, 3, 3), 0, std::numeric_limits<std::int32_t>::min());
  const auto r = weft::image::load_exr(dir / "bad.exr");
  REQUIRE_FALSE(r);
  CHECK_MESSAGE(r.error().message.find("data window") != std::string::npos, r.error().message);
}

TEST_CASE("an EXR attribute whose size does not match its type is refused before tinyexr reads past it") {
  TempDir dir;
  const fs::path p = dir / "ok.exr";
  REQUIRE(weft::image::save_exr(p, pattern(4, 3, 3)));
  auto bytes = read_all(p);
  REQUIRE(weft::image::load_exr(p));
  const std::size_t at = find_bytes(bytes, std::string_view("compression\0compression\0", 24));
  REQUIRE(at != std::string::npos);
  const std::int32_t two = 2;  // a compression attribute is one byte
  std::memcpy(bytes.data() + at + 24, &two, 4);
  write_all(dir / "bad.exr", bytes);
  const auto r = weft::image::load_exr(dir / "bad.exr");
  REQUIRE_FALSE(r);
  CHECK_MESSAGE(r.error().message.find("attribute 'compression' of type compression has 2 bytes") != std::string::npos,
                r.error().message);
}

TEST_CASE("bytes without a PNG, JPEG or BMP signature are not handed to stb_image's header-less TGA reader") {
  // A TGA header (no signature): type 2, 16 x 16, 24 bits, then no pixels. stb would take it.
  std::vector<std::uint8_t> tga = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 16, 0, 16, 0, 24, 0};
  const auto r = weft::image::decode_ldr(tga, "fake.png");
  REQUIRE_FALSE(r);
  CHECK(r.error().kind == ErrorKind::Parse);
  CHECK_MESSAGE(r.error().message.find("not a PNG, JPEG or BMP file") != std::string::npos, r.error().message);
}

TEST_CASE("an EXR data window far larger than its file can hold is refused; a constant image zlib packs 1000:1 loads") {
  TempDir dir;
  SUBCASE("a 404-byte file claiming 2,424,840 x 6 pixels (fuzz_exr: minutes of decoding)") {
    const auto bytes = exr_with_window_field(dir, pattern(8, 6, 4), 2, 2424839);
    const auto r = weft::image::load_exr(dir / "bad.exr");
    REQUIRE_FALSE(r);
    CHECK_MESSAGE(r.error().message.find("data window of 14549040 pixels") != std::string::npos, r.error().message);
    CHECK_MESSAGE(r.error().message.find("more than a " + std::to_string(bytes.size()) + "-byte file can hold") !=
                      std::string::npos,
                  r.error().message);
  }
  SUBCASE("the bound leaves room for the best real compression") {
    // 1024 x 1024 RGB of one value: 12 MiB of floats that weft's ZIP writer packs near zlib's limit.
    const fs::path p = dir / "flat.exr";
    REQUIRE(weft::image::save_exr(p, weft::image::Image::filled(1024, 1024, 3, 0.25f)));
    const auto size = fs::file_size(p);
    CHECK(1024.0 * 1024 * 3 * 4 / double(size) > 200.0);  // it is a file the bound is for
    const auto r = weft::image::load_exr(p);
    REQUIRE_MESSAGE(r, r.error().message);
    CHECK(r->width == 1024);
    CHECK(r->pixels[12345] == 0.25f);
  }
}

TEST_CASE("a JPEG or BMP header declaring more pixels than its bytes can code is refused before it is decoded") {
  SUBCASE("JPEG: 16 x 16 made 2567 x 1029 in its frame header (fuzz_jpg: 0.8 s per 626-byte input)") {
    TempDir dir;
    const fs::path p = dir / "ok.jpg";
    REQUIRE(weft::image::save_jpeg(p, pattern8(16, 16, 3)));
    auto bytes = read_all(p);
    const std::size_t sof = find_bytes(bytes, std::string_view("\xFF\xC0", 2));
    REQUIRE(sof != std::string::npos);
    // FFC0, length (2), precision (1), height (2), width (2): big-endian.
    bytes[sof + 5] = 1029 >> 8, bytes[sof + 6] = 1029 & 255, bytes[sof + 7] = 2567 >> 8, bytes[sof + 8] = 2567 & 255;
    const auto r = weft::image::decode_ldr(bytes, "big.jpg");
    REQUIRE_FALSE(r);
    CHECK_MESSAGE(r.error().message.find("JPEG header declares 2567 x 1029 pixels, more than its " +
                                         std::to_string(bytes.size()) + " bytes can code") != std::string::npos,
                  r.error().message);
  }
  SUBCASE("JPEG: a flat 1024 x 1024 image, the bound's real neighbour, still loads") {
    TempDir dir;
    const fs::path p = dir / "flat.jpg";
    weft::image::Image8 flat = weft::image::Image8::filled(1024, 1024, 3, 77);
    REQUIRE(weft::image::save_jpeg(p, flat));
    const auto r = weft::image::load_ldr(p);
    REQUIRE_MESSAGE(r, r.error().message);
    CHECK(r->width == 1024);
    CHECK(std::abs(int(r->pixels[5000]) - 77) <= 2);
  }
  SUBCASE("BMP: 2 x 2 at 24 bits decodes; the same header made 4096 x 4096 is refused") {
    // BITMAPFILEHEADER (14 bytes) + BITMAPINFOHEADER (40), then 2 rows of 2 BGR pixels padded to 8 bytes.
    auto le = [](std::vector<std::uint8_t>& v, std::uint32_t x, int n) {
      for (int i = 0; i < n; ++i) v.push_back(std::uint8_t(x >> (8 * i)));
    };
    auto bmp = [&](std::uint32_t w, std::uint32_t h) {
      std::vector<std::uint8_t> v = {'B', 'M'};
      le(v, 54 + 16, 4), le(v, 0, 4), le(v, 54, 4);
      le(v, 40, 4), le(v, w, 4), le(v, h, 4), le(v, 1, 2), le(v, 24, 2), le(v, 0, 4), le(v, 16, 4);
      le(v, 2835, 4), le(v, 2835, 4), le(v, 0, 4), le(v, 0, 4);
      for (int row = 0; row < 2; ++row) v.insert(v.end(), {10, 20, 30, 40, 50, 60, 0, 0});
      return v;
    };
    const auto small = weft::image::decode_ldr(bmp(2, 2), "small.bmp");
    REQUIRE_MESSAGE(small, small.error().message);
    CHECK(small->width == 2);
    CHECK(small->pixels[0] == 30);  // BGR stored, RGB decoded
    const auto big = weft::image::decode_ldr(bmp(4096, 4096), "big.bmp");
    REQUIRE_FALSE(big);
    CHECK_MESSAGE(big.error().message.find("BMP header declares 4096 x 4096 pixels, more than its 70 bytes") !=
                      std::string::npos,
                  big.error().message);
  }
}

namespace {
// A w x h JPEG of one colour, written with libjpeg itself (weft.image writes only YCbCr).
std::vector<std::uint8_t> libjpeg_flat(int w, int h, J_COLOR_SPACE space, std::vector<std::uint8_t> colour) {
  const int n = int(colour.size());
  std::vector<std::uint8_t> row(std::size_t(w * n));
  for (int x = 0; x < w; ++x) std::copy(colour.begin(), colour.end(), row.begin() + x * n);
  jpeg_compress_struct c{};
  jpeg_error_mgr err{};
  c.err = jpeg_std_error(&err);
  jpeg_create_compress(&c);
  unsigned char* out = nullptr;
  unsigned long out_size = 0;
  jpeg_mem_dest(&c, &out, &out_size);
  c.image_width = JDIMENSION(w);
  c.image_height = JDIMENSION(h);
  c.input_components = n;
  c.in_color_space = space;
  jpeg_set_defaults(&c);
  jpeg_set_quality(&c, 100, TRUE);
  jpeg_start_compress(&c, TRUE);
  for (int y = 0; y < h; ++y) {
    JSAMPROW r = row.data();
    jpeg_write_scanlines(&c, &r, 1);
  }
  jpeg_finish_compress(&c);
  std::vector<std::uint8_t> bytes(out, out + out_size);
  jpeg_destroy_compress(&c);
  std::free(out);
  return bytes;
}
}  // namespace

TEST_CASE("JPEG decoding (libjpeg-turbo): a truncated stream is an error, CMYK becomes RGB, grey stays one channel") {
  TempDir dir;
  SUBCASE("cut in the middle of its entropy-coded data") {
    const fs::path p = dir / "ok.jpg";
    REQUIRE(weft::image::save_jpeg(p, pattern8(64, 64, 3)));
    auto bytes = read_all(p);
    REQUIRE(weft::image::decode_ldr(bytes, "ok.jpg"));
    const std::size_t sos = find_bytes(bytes, std::string_view("\xFF\xDA", 2));
    REQUIRE(sos != std::string::npos);
    bytes.resize(sos + (bytes.size() - sos) / 2);
    const auto r = weft::image::decode_ldr(bytes, "cut.jpg");
    REQUIRE_FALSE(r);  // stb_image filled the rest and succeeded
    CHECK_MESSAGE(r.error().message.find("Premature end of JPEG file") != std::string::npos, r.error().message);
    CHECK_MESSAGE(r.error().message.find("cut.jpg") != std::string::npos, r.error().message);
  }
  SUBCASE("an Adobe CMYK file (stored inverted): RGB = C * K / 255") {
    const std::vector<std::uint8_t> cmyk = {200, 100, 50, 128};
    const auto img = weft::image::decode_ldr(libjpeg_flat(16, 8, JCS_CMYK, cmyk), "cmyk.jpg");
    REQUIRE_MESSAGE(img, img.error().message);
    CHECK(img->channels == 3);
    for (int ch = 0; ch < 3; ++ch)
      CHECK_MESSAGE(std::abs(int(img->pixels[std::size_t(5 * 3 + ch)]) - cmyk[std::size_t(ch)] * cmyk[3] / 255) <= 2, ch);
  }
  SUBCASE("grey") {
    const auto img = weft::image::decode_ldr(libjpeg_flat(8, 8, JCS_GRAYSCALE, {90}), "grey.jpg");
    REQUIRE_MESSAGE(img, img.error().message);
    CHECK(img->channels == 1);
    CHECK(std::abs(int(img->pixels[10]) - 90) <= 1);
  }
}

// ---- mip chains ----------------------------------------------------------------------------

TEST_CASE("mip chains: sizes to 1x1, sRGB averaged in linear light, data as stored, odd sides keep every texel") {
  using weft::image::MipContent;
  CHECK(weft::image::full_mip_count(1, 1) == 1);
  CHECK(weft::image::full_mip_count(4096, 1) == 13);
  CHECK(weft::image::full_mip_count(5, 3) == 3);
  // Black and white in a checkerboard: sRGB's average is linear 0.5 = code 188, not 128.
  const std::vector<std::uint8_t> checker = {0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0, 255};
  const auto srgb = weft::image::rgba8_mip_chain(checker, 2, 2, MipContent::Srgb);
  REQUIRE(srgb.size() == 2);
  CHECK(srgb[0] == checker);
  CHECK(int(srgb[1][0]) == int(std::lround(weft::image::linear_to_srgb(0.5f) * 255.0f)));
  CHECK(int(srgb[1][0]) == 188);
  CHECK(int(srgb[1][3]) == 255);  // alpha is linear: the mean of 255s
  const auto data = weft::image::rgba8_mip_chain(checker, 2, 2, MipContent::Linear);
  CHECK(int(data[1][0]) == 128);  // 127.5 rounds up
  // 5 x 1: the last level-1 texel averages three (texels 2, 3, 4), so none is dropped.
  std::vector<std::uint8_t> row;
  for (int v : {0, 30, 60, 90, 120})
    for (int c = 0; c < 4; ++c) row.push_back(std::uint8_t(c == 3 ? 255 : v));
  const auto odd = weft::image::rgba8_mip_chain(row, 5, 1, MipContent::Linear);
  REQUIRE(odd.size() == 3);
  REQUIRE(odd[1].size() == 2 * 4);
  CHECK(int(odd[1][0]) == 15);
  CHECK(int(odd[1][4]) == 90);
  REQUIRE(odd[2].size() == 4);
  CHECK(int(odd[2][0]) == 53);  // (15 + 90) / 2 = 52.5 from the unrounded level above
  // Bad input: nothing.
  CHECK(weft::image::rgba8_mip_chain(row, 4, 1, MipContent::Linear).empty());
  CHECK(weft::image::rgba8_mip_chain({}, 0, 0, MipContent::Linear).empty());
}

TEST_CASE("mip chains of normal maps are renormalised: opposite tilts average to straight up") {
  using weft::image::MipContent;
  auto encode = [](float x, float y, float z) {
    const float l = std::sqrt(x * x + y * y + z * z);
    return std::array<std::uint8_t, 4>{std::uint8_t(std::lround((x / l * 0.5f + 0.5f) * 255.0f)),
                                       std::uint8_t(std::lround((y / l * 0.5f + 0.5f) * 255.0f)),
                                       std::uint8_t(std::lround((z / l * 0.5f + 0.5f) * 255.0f)), 255};
  };
  std::vector<std::uint8_t> tilted;
  for (auto t : {encode(0.6f, 0, 0.8f), encode(-0.6f, 0, 0.8f)}) tilted.insert(tilted.end(), t.begin(), t.end());
  const auto plain = weft::image::rgba8_mip_chain(tilted, 2, 1, MipContent::Linear);
  const auto normal = weft::image::rgba8_mip_chain(tilted, 2, 1, MipContent::NormalMap);
  // Averaged as data the normal shrinks to length 0.8 (z code 229); renormalised it is (0, 0, 1).
  CHECK(std::abs(int(plain[1][2]) - 230) <= 1);
  CHECK(std::abs(int(normal[1][0]) - 128) <= 1);
  CHECK(int(normal[1][2]) == 255);
  // Every level's normal is unit length within 8-bit rounding.
  std::vector<std::uint8_t> noise;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 64 * 32; ++i) {
    auto t = encode(u(rng), u(rng), 0.3f + std::abs(u(rng)));
    noise.insert(noise.end(), t.begin(), t.end());
  }
  const auto chain = weft::image::rgba8_mip_chain(noise, 64, 32, MipContent::NormalMap);
  REQUIRE(chain.size() == 7);
  for (std::size_t m = 1; m < chain.size(); ++m)
    for (std::size_t t = 0; t < chain[m].size() / 4; ++t) {
      float len2 = 0;
      for (int c = 0; c < 3; ++c) {
        const float v = chain[m][t * 4 + c] / 255.0f * 2.0f - 1.0f;
        len2 += v * v;
      }
      CHECK(std::sqrt(len2) == doctest::Approx(1.0f).epsilon(0.02));
    }
}
