// weft.farm without a GPU: the task list file, the sweep spec reader and the local runner,
// with shell commands standing in for weft's tasks.
#include <doctest/doctest.h>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>
#include <unistd.h>
import weft.core;
import weft.farm;

namespace {
namespace fs = std::filesystem;
using weft::farm::Task;
using weft::farm::TaskList;

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("weft-farm-" + std::to_string(::getpid()) + "-" +
                                        std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::string read(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

Task shell_task(std::string id, std::string script, std::string output) {
  return {.id = std::move(id), .label = "task " + output, .command = {"/bin/sh", "-c", std::move(script)}, .outputs = {std::move(output)}};
}
}  // namespace

TEST_CASE("a task list reads back to itself; bad lists are named at their JSON path") {
  TaskList list;
  list.what = "test";
  list.cache = "/tmp/cache";
  list.tasks.push_back({.id = "00ff", .label = "a", .command = {"weft", "x"}, .outputs = {"t/00ff.json"}});
  list.reduce.push_back({"weft", "reduce"});
  auto back = weft::farm::parse_task_list(weft::farm::to_text(list), "l.json");
  REQUIRE_MESSAGE(back, back.error().what());
  CHECK(back->tasks.size() == 1);
  CHECK(back->tasks[0].command == list.tasks[0].command);
  CHECK(back->reduce == list.reduce);
  CHECK(weft::farm::to_text(*back) == weft::farm::to_text(list));

  struct Case {
    std::string text, expect;
  };
  for (const auto& c : {Case{"[1", "not JSON"},
                        Case{R"({"version": 2, "cache": "/c", "tasks": []})", "$.version"},
                        Case{R"({"version": 1, "tasks": []})", "$.cache"},
                        Case{R"({"version": 1, "cache": "/c", "tasks": [], "extra": 1})", "$.extra"},
                        Case{R"({"version": 1, "cache": "/c", "tasks": [{"id": "XY", "command": ["a"], "outputs": ["o"]}]})", "$.tasks[0].id"},
                        Case{R"({"version": 1, "cache": "/c", "tasks": [{"id": "aa", "command": [], "outputs": ["o"]}]})", "$.tasks[0].command"},
                        Case{R"({"version": 1, "cache": "/c", "tasks": [{"id": "aa", "command": ["a"], "outputs": ["../o"]}]})", "$.tasks[0].outputs[0]"},
                        Case{R"({"version": 1, "cache": "/c", "tasks": [{"id": "aa", "command": ["a"], "outputs": ["/etc/o"]}]})", "$.tasks[0].outputs[0]"},
                        Case{R"({"version": 1, "cache": "/c", "tasks": [{"id": "aa", "command": ["a"], "outputs": ["o"]}, {"id": "aa", "command": ["a"], "outputs": ["p"]}]})", "listed twice"},
                        Case{R"({"version": 1, "cache": "/c", "tasks": [], "reduce": [[1]]})", "$.reduce[0]"}}) {
    auto r = weft::farm::parse_task_list(c.text, "l.json");
    REQUIRE_FALSE_MESSAGE(r, c.text);
    CHECK_MESSAGE(contains(r.error().message, c.expect), r.error().message);
    CHECK(contains(r.error().message, "l.json"));
  }
}

TEST_CASE("sweep spec: scenes x knob values listed and crossed; every typo and bad value named at its JSON path") {
  TempDir dir;
  std::ofstream(dir.path / "a.json") << "{}";
  std::ofstream(dir.path / "b.json") << "{}";
  auto sweep = weft::farm::parse_sweep_spec(R"({"version": 1, "studies": [{"scenes": ["a.json", "b.json"], "feature": "fur",
      "size": "32x24", "frames": 2, "values": {"layers": [1, 2.0]}, "cross": {"layers": [4, 8], "fins": [true, false]},
      "out": "out/{feature}-{scene}"}]})", "spec.json", dir.path);
  REQUIRE_MESSAGE(sweep, sweep.error().what());
  const auto* specs = &sweep->studies;
  REQUIRE(specs->size() == 2);
  const auto& s = (*specs)[1];
  CHECK(s.feature == "shell_fur");  // the registry's name for the alias
  CHECK(s.scene == dir.path / "b.json");
  CHECK(s.out == dir.path / "out/shell_fur-b");
  CHECK(s.size == "32x24");
  CHECK(s.frames == 2);
  CHECK(s.values == std::vector<std::string>{"layers=1,2"});
  CHECK(s.cross == std::vector<std::string>{"fins=true,false", "layers=4,8"});
  CHECK(s.json_path == "$.studies[0].scenes[1]");

  struct Case {
    std::string text;
    std::vector<std::string> expect;
  };
  const std::string head = R"({"version": 1, "studies": [{"scene": "a.json", "feature": "fur", )";
  for (const auto& c : {
           Case{head + R"("values": {"layerz": [1]}}]})", {"$.studies[0].values.layerz", "'layerz'", "layers"}},
           Case{head + R"("cross": {"layers": [4, 0]}}]})", {"$.studies[0].cross.layers[1]", "layers"}},
           Case{head + R"("cross": {"layers": [4, 2.5]}}]})", {"$.studies[0].cross.layers[1]"}},
           Case{head + R"("values": {"fins": ["yes"]}}]})", {"$.studies[0].values.fins[0]"}},
           Case{head + R"("values": {"layers": []}}]})", {"$.studies[0].values.layers", "non-empty"}},
           Case{head + R"("size": "0x5"}]})", {"$.studies[0].size"}},
           Case{head + R"("frames": 0}]})", {"$.studies[0].frames"}},
           Case{head + R"("exposure": -1}]})", {"$.studies[0].exposure"}},
           Case{head + R"("colour": 1}]})", {"$.studies[0].colour", "unknown field"}},
           Case{R"({"version": 1, "studies": [{"scene": "nope.json", "feature": "fur"}]})", {"$.studies[0].scene", "nope.json"}},
           Case{R"({"version": 1, "studies": [{"scene": "a.json", "feature": "hair"}]})", {"$.studies[0].feature", "'hair'"}},
           Case{R"({"version": 1, "studies": [{"scenes": ["a.json", "b.json"], "feature": "fur", "out": "x"}]})", {"$.studies[0].out", "{scene}"}},
           Case{R"({"version": 1, "studies": []})", {"$.studies"}},
           Case{R"({"studies": [{"scene": "a.json", "feature": "fur"}]})", {"$.version"}},
           // every problem at once
           Case{head + R"("values": {"layerz": [1]}, "frames": 0}]})", {"$.studies[0].values.layerz", "$.studies[0].frames"}},
           Case{"{", {"not JSON"}}}) {
    auto r = weft::farm::parse_sweep_spec(c.text, "spec.json", dir.path);
    REQUIRE_FALSE_MESSAGE(r, c.text);
    CHECK(contains(r.error().message, "spec.json"));
    for (const auto& e : c.expect) CHECK_MESSAGE(contains(r.error().message, e), r.error().message, " lacks ", e);
  }
}

