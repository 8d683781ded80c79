// Reading a feature material's fields: the JSON path, the object check, unknown fields and
// the one error naming every bad field, done once for every feature's parser.
module;
#include <exception>
#include <expected>
#include <functional>
#include <string>
#include <string_view>
module weft.feature;
import weft.core;
import weft.scene;

namespace weft {

Result<void> read_material_fields(const scene::Material& material, std::string_view type,
                                  const std::function<void(scene::JsonReader& reader)>& read) {
  const std::string header = weft::format("{} material '{}'", type, material.name);
  try {
    scene::JsonErrors errors;
    const std::string path = material.json_path.empty() ? "$.materials." + material.name : material.json_path;
    scene::JsonReader reader(material.params, path, errors, material.base_dir);
    if (!reader.is_object()) {
      reader.error(weft::format("the fields of a {} material are a JSON object, got {}", type,
                               scene::json_type_name(material.params)));
    } else {
      read(reader);
      reader.finish();
    }
    if (!errors.empty()) return std::unexpected(errors.to_error(header));
    return {};
  } catch (const std::exception& e) {
    return fail(ErrorKind::Parse, "{}: {}", header, e.what());
  }
}

}  // namespace weft
