// JPEG decoding with libjpeg-turbo (internal to weft.image; see codecs.h). Not stb_image:
// Debian 12's copy has known JPEG bugs (fuzz_jpg found a Huffman table overflow and a
// negative bit count feeding an oversized shift, both fixed upstream after 2022), while
// libjpeg-turbo is the reference decoder, fuzzed continuously upstream.
//
// libjpeg reports errors through a callback that must not return: it longjmps back here.
// Everything with a destructor is constructed before setjmp, so the jump skips none.
#include "codecs.h"

#include <csetjmp>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <jerror.h>
#include <jpeglib.h>

namespace weft::image::codec {

namespace {

struct ErrorManager {
  jpeg_error_mgr base;  // first: libjpeg's callbacks get a pointer to it
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX] = {};
};

// A truncated or corrupt stream is an error here, not a warning: libjpeg would fill the rest
// with grey and succeed. Other warnings (extraneous bytes before a marker, common in camera
// files) are harmless and ignored.
bool warning_is_error(int code) {
  return code == JWRN_JPEG_EOF || code == JWRN_HIT_MARKER || code == JWRN_HUFF_BAD_CODE ||
         code == JWRN_MUST_RESYNC || code == JWRN_NOT_SEQUENTIAL || code == JWRN_BOGUS_PROGRESSION;
}

[[noreturn]] void on_error(j_common_ptr cinfo) {
  auto* err = reinterpret_cast<ErrorManager*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, err->message);
  std::longjmp(err->jump, 1);
}

void on_message(j_common_ptr cinfo, int level) {
  if (level >= 0 || !warning_is_error(cinfo->err->msg_code)) return;  // traces, harmless warnings
  on_error(cinfo);
}

}  // namespace

Decoded<std::uint8_t> decode_jpeg(const std::uint8_t* data, std::size_t size, std::uint64_t most_pixels_per_byte,
                                  std::uint64_t pixel_slack) {
  Decoded<std::uint8_t> out;
  jpeg_decompress_struct cinfo{};
  ErrorManager err;
  std::vector<std::uint8_t> cmyk;  // 4-component files decode through this row
  cinfo.err = jpeg_std_error(&err.base);
  err.base.error_exit = on_error;
  err.base.emit_message = on_message;
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&cinfo);
    out.pixels.clear();
    out.error = std::string("JPEG: ") + err.message;
    return out;
  }
  jpeg_create_decompress(&cinfo);
  jpeg_mem_src(&cinfo, data, static_cast<unsigned long>(size));
  jpeg_read_header(&cinfo, TRUE);
  // A header declaring far more pixels than the file's bytes can code: the decoder would
  // allocate and fill the whole image from nothing (fuzz_jpg: 2567 x 1029 from 626 bytes).
  const std::uint64_t pixels = std::uint64_t(cinfo.image_width) * cinfo.image_height;
  if (pixels > most_pixels_per_byte * size + pixel_slack) {
    out.error = "JPEG header declares " + std::to_string(cinfo.image_width) + " x " +
                std::to_string(cinfo.image_height) + " pixels, more than its " + std::to_string(size) +
                " bytes can code (a JPEG codes at most 512 pixels a byte)";
    jpeg_destroy_decompress(&cinfo);
    return out;
  }
  // Grey stays one channel; colour becomes RGB; CMYK / YCCK (Adobe, stored inverted) is
  // multiplied out to RGB below, as stb_image did.
  const bool four = cinfo.num_components == 4;
  cinfo.out_color_space = four ? JCS_CMYK : cinfo.num_components == 1 ? JCS_GRAYSCALE : JCS_RGB;
  jpeg_start_decompress(&cinfo);
  const int channels = four ? 3 : int(cinfo.output_components);
  const std::size_t w = cinfo.output_width, h = cinfo.output_height;
  out.pixels.resize(w * h * std::size_t(channels));
  if (four) cmyk.resize(w * 4);
  while (cinfo.output_scanline < cinfo.output_height) {
    std::uint8_t* row = out.pixels.data() + std::size_t(cinfo.output_scanline) * w * std::size_t(channels);
    JSAMPROW target = four ? cmyk.data() : row;
    jpeg_read_scanlines(&cinfo, &target, 1);
    if (four)
      for (std::size_t x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) row[x * 3 + c] = std::uint8_t((cmyk[x * 4 + c] * cmyk[x * 4 + 3] + 127) / 255);
  }
  jpeg_finish_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  out.width = int(w);
  out.height = int(h);
  out.channels = channels;
  return out;
}

}  // namespace weft::image::codec
