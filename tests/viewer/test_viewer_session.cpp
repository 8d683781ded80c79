// `weft view` sessions under a real X server (ctest runs this suite under xvfb-run): a
// scripted session under validation and synchronization validation, the viewer's image
// against `weft render`'s, and scene hot reload. Without a display the window tests exit 77,
// which ctest reports as skipped (with the reason printed), never as passed.
#include <doctest/doctest.h>
#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>
#include <sys/stat.h>
#include <unistd.h>
import weft.core;
import weft.image;

namespace fs = std::filesystem;

namespace {

struct Run {
  int code = -1;
  std::string output;
};

Run run(const std::string& command) {
  Run r;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  REQUIRE(pipe);
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), int(buffer.size()), pipe)) r.output += buffer.data();
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// The session's files; removed at exit unless WEFT_KEEP_SCRATCH is set (to look at the screenshots).
struct Scratch {
  fs::path dir = fs::temp_directory_path() / ("weft-viewer-test-" + std::to_string(getpid()));
  Scratch() { fs::create_directories(dir); }
  ~Scratch() {
    std::error_code ec;
    if (!std::getenv("WEFT_KEEP_SCRATCH")) fs::remove_all(dir, ec);
  }
};
fs::path scratch() {
  static const Scratch s;
  return s.dir;
}

void write(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  REQUIRE(out.good());
}

// A ball on a floor under a constant sky: primitives only, so the file can be copied anywhere.
std::string ball_scene(const std::string& ball_color, const std::string& extra_material = "",
                       const std::string& extra_object = "") {
  return R"({"version": 1, "output": {"width": 160, "height": 120},
  "camera": {"position": [0, 0.6, 2.2], "target": [0, 0.3, 0], "fov": 40, "near": 0.05, "far": 20},
  "environment": {"color": [0.2, 0.25, 0.3]},
  "lights": [{"type": "directional", "direction": [-0.5, -1, -0.4], "intensity": 3}],
  "meshes": {"ball": {"primitive": "sphere", "radius": 0.3, "segments": 32},
             "small": {"primitive": "sphere", "radius": 0.1, "segments": 32},
             "floor": {"primitive": "plane", "size": 4, "subdivisions": 1}},
  "materials": {"ball": {"base_color": )" + ball_color + R"(, "roughness": 0.4},
                "floor": {"base_color": [0.5, 0.5, 0.5]})" + extra_material + R"(},
  "objects": [{"name": "ball", "mesh": "ball", "material": "ball", "transform": {"translation": [0, 0.3, 0]}},
              {"name": "floor", "mesh": "floor", "material": "floor"})" + extra_object + R"(]})";
}

// ball_scene with a second ball in skin: `mesh` ("small" or "ball") at `at`.
std::string skin_scene(const std::string& mm_per_unit, const std::string& mesh, const std::string& at) {
  return ball_scene("[0.8, 0.1, 0.05]",
                    R"(, "skin": {"type": "skin", "albedo": [0.84, 0.6, 0.5], "mm_per_unit": )" + mm_per_unit + "}",
                    R"(, {"name": "skin ball", "mesh": ")" + mesh + R"(", "material": "skin", "transform": {"translation": )" +
                        at + "}}");
}

std::string weft_cli() { return WEFT_CLI; }

void require_display() {
  const char* display = std::getenv("DISPLAY");
  if (display && *display) return;
  std::printf("SKIPPED: no X display (DISPLAY is unset); ctest runs this suite under xvfb-run -a when Xvfb is "
              "installed (apt install xvfb xauth)\n");
  std::fflush(stdout);
  std::_Exit(77);
}

// The largest per-channel difference and the mean absolute difference (0..255) of two PNGs.
struct Difference {
  int max = 0;
  double mean = 0.0;
};
Difference difference(const fs::path& a, const fs::path& b) {
  auto x = weft::image::load_png(a);
  auto y = weft::image::load_png(b);
  REQUIRE_MESSAGE(x, a.string());
  REQUIRE_MESSAGE(y, b.string());
  REQUIRE(x->width == y->width);
  REQUIRE(x->height == y->height);
  Difference d;
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < std::size_t(x->width) * x->height; ++i)
    for (std::uint32_t c = 0; c < 3; ++c) {
      const int v = std::abs(int(x->pixels[i * x->channels + c]) - int(y->pixels[i * y->channels + c]));
      d.max = std::max(d.max, v);
      sum += v;
      ++n;
    }
  d.mean = sum / double(n);
  return d;
}

