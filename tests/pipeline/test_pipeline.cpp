// weft.pipeline without a device: the pass-type registry, the default pipeline, options, the
// file round trip, the generated docs, and a folder of broken pipelines (broken/*.json), each
// with the exact message weft must print (broken/*.expected) -- the kind of suite a user
// writes for their own frames. WEFT_WRITE_EXPECTED=1 writes missing .expected files (review
// them before committing: they are the specification).
#include <doctest/doctest.h>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>
import weft.core;
import weft.gpu;
import weft.pipeline;

namespace fs = std::filesystem;
using namespace weft;

namespace {
fs::path source_dir() {
  const char* dir = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE_MESSAGE(dir, "WEFT_SOURCE_DIR is not set (ctest sets it)");
  return dir;
}
std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
std::vector<std::string> pass_names(const pipeline::Pipeline& p) {
  std::vector<std::string> out;
  for (const auto& pass : p.passes) out.push_back(pass.name);
  return out;
}
}  // namespace

TEST_CASE("the default pipeline: four passes in order, options defaulted, no warnings") {
  auto p = pipeline::default_pipeline();
  REQUIRE_MESSAGE(p, (p ? "" : p.error().message));
  CHECK(pass_names(*p) == std::vector<std::string>{"shadow_map", "scene", "background", "tonemap"});
  CHECK(p->warnings.empty());
  REQUIRE(p->outputs.size() == 1);
  CHECK(p->outputs[0].text() == "tonemap.color");
  const auto* tonemap = p->find("tonemap");
  REQUIRE(tonemap);
  CHECK(tonemap->options.number("exposure") == 1.0);
  CHECK(tonemap->options.choice("operator") == "aces");
  CHECK((p->format_of({"background", "color"}) == gpu::Format::RGBA16Float));  // same_as its input
  CHECK((p->format_of({"tonemap", "color"}) == gpu::Format::RGBA8Unorm));
  CHECK((p->source_of({"tonemap", "color"}) == pipeline::SlotRef{"background", "color"}));
  // The file in assets/ is the one built in.
  CHECK(read_text(source_dir() / "assets/pipelines/default.json") == std::string(pipeline::default_pipeline_text()));
}

TEST_CASE("file order is kept where connections leave it free; connections decide otherwise") {
  auto p = pipeline::parse_pipeline(R"({
    "passes": {"tonemap": {"type": "tonemap"}, "background": {"type": "background"}, "scene": {"type": "scene_color"},
               "shadow_b": {"type": "shadow_map"}, "shadow_a": {"type": "shadow_map"}},
    "connections": ["background.color -> tonemap.color", "scene.color -> background.color", "scene.depth -> background.depth",
                    "shadow_a.depth -> scene.shadow_map"],
    "outputs": ["tonemap.color"]})", "order.json");
  REQUIRE_MESSAGE(p, (p ? "" : p.error().message));
  CHECK(pass_names(*p) == std::vector<std::string>{"shadow_b", "shadow_a", "scene", "background", "tonemap"});
  REQUIRE(p->warnings.size() == 1);
  CHECK(p->warnings[0] == "order.json: $.passes.shadow_b: pass 'shadow_b' reaches no output; it is culled");
}

TEST_CASE("a pass given an accepted format it is not made for is warned about: FXAA on linear HDR colour") {
  const char* text = R"({
    "passes": {"scene": {"type": "scene_color"}, "background": {"type": "background"}, "fxaa": {"type": "fxaa"},
               "tonemap": {"type": "tonemap"}, "after": {"type": "fxaa"}},
    "connections": ["scene.color -> background.color", "scene.depth -> background.depth",
                    "background.color -> fxaa.color", "fxaa.color -> tonemap.color", "tonemap.color -> after.color"],
    "outputs": ["after.color"]})";
  auto p = pipeline::parse_pipeline(text, "fxaa_hdr.json");
  REQUIRE_MESSAGE(p, (p ? "" : p.error().message));
  REQUIRE(p->warnings.size() == 1);  // the fxaa after the tonemap gets what it is made for
  CHECK(p->warnings[0] ==
        "fxaa_hdr.json: $.passes.fxaa: pass 'fxaa' (fxaa) gets rgba16float from 'background.color' in its input 'color': "
        "FXAA's contrast thresholds are for display-encoded luma: on linear HDR colour it misses edges in the dark and "
        "smooths bright ones too much; put it after the tonemap");
  // The temporal pass types say so in their descriptors (weft render warns about one frame).
  CHECK(pipeline::pass_type_registry().find("taa")->temporal);
  CHECK(pipeline::pass_type_registry().find("accumulate")->temporal);
  CHECK_FALSE(pipeline::pass_type_registry().find("fxaa")->temporal);
}

TEST_CASE("to_json writes a file that reads back to the same pipeline") {
  auto p = pipeline::parse_pipeline(R"({"description": "d",
    "passes": {"scene": {"type": "scene_color", "options": {"clear": 0.25}},
               "tonemap": {"type": "tonemap", "options": {"operator": "clamp", "exposure": 2}}},
    "connections": ["scene.color -> tonemap.color"], "outputs": ["tonemap.color", "scene.depth"]})", "a.json");
  REQUIRE_MESSAGE(p, (p ? "" : p.error().message));
  const std::string text = pipeline::to_json(*p);
  auto again = pipeline::parse_pipeline(text, "b.json");
  REQUIRE_MESSAGE(again, (again ? "" : again.error().message));
  CHECK(pass_names(*again) == pass_names(*p));
  CHECK(again->description == "d");
  CHECK(again->outputs == p->outputs);
  REQUIRE(again->connections.size() == 1);
  CHECK(again->connections[0].from == p->connections[0].from);
  for (std::size_t i = 0; i < p->passes.size(); ++i) {
    CHECK(again->passes[i].type == p->passes[i].type);
    CHECK(again->passes[i].options == p->passes[i].options);
  }
  CHECK(pipeline::to_json(*again) == text);
  CHECK(again->find("tonemap")->options.number("exposure") == 2.0);
}

