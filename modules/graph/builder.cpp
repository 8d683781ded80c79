// Declaration: RenderGraph, PassBuilder and Blackboard record passes, resources, versions
// and accesses into flat arrays. Mistakes are recorded here and reported by compile(),
// together with everything compile() finds, so a user sees every problem at once.
module;
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
module weft.graph;
import weft.core;
import weft.gpu;
import :compiled_state;

namespace weft::detail {

// The next block a reset() kept, if it is large enough; otherwise a new one in its place.
void* Arena::allocate_in_next_block(std::size_t size, std::size_t alignment) {
  const std::size_t next = cursor_ == nullptr ? 0 : block_ + 1;
  if (next == blocks_.size() || blocks_[next].size < size + alignment) {
    const std::size_t block_size = std::max<std::size_t>(16 * 1024, size + alignment);
    blocks_.insert(blocks_.begin() + std::ptrdiff_t(next),
                   Block{std::make_unique_for_overwrite<std::byte[]>(block_size), block_size});
  }
  block_ = next;
  std::byte* start = blocks_[next].bytes.get();
  std::byte* p = align(start, alignment);
  left_ = blocks_[next].size - std::size_t(p - start) - size;
  cursor_ = p + size;
  return p;
}

void Arena::reset() {
  block_ = 0;
  cursor_ = blocks_.empty() ? nullptr : blocks_[0].bytes.get();
  left_ = blocks_.empty() ? 0 : blocks_[0].size;
}

GraphData::GraphData(std::string_view graph_name) : name(graph_name) {
  blackboard.graph_ = this;
  passes.reserve(64);
  resources.reserve(64);
  versions.reserve(128);
  accesses.reserve(192);
}

GraphData::~GraphData() { release_callbacks(); }

void GraphData::release_callbacks() {
  // Most callbacks capture by reference and need no destructor: then there is nothing to walk.
  if (!has_destructors) return;
  for (PassNode& pass : passes) {
    if (pass.execute.destroy) pass.execute.destroy(pass.execute.callable, pass.execute.data);
    pass.execute = ErasedExecute{};
  }
  has_destructors = false;
}

void GraphData::clear() {
  release_callbacks();
  passes.clear();
  resources.clear();
  versions.clear();
  accesses.clear();
  outputs.clear();
  declaration_errors.clear();
  blackboard.entries_.clear();
  current_pass = invalid_index;
  backward_edges = false;
  maybe_unwritten_read = false;
  multisampled = false;
  if (subresources) ranges.resize(1);
  subresources = false;
  previous = nullptr;
  arena.reset();
}

std::string GraphData::describe(std::uint32_t resource) const {
  if (resource >= resources.size()) return weft::format("resource #{}", resource);
  const ResourceNode& r = resources[resource];
  return weft::format("{} '{}'", r.type == ResourceType::Texture ? "texture" : "buffer", r.name);
}

std::uint32_t GraphData::find_slot(std::uint32_t resource, std::uint32_t version) const {
  if (resource >= resources.size()) return invalid_index;
  std::uint32_t slot = resources[resource].latest_slot;
  while (slot != invalid_index && versions[slot].version > version) slot = versions[slot].previous;
  return slot != invalid_index && versions[slot].version == version ? slot : invalid_index;
}

void* arena_allocate(GraphData& graph, std::size_t size, std::size_t alignment) {
  return graph.arena.allocate(size, alignment);
}

namespace {

void add_error(GraphData& g, GraphErrorKind kind, std::string message, std::vector<std::string> passes,
               std::vector<std::string> resources) {
  g.declaration_errors.push_back(GraphError{kind, std::move(message), std::move(passes), std::move(resources)});
}

// The state one pass's two declarations of one resource combine into, if they can: a pass
// is in one state per resource, because a barrier moves a whole resource to one state.
std::optional<gpu::Access> merge_access(gpu::Access a, gpu::Access b, ResourceType type) {
  using A = gpu::Access;
  if (a == b) return a;
  auto either = [&](A x, A y) { return (a == x && b == y) || (a == y && b == x); };
  // A buffer has no layout: a copy between two ranges of one buffer is one transfer state,
  // whose barrier covers the reads and the writes (CopyDst waits for and makes visible both).
  if (type == ResourceType::Buffer && either(A::CopySrc, A::CopyDst)) return A::CopyDst;
  if (either(A::StorageRead, A::StorageWrite)) return A::StorageWrite;
  if (either(A::DepthRead, A::DepthAttachment)) return A::DepthAttachment;
  if (either(A::ShaderRead, A::DepthRead)) return A::DepthRead;  // same layout; DepthRead covers shaders
  return std::nullopt;
}

std::string use_names(std::uint16_t uses, ResourceType type) {
  std::string out;
  for (unsigned bit = 0; bit < 8; ++bit) {
    if (!(uses & (1u << bit))) continue;
    if (!out.empty()) out += "+";
    out += type == ResourceType::Texture ? to_string(TextureUse(bit)) : to_string(BufferUse(bit));
  }
  return out;
}

[[gnu::cold, gnu::noinline]] void report_invalid_handle(GraphData& g, std::uint32_t pass, ResourceType type,
                                                        std::uint32_t resource, std::uint32_t version, bool write) {
  const std::string_view pass_name = g.passes[pass].name;
  if (resource >= g.resources.size() || g.resources[resource].type != type) {
    add_error(g, GraphErrorKind::InvalidHandle,
              weft::format("pass '{}': {}s a {} through an invalid handle (index {}, version {})", pass_name,
                          write ? "write" : "read", type == ResourceType::Texture ? "texture" : "buffer", resource,
                          version),
              {std::string(pass_name)}, {});
    return;
  }
  add_error(g, GraphErrorKind::InvalidHandle,
            weft::format("pass '{}': uses {} version {}, which does not exist (latest is version {})", pass_name,
                        g.describe(resource), version, g.versions[g.resources[resource].latest_slot].version),
            {std::string(pass_name)}, {std::string(g.resources[resource].name)});
}

[[gnu::cold, gnu::noinline]] void report_conflict(GraphData& g, std::uint32_t pass, ResourceType type,
                                                  std::uint32_t resource, const AccessNode& existing,
                                                  std::uint32_t version, std::uint16_t use, bool two_versions) {
  const std::string_view pass_name = g.passes[pass].name;
  add_error(g, GraphErrorKind::ConflictingUsage,
            two_versions ? weft::format("pass '{}': declares {} at two versions ({} and {}); a pass sees one version "
                                       "of a resource: declare every use in this pass with the handle of the "
                                       "version it should see (the one the last write() returned)",
                                       pass_name, g.describe(resource), g.versions[existing.slot].version, version)
                         : weft::format("pass '{}': uses {} both as {} and as {}; a pass can use a resource one way at "
                                       "a time: to read what it writes, copy it to a second resource in an earlier "
                                       "pass (or split the pass in two){}",
                                       pass_name, g.describe(resource), use_names(existing.uses, type),
                                       use_names(use, type),
                                       type == ResourceType::Texture
                                           ? "; where it uses different mips or layers, declare each with its "
                                             "TextureRange"
                                           : ""),
            {std::string(pass_name)}, {std::string(g.resources[resource].name)});
}

[[gnu::cold, gnu::noinline]] void report_second_writer(GraphData& g, std::uint32_t pass, std::uint32_t resource,
                                                       std::uint32_t version, std::uint32_t other_pass) {
  const std::string_view pass_name = g.passes[pass].name, other = g.passes[other_pass].name;
  add_error(g, GraphErrorKind::MultipleWriters,
            weft::format("{} (version {}) has two writers: pass '{}' and pass '{}' both write it; write the handle "
                        "the first write returns to order them",
                        g.describe(resource), version, other, pass_name),
            {std::string(other), std::string(pass_name)}, {std::string(g.resources[resource].name)});
}

[[gnu::cold, gnu::noinline]] void report_overlap(GraphData& g, std::uint32_t pass, std::uint32_t resource,
                                                 const AccessNode& existing, std::uint16_t use,
                                                 std::uint16_t range) {
  const std::string_view pass_name = g.passes[pass].name;
  const TextureDesc& desc = g.resources[resource].texture_desc;
  const std::uint32_t mips = desc.mip_level_count, layers = declared_layers(desc);
  add_error(g, GraphErrorKind::ConflictingUsage,
            weft::format("pass '{}': uses {} of {} as {} and {} of it as {}; the two overlap, and a mip or layer is "
                         "in one state at a time: declare ranges that do not overlap (TextureRange::mip, ::layer, "
                         "::at), or one use of the whole",
                         pass_name, gpu::describe(g.ranges[existing.range], mips, layers), g.describe(resource),
                         use_names(existing.uses, ResourceType::Texture), gpu::describe(g.ranges[range], mips, layers),
                         use_names(use, ResourceType::Texture)),
            {std::string(pass_name)}, {std::string(g.resources[resource].name)});
}

// The version this pass's write of another range of `resource` made from `input`, if any.
std::uint32_t sibling_output(const GraphData& g, const PassNode& pass, std::uint32_t resource, std::uint32_t input) {
  for (std::uint32_t i = pass.first_access, n = std::uint32_t(g.accesses.size()); i < n; ++i) {
    const AccessNode& a = g.accesses[i];
    if (a.resource == resource && a.slot == input && a.writes()) return a.out_slot;
  }
  return invalid_index;
}

}  // namespace

bool overlap(const TextureRange& a, const TextureRange& b, std::uint32_t mips, std::uint32_t layers) {
  auto apart = [](std::uint64_t a0, std::uint64_t an, std::uint64_t b0, std::uint64_t bn) {
    return a0 + an <= b0 || b0 + bn <= a0;
  };
  return !apart(a.base_mip, a.mips_of(mips), b.base_mip, b.mips_of(mips)) &&
         !apart(a.base_layer, a.layers_of(layers), b.base_layer, b.layers_of(layers));
}

namespace {

// declare()'s slow path: a second declaration of a resource by one pass (merged into one
// access, or a second access for another range of a texture), an older version, and every
// mistake (reported here, out of line). `range` indexes GraphData::ranges (0: the whole).
std::uint32_t declare_any(GraphData& g, std::uint32_t pass, ResourceType type, std::uint32_t resource,
                          std::uint32_t version, std::uint16_t use, bool write, gpu::Access access,
                          std::uint16_t range = 0) {
  if (resource >= g.resources.size() || g.resources[resource].type != type) {
    report_invalid_handle(g, pass, type, resource, version, write);
    return version;
  }
  ResourceNode& node = g.resources[resource];
  // Most handles name the latest version: no walk back through the versions.
  std::uint32_t slot = node.latest_slot;
  if (g.versions[slot].version != version) slot = g.find_slot(resource, version);
  if (slot == invalid_index) {
    report_invalid_handle(g, pass, type, resource, version, write);
    return version;
  }
  // What this pass starts from makes its producer needed (see PassNode::consumed).
  if (const std::uint32_t producer = g.versions[slot].producer; producer != invalid_index && producer != pass)
    g.passes[producer].consumed = true;
  PassNode& pass_node = g.passes[pass];
  const std::uint32_t mips = node.texture_desc.mip_level_count, layers = declared_layers(node.texture_desc);
  // A write of another range of this texture by this pass already made the next version:
  // a second write (of a range apart from it) joins that version.
  std::uint32_t sibling_out = invalid_index;

  // A second declaration of the same resource by this pass merges into the first.
  for (std::uint32_t i = pass_node.first_access, n = std::uint32_t(g.accesses.size()); i < n; ++i) {
    AccessNode& existing = g.accesses[i];
    if (existing.resource != resource) continue;
    const bool same_input = slot == existing.slot;
    const bool own_output = existing.writes() && slot == existing.out_slot;
    if (existing.range != range) {
      if (!same_input && !own_output) {
        report_conflict(g, pass, type, resource, existing, version, use, true);
        return version;
      }
      const bool apart = !overlap(g.ranges[existing.range], g.ranges[range], mips, layers);
      // Overlapping ranges read the same way are two reads in one state; anything else would
      // put one subresource in two states.
      if (!apart && (write || existing.writes() || existing.access != access)) {
        report_overlap(g, pass, resource, existing, use, range);
        return version;
      }
      slot = existing.slot;  // the version this pass starts from, also when named by its own output
      if (existing.writes()) sibling_out = existing.out_slot;
      continue;
    }
    const auto merged = merge_access(existing.access, access, type);
    if ((!same_input && !own_output) || !merged) {
      report_conflict(g, pass, type, resource, existing, version, use, merged.has_value());
      return version;
    }
    existing.access = *merged;
    existing.uses |= use;
    if (own_output) {
      if (!write) existing.reads = true;
      note_access(g, pass, node, resource, type, existing.slot, use, !write, write);
      return g.versions[existing.out_slot].version;
    }
    if (!write) {
      existing.reads = true;
      note_access(g, pass, node, resource, type, existing.slot, use, true, false);
      return version;
    }
    if (!existing.writes()) {
      if (sibling_out == invalid_index) sibling_out = sibling_output(g, pass_node, resource, existing.slot);
      existing.out_slot = sibling_out != invalid_index ? sibling_out : new_version(g, resource, pass);
      g.versions[existing.slot].next_writer = pass;
    }
    note_access(g, pass, node, resource, type, existing.slot, use, false, true);
    return g.versions[existing.out_slot].version;
  }

  AccessNode a;
  a.resource = resource;
  a.slot = slot;
  a.access = access;
  a.uses = use;
  a.reads = !write;
  a.texture = type == ResourceType::Texture;
  a.imported = node.imported;
  a.range = range;
  if (write && sibling_out != invalid_index) {
    a.out_slot = sibling_out;
  } else if (write) {
    VersionNode& input = g.versions[slot];
    if (input.next_writer != invalid_index) report_second_writer(g, pass, resource, version, input.next_writer);
    else input.next_writer = pass;
    a.out_slot = new_version(g, resource, pass);
  }
  g.accesses.push_back(a);
  note_access(g, pass, node, resource, type, slot, use, !write, write);
  return write ? g.versions[a.out_slot].version : version;
}

// A read() with a writing use or a write() with a reading one.
[[gnu::cold, gnu::noinline]] void report_direction(GraphData& g, std::uint32_t pass, std::uint32_t resource,
                                                   bool declared_write, std::string_view use_name) {
  const std::string_view pass_name = g.passes[pass].name;
  const std::string what = resource < g.resources.size() ? g.describe(resource) : std::string("a resource");
  add_error(g, GraphErrorKind::ConflictingUsage,
            declared_write ? weft::format("pass '{}': writes {} with usage {}, which only reads; use read()", pass_name,
                                         what, use_name)
                           : weft::format("pass '{}': reads {} with usage {}, which writes; use write() and keep the "
                                         "handle it returns",
                                         pass_name, what, use_name),
            {std::string(pass_name)}, resource < g.resources.size() ? std::vector<std::string>{std::string(g.resources[resource].name)}
                                                                    : std::vector<std::string>{});
}

}  // namespace

void report_texture_desc(GraphData& g, std::uint32_t resource, const TextureDesc& desc, std::string_view pass_name) {
  if (desc.sample_count != 1) g.multisampled = true;
  std::string problem;
  if (desc.format == gpu::Format::Undefined) problem = "an undefined format";
  else if (desc.mip_level_count == 0) problem = "zero mip levels";
  else if (std::popcount(desc.sample_count) != 1 || desc.sample_count > 64)
    problem = weft::format("{} samples (a power of two from 1 to 64)", desc.sample_count);
  else if (desc.sample_count > 1 && desc.mip_level_count != 1)
    problem = weft::format("{} samples and {} mip levels (a multisampled texture has one)", desc.sample_count,
                           desc.mip_level_count);
  else if (!desc.size.is_relative && (desc.size.absolute.width == 0 || desc.size.absolute.height == 0 ||
                                      desc.size.absolute.depth_or_layers == 0))
    problem = weft::format("a zero size ({})", format_extent(desc.size.absolute));
  else if (desc.size.is_relative && !(desc.size.relative.width > 0.0f && desc.size.relative.height > 0.0f))
    problem = weft::format("a relative size of {}x{}, which is not positive", desc.size.relative.width,
                          desc.size.relative.height);
  if (problem.empty()) return;
  add_error(g, GraphErrorKind::InvalidDescriptor,
            pass_name.empty() ? weft::format("{} has {}", g.describe(resource), problem)
                              : weft::format("pass '{}': creates {} with {}", pass_name, g.describe(resource), problem),
            pass_name.empty() ? std::vector<std::string>{} : std::vector<std::string>{std::string(pass_name)},
            {std::string(g.resources[resource].name)});
}

namespace {

void check_texture_desc(GraphData& g, std::uint32_t resource, const TextureDesc& desc, std::string_view pass_name) {
  const gpu::Extent3D& e = desc.size.absolute;
  if (desc.sample_count != 1) g.multisampled = true;
  const bool valid = desc.format != gpu::Format::Undefined && desc.mip_level_count != 0 &&
                     (desc.sample_count == 1 || (std::popcount(desc.sample_count) == 1 && desc.sample_count <= 64 &&
                                                 desc.mip_level_count == 1)) &&
                     (desc.size.is_relative ? desc.size.relative.width > 0.0f && desc.size.relative.height > 0.0f
                                            : e.width != 0 && e.height != 0 && e.depth_or_layers != 0);
  if (!valid) report_texture_desc(g, resource, desc, pass_name);
}

}  // namespace

void report_nested_pass(GraphData& g, std::string_view name) {
  add_error(g, GraphErrorKind::InvalidDescriptor,
            weft::format("pass '{}' is added inside the setup of pass '{}'; add passes one after another", name,
                         g.passes[g.current_pass].name),
            {std::string(name), std::string(g.passes[g.current_pass].name)}, {});
}

std::uint32_t declare_slow(GraphData& g, std::uint32_t pass, ResourceType type, std::uint32_t resource,
                           std::uint32_t version, std::uint16_t use, bool write, gpu::Access access,
                           bool wrong_direction) {
  if (wrong_direction) {
    const std::string_view use_name =
        type == ResourceType::Texture ? to_string(TextureUse(std::countr_zero(unsigned(use))))
                                      : to_string(BufferUse(std::countr_zero(unsigned(use))));
    report_direction(g, pass, resource, write, use_name);
  }
  return declare_any(g, pass, type, resource, version, use, write, access);
}

std::uint32_t declared_layers(const TextureDesc& desc) {
  if (desc.size.is_relative || desc.dimension == gpu::TextureDimension::D3) return 1;
  return std::max(1u, desc.size.absolute.depth_or_layers);
}

std::uint32_t declare_range(GraphData& g, std::uint32_t pass, std::uint32_t resource, std::uint32_t version,
                            TextureUse use, bool write, const TextureRange& range) {
  const std::uint16_t bit = use_bit(use);
  const gpu::Access access = access_of(use);
  const bool wrong_direction = write != is_write(use);
  if (wrong_direction || resource >= g.resources.size() || g.resources[resource].type != ResourceType::Texture)
    return declare_slow(g, pass, ResourceType::Texture, resource, version, bit, write, access, wrong_direction);
  ResourceNode& node = g.resources[resource];
  const std::uint32_t mips = node.texture_desc.mip_level_count, layers = declared_layers(node.texture_desc);
  if (range.covers(mips, layers))  // the whole texture: the usual path
    return declare(g, pass, ResourceType::Texture, resource, version, bit, write, access, false);
  const std::string_view pass_name = g.passes[pass].name;
  if (!range.fits(mips, layers)) {
    add_error(g, GraphErrorKind::InvalidDescriptor,
              weft::format("pass '{}': {} {} of {}, which has {} mip{} and {} layer{}", pass_name,
                           write ? "writes" : "reads", gpu::describe(range), g.describe(resource), mips,
                           mips == 1 ? "" : "s", layers, layers == 1 ? "" : "s"),
              {std::string(pass_name)}, {std::string(node.name)});
    return version;
  }
  // Stored with its counts spelled out, so that equal ranges compare equal.
  const TextureRange exact{range.base_mip, range.mips_of(mips), range.base_layer, range.layers_of(layers)};
  std::size_t index = 1;
  while (index < g.ranges.size() && g.ranges[index] != exact) ++index;
  if (index == g.ranges.size()) {
    if (index > 0xffff) {
      add_error(g, GraphErrorKind::InvalidDescriptor,
                weft::format("pass '{}': more than 65,535 distinct texture ranges in one graph", pass_name),
                {std::string(pass_name)}, {std::string(node.name)});
      return version;
    }
    g.ranges.push_back(exact);
  }
  node.ranged = true;
  g.subresources = true;
  // An attachment of a mip other than 0 has that mip's size: compile compares sizes then.
  if (bit & attachment_use_bits) g.passes[pass].attachment_sizes_differ = true;
  return declare_any(g, pass, ResourceType::Texture, resource, version, bit, write, access, std::uint16_t(index));
}

std::string format_extent(gpu::Extent3D e) {
  return e.depth_or_layers > 1 ? weft::format("{}x{}x{}", e.width, e.height, e.depth_or_layers)
                               : weft::format("{}x{}", e.width, e.height);
}

}  // namespace weft::detail

