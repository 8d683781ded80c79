// The command line as a user meets it: bad input gives a one-line reason and a non-zero
// exit; good input writes the image. Runs the real binaries.
#include <doctest/doctest.h>
#include "../support/run_command.h"
#include <algorithm>
#include <chrono>
#include <cmath>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

import weft.image;

namespace {
using weft::test::run_command;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::filesystem::path temp_dir() {
  auto dir = std::filesystem::temp_directory_path() / ("weft-cli-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

const std::string cli = WEFT_CLI;
const char* scene = R"({"version": 1, "output": {"width": 32, "height": 24},
  "camera": {"position": [0, 0, 3], "target": [0, 0, 0]},
  "environment": {"color": [0.2, 0.2, 0.2]},
  "meshes": {"ball": {"primitive": "sphere", "radius": 0.5}},
  "materials": {"m": {"type": "standard"}},
  "objects": [{"name": "ball", "mesh": "ball", "material": "m"}]})";
}  // namespace

TEST_CASE("weft render writes a PNG, and --profile prints the pass table") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  const auto r = run_command(cli + " render " + (dir / "s.json").string() + " -o " + (dir / "out.png").string() + " --profile");
  CHECK_MESSAGE(r.exit_code == 0, r.output);
  CHECK(std::filesystem::file_size(dir / "out.png") > 50);
  CHECK(contains(r.output, "| forward |"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("bad input: missing scene, malformed JSON, unknown field, unwritable output, bad size, bad quality") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  std::ofstream(dir / "broken.json") << "{\"version\": 1, \"objects\": [";
  std::ofstream(dir / "unknown.json") << R"({"version": 1, "colour": 3})";
  const std::string s = (dir / "s.json").string();
  struct Case {
    std::string args, expect;
  };
  for (const auto& c : {Case{"render " + (dir / "nope.json").string() + " -o x.png", "nope.json"},
                        Case{"render " + (dir / "broken.json").string() + " -o x.png", "broken.json"},
                        Case{"render " + (dir / "unknown.json").string() + " -o x.png", "$.colour"},
                        Case{"render " + s + " -o /nonexistent-dir/out.png", "/nonexistent-dir/out.png"},
                        Case{"render " + s + " -o x.png --size 0x5", "--size"},
                        Case{"render " + s + " -o x.png --quality ultra", "ultra"},
                        Case{"graph " + (dir / "nope.json").string(), "nope.json"},
                        // Jittered samples that nothing averages: refused before rendering.
                        Case{"render " + s + " -o x.png --accumulate 4", "no pass of type 'accumulate'"},
                        Case{"render " + s + " -o x.png --accumulate 4 --frames 2", "--accumulate and --frames"},
                        Case{"render " + s + " -o x.png --accumulate 0", "--accumulate"},
                        Case{"render " + s + " -o x.png --accumulate many", "--accumulate"}}) {
    const auto r = run_command(cli + " " + c.args);
    CHECK_MESSAGE(r.exit_code != 0, c.args);
    CHECK_MESSAGE(contains(r.output, c.expect), c.args << " -> " << r.output);
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("weft render of a temporal pipeline in one frame says it shows sample 0 only; --accumulate does not") {
  const char* source = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE(source);
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  const std::string base = cli + " render " + (dir / "s.json").string() + " --size 32x18 -o " + (dir / "x.png").string();
  const std::string taa = std::string(source) + "/examples/pipelines/taa.json";
  const std::string accumulate = std::string(source) + "/examples/pipelines/accumulate.json";
  const auto one = run_command(base + " --pipeline " + taa);
  CHECK_MESSAGE(one.exit_code == 0, one.output);
  CHECK_MESSAGE(contains(one.output, "the pipeline's 'taa' (taa) blends frames over time, and one frame shows sample 0 "
                                     "only: render with --accumulate N"),
                one.output);
  const auto several = run_command(base + " --pipeline " + accumulate + " --accumulate 3");
  CHECK_MESSAGE(several.exit_code == 0, several.output);
  CHECK_FALSE(contains(several.output, "blends frames over time"));
  const auto plain = run_command(base);
  CHECK_MESSAGE(plain.exit_code == 0, plain.output);
  CHECK_FALSE(contains(plain.output, "blends frames over time"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("weft graph prints the passes and writes DOT") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  const auto r = run_command(cli + " graph " + (dir / "s.json").string() + " --dot " + (dir / "g.dot").string());
  CHECK_MESSAGE(r.exit_code == 0, r.output);
  CHECK(contains(r.output, "passes: forward background tonemap"));
  std::ifstream dot(dir / "g.dot");
  std::string first;
  std::getline(dot, first);
  CHECK(contains(first, "digraph"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("weft info names the adapter; weft-triangle rejects a bad size and an unwritable path") {
  const auto info = run_command(cli + " info");
  CHECK(info.exit_code == 0);
  CHECK(contains(info.output, "chosen:"));
  const std::string triangle = WEFT_TRIANGLE;
  CHECK(run_command(triangle + " --size 12").exit_code != 0);
  const auto r = run_command(triangle + " -o /nonexistent-dir/t.png --size 16x16");
  CHECK(r.exit_code != 0);
  CHECK(contains(r.output, "/nonexistent-dir/t.png"));
}

TEST_CASE("weft tradeoff: bad input is named; a small fur sweep writes its CSV, SVG, markdown and reference") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;  // standard material only
  const char* source = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE(source);
  const auto photo = std::filesystem::path(source) / "examples/fur/synthetic_fur.png";
  std::ofstream(dir / "fur.json") << R"({"version": 1, "output": {"width": 32, "height": 24},
    "camera": {"position": [0, 0.4, 2], "target": [0, 0, 0]},
    "lights": [{"type": "directional", "direction": [-0.5, -1, -0.4], "intensity": 2}],
    "environment": {"color": [0.2, 0.2, 0.2]},
    "meshes": {"ball": {"primitive": "sphere", "radius": 0.5, "segments": 16}},
    "materials": {"fur": {"type": "fur", "photo": ")" << photo.string() << R"(", "layers": 4, "wrap": "repeat"}},
    "objects": [{"name": "ball", "mesh": "ball", "material": "fur"}]})";
  const std::string s = (dir / "s.json").string(), fur = (dir / "fur.json").string();
  struct Case {
    std::string args, expect;
  };
  for (const auto& c : {Case{"tradeoff --feature fur", "scene file is required"},
                        Case{"tradeoff " + fur, "--feature F or --pass NAME"},
                        Case{"tradeoff " + fur + " --feature fur --pass shadow_map", "one of them"},
                        Case{"tradeoff " + fur + " --feature fur --pipeline x.json", "--pipeline is for --pass"},
                        Case{"tradeoff " + fur + " --pass tonemap", "trades no accuracy"},
                        Case{"tradeoff " + fur + " --pass nosuch", "no pass 'nosuch'"},
                        Case{"tradeoff " + fur + " --pass shadow_map --values resolution=99999", "resolution"},
                        Case{"tradeoff " + fur + " --pass shadow_map --farm local", "--pass studies run in this process"},
                        Case{"tradeoff " + fur + " --pass shadow_map --pipeline " + (dir / "nope.json").string(), "nope.json"},
                        Case{"tradeoff " + fur + " --feature hair", "'hair'"},
                        Case{"tradeoff " + s + " --feature fur", "no \"shell_fur\" material"},  // "fur" is its alias
                        Case{"tradeoff " + fur + " --feature fur --values layers=0", "layers"},
                        Case{"tradeoff " + fur + " --feature fur --values layers", "KNOB=V1"},
                        Case{"tradeoff " + fur + " --feature fur --values hairs=2", "'hairs'"},
                        Case{"tradeoff " + fur + " --feature fur --size 0x5", "--size"},
                        Case{"tradeoff " + (dir / "nope.json").string() + " --feature fur", "nope.json"}}) {
    const auto r = run_command(cli + " " + c.args);
    CHECK_MESSAGE(r.exit_code != 0, c.args);
    CHECK_MESSAGE(contains(r.output, c.expect), c.args << " -> " << r.output);
  }
  const auto out = dir / "study";
  const auto r = run_command(cli + " tradeoff " + fur + " --feature fur --frames 1 --values layers=1,2 --values fin_threshold=0.5 -o " +
                             out.string());
  REQUIRE_MESSAGE(r.exit_code == 0, r.output);
  std::ifstream csv(out / "tradeoff.csv");
  std::string text((std::istreambuf_iterator<char>(csv)), std::istreambuf_iterator<char>());
  CHECK(contains(text, "fins=false layers=1"));
  CHECK(contains(text, "reference"));
  std::ifstream svg(out / "tradeoff.svg");
  std::string plot((std::istreambuf_iterator<char>(svg)), std::istreambuf_iterator<char>());
  CHECK(contains(plot, "</svg>"));
  CHECK(std::filesystem::file_size(out / "tradeoff.md") > 100);
  CHECK(std::filesystem::file_size(out / "reference.png") > 50);
  // A pass of the pipeline: the shadow map's resolution against its 8192-texel reference.
  const auto shadow_out = dir / "shadow";
  const auto sr = run_command(cli + " tradeoff " + fur + " --pass shadow_map --frames 1 --values resolution=64,1024 -o " +
                              shadow_out.string());
  REQUIRE_MESSAGE(sr.exit_code == 0, sr.output);
  std::ifstream shadow_csv(shadow_out / "tradeoff.csv");
  std::string shadow_text((std::istreambuf_iterator<char>(shadow_csv)), std::istreambuf_iterator<char>());
  CHECK(contains(shadow_text, "resolution=64"));
  CHECK(contains(shadow_text, "resolution=1024"));
  CHECK(contains(shadow_text, "reference"));
  CHECK(!contains(shadow_text, "preset low"));  // no quality presets in a pass study
  CHECK(contains(sr.output, "all 768 pixels"));  // 32 x 24: a pass study's error is over the whole frame
  std::filesystem::remove_all(dir);
}

TEST_CASE("weft bake btf: bad input is named; a 4 x 4 synthetic fabric trains into a .wbtf") {
  const auto dir = temp_dir();
  std::ofstream(dir / "corrupt.btfraw") << "not a BTF at all";
  const std::string out = " -o " + (dir / "x.wbtf").string();
  struct Case {
    std::string args, expect;
  };
  for (const auto& c : {Case{"bake btf" + out, "either a BTF path"},
                        Case{"bake btf " + (dir / "corrupt.btfraw").string() + " --synthetic 4x4" + out, "not both"},
                        Case{"bake btf --synthetic 0x4" + out, "'0x4'"},
                        Case{"bake btf --synthetic 4x4 --clusters 17" + out, "--clusters 17 is more than the 16 texels"},
                        Case{"bake btf --synthetic 4x4 --finetune 2" + out, "--finetune 2"},
                        Case{"bake btf --synthetic 4x4 --resume" + out, "--checkpoint"},
                        Case{"bake btf --synthetic 4x4 --weave satin" + out, "satin"},
                        Case{"bake btf --synthetic 4x4 --recipe fancy" + out, "--recipe 'fancy' is not best or paper"},
                        Case{"bake btf --synthetic 4x4 --batch 0" + out, "--batch 0"},
                        Case{"bake btf " + (dir / "nope.btfraw").string() + out, "nope.btfraw"},
                        Case{"bake btf " + (dir / "corrupt.btfraw").string() + out, "corrupt.btfraw"}}) {
    const auto r = run_command(cli + " " + c.args);
    CHECK_MESSAGE(r.exit_code != 0, c.args);
    CHECK_MESSAGE(contains(r.output, c.expect), c.args << " -> " << r.output);
  }
  CHECK_FALSE(std::filesystem::exists(dir / "x.wbtf"));  // no failed bake left a file
  const auto r = run_command(cli + " bake btf --synthetic 4x4 --clusters 4 --epochs 1 --directions 64" + out);
  REQUIRE_MESSAGE(r.exit_code == 0, r.output);
  CHECK(contains(r.output, "RMSE"));
  // The best recipe by default (a 16-texel fabric takes all 16 a step), the given option winning.
  CHECK_MESSAGE(contains(r.output, "recipe: best (adam, learning rate 0.003, cosine, batch 16, 64 directions per texel, holdout 0)"),
                r.output);
  CHECK(std::filesystem::file_size(dir / "x.wbtf") > 1000);
  const auto paper = run_command(cli + " bake btf --synthetic 4x4 --epochs 1 --recipe paper --batch 4" + out);
  REQUIRE_MESSAGE(paper.exit_code == 0, paper.output);
  CHECK_MESSAGE(contains(paper.output, "recipe: paper (sgd, learning rate 0, constant, batch 4, all directions per texel, holdout 0)"),
                paper.output);
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 21: bad numbers and words on the command line are named, never echoed wrong") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  const std::string s = (dir / "s.json").string(), png = " -o " + (dir / "x.png").string();
  struct Case {
    std::string args, expect;
  };
  // NaN and infinity are refused by the command line itself since issue 33 (every floating-point option).
  for (const auto& c : {Case{"render " + s + png + " --exposure nan", "--exposure: 'nan' is not a finite number"},
                        Case{"render " + s + png + " --exposure -1", "--exposure -1"},
                        Case{"render " + s + png + " --exposure inf", "--exposure: 'inf' is not a finite number"},
                        Case{"render " + s + png + " --exposure 0", "--exposure 0"},
                        Case{"render " + s + png + " --size -1x-1", "got '-1x-1'"},
                        Case{"render " + s + png + " --size 16384x16384", "each side 1 to 8192"},
                        Case{"render " + s + " -o " + (dir / "x.bmp").string(), "weft writes .png, .jpg, .exr and .hdr"},
                        Case{"rnder " + s, "unknown command 'rnder' (commands: info, render"},
                        Case{"bake btf --synthetic 4x4 --epochs 0 -o " + (dir / "x.wbtf").string(), "--epochs"},
                        Case{"bake skin-lut --size 4096 --samples 65536 -o " + (dir / "lut.exr").string(), "texel-samples"}}) {
    const auto r = run_command(cli + " " + c.args);
    CHECK_MESSAGE(r.exit_code != 0, c.args);
    CHECK_MESSAGE(contains(r.output, c.expect), c.args << " -> " << r.output);
    CHECK_MESSAGE(!contains(r.output, "4294967295"), r.output);
  }
  CHECK_FALSE(std::filesystem::exists(dir / "x.png"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 21: a synthetic BTF too large for memory is refused up front, not a bad_alloc") {
  const auto dir = temp_dir();
  const auto r = run_command(cli + " bake btf --synthetic 4096x4096 --epochs 1 -o " + (dir / "x.wbtf").string());
  CHECK(r.exit_code == 1);
  CHECK_MESSAGE(contains(r.output, "4096 x 4096 texels at 81 x 81 directions is 1230.2 GiB of samples"), r.output);
  CHECK_FALSE(contains(r.output, "exception"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 21: -o .exr, .hdr and .jpg write those formats, not PNG bytes") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  const auto first_bytes = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::string head(10, '\0');
    in.read(head.data(), 10);
    return head;
  };
  for (const std::string ext : {".exr", ".hdr", ".jpg", ".png"}) {
    const auto out = dir / ("out" + ext);
    const auto r = run_command(cli + " render " + (dir / "s.json").string() + " -o " + out.string());
    REQUIRE_MESSAGE(r.exit_code == 0, r.output);
    const std::string head = first_bytes(out);
    if (ext == ".exr") CHECK(head.substr(0, 4) == std::string("\x76\x2f\x31\x01", 4));
    if (ext == ".hdr") CHECK(head.substr(0, 2) == "#?");
    if (ext == ".jpg") CHECK(head.substr(0, 3) == std::string("\xff\xd8\xff", 3));
    if (ext == ".png") CHECK(head.substr(1, 3) == "PNG");
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 21: weft-bench-btf-train --help answers without training") {
  const auto r = run_command(std::string("timeout 20 ") + WEFT_BENCH_BTF_TRAIN + " --help");
  CHECK(r.exit_code == 0);
  CHECK(contains(r.output, "usage: weft-bench-btf-train"));
  CHECK_FALSE(contains(r.output, "training on"));
  CHECK_FALSE(contains(r.output, "loss"));
}

TEST_CASE("issue 20: weft-bench-btf-interpolation answers --help, and a missing model is named") {
  const auto help = run_command(std::string("timeout 20 ") + WEFT_BENCH_BTF_INTERPOLATION + " --help");
  CHECK(help.exit_code == 0);
  CHECK(contains(help.output, "usage: weft-bench-btf-interpolation"));
  CHECK_FALSE(contains(help.output, "synthetic BTF"));
  const auto missing = run_command(std::string("timeout 20 ") + WEFT_BENCH_BTF_INTERPOLATION + " /nonexistent/model.wbtf 2>&1");
  CHECK(missing.exit_code != 0);
  CHECK(contains(missing.output, "/nonexistent/model.wbtf"));
  const auto nothing = run_command(std::string("timeout 20 ") + WEFT_BENCH_BTF_INTERPOLATION + " 2>&1");
  CHECK(nothing.exit_code == 2);
  CHECK(contains(nothing.output, "usage"));
  for (const char* n : {"0", "257", "100000000000"}) {  // the knob's extremes, refused before any work
    CAPTURE(n);
    const auto r = run_command(std::string("timeout 20 ") + WEFT_BENCH_BTF_INTERPOLATION + " /nonexistent/model.wbtf --directions " + n + " 2>&1");
    CHECK(r.exit_code == 2);
    CHECK(contains(r.output, "--directions"));
  }
}

TEST_CASE("issue 21: the brightest light a scene may have shades finite pixels (1e38 drew black faces)") {
  const auto dir = temp_dir();
  std::ofstream(dir / "bright.json") << R"({"version": 1, "output": {"width": 32, "height": 24},
    "camera": {"position": [0, 0, 3], "target": [0, 0, 0]},
    "lights": [{"type": "directional", "direction": [0, 0, -1], "color": [100, 100, 100], "intensity": 1e7}],
    "meshes": {"ball": {"primitive": "sphere", "radius": 0.5}},
    "materials": {"m": {"type": "standard", "roughness": 0.05}},
    "objects": [{"name": "ball", "mesh": "ball", "material": "m"}]})";
  const auto out = dir / "bright.exr";
  const auto r = run_command(cli + " render " + (dir / "bright.json").string() + " -o " + out.string());
  REQUIRE_MESSAGE(r.exit_code == 0, r.output);
  auto image = weft::image::load_exr(out);
  REQUIRE(image.has_value());
  float brightest = 0.0f;
  bool finite = true;
  for (float v : image->pixels) {
    finite = finite && std::isfinite(v);
    brightest = std::max(brightest, v);
  }
  CHECK(finite);
  // The lit front of the ball saturates the half-float scene colour (65504) instead of
  // overflowing to infinity and NaN, which drew black.
  CHECK(brightest > 1e4f);
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 33: input paths that are FIFOs, folders or devices are named errors, never a wait") {
  // Each command runs under `timeout`: a reader that waits on a FIFO for a writer (or on
  // /dev/zero for its end) fails this test with exit 124 instead of hanging it.
  const auto dir = temp_dir();
  const auto fifo = [&](const std::string& name) {
    const auto p = dir / name;
    REQUIRE(::mkfifo(p.c_str(), 0600) == 0);
    return p.string();
  };
  const std::string scene_fifo = fifo("fifo.json"), mesh_fifo = fifo("mesh.obj"), stl_fifo = fifo("mesh.stl"),
                    texture_fifo = fifo("texture.png"), hdr_fifo = fifo("sky.hdr"), exr_fifo = fifo("sky.exr"),
                    photo_fifo = fifo("photo.png"), model_fifo = fifo("cloth.wbtf"), btf_fifo = fifo("cloth.btfraw"),
                    gltf_fifo = fifo("model.gltf");
  std::filesystem::create_directories(dir / "folder.obj");
  std::filesystem::create_symlink("/dev/zero", dir / "zero.obj");
  const auto with = [&](const std::string& name, const std::string& meshes, const std::string& materials,
                        const std::string& extra = "") {
    std::ofstream(dir / name) << R"({"version": 1, "output": {"width": 32, "height": 24},
      "camera": {"position": [0, 0, 3], "target": [0, 0, 0]},)" << extra << R"(
      "meshes": )" << meshes << R"(, "materials": )" << materials << R"(,
      "objects": [{"name": "o", "mesh": "m", "material": "a"}]})";
    return (dir / name).string();
  };
  const std::string ball = R"({"m": {"primitive": "sphere", "radius": 0.5, "segments": 8}})";
  const std::string plain = R"({"a": {"type": "standard"}})";
  const auto mesh_at = [](const std::string& p) { return R"({"m": {"path": ")" + p + R"("}})"; };
  struct Case {
    std::string args, path, what;
  };
  const std::vector<Case> cases = {
      {"render " + scene_fifo + " -o OUT", scene_fifo, "is a FIFO, not a regular file"},
      {"graph " + scene_fifo, scene_fifo, "is a FIFO, not a regular file"},
      {"render " + mesh_fifo + " -o OUT", mesh_fifo, "is a FIFO, not a regular file"},
      {"render " + stl_fifo + " -o OUT", stl_fifo, "is a FIFO, not a regular file"},
      {"render " + gltf_fifo + " -o OUT", gltf_fifo, "is a FIFO, not a regular file"},
      {"render " + (dir / "folder.obj").string() + " -o OUT", (dir / "folder.obj").string(), "is a folder"},
      {"render " + (dir / "zero.obj").string() + " -o OUT", (dir / "zero.obj").string(), "is a character device"},
      {"render " + with("mesh.json", mesh_at(mesh_fifo), plain) + " -o OUT", mesh_fifo, "is a FIFO"},
      {"render " + with("zero.json", mesh_at((dir / "zero.obj").string()), plain) + " -o OUT",
       (dir / "zero.obj").string(), "is a character device"},
      {"render " + with("texture.json", ball, R"({"a": {"base_color_texture": ")" + texture_fifo + R"("}})") + " -o OUT",
       texture_fifo, "is a FIFO"},
      {"render " + with("hdr.json", ball, plain, R"("environment": {"hdr": ")" + hdr_fifo + R"("},)") + " -o OUT", hdr_fifo,
       "is a FIFO"},
      {"render " + with("exr.json", ball, plain, R"("environment": {"hdr": ")" + exr_fifo + R"("},)") + " -o OUT", exr_fifo,
       "is a FIFO"},
      {"render " + with("fur.json", ball, R"({"a": {"type": "fur", "photo": ")" + photo_fifo + R"("}})") + " -o OUT",
       photo_fifo, "is a FIFO"},
      {"render " + with("btf.json", ball, R"({"a": {"type": "neural_btf", "model": ")" + model_fifo + R"("}})") + " -o OUT",
       model_fifo, "is a FIFO"},
      {"bake btf " + btf_fifo + " -o " + (dir / "out.wbtf").string(), btf_fifo, "is a FIFO"},
      {"tradeoff " + scene_fifo + " --feature fur", scene_fifo, "is a FIFO"},
      {"view " + with("ok.json", ball, plain) + " --script " + fifo("session.txt"), (dir / "session.txt").string(),
       "is a FIFO"},
  };
  for (const auto& c : cases) {
    const auto out = dir / "out.png";
    std::string args = c.args;
    if (const auto at = args.find("OUT"); at != std::string::npos) args.replace(at, 3, out.string());
    CAPTURE(args);
    const auto r = run_command("timeout 60 " + cli + " " + args + " </dev/null");
    CHECK_MESSAGE(r.exit_code != 124, "timed out: " << r.output);
    CHECK_MESSAGE(r.exit_code != 0, r.output);
    CHECK_MESSAGE(contains(r.output, c.path), r.output);
    CHECK_MESSAGE(contains(r.output, c.what), r.output);
    CHECK_FALSE(std::filesystem::exists(out));
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 33: weft-bench-objects answers --help without work, refuses bad arguments, and its selection agrees") {
  const std::string bench = WEFT_BENCH_OBJECTS;
  const auto help = run_command("timeout 20 " + bench + " --help");
  CHECK(help.exit_code == 0);
  CHECK(contains(help.output, "usage: weft-bench-objects"));
  CHECK_FALSE(contains(help.output, "adapter:"));
  for (const char* args : {"--counts 0", "--counts 100000000000", "--counts 10,,20", "--counts 1e3", "--runs abc", "--runs 0",
                           "--size 0x5", "--size 64", "--mesh cone", "--quality ultra", "--reference-max -1", "--runs",
                           "--frobnicate"}) {
    CAPTURE(args);
    const auto r = run_command("timeout 20 " + bench + " " + args);
    CHECK(r.exit_code == 2);
    CHECK(contains(r.output, "weft-bench-objects: "));
    CHECK_FALSE(contains(r.output, "adapter:"));
  }
  // The selection table alone needs no device: the hierarchy's answer equals the reference's.
  const auto r = run_command("timeout 60 " + bench + " --no-render --mesh quad --counts 10,500 --runs 1");
  CHECK_MESSAGE(r.exit_code == 0, r.output);
  CHECK_MESSAGE(contains(r.output, "| 500 |"), r.output);
  CHECK_MESSAGE(contains(r.output, "| yes |"), r.output);
  CHECK_FALSE(contains(r.output, "| NO |"));
  // And it renders: a few objects, lit and unlit (it once failed to find the default
  // pipeline's pass types, which it had not registered).
  const auto rendered = run_command("timeout 120 " + bench + " --counts 4 --runs 1 --size 16x12 --reference-max 0");
  CHECK_MESSAGE(rendered.exit_code == 0, rendered.output);
  CHECK_MESSAGE(contains(rendered.output, "| 4 | "), rendered.output);
  CHECK_FALSE(contains(rendered.output, "error"));
}

TEST_CASE("weft render --output writes any resource: depth, the shadow map and an intermediate of every feature") {
  const char* source = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE(source);
  const auto dir = temp_dir();
  const std::string showcase = std::string(source) + "/examples/scenes/showcase.json";
  // (resource, what it is): the showcase has all four features.
  const std::vector<std::pair<std::string, std::string>> resources = {
      {"scene.depth", "the camera's depth"},          {"shadow_map.depth", "the key light's depth"},
      {"background.color", "the linear scene colour"}, {"neural_btf_coords", "the neural BTF's G-buffer"},
      {"skin_lut", "the skin's pre-integrated LUT"},  {"synthetic_fur.png.photo", "the fur's photo"}};
  for (const auto& [name, what] : resources) {
    CAPTURE(name);
    const auto png = dir / (name + ".png");
    const auto r = run_command(cli + " render " + showcase + " --quality low --size 96x54 --output " + name + " -o " +
                               png.string());
    CHECK_MESSAGE(r.exit_code == 0, what << ": " << r.output);
    CHECK(contains(r.output, "wrote " + name + " to "));
    CHECK(std::filesystem::exists(png));
  }
  // Linear values to EXR, as they are.
  const auto exr = dir / "depth.exr";
  const auto d = run_command(cli + " render " + showcase + " --quality low --size 96x54 --output scene.depth -o " + exr.string());
  CHECK_MESSAGE(d.exit_code == 0, d.output);
  CHECK(std::filesystem::file_size(exr) > 1000);
  // The SSDF's data are buffers: named, refused.
  const auto b = run_command(cli + " render " + showcase + " --quality low --size 96x54 --output ssdf.irradiance_table -o " +
                             (dir / "b.png").string());
  CHECK(b.exit_code != 0);
  CHECK(contains(b.output, "'ssdf.irradiance_table': that resource is a buffer"));
  const auto u = run_command(cli + " render " + showcase + " --quality low --size 96x54 --output nothing.here -o " +
                             (dir / "u.png").string());
  CHECK(u.exit_code != 0);
  CHECK(contains(u.output, "no pass slot or resource of this frame has that name (slots: shadow_map.depth"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("weft graph check: 0 for a frame that compiles, 1 with every problem; --export-pipeline reads back") {
  const char* source = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE(source);
  const std::string src = source;
  const auto good = run_command(cli + " graph check " + src + "/examples/scenes/default.json --pipeline " + src +
                                "/examples/pipelines/bloom_outline.json");
  CHECK_MESSAGE(good.exit_code == 0, good.output);
  CHECK(contains(good.output, "ok: "));
  const auto bad = run_command(cli + " graph check " + src + "/examples/scenes/default.json --pipeline " + src +
                               "/tests/pipeline/broken/bad_options.json");
  CHECK(bad.exit_code == 1);
  CHECK(contains(bad.output, "3 problems"));
  CHECK(contains(bad.output, "$.passes.tonemap.options.gamma: unknown field"));
  const auto dir = temp_dir();
  const auto exported = dir / "exported.json";
  const auto e = run_command(cli + " graph " + src + "/examples/scenes/default.json --export-pipeline " + exported.string());
  CHECK_MESSAGE(e.exit_code == 0, e.output);
  const auto again = run_command(cli + " graph check " + src + "/examples/scenes/default.json --pipeline " + exported.string());
  CHECK_MESSAGE(again.exit_code == 0, again.output);
  // A plugin that is not one: one line naming the file, exit 2.
  std::ofstream(dir / "fake.so") << "not a shared library";
  const auto p = run_command(cli + " --plugin " + (dir / "fake.so").string() + " info");
  CHECK(p.exit_code == 2);
  CHECK(contains(p.output, "plugin '" + (dir / "fake.so").string() + "': cannot be loaded"));
  const auto missing = run_command(cli + " --plugin " + (dir / "none.so").string() + " info");
  CHECK(missing.exit_code == 2);
  CHECK(contains(missing.output, "no such file"));
  // A shared library that is not a weft plugin (the C maths library has no entry point).
  for (const char* libm : {"/lib/x86_64-linux-gnu/libm.so.6", "/usr/lib/x86_64-linux-gnu/libm.so.6"})
    if (std::filesystem::exists(libm)) {
      const auto m = run_command(cli + " --plugin " + libm + " info");
      CHECK(m.exit_code == 2);
      CHECK(contains(m.output, "no weft plugin entry point"));
      break;
    }
  // From WEFT_PLUGIN_PATH a bad plugin is a warning, and the command still runs.
  const auto env = run_command("WEFT_PLUGIN_PATH=" + dir.string() + " " + cli + " graph check " + src +
                               "/examples/scenes/default.json");
  CHECK_MESSAGE(env.exit_code == 0, env.output);
  CHECK(contains(env.output, "WEFT_PLUGIN_PATH: plugin '"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 33: empty values, negative or huge unsigned numbers, NaN and unknown words are named before any work") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  std::ofstream(dir / "session.txt") << "orbit 10 5\nquality ultra\n";
  REQUIRE(::mkfifo((dir / "pipeline.json").c_str(), 0600) == 0);
  const std::string s = (dir / "s.json").string(), png = " -o " + (dir / "x.png").string();
  const std::string btf = "bake btf --synthetic 4x4 --epochs 1 -o " + (dir / "x.wbtf").string();
  struct Case {
    std::string args, expect;
  };
  for (const auto& c : {
           // An empty value was "not given": the frame rendered without the size or the pipeline.
           Case{"render " + s + png + " --size ''", "weft: --size was given an empty value"},
           Case{"render " + s + png + " --pipeline=", "weft: --pipeline was given an empty value"},
           Case{"render ''" + png, "weft: argument 2 is empty"},
           // CLI11 read unsigned values with strtoull: -1 was 4294967295, 010 eight, 1e23 the largest.
           Case{"render " + s + png + " --frames -1", "--frames: '-1' is not a whole number (decimal digits only)"},
           Case{"bake ssdf " + s + " -o " + (dir / "x.wssdf").string() + " --seed 99999999999999999999999", "is too large"},
           // NaN passed every CLI::Range; --budget-ms nan rendered without a budget.
           Case{"render " + s + png + " --budget-ms nan", "--budget-ms: 'nan' is not a finite number"},
           Case{btf + " --minutes inf", "--minutes: 'inf' is not a finite number"},
           Case{btf + " --threads 100000", "--threads: Value 100000 not in range 0 to 1024"},  // it started 100,000 threads
           // CLI11 said "A subcommand is required" for each of these.
           Case{"--frobnicate info", "weft: unknown option '--frobnicate' before the command"},
           Case{"bake nosuch", "weft bake: unknown bake 'nosuch' (skin-lut"},
           Case{"farm nosuch", "weft farm: unknown farm 'nosuch' (plan, run"},
           // Before the window opens (no display here): the script's quality and a --pipeline FIFO.
           Case{"view " + s + " --script " + (dir / "session.txt").string(), "quality takes low, medium, high or reference, got 'ultra'"},
           Case{"view " + s + " --pipeline " + (dir / "pipeline.json").string(), "is a FIFO, not a regular file"}}) {
    const auto r = run_command("env -u DISPLAY timeout 60 " + cli + " " + c.args + " </dev/null");
    CHECK_MESSAGE(r.exit_code != 0, c.args);
    CHECK_MESSAGE(r.exit_code != 124, "timed out: " << c.args);
    CHECK_MESSAGE(contains(r.output, c.expect), c.args << " -> " << r.output);
  }
  CHECK_FALSE(std::filesystem::exists(dir / "x.png"));
  CHECK_FALSE(std::filesystem::exists(dir / "x.wbtf"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 33: an output that is read-only, a FIFO, a device or on a full disk is refused and left as it was") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  const std::string s = (dir / "s.json").string();
  // A read-only file: root's rename replaced it before.
  const auto ro = dir / "ro.png";
  std::ofstream(ro) << "precious";
  std::filesystem::permissions(ro, std::filesystem::perms::owner_read);
  REQUIRE(::mkfifo((dir / "fifo.png").c_str(), 0600) == 0);
  REQUIRE(::mkfifo((dir / "fifo.dot").c_str(), 0600) == 0);
  std::filesystem::create_symlink("/dev/full", dir / "full.dot");
  struct Case {
    std::string args, expect;
  };
  for (const auto& c : {Case{"render " + s + " -o " + ro.string(), "the file is read-only"},
                        Case{"render " + s + " -o " + (dir / "fifo.png").string(), "it is a FIFO, not a regular file"},
                        // An ofstream opened the FIFO and waited for a reader for ever.
                        Case{"graph " + s + " --dot " + (dir / "fifo.dot").string(), "it is a FIFO, not a regular file"},
                        Case{"graph " + s + " --dot " + (dir / "full.dot").string(), "it is a character device"}}) {
    const auto r = run_command("timeout 60 " + cli + " " + c.args + " </dev/null");
    CHECK_MESSAGE(r.exit_code != 0, c.args);
    CHECK_MESSAGE(r.exit_code != 124, "timed out: " << c.args);
    CHECK_MESSAGE(contains(r.output, c.expect), c.args << " -> " << r.output);
  }
  std::ifstream in(ro);
  std::string kept;
  std::getline(in, kept);
  CHECK(kept == "precious");
  CHECK(std::filesystem::is_fifo(dir / "fifo.png"));
  CHECK(std::filesystem::is_symlink(dir / "full.dot"));
  // A full disk (a 512-byte file-size limit; lavapipe's memfd memory needs no file size, as
  // `weft graph` opens no device): an error, and neither the file nor a temporary is left.
  const auto dot = dir / "big.dot";
  const auto full = run_command("sh -c 'ulimit -f 1; trap \"\" XFSZ; exec " + cli + " graph " + s + " --dump --dot " + dot.string() + "'");
  CHECK(full.exit_code != 0);
  CHECK_MESSAGE(contains(full.output, "cannot write DOT graph '" + dot.string() + "': File too large"), full.output);
  for (const auto& e : std::filesystem::directory_iterator(dir)) CHECK_MESSAGE(e.path().filename().string().find("big.dot") == std::string::npos, e.path());
  // A symlink is written through: the target gets the image, the link stays.
  std::filesystem::create_directories(dir / "renders");
  std::filesystem::create_symlink("renders/frame.png", dir / "latest.png");
  const auto linked = run_command(cli + " render " + s + " -o " + (dir / "latest.png").string());
  CHECK_MESSAGE(linked.exit_code == 0, linked.output);
  CHECK(std::filesystem::is_symlink(dir / "latest.png"));
  CHECK(std::filesystem::file_size(dir / "renders" / "frame.png") > 50);
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 33: a large binary file given as a scene, a pipeline or a script is refused without reading it all") {
  // 3 GiB of zeros (sparse: no disk used) took 10 s to read before the parser's "line 1".
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  for (const char* name : {"big.json", "big.glb", "big.txt"}) {
    std::ofstream(dir / name).close();
    std::filesystem::resize_file(dir / name, std::uintmax_t(3) << 30);
  }
  const std::string big = (dir / "big.json").string();
  for (const std::string& args : {"graph check " + big, "graph check " + (dir / "big.glb").string(),
                                  "graph check " + (dir / "s.json").string() + " --pipeline " + big,
                                  "view " + (dir / "s.json").string() + " --script " + (dir / "big.txt").string()}) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = run_command("env -u DISPLAY timeout 60 " + cli + " " + args);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    CHECK_MESSAGE(r.exit_code != 0, args);
    CHECK_MESSAGE(contains(r.output, "is not a text file (3072.0 MiB, a NUL byte at offset 0)"), args << " -> " << r.output);
    CHECK_MESSAGE(seconds < 5.0, args << ": " << seconds << " s");
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("issue 33: benchmarks and examples refuse bad numbers and unknown words before any work") {
  struct Case {
    std::string program, args, expect;
  };
  for (const auto& c : {Case{WEFT_TRIANGLE, "--size -1x-1", "weft-triangle: --size expects WxH with sides 1..8192, got '-1x-1'"},
                        Case{WEFT_TRIANGLE, "--frobnicate", "weft-triangle: unknown or incomplete argument '--frobnicate'"},
                        // std::stoul's exception ended these ("terminate called"); atoi's 0 ran a benchmark.
                        Case{WEFT_BENCH_BTF_DATA, "--size abc", "weft-bench-btf-data: --size 'abc': expected a whole number"},
                        Case{WEFT_BENCH_BTF_DATA, "--clusters 1,,2", "--clusters '1,,2'"},
                        Case{WEFT_BENCH_BTF_TRAIN, "--texels -1", "weft-bench-btf-train: --texels '-1': expected a whole number 1..65536"},
                        Case{WEFT_BENCH_BTF_TRAIN, "--threads 100000", "--threads '100000'"},
                        Case{WEFT_BENCH_BTF_TRAIN, "--minutes nan", "--minutes 'nan'"},
                        Case{WEFT_BENCH_BTF_INTERPOLATION, "--seed -1", "--seed '-1': expected a whole number"},
                        Case{WEFT_BENCH_SSDF, "--resolution -1", "weft-bench-ssdf: --resolution expects a whole number 1..1024"},
                        Case{WEFT_BENCH_SSDF, "--lighting --samples abc", "--samples expects a whole number"}}) {
    const auto r = run_command("timeout 20 " + c.program + " " + c.args);
    CAPTURE(c.args);
    CHECK(r.exit_code == 2);
    CHECK_MESSAGE(contains(r.output, c.expect), r.output);
    CHECK_FALSE(contains(r.output, "terminate called"));
    CHECK_FALSE(contains(r.output, "4294967295"));
  }
  for (const char* program : {WEFT_BENCH_BTF_DATA, WEFT_BENCH_SSDF}) {
    const auto help = run_command(std::string("timeout 20 ") + program + " --help");
    CHECK(help.exit_code == 0);
    CHECK(contains(help.output, "usage: "));
  }
}