// Mean of one channel over the centre tenth of the image (where the ball is).
double centre_mean(const fs::path& path, int channel) {
  auto img = weft::image::load_png(path);
  REQUIRE(img);
  double sum = 0;
  int n = 0;
  for (std::uint32_t y = img->height * 9 / 20; y < img->height * 11 / 20; ++y)
    for (std::uint32_t x = img->width * 9 / 20; x < img->width * 11 / 20; ++x, ++n)
      sum += img->pixels[(std::size_t(y) * img->width + x) * img->channels + channel];
  return sum / n;
}

}  // namespace

TEST_CASE("without a display weft view says so in one line, points to weft render, and exits non-zero") {
  write(scratch() / "plain.json", ball_scene("[0.8, 0.1, 0.05]"));
  auto r = run("env -u DISPLAY " + weft_cli() + " view " + (scratch() / "plain.json").string());
  CHECK(r.code != 0);
  CHECK(r.output.find("weft view: no display") != std::string::npos);
  CHECK(r.output.find("weft render") != std::string::npos);
  CHECK(std::count(r.output.begin(), r.output.end(), '\n') == 1);

  auto missing = run(weft_cli() + " view " + (scratch() / "missing.json").string());
  CHECK(missing.code == 1);
  CHECK(missing.output.find("missing.json") != std::string::npos);

  write(scratch() / "bad.txt", "orbit 10 0\nspin 3\n");
  auto bad = run(weft_cli() + " view " + (scratch() / "plain.json").string() + " --script " + (scratch() / "bad.txt").string());
  CHECK(bad.code == 1);
  CHECK(bad.output.find("bad.txt:2: unknown command 'spin'") != std::string::npos);
}

TEST_CASE("a scripted session (camera, knob, tiny and large resize, minimise, restore, screenshot) has no validation message") {
  require_display();
  write(scratch() / "session.json", skin_scene("1000", "small", "[0.5, 0.1, 0.3]"));
  const fs::path shot = scratch() / "session.png";
  write(scratch() / "session.txt", "orbit 20 0\norbit 20 5\nzoom 0.8\npan 0.05 0\nfly 0.1 0 0\nreset\n"
                                   "knob skin lut.size 32\nknob skin lut.range \"full\"\nquality medium\nwait 2\n"
                                   "resize 8 6\nwait 2\nresize 640 480\nwait 2\n"
                                   "minimize\nwait 3\nrestore\nwait 2\nrefine\nscreenshot " + shot.string() + "\nquit\n");
  auto r = run("WEFT_VALIDATION=1 WEFT_SYNC_VALIDATION=1 " + weft_cli() + " view " + (scratch() / "session.json").string() +
               " --size 200x150 --quality low --script " + (scratch() / "session.txt").string());
  INFO(r.output);
  CHECK(r.code == 0);
  CHECK(r.output.find("weft view: 0 validation message(s)") != std::string::npos);
  CHECK(r.output.find("1 screenshot(s)") != std::string::npos);
  auto image = weft::image::load_png(shot);
  REQUIRE(image);
  CHECK(image->width == 640);
  CHECK(image->height == 480);
}

TEST_CASE("the viewer's image with the UI hidden is weft render's image of the same scene, camera and size") {
  require_display();
  write(scratch() / "same.json", ball_scene("[0.8, 0.1, 0.05]"));
  const fs::path viewed = scratch() / "viewed.png", rendered = scratch() / "rendered.png";
  write(scratch() / "same.txt", "ui off\nrefine\nscreenshot " + viewed.string() + "\nquit\n");
  auto v = run(weft_cli() + " view " + (scratch() / "same.json").string() + " --size 160x120 --script " +
               (scratch() / "same.txt").string());
  INFO(v.output);
  REQUIRE(v.code == 0);
  auto r = run(weft_cli() + " render " + (scratch() / "same.json").string() + " --size 160x120 -o " + rendered.string());
  INFO(r.output);
  REQUIRE(r.code == 0);
  // Tolerance: the same renderer on the same adapter, copied 1:1 into the window's BGRA
  // texture and read back, so no channel may differ by more than one step.
  const Difference d = difference(viewed, rendered);
  CHECK(d.max <= 1);
  CHECK(d.mean < 0.01);
}

