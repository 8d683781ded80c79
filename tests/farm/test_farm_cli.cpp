// `weft tradeoff --farm local` and `weft farm` as a user meets them, with the real binary: the
// farm's errors equal the serial run's byte for byte, costs come as ratios, a second run skips
// every task, a missing task is named with its log and no table is written, bad input is one
// line naming what is wrong, and every subcommand answers --help.
#include <doctest/doctest.h>
#include "../support/run_command.h"
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>
#include <unistd.h>

namespace {
namespace fs = std::filesystem;
using weft::test::run_command;
const std::string cli = WEFT_CLI;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::string read(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Naive CSV split (the fields tested here hold no quoted commas except "values", which is
// kept whole by joining on the quote).
std::vector<std::string> fields(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') quoted = !quoted;
    if (c == ',' && !quoted) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

// setting label -> the error columns (rmse_linear .. pixels), as text.
std::map<std::string, std::string> errors(const std::string& csv, std::vector<std::string>* header = nullptr) {
  std::map<std::string, std::string> out;
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);
  const auto head = fields(line);
  if (header) *header = head;
  std::size_t first = 0;
  for (std::size_t i = 0; i < head.size(); ++i)
    if (head[i] == "rmse_linear") first = i;
  while (std::getline(in, line)) {
    const auto f = fields(line);
    std::string e;
    for (std::size_t i = first; i < first + 6 && i < f.size(); ++i) e += f[i] + ",";
    out[f[1]] = e;
  }
  return out;
}

struct Fixture {
  fs::path dir, scene, cache;
  Fixture() {
    dir = fs::temp_directory_path() / ("weft-farm-cli-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const char* source = std::getenv("WEFT_SOURCE_DIR");
    REQUIRE(source);
    const auto photo = fs::path(source) / "examples/fur/synthetic_fur.png";
    scene = dir / "fur.json";
    std::ofstream(scene) << R"({"version": 1, "output": {"width": 32, "height": 24},
      "camera": {"position": [0, 0.4, 2], "target": [0, 0, 0]},
      "lights": [{"type": "directional", "direction": [-0.5, -1, -0.4], "intensity": 2}],
      "environment": {"color": [0.2, 0.2, 0.2]},
      "meshes": {"ball": {"primitive": "sphere", "radius": 0.5, "segments": 16}},
      "materials": {"fur": {"type": "fur", "photo": ")" << photo.string() << R"(", "layers": 4, "wrap": "repeat"}},
      "objects": [{"name": "ball", "mesh": "ball", "material": "fur"}]})";
    cache = dir / "cache";
  }
  ~Fixture() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  [[nodiscard]] std::string study() const {
    return cli + " tradeoff " + scene.string() + " --feature fur --frames 1 --values layers=1,2 --values fin_threshold=0.5 --cross fins=true,false --cross layers=4,8";
  }
};
}  // namespace

TEST_CASE("weft tradeoff --farm local -j 2: the serial run's errors byte for byte, costs as ratios, skips, a missing task named") {
  Fixture f;
  const auto serial = run_command(f.study() + " -o " + (f.dir / "serial").string());
  REQUIRE_MESSAGE(serial.exit_code == 0, serial.output);
  const auto farmed = run_command(f.study() + " --farm local -j 2 --cache " + f.cache.string() + " -o " + (f.dir / "farm").string());
  REQUIRE_MESSAGE(farmed.exit_code == 0, farmed.output);
  std::vector<std::string> header;
  const auto a = errors(read(f.dir / "serial/tradeoff.csv"));
  const auto b = errors(read(f.dir / "farm/tradeoff.csv"), &header);
  CHECK(a.size() >= 8);
  CHECK(a.count("fins=false layers=8") == 1);  // a crossed setting
  CHECK(a == b);
  CHECK(header.back() == "node");
  CHECK(header[header.size() - 2] == "cost_ratio");
  CHECK(contains(read(f.dir / "farm/tradeoff.md"), "cost ratio"));
  CHECK(contains(read(f.dir / "farm/tradeoff.svg"), "</svg>"));
  CHECK(read(f.dir / "farm/reference.png") == read(f.dir / "serial/reference.png"));
  // the medium preset is the baseline: its ratio to itself is about 1
  {
    std::istringstream in(read(f.dir / "farm/tradeoff.csv"));
    std::string line;
    bool seen = false;
    while (std::getline(in, line))
      if (contains(line, "preset medium")) {
        const auto fl = fields(line);
        const double ratio = std::stod(fl[fl.size() - 2]);
        CHECK(ratio > 0.3);
        CHECK(ratio < 3.0);
        seen = true;
      }
    CHECK(seen);
  }

  // Several settings per task and no baseline: the same errors, and then the serial run's columns.
  const auto batched = run_command(f.study() + " --farm local -j 2 --batch 5 --baseline none --cache " + (f.dir / "cache-b").string() +
                                   " -o " + (f.dir / "batched").string());
  REQUIRE_MESSAGE(batched.exit_code == 0, batched.output);
  std::vector<std::string> plain, serial_header;
  CHECK(errors(read(f.dir / "batched/tradeoff.csv"), &plain) == a);
  errors(read(f.dir / "serial/tradeoff.csv"), &serial_header);
  CHECK(plain == serial_header);
  const std::size_t units = a.size() + 2;  // the settings and the two coverage frames
  CHECK_MESSAGE(contains(batched.output, "farm: " + std::to_string((units + 4) / 5) + " tasks"), batched.output);
  CHECK(contains(farmed.output, "farm: " + std::to_string(units) + " tasks"));
  const auto bad_baseline = run_command(f.study() + " --farm local --baseline ultra --cache " + (f.dir / "cache-x").string());
  CHECK(bad_baseline.exit_code != 0);
  CHECK(contains(bad_baseline.output, "--baseline 'ultra'"));

  // Again: every task is in the cache, nothing renders, the same report.
  const auto again = run_command(f.study() + " --farm local -j 2 --cache " + f.cache.string() + " -o " + (f.dir / "farm2").string());
  REQUIRE_MESSAGE(again.exit_code == 0, again.output);
  CHECK(contains(again.output, "already in the cache"));
  CHECK(read(f.dir / "farm2/tradeoff.csv") == read(f.dir / "farm/tradeoff.csv"));

  // The task list names each task's command and outputs; a missing output is named by the reduce.
  const auto list_file = f.dir / "tasks.json";
  const auto listed = run_command(f.study() + " --tasks " + list_file.string() + " --cache " + f.cache.string() + " -o " +
                                  (f.dir / "farm3").string());
  REQUIRE_MESSAGE(listed.exit_code == 0, listed.output);
  const std::string list = read(list_file);
  CHECK(contains(list, "\"--task\""));
  CHECK(contains(list, "--from-cache"));
  const auto pos = list.find("tradeoff/");
  REQUIRE(pos != std::string::npos);
  const std::string id = list.substr(pos + 9, 16);
  fs::remove(f.cache / "tradeoff" / (id + ".json"));
  const auto reduced = run_command(f.study() + " --from-cache " + f.cache.string() + " -o " + (f.dir / "partial").string());
  CHECK(reduced.exit_code != 0);
  CHECK_MESSAGE(contains(reduced.output, "1 of"), reduced.output);
  CHECK(contains(reduced.output, id));
  CHECK(contains(reduced.output, "no table was written"));
  CHECK(contains(reduced.output, (f.cache / "logs" / (id + ".log")).string()));
  CHECK_FALSE(fs::exists(f.dir / "partial/tradeoff.csv"));
  // weft farm reduce says the same before running anything; weft farm run recomputes just that task
  const auto rerun = run_command(cli + " farm run " + list_file.string() + " --farm local -j 2");
  CHECK_MESSAGE(rerun.exit_code == 0, rerun.output);
  CHECK(contains(rerun.output, "already in the cache"));
  CHECK(fs::exists(f.cache / "tradeoff" / (id + ".json")));
  CHECK(errors(read(f.dir / "farm3/tradeoff.csv")) == a);
}

TEST_CASE("weft tradeoff --extremes: the stability sweep's settings as tasks, the serial run's errors") {
  Fixture f;
  const std::string study = cli + " tradeoff " + f.scene.string() + " --feature fur --frames 1 --extremes --base layers=4";
  const auto serial = run_command(study + " -o " + (f.dir / "serial").string());
  REQUIRE_MESSAGE(serial.exit_code == 0, serial.output);
  const auto farmed = run_command(study + " --farm local -j 2 --batch 3 --cache " + f.cache.string() + " -o " + (f.dir / "farm").string());
  REQUIRE_MESSAGE(farmed.exit_code == 0, farmed.output);
  const auto a = errors(read(f.dir / "serial/tradeoff.csv"));
  CHECK(a.count("layers=1") == 1);    // the knob's minimum
  CHECK(a.count("layers=256") == 1);  // and maximum
  CHECK(a == errors(read(f.dir / "farm/tradeoff.csv")));
  for (const auto& [args, expect] : {std::pair{" --values layers=1", "give --base"}, std::pair{" --base layers=1,2", "one value"},
                                     std::pair{" --base layerz=1", "'layerz'"}}) {
    const auto r = run_command(study + args);
    CHECK(r.exit_code != 0);
    CHECK_MESSAGE(contains(r.output, expect), args << " -> " << r.output);
  }
  const auto no_extremes = run_command(cli + " tradeoff " + f.scene.string() + " --feature fur --base layers=4");
  CHECK(no_extremes.exit_code != 0);
  CHECK(contains(no_extremes.output, "--base is for --extremes"));
}

TEST_CASE("weft farm plan: a sweep spec becomes a task list; typos are named at their JSON path before anything runs") {
  Fixture f;
  std::ofstream(f.dir / "spec.json") << R"({"version": 1, "studies": [{"scene": "fur.json", "feature": "fur", "frames": 1,
    "values": {"layers": [1, 2]}, "cross": {"fins": [true, false]}, "out": "out-{scene}"}]})";
  const auto plan = run_command(cli + " farm plan " + (f.dir / "spec.json").string() + " --cache " + f.cache.string() + " -o " +
                                (f.dir / "tasks.json").string());
  REQUIRE_MESSAGE(plan.exit_code == 0, plan.output);
  const std::string list = read(f.dir / "tasks.json");
  CHECK(contains(list, "\"--cross\""));
  CHECK(contains(list, "fins=true,false"));
  CHECK(contains(list, (f.dir / "out-fur").string()));
  CHECK_FALSE(fs::exists(f.cache / "tradeoff"));  // planned, nothing ran

  std::ofstream(f.dir / "typo.json") << R"({"version": 1, "studies": [{"scene": "fur.json", "feature": "fur", "values": {"layerz": [1]}, "cross": {"layers": [2, 100000]}}]})";
  struct Case {
    std::string args;
    std::vector<std::string> expect;
  };
  const std::string s = f.scene.string();
  for (const auto& c : {
           Case{"farm plan " + (f.dir / "typo.json").string(), {"$.studies[0].values.layerz", "$.studies[0].cross.layers[1]", "typo.json"}},
           Case{"farm plan " + (f.dir / "nope.json").string(), {"nope.json"}},
           Case{"farm run " + (f.dir / "typo.json").string() + " --farm local", {"$.studies[0].values.layerz"}},
           Case{"farm run " + (f.dir / "spec.json").string(), {"--farm local or --farm slurm"}},
           Case{"farm task " + (f.dir / "tasks.json").string() + " 999", {"task 999 is not in the list"}},
           Case{"farm task " + (f.dir / "spec.json").string() + " 0", {"spec.json", "$.studies"}},
           Case{"farm status 12x", {"'12x' is not a Slurm job id"}},
           Case{"farm task " + (f.dir / "nope.json").string() + " 0", {"nope.json", "not found"}},
           Case{"farm reduce " + (f.dir / "nope.json").string(), {"nope.json"}},
           Case{"farm place " + (f.dir / "nope.wbtf").string() + " " + (f.dir / "x.wbtf").string(), {"nope.wbtf"}},
           Case{"farm run " + (f.dir / "spec.json").string() + " --farm local --partition p", {"for --farm slurm"}},
           Case{"tradeoff " + s + " --feature fur --farm local --batch 0", {"--batch"}},
           Case{"farm wait 4242 --cache " + f.cache.string(), {"no farm job 4242"}},
           Case{"farm collect 4242 --cache " + f.cache.string(), {"no farm job 4242"}},
           Case{"tradeoff " + s + " --feature fur --farm cloud", {"--farm", "cloud"}},
           Case{"tradeoff " + s + " --feature fur --partition gpu", {"for --farm slurm"}},
           Case{"tradeoff " + s + " --feature fur --cross layerz=1", {"--cross", "'layerz'"}},
           Case{"tradeoff " + s + " --feature fur --task 0123456789abcdef --cache " + f.cache.string(), {"no setting or coverage frame"}},
           Case{"tradeoff " + s + " --feature fur --task 0123456789abcdef", {"--task needs --cache"}},
           Case{"tradeoff " + s + " --feature fur --tasks x.json --farm local", {"one each"}},
       }) {
    const auto r = run_command(cli + " " + c.args);
    CHECK_MESSAGE(r.exit_code != 0, c.args);
    for (const auto& e : c.expect) CHECK_MESSAGE(contains(r.output, e), c.args << " -> " << r.output);
  }
  // sbatch missing: named before anything is planned or submitted
  const auto no_slurm = run_command("env PATH=/nonexistent " + cli + " tradeoff " + s + " --feature fur --farm slurm --cache " +
                                    f.cache.string());
  CHECK(no_slurm.exit_code != 0);
  CHECK_MESSAGE(contains(no_slurm.output, "'sbatch' is not on PATH"), no_slurm.output);
  CHECK_FALSE(fs::exists(f.cache / "farm"));
}

