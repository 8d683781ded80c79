// How declared uses translate into barrier states and gpu usage flags, and the names every
// message uses for them.
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

gpu::Access access_of(TextureUse use) {
  switch (use) {
    case TextureUse::Sampled: return gpu::Access::ShaderRead;
    case TextureUse::StorageRead: return gpu::Access::StorageRead;
    case TextureUse::StorageWrite: return gpu::Access::StorageWrite;
    case TextureUse::ColorAttachment: return gpu::Access::ColorAttachment;
    case TextureUse::DepthAttachment: return gpu::Access::DepthAttachment;
    case TextureUse::DepthRead: return gpu::Access::DepthRead;
    case TextureUse::CopySrc: return gpu::Access::CopySrc;
    case TextureUse::CopyDst: return gpu::Access::CopyDst;
  }
  return gpu::Access::Undefined;
}

gpu::Access access_of(BufferUse use) {
  switch (use) {
    case BufferUse::Vertex: return gpu::Access::VertexBuffer;
    case BufferUse::Index: return gpu::Access::IndexBuffer;
    case BufferUse::Uniform: return gpu::Access::UniformRead;
    case BufferUse::StorageRead: return gpu::Access::StorageRead;
    case BufferUse::StorageWrite: return gpu::Access::StorageWrite;
    case BufferUse::Indirect: return gpu::Access::IndirectBuffer;
    case BufferUse::CopySrc: return gpu::Access::CopySrc;
    case BufferUse::CopyDst: return gpu::Access::CopyDst;
  }
  return gpu::Access::Undefined;
}

gpu::TextureUsage usage_of(TextureUse use) {
  using U = gpu::TextureUsage;
  switch (use) {
    case TextureUse::Sampled: return U::Sampled;
    case TextureUse::StorageRead:
    case TextureUse::StorageWrite: return U::Storage;
    case TextureUse::ColorAttachment: return U::ColorAttachment;
    case TextureUse::DepthAttachment: return U::DepthAttachment;
    // A read-only depth attachment that shaders may also sample (Access::DepthRead covers both).
    case TextureUse::DepthRead: return U::DepthAttachment | U::Sampled;
    case TextureUse::CopySrc: return U::CopySrc;
    case TextureUse::CopyDst: return U::CopyDst;
  }
  return U::None;
}

gpu::BufferUsage usage_of(BufferUse use) {
  using U = gpu::BufferUsage;
  switch (use) {
    case BufferUse::Vertex: return U::Vertex;
    case BufferUse::Index: return U::Index;
    case BufferUse::Uniform: return U::Uniform;
    case BufferUse::StorageRead:
    case BufferUse::StorageWrite: return U::Storage;
    case BufferUse::Indirect: return U::Indirect;
    case BufferUse::CopySrc: return U::CopySrc;
    case BufferUse::CopyDst: return U::CopyDst;
  }
  return U::None;
}

gpu::Extent3D TextureSize::resolve(gpu::Extent3D output) const {
  if (!is_relative) return absolute;
  auto scaled = [](std::uint32_t v, float s) {
    return std::max<std::uint32_t>(1u, static_cast<std::uint32_t>(float(v) * s));
  };
  return {scaled(output.width, relative.width), scaled(output.height, relative.height), 1};
}

}  // namespace weft