TEST_CASE("a still view refines by accumulation: settled, it is weft render --accumulate's image; a camera move starts again") {
  require_display();
  write(scratch() / "refine.json", ball_scene("[0.8, 0.1, 0.05]"));
  const fs::path first = scratch() / "refine_first.png", settled = scratch() / "refine_settled.png",
                 moved = scratch() / "refine_moved.png", rendered = scratch() / "refine_rendered.png",
                 single = scratch() / "refine_single.png";
  // A script's view does not accumulate until it says so: refined is one frame (sample 0).
  // Then 8 samples, settled; an orbit there and back is the same view, which refines again
  // from its first sample to the same 8.
  write(scratch() / "refine.txt", "ui off\nrefine\nscreenshot " + first.string() + "\naccumulate 8\nsettle\nscreenshot " +
                                      settled.string() + "\norbit 5 0\norbit -5 0\nsettle\nscreenshot " + moved.string() +
                                      "\nquit\n");
  auto v = run(weft_cli() + " view " + (scratch() / "refine.json").string() + " --size 160x120 --script " +
               (scratch() / "refine.txt").string());
  INFO(v.output);
  REQUIRE(v.code == 0);
  CHECK(v.output.find("3 screenshot(s)") != std::string::npos);
  const std::string source = std::getenv("WEFT_SOURCE_DIR");
  auto r = run(weft_cli() + " render " + (scratch() / "refine.json").string() + " --size 160x120 --pipeline " + source +
               "/examples/pipelines/accumulate.json --accumulate 8 -o " + rendered.string());
  INFO(r.output);
  REQUIRE(r.code == 0);
  auto one = run(weft_cli() + " render " + (scratch() / "refine.json").string() + " --size 160x120 -o " + single.string());
  REQUIRE(one.code == 0);
  // Settled: the mean of the same 8 jittered samples weft render averages.
  const Difference settled_vs_render = difference(settled, rendered);
  CHECK(settled_vs_render.max <= 1);
  // Its first refined frame is the frame without accumulation (sample 0: no jitter)...
  CHECK(difference(first, single).max <= 1);
  // ...which the accumulation changed along the ball's edge.
  CHECK(difference(settled, first).max > 8);
  // After the move the accumulation started again and reached the same mean (an orbit there
  // and back may move the camera by a rounding error: within two steps).
  CHECK(difference(moved, settled).max <= 2);
}

TEST_CASE("hot reload: a changed colour shows, invalid JSON is reported and the frame kept, a fix recovers") {
  require_display();
  const fs::path live = scratch() / "live.json";
  write(scratch() / "red.json", ball_scene("[0.8, 0.1, 0.05]"));
  write(scratch() / "blue.json", ball_scene("[0.05, 0.1, 0.8]"));
  write(scratch() / "broken.json", "{\"version\": 1, \"objects\": [ oops");
  fs::copy_file(scratch() / "red.json", live, fs::copy_options::overwrite_existing);
  auto shot = [&](const char* name) { return (scratch() / name).string(); };
  write(scratch() / "reload.txt", "ui off\nrefine\nscreenshot " + shot("a.png") + "\n" +
                                  "copy " + shot("blue.json") + " " + live.string() + "\nwait 3\nrefine\nscreenshot " + shot("b.png") + "\n" +
                                  "copy " + shot("broken.json") + " " + live.string() + "\nwait 3\nrefine\nscreenshot " + shot("c.png") + "\n" +
                                  "copy " + shot("red.json") + " " + live.string() + "\nwait 3\nrefine\nscreenshot " + shot("d.png") + "\nquit\n");
  auto r = run(weft_cli() + " view " + live.string() + " --size 160x120 --script " + (scratch() / "reload.txt").string());
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("4 screenshot(s)") != std::string::npos);
  // Red ball, then blue: the centre's blue channel rises and its red falls.
  CHECK(centre_mean(shot("b.png"), 2) > centre_mean(shot("a.png"), 2) + 40);
  CHECK(centre_mean(shot("b.png"), 0) < centre_mean(shot("a.png"), 0) - 40);
  // The broken file: its error names the file, and the last good frame stays.
  CHECK(r.output.find("reload of " + live.string() + " failed") != std::string::npos);
  CHECK(difference(shot("b.png"), shot("c.png")).max == 0);
  // Fixed again: back to the first image.
  CHECK(difference(shot("a.png"), shot("d.png")).max <= 1);
}