TEST_CASE("slot references") {
  CHECK((pipeline::parse_slot_ref(" a.b ") == pipeline::SlotRef{"a", "b"}));
  CHECK(!pipeline::parse_slot_ref("ab"));
  CHECK(!pipeline::parse_slot_ref(".b"));
  CHECK(!pipeline::parse_slot_ref("a."));
}

// First: the messages list the registered pass types, and the tests below register more.
TEST_CASE("every broken pipeline gives exactly its expected message") {
  const fs::path folder = source_dir() / "tests/pipeline/broken";
  std::size_t cases = 0;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.path().extension() != ".json") continue;
    ++cases;
    const std::string name = entry.path().stem().string();
    CAPTURE(name);
    auto p = pipeline::load_pipeline(entry.path());
    REQUIRE_MESSAGE(!p, name << " was accepted");
    // Messages name the file by the path given; compare with the folder's part dropped.
    std::string message = p.error().what();
    for (std::string prefix = folder.string() + "/"; message.find(prefix) != std::string::npos;)
      message.erase(message.find(prefix), prefix.size());
    fs::path expected = entry.path();
    expected.replace_extension(".expected");
    if (!fs::exists(expected) && std::getenv("WEFT_WRITE_EXPECTED")) std::ofstream(expected) << message << "\n";
    REQUIRE_MESSAGE(fs::exists(expected), "no " << expected.filename().string() << "; weft printed:\n" << message);
    std::string want = read_text(expected);
    while (!want.empty() && want.back() == '\n') want.pop_back();
    CHECK(message == want);
  }
  CHECK(cases >= 12);
}

namespace {
Result<std::unique_ptr<pipeline::FramePass>> no_pass(const pipeline::PassOptions&) {
  return fail(ErrorKind::Unsupported, "test type");
}
}  // namespace

TEST_CASE("the registry refuses bad and colliding descriptors, and takes the same one twice") {
  auto& registry = pipeline::pass_type_registry();
  pipeline::PassTypeDescriptor d{.name = "test_copy",
                                 .summary = "s",
                                 .inputs = {{.name = "color"}},
                                 .outputs = {{.name = "color", .same_as = "color"}},
                                 .options = {pipeline::number_option("gain", 0, 2, 1, "m")},
                                 .create = &no_pass};
  REQUIRE(registry.add(d));
  CHECK(registry.add(d));  // idempotent
  auto other = d;
  other.options.clear();
  auto collided = registry.add(other);
  REQUIRE(!collided);
  CHECK(collided.error().message == "pass type 'test_copy' is registered already (by another descriptor)");
  auto bad_default = d;
  bad_default.name = "test_bad_default";
  bad_default.options = {pipeline::number_option("gain", 0, 2, 3, "m")};
  auto refused = registry.add(bad_default);
  REQUIRE(!refused);
  CHECK(refused.error().message == "pass type 'test_bad_default': option 'gain' has a default outside its range or choices");
  auto bad_same = d;
  bad_same.name = "test_bad_same";
  bad_same.outputs = {{.name = "out", .same_as = "nothing"}};
  auto refused_same = registry.add(bad_same);
  REQUIRE(!refused_same);
  CHECK(refused_same.error().message ==
        "pass type 'test_bad_same': output 'out' is the same as input 'nothing', which it does not have");
  auto bad_name = d;
  bad_name.name = "has.dot";
  CHECK(!registry.add(bad_name));
  auto bad_intent = d;
  bad_intent.name = "test_bad_intent";
  bad_intent.inputs.at(0).formats = {gpu::Format::RGBA16Float};
  bad_intent.inputs.at(0).intended_formats = {gpu::Format::RGBA8Unorm};
  const auto intent_refused = registry.add(bad_intent);
  REQUIRE_FALSE(intent_refused);
  CHECK(intent_refused.error().message.find("made for rgba8unorm, which it does not accept") != std::string::npos);
  CHECK(registry.find("test_bad_default") == nullptr);
}

TEST_CASE("docs/pipelines.md carries the generated pass-type reference") {
  const std::string doc = read_text(source_dir() / "docs/pipelines.md");
  const std::string begin = "<!-- pass types: generated by `weft graph --pass-types` -->\n";
  const std::string end = "<!-- end of pass types -->";
  const auto a = doc.find(begin), b = doc.find(end);
  REQUIRE_MESSAGE(a != std::string::npos, "docs/pipelines.md lacks the generated section's begin marker");
  REQUIRE(b != std::string::npos);
  // Only the built-in types: drop what this suite registered itself.
  std::string generated = pipeline::pass_types_markdown();
  const auto test_type = generated.find("### `test_copy`");
  if (test_type != std::string::npos) generated.erase(test_type);
  CHECK_MESSAGE(doc.substr(a + begin.size(), b - a - begin.size()) == generated,
                "regenerate it: build/bin/weft graph --pass-types");
}

