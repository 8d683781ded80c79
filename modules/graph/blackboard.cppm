// weft.graph:blackboard — well-known handles passed between the passes of one frame by name.
module;
#include <cstdint>
#include <expected>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>
export module weft.graph:blackboard;
import weft.core;
import weft.gpu;
import :types;

namespace weft::detail {
struct GraphData;
}  // namespace weft::detail

export namespace weft {

// ---- blackboard ------------------------------------------------------------------------
// Well-known handles passed between features by name ("scene_depth", "shadow_map"), so a
// feature finds another's output without importing it. put() replaces an existing key.
class Blackboard {
 public:
  void put(std::string_view key, TextureHandle handle);
  void put(std::string_view key, BufferHandle handle);
  // The handle under `key`, or an error naming the key and the pass that asked.
  template <class Handle>
  [[nodiscard]] Result<Handle> get(std::string_view key) const {
    if constexpr (std::is_same_v<Handle, TextureHandle>) {
      auto found = find_entry(key, ResourceType::Texture);
      if (!found) return std::unexpected(missing(key, ResourceType::Texture));
      return TextureHandle{found->first, found->second};
    } else {
      static_assert(std::is_same_v<Handle, BufferHandle>, "get<TextureHandle> or get<BufferHandle>");
      auto found = find_entry(key, ResourceType::Buffer);
      if (!found) return std::unexpected(missing(key, ResourceType::Buffer));
      return BufferHandle{found->first, found->second};
    }
  }
  template <class Handle>
  [[nodiscard]] std::optional<Handle> find(std::string_view key) const {
    auto handle = get<Handle>(key);
    return handle ? std::optional<Handle>(*handle) : std::nullopt;
  }
  [[nodiscard]] bool contains(std::string_view key) const;
  [[nodiscard]] std::vector<std::string> keys() const;

 private:
  struct Entry {
    std::string key;
    ResourceType type;
    std::uint32_t index, version;
  };
  void put_entry(std::string_view key, ResourceType type, std::uint32_t index, std::uint32_t version);
  [[nodiscard]] std::optional<std::pair<std::uint32_t, std::uint32_t>> find_entry(std::string_view key,
                                                                                  ResourceType type) const;
  [[nodiscard]] Error missing(std::string_view key, ResourceType type) const;
  const detail::GraphData* graph_ = nullptr;  // to name the pass that is asking
  std::vector<Entry> entries_;
  friend struct detail::GraphData;
};

}  // namespace weft