TEST_CASE("issue 33: hot reload to a scene whose mesh is a FIFO is an error naming it; the frame stays, nothing waits") {
  require_display();
  const fs::path live = scratch() / "fifo_live.json", fifo = scratch() / "fifo_mesh.obj";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  std::string with_fifo = ball_scene("[0.05, 0.1, 0.8]");
  const std::string primitive = R"({"primitive": "sphere", "radius": 0.3, "segments": 32})";
  with_fifo.replace(with_fifo.find(primitive), primitive.size(), R"({"path": ")" + fifo.string() + R"("})");
  write(scratch() / "fifo_red.json", ball_scene("[0.8, 0.1, 0.05]"));
  write(scratch() / "fifo_scene.json", with_fifo);
  fs::copy_file(scratch() / "fifo_red.json", live, fs::copy_options::overwrite_existing);
  auto shot = [&](const char* name) { return (scratch() / name).string(); };
  write(scratch() / "fifo.txt", "ui off\nrefine\nscreenshot " + shot("f_a.png") + "\n" +
                                "copy " + shot("fifo_scene.json") + " " + live.string() + "\nwait 3\nrefine\nscreenshot " + shot("f_b.png") + "\nquit\n");
  // `timeout`: a viewer that waits on the FIFO fails here (124) instead of hanging the suite.
  auto r = run("timeout 120 " + weft_cli() + " view " + live.string() + " --size 160x120 --script " + (scratch() / "fifo.txt").string());
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("2 screenshot(s)") != std::string::npos);
  CHECK(r.output.find("reload of " + live.string() + " failed") != std::string::npos);
  CHECK(r.output.find(fifo.string() + "' is a FIFO, not a regular file") != std::string::npos);
  CHECK(difference(shot("f_a.png"), shot("f_b.png")).max == 0);  // the last good frame
}

TEST_CASE("issue 33: a script line with NaN or infinity is refused before the window opens") {
  write(scratch() / "nan.txt", "orbit 10 0\norbit nan nan\nquit\n");
  write(scratch() / "nan.json", ball_scene("[0.8, 0.1, 0.05]"));
  auto r = run("timeout 60 " + weft_cli() + " view " + (scratch() / "nan.json").string() + " --size 160x120 --script " +
               (scratch() / "nan.txt").string());
  INFO(r.output);
  CHECK(r.code != 0);
  CHECK(r.code != 124);
  CHECK(r.output.find("nan.txt:2: 'orbit' expects finite numbers, got 'nan'") != std::string::npos);
}

TEST_CASE("compare with reference: the reference setting against itself is exact, a coarse skin LUT is not") {
  require_display();
  write(scratch() / "compare.json", skin_scene("100", "ball", "[0.45, 0.3, 0.2]"));
  const fs::path same = scratch() / "overlay_same.png", coarse = scratch() / "overlay_coarse.png";
  write(scratch() / "compare.txt", "ui off\nknob skin reference true\nrefine\ncompare skin\noverlay on\nscreenshot " +
                                   same.string() + "\noverlay off\n"
                                   "knob skin reference false\nknob skin lut.size 4\nknob skin lut.samples 4\nrefine\n"
                                   "compare skin\noverlay on\nscreenshot " + coarse.string() + "\nquit\n");
  auto r = run(weft_cli() + " view " + (scratch() / "compare.json").string() + " --size 160x120 --quality low --script " +
               (scratch() / "compare.txt").string());
  INFO(r.output);
  REQUIRE(r.code == 0);
  std::vector<double> rmse;
  for (std::size_t at = r.output.find("compare skin (skin_sss): RMSE "); at != std::string::npos;
       at = r.output.find("compare skin (skin_sss): RMSE ", at + 1))
    rmse.push_back(std::stod(r.output.substr(at + std::strlen("compare skin (skin_sss): RMSE "))));
  REQUIRE(rmse.size() == 2);
  CHECK(rmse[0] == 0.0);  // the reference against itself
  CHECK(r.output.find("PSNR inf dB") != std::string::npos);
  CHECK(rmse[1] > 1e-4);  // a 4x4 LUT of 4 samples differs from the brute-force scattering
  CHECK(rmse[1] < 0.5);
  // The difference overlay: black where the images agree, so all black for the first.
  auto brightest = [](const fs::path& path) {
    auto img = weft::image::load_png(path);
    REQUIRE(img);
    int most = 0;
    for (std::size_t i = 0; i < img->pixels.size(); ++i)
      if (i % img->channels < 3) most = std::max(most, int(img->pixels[i]));
    return most;
  };
  CHECK(brightest(same) == 0);
  CHECK(brightest(coarse) > 0);
}

