// weft.image — images on the CPU: load and save PNG/JPEG (8-bit), Radiance HDR and OpenEXR
// (float); convert between linear float and sRGB 8-bit; compare two images (RMSE, PSNR,
// SSIM, max difference) for tests, benchmarks and the speed/accuracy trade-off studies.
//
// Decisions a user may want to know:
// - Pixels are row-major, top row first, channels interleaved; 1..4 channels, where 2 means
//   gray+alpha and 4 means RGBA. Alpha is always linear: sRGB and exposure never touch it.
// - Every save writes `path + ".tmp"` and renames it over `path`, so a failed save leaves
//   no half-written file behind (an existing file at `path` stays as it was).
// - Radiance .hdr holds non-negative RGB only: NaN and negative values are written as 0,
//   gray is written as RGB and alpha is dropped; it reads back as 3 channels.
// - OpenEXR channels are written as Y / YA / RGB / RGBA (float32 by default, or half) with
//   ZIP compression. Reading takes RGB(A), Y(A) or any single channel, scanline or tiled
//   (first level); other layouts are ErrorKind::Unsupported.
// - Decoding never trusts the file: truncated or corrupt data is ErrorKind::Parse (the
//   Radiance stream is checked before stb_image sees it; stb would hang or zero-fill).
// - Metrics refuse NaN or infinite pixels (InvalidArgument naming the pixel) instead of
//   returning NaN. SSIM on an image smaller than its 11x11 window shrinks the window to
//   the image (per axis, same sigma), so a 1x1 image gives SSIM's luminance term.
module;
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>
#include <vector>
export module weft.image;
import weft.core;

export namespace weft::image {

// A float image: linear radiance, data or anything else; `pixels.size()` must equal
// width * height * channels (see validate()).
struct Image {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t channels = 0;
  std::vector<float> pixels;

  // An image of the given size with every sample set to `value`.
  [[nodiscard]] static Image filled(std::uint32_t w, std::uint32_t h, std::uint32_t c, float value = 0.0f) {
    return Image{w, h, c, std::vector<float>(std::size_t{w} * h * c, value)};
  }
  [[nodiscard]] std::size_t sample_count() const { return std::size_t{width} * height * channels; }
  [[nodiscard]] float& at(std::uint32_t x, std::uint32_t y, std::uint32_t c) {
    return pixels[(std::size_t{y} * width + x) * channels + c];
  }
  [[nodiscard]] const float& at(std::uint32_t x, std::uint32_t y, std::uint32_t c) const {
    return pixels[(std::size_t{y} * width + x) * channels + c];
  }
};

// An 8-bit image, as stored in PNG/JPEG: sRGB-encoded colour, linear alpha.
struct Image8 {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t channels = 0;
  std::vector<std::uint8_t> pixels;