TEST_CASE("weft farm run: a two-material bake as tasks, placed by the reduce step; done bakes skipped") {
  Fixture f;
  std::ofstream(f.dir / "bakes.json") << R"({"version": 1, "bakes": [
    {"bake": "btf", "args": ["--synthetic", "4x4", "--weave", "plain", "--clusters", "4", "--epochs", "1", "--directions", "64"], "output": "lib/plain.wbtf"},
    {"bake": "btf", "args": ["--synthetic", "4x4", "--weave", "twill", "--clusters", "4", "--epochs", "1", "--directions", "64"], "output": "lib/twill.wbtf"}]})";
  const std::string run = cli + " farm run " + (f.dir / "bakes.json").string() + " --farm local -j 2 --cache " + f.cache.string();
  const auto r = run_command(run);
  REQUIRE_MESSAGE(r.exit_code == 0, r.output);
  CHECK(contains(r.output, "placed " + (f.dir / "lib/plain.wbtf").string()));
  CHECK(fs::file_size(f.dir / "lib/plain.wbtf") > 1000);
  CHECK(fs::file_size(f.dir / "lib/twill.wbtf") > 1000);
  CHECK(read(f.dir / "lib/plain.wbtf") != read(f.dir / "lib/twill.wbtf"));
  fs::remove(f.dir / "lib/twill.wbtf");
  const auto again = run_command(run);
  REQUIRE_MESSAGE(again.exit_code == 0, again.output);
  CHECK(contains(again.output, "2 of 2 tasks already in the cache"));
  CHECK(fs::file_size(f.dir / "lib/twill.wbtf") > 1000);
  // a bake that fails is named with its log's last line, and nothing is placed
  std::ofstream(f.dir / "bad.json") << R"({"version": 1, "bakes": [{"bake": "btf", "args": ["--synthetic", "4x4", "--weave", "satin"], "output": "lib/satin.wbtf"}]})";
  const auto bad = run_command(cli + " farm run " + (f.dir / "bad.json").string() + " --farm local --cache " + f.cache.string());
  CHECK(bad.exit_code != 0);
  CHECK_MESSAGE(contains(bad.output, "satin"), bad.output);
  CHECK(contains(bad.output, "nothing was reduced"));
  CHECK_FALSE(fs::exists(f.dir / "lib/satin.wbtf"));
}

TEST_CASE("every weft farm subcommand answers --help without working") {
  for (const char* sub : {"farm", "farm plan", "farm run", "farm task", "farm reduce", "farm place", "farm status", "farm wait", "farm collect"}) {
    const auto r = run_command(cli + " " + sub + " --help");
    CHECK_MESSAGE(r.exit_code == 0, sub << ": " << r.output);
    CHECK_MESSAGE(contains(r.output, "Usage"), sub << ": " << r.output);
  }
  const auto t = run_command(cli + " tradeoff --help");
  CHECK(contains(t.output, "--farm"));
  CHECK(contains(t.output, "--from-cache"));
}