TEST_CASE("the frame-time budget: a budget above everything takes the best presets, one below the cheapest says so") {
  require_display();
  write(scratch() / "budget.json", skin_scene("100", "ball", "[0.45, 0.3, 0.2]"));
  const fs::path fitted = scratch() / "budget.png";
  write(scratch() / "budget.txt", "ui off\nrefine\nbudget 1000000\nrefine\nscreenshot " + fitted.string() +
                                  "\nbudget 0.001\nrefine\nquit\n");
  auto r = run("WEFT_VALIDATION=1 WEFT_SYNC_VALIDATION=1 " + weft_cli() + " view " + (scratch() / "budget.json").string() +
               " --size 160x120 --script " + (scratch() / "budget.txt").string());
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("weft view: 0 validation message(s)") != std::string::npos);
  // One feature (skin_sss) in the scene: the best level within a huge budget...
  CHECK(r.output.find("budget: skin_sss=preset high: ") != std::string::npos);
  // ...and the cheapest, reported as not met, within one nothing meets.
  CHECK(r.output.find("budget: skin_sss=preset low: ") != std::string::npos);
  CHECK(r.output.find("cannot be met") != std::string::npos);
  CHECK(r.output.find("1 screenshot(s)") != std::string::npos);
}

TEST_CASE("shader hot reload: an edited tone map shows, a shader that does not compile is reported and the frame kept, a fix recovers") {
  require_display();
  const char* root = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE(root);
  std::ifstream in(fs::path(root) / "passes/tonemap/tonemap.frag");
  REQUIRE(in);
  const std::string original{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  // The edit: the shader's own main() runs, then its output is painted pure red.
  const std::size_t main_at = original.find("void main()");
  REQUIRE(main_at != std::string::npos);
  REQUIRE(original.find("out vec4 out_color;") != std::string::npos);
  const std::string red = original.substr(0, main_at) + "void original_main()" + original.substr(main_at + 11) +
                          "\nvoid main() { original_main(); out_color = vec4(1.0, 0.0, 0.0, 1.0); }\n";
  const fs::path dir = scratch() / "shaders";
  fs::create_directories(dir);
  write(dir / "tonemap.frag", original);
  write(scratch() / "tonemap_red.frag", red);
  write(scratch() / "tonemap_broken.frag", original + "\nthis is not GLSL\n");
  write(scratch() / "tonemap_original.frag", original);
  write(scratch() / "shader.json", ball_scene("[0.1, 0.6, 0.1]"));
  auto shot = [&](const char* name) { return (scratch() / name).string(); };
  const std::string live = (dir / "tonemap.frag").string();
  write(scratch() / "shader.txt", "ui off\nrefine\nscreenshot " + shot("s_a.png") + "\n" +
                                  "copy " + shot("tonemap_red.frag") + " " + live + "\nwait 3\nrefine\nscreenshot " + shot("s_b.png") + "\n" +
                                  "copy " + shot("tonemap_broken.frag") + " " + live + "\nwait 3\nrefine\nscreenshot " + shot("s_c.png") + "\n" +
                                  "copy " + shot("tonemap_original.frag") + " " + live + "\nwait 3\nrefine\nscreenshot " + shot("s_d.png") + "\nquit\n");
  auto r = run("WEFT_VALIDATION=1 WEFT_SYNC_VALIDATION=1 " + weft_cli() + " view " + (scratch() / "shader.json").string() +
               " --size 160x120 --shader-dir " + dir.string() + " --script " + (scratch() / "shader.txt").string());
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("weft view: 0 validation message(s)") != std::string::npos);
  CHECK(r.output.find("4 screenshot(s)") != std::string::npos);
  // The red tone map: every pixel red.
  CHECK(centre_mean(shot("s_b.png"), 0) == 255.0);
  CHECK(centre_mean(shot("s_b.png"), 1) == 0.0);
  CHECK(centre_mean(shot("s_a.png"), 1) > 60.0);  // the green ball before
  // The broken shader: one line naming it and glslang's error; the red frame stays.
  CHECK(r.output.find("shader reload failed: shader tonemap.frag: ERROR") != std::string::npos);
  CHECK(difference(shot("s_b.png"), shot("s_c.png")).max == 0);
  // The original again: the first image.
  CHECK(difference(shot("s_a.png"), shot("s_d.png")).max <= 1);
}