  [[nodiscard]] static Image8 filled(std::uint32_t w, std::uint32_t h, std::uint32_t c, std::uint8_t value = 0) {
    return Image8{w, h, c, std::vector<std::uint8_t>(std::size_t{w} * h * c, value)};
  }
  [[nodiscard]] std::size_t sample_count() const { return std::size_t{width} * height * channels; }
  [[nodiscard]] std::uint8_t& at(std::uint32_t x, std::uint32_t y, std::uint32_t c) {
    return pixels[(std::size_t{y} * width + x) * channels + c];
  }
  [[nodiscard]] const std::uint8_t& at(std::uint32_t x, std::uint32_t y, std::uint32_t c) const {
    return pixels[(std::size_t{y} * width + x) * channels + c];
  }
};

// InvalidArgument when a size is zero, channels are not 1..4, or the pixel count does not
// match the size.
[[nodiscard]] Result<void> validate(const Image& image);
[[nodiscard]] Result<void> validate(const Image8& image);

// ---- files -----------------------------------------------------------------------------
// Errors: NotFound (no such file), Parse (corrupt or truncated; names the decoder's reason),
// Io (cannot read or write, e.g. the folder does not exist), InvalidArgument (bad image),
// Unsupported (a file kind or layout this module does not read). Each names the path.

// PNG, JPEG or BMP (stb_image; formats without a signature, such as TGA, are refused: any
// bytes can pass for one), keeping the file's channels.
// 16-bit PNGs are reduced to 8 bits.
[[nodiscard]] Result<Image8> load_ldr(const std::filesystem::path& path);
// Like load_ldr, from encoded bytes in memory (a glTF data URI or GLB buffer view); `label`
// names them in errors ("glTF 'a.glb' image 2").
[[nodiscard]] Result<Image8> decode_ldr(std::span<const std::uint8_t> bytes, std::string_view label);
// Like load_ldr, but the file must be a PNG.
[[nodiscard]] Result<Image8> load_png(const std::filesystem::path& path);
[[nodiscard]] Result<void> save_png(const std::filesystem::path& path, const Image8& image);
// Baseline JPEG at quality 90 (alpha dropped): for pictures, not data.
[[nodiscard]] Result<void> save_jpeg(const std::filesystem::path& path, const Image8& image);

// Radiance RGBE (.hdr): 3 channels of linear float.
[[nodiscard]] Result<Image> load_hdr(const std::filesystem::path& path);
[[nodiscard]] Result<void> save_hdr(const std::filesystem::path& path, const Image& image);

enum class ExrPixelType : std::uint8_t { Float32, Half };
[[nodiscard]] Result<Image> load_exr(const std::filesystem::path& path);
[[nodiscard]] Result<void> save_exr(const std::filesystem::path& path, const Image& image,
                                    ExrPixelType type = ExrPixelType::Float32);

// By extension (case-insensitive): .exr, .hdr, or .png/.jpg/.jpeg (decoded to linear with
// from_srgb8).
[[nodiscard]] Result<Image> load_float_image(const std::filesystem::path& path);
// By extension: .exr (float32), .hdr, or .png (encoded with to_srgb8(image, exposure);
// exposure applies only to .png).
[[nodiscard]] Result<void> save_image(const std::filesystem::path& path, const Image& image, float exposure = 1.0f);
// By extension: .png as is; .exr/.hdr after from_srgb8.
[[nodiscard]] Result<void> save_image(const std::filesystem::path& path, const Image8& image);

// ---- colour ----------------------------------------------------------------------------
// The exact sRGB transfer functions (IEC 61966-2-1), input clamped to [0, 1], NaN -> 0.
[[nodiscard]] float linear_to_srgb(float linear);
[[nodiscard]] float srgb_to_linear(float encoded);

// Linear float -> sRGB 8-bit: colour is multiplied by `exposure`, clamped, encoded and
// rounded; alpha is clamped and rounded. NaN becomes 0. An invalid image gives an empty one.
[[nodiscard]] Image8 to_srgb8(const Image& image, float exposure = 1.0f);
// sRGB 8-bit -> linear float (alpha c/255). Inverse of to_srgb8 for every code.
[[nodiscard]] Image from_srgb8(const Image8& image);
// One channel: Rec.709 luminance of RGB(A), the gray channel of Y(A). An invalid image
// gives an empty one.
[[nodiscard]] Image luminance(const Image& image);

// ---- mip chains ------------------------------------------------------------------------
// What the texels of an RGBA8 texture mean, for averaging them into smaller levels.
enum class MipContent : std::uint8_t {
  Srgb,       // sRGB-encoded colour (alpha linear): averaged in linear light, then encoded
  Linear,     // data (roughness, metalness, occlusion): averaged as stored
  NormalMap,  // tangent-space normals (rgb = n * 0.5 + 0.5): averaged, then renormalised
};
// The mip chain of a tightly packed RGBA8 image of width x height: level 0 (a copy of
// `rgba`) down to 1x1, each texel the average of the 2x2 texels above it (on an odd side the
// last row or column is averaged in with its neighbour, so no texel is dropped). Empty when
// the size is zero or `rgba` is not width * height * 4 bytes.
[[nodiscard]] std::vector<std::vector<std::uint8_t>> rgba8_mip_chain(std::span<const std::uint8_t> rgba,
                                                                      std::uint32_t width, std::uint32_t height,
                                                                      MipContent content);
// The same chain of a tightly packed RGBA float image (linear radiance: an environment map),
// averaged as stored. Empty when the size is zero or `rgba` is not width * height * 4 floats.
[[nodiscard]] std::vector<std::vector<float>> rgba32f_mip_chain(std::span<const float> rgba, std::uint32_t width,
                                                                std::uint32_t height);
// 1 + floor(log2(max(width, height))): the levels of a full chain.
[[nodiscard]] std::uint32_t full_mip_count(std::uint32_t width, std::uint32_t height);

// ---- metrics ---------------------------------------------------------------------------
// Both images must be valid, the same width, height and channels (else InvalidArgument
// naming both sizes) and finite. Sums run in double, so float extremes stay finite.

// Root mean square difference over all samples.
[[nodiscard]] Result<double> rmse(const Image& a, const Image& b);
// 10 log10(peak^2 / MSE) in dB; +infinity for identical images.
[[nodiscard]] Result<double> psnr(const Image& a, const Image& b, double peak = 1.0);
// Mean SSIM (Wang et al. 2004) of the luminance: 11x11 Gaussian window, sigma 1.5,
// K1 = 0.01, K2 = 0.03, no padding ("valid" windows only), no downsampling.
[[nodiscard]] Result<double> ssim(const Image& a, const Image& b, double dynamic_range = 1.0);
// Largest |a - b| over all samples.
[[nodiscard]] Result<double> max_abs_diff(const Image& a, const Image& b);

}  // namespace weft::image