namespace weft {

using detail::GraphData;

// ---- PassBuilder ---------------------------------------------------------------------------

BufferHandle PassBuilder::create_buffer(std::string_view name, const BufferDesc& desc) {
  const std::uint32_t index = detail::add_resource(*graph_, name, ResourceType::Buffer, pass_);
  graph_->resources[index].buffer_desc.size = desc.size;  // field by field (see ResourceNode)
  graph_->resources[index].buffer_desc.extra_usage = desc.extra_usage;
  if (desc.size == 0)
    detail::add_error(*graph_, GraphErrorKind::InvalidDescriptor,
                      weft::format("pass '{}': creates buffer '{}' with a zero size", graph_->passes[pass_].name, name),
                      {std::string(graph_->passes[pass_].name)}, {std::string(name)});
  return {index, 0};
}

TextureHandle PassBuilder::read(TextureHandle handle, TextureUse use, const TextureRange& range) {
  return {handle.index, detail::declare_range(*graph_, pass_, handle.index, handle.version, use, false, range)};
}
TextureHandle PassBuilder::write(TextureHandle handle, TextureUse use, const TextureRange& range) {
  return {handle.index, detail::declare_range(*graph_, pass_, handle.index, handle.version, use, true, range)};
}

void PassBuilder::side_effect() { graph_->passes[pass_].side_effect = true; }

void PassBuilder::kind(PassKind kind) {
  graph_->passes[pass_].declared_kind = kind;
  graph_->passes[pass_].kind_declared = true;
}

Blackboard& PassBuilder::blackboard() { return graph_->blackboard; }
std::string_view PassBuilder::pass_name() const { return graph_->passes[pass_].name; }

// ---- Blackboard ----------------------------------------------------------------------------

void Blackboard::put(std::string_view key, TextureHandle handle) {
  put_entry(key, ResourceType::Texture, handle.index, handle.version);
}
void Blackboard::put(std::string_view key, BufferHandle handle) {
  put_entry(key, ResourceType::Buffer, handle.index, handle.version);
}

void Blackboard::put_entry(std::string_view key, ResourceType type, std::uint32_t index, std::uint32_t version) {
  for (Entry& e : entries_) {
    if (e.key == key) {
      e.type = type;
      e.index = index;
      e.version = version;
      return;
    }
  }
  entries_.push_back(Entry{std::string(key), type, index, version});
}

std::optional<std::pair<std::uint32_t, std::uint32_t>> Blackboard::find_entry(std::string_view key,
                                                                              ResourceType type) const {
  for (const Entry& e : entries_)
    if (e.key == key && e.type == type) return std::pair{e.index, e.version};
  return std::nullopt;
}

bool Blackboard::contains(std::string_view key) const {
  return std::any_of(entries_.begin(), entries_.end(), [&](const Entry& e) { return e.key == key; });
}

std::vector<std::string> Blackboard::keys() const {
  std::vector<std::string> out;
  out.reserve(entries_.size());
  for (const Entry& e : entries_) out.push_back(e.key);
  return out;
}

Error Blackboard::missing(std::string_view key, ResourceType type) const {
  const std::string_view asker = graph_ ? graph_->current_pass_name() : std::string_view{};
  const std::string prefix = asker.empty() ? std::string() : weft::format("pass '{}': ", asker);
  const std::string_view wanted = type == ResourceType::Texture ? "texture" : "buffer";
  for (const Entry& e : entries_) {
    if (e.key == key)
      return Error{ErrorKind::InvalidArgument,
                   weft::format("{}blackboard entry '{}' is a {}, not a {}", prefix, key,
                               e.type == ResourceType::Texture ? "texture" : "buffer", wanted)};
  }
  std::string held;
  for (const Entry& e : entries_) held += weft::format("{}'{}'", held.empty() ? "" : ", ", e.key);
  return Error{ErrorKind::NotFound, weft::format("{}blackboard has no {} named '{}' ({})", prefix, wanted, key,
                                                held.empty() ? std::string("it is empty") : "it holds " + held)};
}

// ---- GraphMemory ---------------------------------------------------------------------------

namespace detail {
// What a GraphMemory keeps between graphs: the two sets of arrays the last graph alternated
// between (its last frame's declarations and the spare set).
struct KeptGraphs {
  std::shared_ptr<GraphData> last, spare;
  // A thread's memory (GraphMemory::for_this_thread): its user never sees it, so it keeps no
  // set a compiled graph still holds (that graph would park its gpu objects in it) and drops
  // the gpu objects of those it keeps -- a device may be destroyed before the thread ends.
  bool thread_default = false;
};

namespace {
// What a thread's memory keeps of a set the graph gives back: the set, emptied of callbacks
// and gpu objects, when nothing else holds it; otherwise nothing (it goes with its holder).
std::shared_ptr<GraphData> keep_for_thread(std::shared_ptr<GraphData> set) {
  if (!set || set.use_count() != 1) return nullptr;
  set->release_callbacks();
  if (set->spare_state) drop_gpu_objects(*set->spare_state);
  return set;
}
}  // namespace
}  // namespace detail

GraphMemory::GraphMemory() : kept_(std::make_shared<detail::KeptGraphs>()) {}
GraphMemory::~GraphMemory() = default;

GraphMemory& GraphMemory::for_this_thread() {
  thread_local GraphMemory memory;
  memory.kept_->thread_default = true;
  return memory;
}

void GraphMemory::release() {
  kept_->last.reset();
  kept_->spare.reset();
}

// ---- RenderGraph ---------------------------------------------------------------------------

RenderGraph::RenderGraph(std::string_view name) : RenderGraph(name, GraphMemory::for_this_thread()) {}

RenderGraph::RenderGraph(std::string_view name, GraphMemory& memory) : memory_(memory.kept_) {
  data_ = std::move(memory_->last);
  spare_ = std::move(memory_->spare);
  if (!data_ && spare_) {  // only the spare set was kept (a thread's memory): no last frame
    data_ = std::move(spare_);
    data_->clear();
    data_->name.assign(name);
    return;
  }
  if (!data_) {  // nothing kept (the first graph, or another graph holds the memory)
    data_ = std::make_shared<GraphData>(name);
    return;
  }
  // The last graph's declarations become this graph's last frame, exactly as after reset().
  reset();
  data_->name.assign(name);
}

RenderGraph::RenderGraph(RenderGraph&&) noexcept = default;

RenderGraph& RenderGraph::operator=(RenderGraph&& other) noexcept {
  if (this != &other) {
    give_back_memory();
    data_ = std::move(other.data_);
    spare_ = std::move(other.spare_);
    memory_ = std::move(other.memory_);
  }
  return *this;
}

RenderGraph::~RenderGraph() { give_back_memory(); }

void RenderGraph::give_back_memory() {
  if (!memory_ || !data_) return;
  if (memory_->thread_default) {
    memory_->last = detail::keep_for_thread(std::move(data_));
    memory_->spare = detail::keep_for_thread(std::move(spare_));
    memory_.reset();
    return;
  }
  // What the callbacks captured goes with the graph, unless its compiled graph still needs
  // it (then when the next graph reuses these arrays), as after reset().
  if (data_.use_count() == 1) data_->release_callbacks();
  memory_->last = std::move(data_);
  memory_->spare = std::move(spare_);
  memory_.reset();
}

void RenderGraph::reset() {
  // This frame's arrays become the previous ones; the next frame's are the other set, unless
  // a compiled graph still holds that set (use_count() > 1), which then keeps it.
  std::shared_ptr<GraphData> next;
  if (spare_ && spare_.use_count() == 1) {
    next = std::move(spare_);
    next->name.assign(data_->name);  // a set a memory kept may come from another graph
  } else {
    next = std::make_shared<GraphData>(data_->name);
  }
  next->clear();
  spare_ = std::move(data_);
  data_ = std::move(next);
  data_->previous = spare_.get();
  // What this frame's callbacks captured is released now, unless its compiled graph still
  // needs them (then when its arrays are reused).
  if (spare_.use_count() == 1) spare_->release_callbacks();
}

TextureHandle RenderGraph::import_texture(std::string_view name, const gpu::Texture* texture,
                                          gpu::Access initial_state) {
  if (texture == nullptr) {
    const std::uint32_t index = detail::add_resource(*data_, name, ResourceType::Texture, invalid_index);
    data_->resources[index].imported = true;
    detail::add_error(*data_, GraphErrorKind::InvalidDescriptor,
                      weft::format("texture '{}' is imported from a null gpu::Texture", name), {}, {std::string(name)});
    return {index, 0};
  }
  gpu::TextureDescriptor desc = texture->descriptor();
  TextureHandle handle = import_texture(name, desc, initial_state);
  data_->resources[handle.index].texture = texture;
  return handle;
}

TextureHandle RenderGraph::import_texture(std::string_view name, const gpu::TextureDescriptor& desc,
                                          gpu::Access initial_state) {
  const std::uint32_t index = detail::add_resource(*data_, name, ResourceType::Texture, invalid_index);
  detail::ResourceNode& r = data_->resources[index];
  r.imported = true;
  r.initial_state = initial_state;
  r.texture_desc.size.absolute.width = desc.size.width;  // field by field (see ResourceNode)
  r.texture_desc.size.absolute.height = desc.size.height;
  r.texture_desc.size.absolute.depth_or_layers = desc.size.depth_or_layers;
  r.texture_desc.size.is_relative = false;
  r.texture_desc.format = desc.format;
  r.texture_desc.mip_level_count = desc.mip_level_count;
  r.texture_desc.dimension = desc.dimension;
  r.texture_desc.sample_count = desc.sample_count;
  r.imported_texture_usage = desc.usage;
  detail::check_texture_desc(*data_, index, r.texture_desc, {});
  return {index, 0};
}

BufferHandle RenderGraph::import_buffer(std::string_view name, const gpu::Buffer* buffer, gpu::Access initial_state) {
  if (buffer == nullptr) {
    const std::uint32_t index = detail::add_resource(*data_, name, ResourceType::Buffer, invalid_index);
    data_->resources[index].imported = true;
    detail::add_error(*data_, GraphErrorKind::InvalidDescriptor,
                      weft::format("buffer '{}' is imported from a null gpu::Buffer", name), {}, {std::string(name)});
    return {index, 0};
  }
  BufferHandle handle =
      import_buffer(name, gpu::BufferDescriptor{buffer->label(), buffer->size(), buffer->usage()}, initial_state);
  data_->resources[handle.index].buffer = buffer;
  return handle;
}

BufferHandle RenderGraph::import_buffer(std::string_view name, const gpu::BufferDescriptor& desc,
                                        gpu::Access initial_state) {
  const std::uint32_t index = detail::add_resource(*data_, name, ResourceType::Buffer, invalid_index);
  detail::ResourceNode& r = data_->resources[index];
  r.imported = true;
  r.initial_state = initial_state;
  r.buffer_desc.size = desc.size;
  r.imported_buffer_usage = desc.usage;
  return {index, 0};
}

namespace {
void mark(GraphData& g, ResourceType type, std::uint32_t index, std::uint32_t version, gpu::Access final_state) {
  if (index >= g.resources.size() || g.resources[index].type != type) {
    detail::add_error(g, GraphErrorKind::InvalidHandle,
                      weft::format("mark_output: invalid {} handle (index {}, version {})",
                                  type == ResourceType::Texture ? "texture" : "buffer", index, version),
                      {}, {});
    return;
  }
  g.outputs.push_back(detail::OutputNode{index, version, final_state});
}
}  // namespace

void RenderGraph::mark_output(TextureHandle handle, gpu::Access final_state) {
  mark(*data_, ResourceType::Texture, handle.index, handle.version, final_state);
}
void RenderGraph::mark_output(BufferHandle handle, gpu::Access final_state) {
  mark(*data_, ResourceType::Buffer, handle.index, handle.version, final_state);
}

Blackboard& RenderGraph::blackboard() { return data_->blackboard; }
const Blackboard& RenderGraph::blackboard() const { return data_->blackboard; }
const std::string& RenderGraph::name() const { return data_->name; }
std::size_t RenderGraph::pass_count() const { return data_->passes.size(); }
std::size_t RenderGraph::resource_count() const { return data_->resources.size(); }
std::string_view RenderGraph::resource_name(std::uint32_t index) const {
  return index < data_->resources.size() ? data_->resources[index].name : std::string_view{};
}

TextureHandle RenderGraph::find_texture(std::string_view name) const {
  const auto& resources = data_->resources;
  for (std::uint32_t i = std::uint32_t(resources.size()); i-- > 0;) {
    const detail::ResourceNode& r = resources[i];
    if (r.type != ResourceType::Texture || r.name != name) continue;
    const std::uint32_t version = r.latest_slot == invalid_index ? 0 : data_->versions[r.latest_slot].version;
    return {i, version};
  }
  return {};
}

std::optional<TextureDesc> RenderGraph::texture_desc(TextureHandle handle) const {
  if (handle.index >= data_->resources.size() || data_->resources[handle.index].type != ResourceType::Texture)
    return std::nullopt;
  return data_->resources[handle.index].texture_desc;
}

}  // namespace weft