TEST_CASE("a pipeline file reloads live (a bad edit keeps the frame), and any resource shows in the window") {
  require_display();
  const fs::path live = scratch() / "frame_pipeline.json";
  const fs::path source = WEFT_SOURCE_DIR;
  write(scratch() / "pipeline_scene.json", ball_scene("[0.8, 0.1, 0.05]"));
  fs::copy_file(source / "assets/pipelines/default.json", live, fs::copy_options::overwrite_existing);
  write(scratch() / "cycle.json", R"({"passes": {"a": {"type": "tonemap"}}, "connections": ["a.color -> a.color"],
                                     "outputs": ["a.color"]})");
  auto shot = [&](const char* name) { return (scratch() / name).string(); };
  const std::string normals = (source / "examples/pipelines/debug_normals.json").string();
  write(scratch() / "pipeline.txt",
        "ui off\nrefine\nscreenshot " + shot("p_default.png") + "\n" +
        "copy " + normals + " " + live.string() + "\nwait 3\nrefine\nscreenshot " + shot("p_normals.png") + "\n" +
        "copy " + shot("cycle.json") + " " + live.string() + "\nwait 3\nrefine\nscreenshot " + shot("p_broken.png") + "\n" +
        "copy " + (source / "assets/pipelines/default.json").string() + " " + live.string() +
        "\nwait 3\nrefine\nscreenshot " + shot("p_back.png") + "\n" +
        "show scene.depth\nwait 2\nrefine\nscreenshot " + shot("p_depth.png") + "\n" +
        "show frame\nwait 2\nrefine\nscreenshot " + shot("p_frame.png") + "\nquit\n");
  auto r = run(weft_cli() + " view " + (scratch() / "pipeline_scene.json").string() + " --pipeline " + live.string() +
               " --size 160x120 --script " + (scratch() / "pipeline.txt").string());
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("6 screenshot(s)") != std::string::npos);
  // The normals view is another picture: the sky turns black, the ball's centre faces the camera.
  CHECK(difference(shot("p_default.png"), shot("p_normals.png")).mean > 20.0);
  // The cycle is the frame's error, naming the file; the last good image stays.
  CHECK(r.output.find(live.string()) != std::string::npos);
  CHECK(r.output.find("feed each other in a cycle") != std::string::npos);
  CHECK(difference(shot("p_normals.png"), shot("p_broken.png")).max == 0);
  // Back to the default pipeline: the first image again.
  CHECK(difference(shot("p_default.png"), shot("p_back.png")).max <= 1);
  // The depth shows as grey (every channel equal): the ball drawn light (the floor's near edge
  // is nearer still, so not white), the sky above it black (nothing drawn).
  auto depth = weft::image::load_png(shot("p_depth.png"));
  REQUIRE(depth);
  const std::size_t centre = (std::size_t(depth->height / 2) * depth->width + depth->width / 2) * depth->channels;
  CHECK(depth->pixels[centre] > 100);
  CHECK(depth->pixels[0] == 0);
  CHECK(depth->pixels[centre] == depth->pixels[centre + 1]);
  CHECK(depth->pixels[centre] == depth->pixels[centre + 2]);
  CHECK(difference(shot("p_default.png"), shot("p_frame.png")).max <= 1);
}