TEST_CASE("sweep spec: bakes of any registered feature, inputs named by content; bad bakes named at their JSON path") {
  TempDir dir;
  std::ofstream(dir.path / "in.btfraw") << "bytes";
  const auto parse = [&](const std::string& bakes) {
    return weft::farm::parse_sweep_spec(R"({"version": 1, "bakes": )" + bakes + "}", "spec.json", dir.path);
  };
  auto a = parse(R"([{"bake": "btf", "args": ["in.btfraw", "--epochs", "1"], "output": "lib/a.wbtf"},
                     {"bake": "btf", "args": ["--synthetic", "4x4"], "output": "lib/b.wbtf"}])");
  REQUIRE_MESSAGE(a, a.error().what());
  REQUIRE(a->bakes.size() == 2);
  CHECK(a->studies.empty());
  CHECK(a->bakes[0].args == std::vector<std::string>{(dir.path / "in.btfraw").string(), "--epochs", "1"});
  CHECK(a->bakes[0].output == dir.path / "lib/a.wbtf");
  CHECK(a->bakes[0].id != a->bakes[1].id);
  // the id follows the input's bytes
  std::ofstream(dir.path / "in.btfraw") << "other bytes";
  auto b = parse(R"([{"bake": "btf", "args": ["in.btfraw", "--epochs", "1"], "output": "lib/a.wbtf"}])");
  REQUIRE(b);
  CHECK(b->bakes[0].id != a->bakes[0].id);
  struct Case {
    std::string bakes;
    std::vector<std::string> expect;
  };
  for (const auto& c : {Case{R"([{"bake": "btff", "output": "x.wbtf"}])", {"$.bakes[0].bake", "btf", "skin-lut"}},
                        Case{R"([{"bake": "btf", "args": ["-o", "y.wbtf"], "output": "x.wbtf"}])", {"$.bakes[0].args[0]", "\"output\""}},
                        Case{R"([{"bake": "btf", "args": [3], "output": "x.wbtf"}])", {"$.bakes[0].args[0]"}},
                        Case{R"([{"bake": "btf", "output": "x"}])", {"$.bakes[0].output", "extension"}},
                        Case{R"([{"bake": "btf", "output": "x.wbtf"}, {"bake": "btf", "output": "x.wbtf"}])", {"$.bakes[1].output", "earlier"}},
                        Case{R"([{"bake": "btf", "output": "x.wbtf", "outptu": 1}])", {"$.bakes[0].outptu"}},
                        Case{R"([])", {"$.bakes"}}}) {
    auto r = parse(c.bakes);
    REQUIRE_FALSE_MESSAGE(r, c.bakes);
    for (const auto& e : c.expect) CHECK_MESSAGE(contains(r.error().message, e), r.error().message, " lacks ", e);
  }
}

