// The names every message uses for uses and pass kinds, and relative sizes.
module;
#include <algorithm>
#include <cstdint>
#include <string_view>
module weft.graph;
import weft.core;
import weft.gpu;

namespace weft {

std::string_view to_string(TextureUse use) {
  switch (use) {
    case TextureUse::Sampled: return "sampled";
    case TextureUse::StorageRead: return "storage-read";
    case TextureUse::StorageWrite: return "storage-write";
    case TextureUse::ColorAttachment: return "color-attachment";
    case TextureUse::DepthAttachment: return "depth-attachment";
    case TextureUse::DepthRead: return "depth-read";
    case TextureUse::CopySrc: return "copy-src";
    case TextureUse::CopyDst: return "copy-dst";
  }
  return "?";
}

std::string_view to_string(BufferUse use) {
  switch (use) {
    case BufferUse::Vertex: return "vertex";
    case BufferUse::Index: return "index";
    case BufferUse::Uniform: return "uniform";
    case BufferUse::StorageRead: return "storage-read";
    case BufferUse::StorageWrite: return "storage-write";
    case BufferUse::Indirect: return "indirect";
    case BufferUse::CopySrc: return "copy-src";
    case BufferUse::CopyDst: return "copy-dst";
  }
  return "?";
}

std::string_view to_string(PassKind kind) {
  switch (kind) {
    case PassKind::Render: return "render";
    case PassKind::Compute: return "compute";
    case PassKind::Transfer: return "transfer";
  }
  return "?";
}

gpu::Extent3D TextureSize::resolve(gpu::Extent3D output) const {
  if (!is_relative) return absolute;
  auto scaled = [](std::uint32_t v, float s) {
    return std::max<std::uint32_t>(1u, static_cast<std::uint32_t>(float(v) * s));
  };
  return {scaled(output.width, relative.width), scaled(output.height, relative.height), 1};
}

}  // namespace weft