TEST_CASE("a pass option set in the viewer (the Pipeline panel's `option`) renders as the same option in a pipeline file; a bad value is named and the frame kept") {
  require_display();
  const fs::path source = WEFT_SOURCE_DIR;
  write(scratch() / "option_scene.json", ball_scene("[0.8, 0.1, 0.05]"));
  auto shot = [&](const char* name) { return (scratch() / name).string(); };
  write(scratch() / "option.txt", "ui off\nrefine\nscreenshot " + shot("o_default.png") +
                                      "\noption tonemap exposure 2.5\nwait 2\nrefine\nscreenshot " + shot("o_bright.png") +
                                      "\noption tonemap exposure 1e9\nwait 2\nrefine\nscreenshot " + shot("o_refused.png") +
                                      "\nquit\n");
  auto v = run(weft_cli() + " view " + (scratch() / "option_scene.json").string() + " --size 160x120 --script " +
               (scratch() / "option.txt").string());
  INFO(v.output);
  REQUIRE(v.code == 0);
  CHECK(v.output.find("3 screenshot(s)") != std::string::npos);
  // The out-of-range value is refused at its JSON path, as the pipeline reader refuses it; the
  // frame stays as it was.
  CHECK(v.output.find("$.passes.tonemap.options.exposure") != std::string::npos);
  CHECK(difference(shot("o_bright.png"), shot("o_refused.png")).max == 0);
  // The same option in a pipeline file, through weft render: the same image.
  write(scratch() / "bright.json", R"({"passes": {"shadow_map": {"type": "shadow_map"}, "scene": {"type": "scene_color"},
    "background": {"type": "background"}, "tonemap": {"type": "tonemap", "options": {"exposure": 2.5}}},
    "connections": ["shadow_map.depth -> scene.shadow_map", "scene.color -> background.color",
                    "scene.depth -> background.depth", "background.color -> tonemap.color"],
    "outputs": ["tonemap.color"]})");
  auto r = run(weft_cli() + " render " + (scratch() / "option_scene.json").string() + " --size 160x120 --pipeline " +
               (scratch() / "bright.json").string() + " -o " + shot("o_rendered.png"));
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(difference(shot("o_bright.png"), shot("o_rendered.png")).max <= 1);
  CHECK(difference(shot("o_default.png"), shot("o_bright.png")).mean > 10.0);  // the option did something
}

TEST_CASE("scene frames on the window's device (--scene-device shared) or on their own: weft render's image, no validation message, compare works") {
  require_display();
  const fs::path scene = scratch() / "devices.json", rendered = scratch() / "devices_rendered.png";
  write(scene, skin_scene("100", "ball", "[0.45, 0.3, 0.2]"));
  auto r = run(weft_cli() + " render " + scene.string() + " --size 160x120 --quality low -o " + rendered.string());
  INFO(r.output);
  REQUIRE(r.code == 0);
  for (const std::string mode : {"shared", "own"}) {
    CAPTURE(mode);
    const fs::path shot = scratch() / ("devices_" + mode + ".png"), script = scratch() / ("devices_" + mode + ".txt");
    // Moves (small frames), a resize both ways (new frame textures), then the refined frame
    // and a comparison (on a shared device its pixels are read from the texture).
    write(script, "orbit 20 0\norbit 10 5\nresize 200 150\nwait 2\nresize 160 120\nwait 2\nreset\nui off\nrefine\n"
                  "screenshot " + shot.string() + "\nknob skin reference true\nrefine\ncompare skin\nquit\n");
    auto v = run("WEFT_VALIDATION=1 WEFT_SYNC_VALIDATION=1 " + weft_cli() + " view " + scene.string() +
                 " --size 160x120 --quality low --scene-device " + mode + " --script " + script.string());
    INFO(v.output);
    CHECK(v.code == 0);
    CHECK(v.output.find("weft view: 0 validation message(s)") != std::string::npos);
    CHECK(v.output.find(mode == "shared" ? "scene frames on the window's device" : "scene frames on a device of their own") !=
          std::string::npos);
    CHECK(v.output.find("compare skin (skin_sss): RMSE 0.000000, PSNR inf dB") != std::string::npos);
    const Difference d = difference(shot, rendered);
    CHECK(d.max <= 1);
    CHECK(d.mean < 0.01);
  }
  auto bad = run(weft_cli() + " view " + scene.string() + " --scene-device both");
  CHECK(bad.code != 0);
  CHECK(bad.output.find("--scene-device") != std::string::npos);
}