TEST_CASE("local runner: done tasks are skipped, -j 2 runs two at once, failures name the task and its log") {
  TempDir dir;
  TaskList list;
  list.cache = dir.path;
  // Each of a and b waits for the other to have started: they finish only when run at once.
  const auto wait_for = [&](const std::string& me, const std::string& other, const std::string& out) {
    const std::string c = (dir.path / other).string(), m = (dir.path / me).string(), o = (dir.path / out).string();
    return "touch " + m + "; i=0; while [ ! -e " + c + " ] && [ $i -lt 300 ]; do sleep 0.05; i=$((i+1)); done; [ -e " + c +
           " ] && echo ok > " + o;
  };
  list.tasks.push_back(shell_task("0a", wait_for("a.started", "b.started", "out/a.txt"), "out/a.txt"));
  list.tasks.push_back(shell_task("0b", wait_for("b.started", "a.started", "out/b.txt"), "out/b.txt"));
  // done already: its command would fail
  fs::create_directories(dir.path / "out");
  std::ofstream(dir.path / "out/c.txt") << "cached";
  list.tasks.push_back(shell_task("0c", "exit 3", "out/c.txt"));
  // fails, with a last word in its log
  list.tasks.push_back(shell_task("0d", "echo 'the photo is too dark' >&2; exit 4", "out/d.txt"));
  // exits 0 without its output: a failure too
  list.tasks.push_back(shell_task("0e", "true", "out/e.txt"));
  auto run = weft::farm::run_local(list, 2);
  REQUIRE_MESSAGE(run, run.error().what());
  CHECK(run->skipped == 1);
  CHECK(run->ran == 4);
  CHECK(run->failed == std::vector<std::size_t>{3, 4});
  CHECK(read(dir.path / "out/a.txt") == "ok\n");
  CHECK(read(dir.path / "out/b.txt") == "ok\n");
  CHECK(read(dir.path / "out/c.txt") == "cached");
  CHECK(weft::farm::missing_tasks(list) == std::vector<std::size_t>{3, 4});
  const std::string why = weft::farm::describe_missing(list, {3});
  CHECK(contains(why, "'task out/d.txt'"));
  CHECK(contains(why, (dir.path / "logs/0d.log").string()));
  CHECK(contains(why, "the photo is too dark"));
  CHECK(contains(weft::farm::describe_missing(list, {4}), "0e.log"));
  TaskList never = list;
  never.tasks = {shell_task("0f", "true", "out/f.txt")};
  CHECK(contains(weft::farm::describe_missing(never, {0}), "never started"));
  for (int i = 0; i < 11; ++i) never.tasks.push_back(shell_task(weft::format("1{}", i), "true", "o"));
  const std::string many = weft::farm::describe_missing(never, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11});
  CHECK(contains(many, "and 4 more"));
  CHECK(contains(many, "task 16,"));
  CHECK_FALSE(contains(many, "task 17,"));
}

TEST_CASE("a killed task leaves no output, and its next run removes the temporary and computes") {
  TempDir dir;
  TaskList list;
  list.cache = dir.path;
  const std::string out = (dir.path / "t/x.bin").string();
  // what a writer killed between its write and its rename leaves: only its temporary
  list.tasks.push_back(shell_task("01", "printf half > " + out + ".4242-0.tmp; kill -9 $$", "t/x.bin"));
  auto first = weft::farm::run_task(list, 0);
  REQUIRE(first);
  CHECK(first->exit_code == 128 + 9);
  CHECK_FALSE(fs::exists(out));
  CHECK(fs::exists(out + ".4242-0.tmp"));
  CHECK(weft::farm::missing_tasks(list).size() == 1);
  // requeued: the same task, this time it finishes
  list.tasks[0].command = {"/bin/sh", "-c", "test ! -e " + out + ".4242-0.tmp && printf whole > " + out};
  auto second = weft::farm::run_task(list, 0);
  REQUIRE(second);
  CHECK(second->exit_code == 0);
  CHECK_FALSE(second->skipped);
  CHECK(read(out) == "whole");
  CHECK_FALSE(fs::exists(out + ".4242-0.tmp"));
  // and once more: done, skipped, the output untouched
  list.tasks[0].command = {"/bin/sh", "-c", "printf again > " + out};
  auto third = weft::farm::run_task(list, 0);
  REQUIRE(third);
  CHECK(third->skipped);
  CHECK(read(out) == "whole");
  auto bad = weft::farm::run_task(list, 5);
  REQUIRE_FALSE(bad);
  CHECK(contains(bad.error().message, "task 5 is not in the list"));
}

TEST_CASE("save_task_list names the list by its content, in CACHE/farm") {
  TempDir dir;
  TaskList list;
  list.cache = dir.path;
  list.tasks.push_back(shell_task("aa", "true", "o"));
  auto a = weft::farm::save_task_list(list);
  REQUIRE(a);
  CHECK(a->parent_path() == dir.path / "farm");
  auto b = weft::farm::save_task_list(list);
  REQUIRE(b);
  CHECK(*a == *b);
  list.tasks[0].label = "other";
  auto c = weft::farm::save_task_list(list);
  REQUIRE(c);
  CHECK(*c != *a);
  auto back = weft::farm::read_task_list(*c);
  REQUIRE(back);
  CHECK(back->tasks[0].label == "other");
}
