#!/usr/bin/python3
"""Hostile command-line input against every weft subcommand and program (issue 33, item 3).

Generates cases the way a hurried user (or a script gone wrong) types them: missing, repeated,
negative, huge, non-numeric, NaN, infinite and empty arguments; output paths that are folders,
unwritable (under /proc or /sys, below a plain file), on a full file system, an existing read-only
file or a FIFO; input paths that are folders, FIFOs, devices, sockets, dangling or looping symlinks,
symlinks out of the asset folder, empty, sparse and huge files. Each case runs in an empty folder of
its own with a timeout and a memory limit, and is classified:

  clean     non-zero exit, a short error (at most a few lines, a usage block and progress logs
            aside) that names what is wrong, nothing left behind
  accepted  exit 0 where the input is valid (or a case says why exit 0 is fine)
  crash     a signal, an abort, an assertion, "terminate called", a sanitizer report
  hang      still running at the timeout (killed with its process group)
  messy     anything else: exit 0 on input that must be refused, no message, a message that does
            not name the problem, an escaped exception, many lines, a file left behind or changed

Prints a table by program and class, writes a CSV, and exits 1 when any case is crash, hang or
messy. --quick runs the few dozen cases that ctest runs (tests/cli/CMakeLists.txt).

usage: tools/hostile_cli.py [--bin DIR] [--jobs N] [--filter REGEX] [--timeout S] [--quick]
                            [--csv FILE] [--list] [--keep] [--memory-mb M]
"""
import argparse
import concurrent.futures
import csv
import dataclasses
import hashlib
import os
import re
import shlex
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

SOURCE = Path(__file__).resolve().parent.parent

# Progress lines of weft.core's log at info/debug level ("[12:00:00.123] [info] loading x"); they
# may come before an error and are not counted as the error's lines.
LOG_LINE = re.compile(r"^\[\d\d:\d\d:\d\d\.\d+\] \[(info|debug|trace)\] ")
CRASH_MARKERS = ("terminate called", "Assertion `", "assertion failed", "AddressSanitizer", "UndefinedBehaviorSanitizer",
                 "LeakSanitizer", "ThreadSanitizer", "runtime error:", "Segmentation fault", "core dumped",
                 "stack smashing", "double free", "free(): invalid", "malloc(): ", "libc++abi", "Aborted")
# An exception or parser error that reached the user as it is, not as a reason.
MESSY_MARKERS = ("Traceback (most recent call last)", "what():", "unexpected exception", "std::invalid_argument",
                 "std::out_of_range", "stoul", "stoull", "stoi", "stod", "stof", "basic_string", "4294967295",
                 "18446744073709551615")
PROBLEMS_LINE = re.compile(r"\d+ problems:$")
MAX_LINES = 3  # an error's lines, not counting progress logs, CLI11's "Run with --help" and a usage block


@dataclasses.dataclass
class Case:
    id: str
    program: str  # a file in --bin
    args: list  # {fx} the fixtures, {cwd} the case's own folder, {src} the source tree, {full} a full file system
    expect: str = "fail"  # fail: must be refused; ok: must succeed; any: either, never a crash or hang
    names: tuple = ()  # the error names at least one of these (case-insensitive); () takes them from the args
    setup: object = None  # setup(cwd): files the case needs in its folder (kept out of the leftover check)
    quick: bool = False  # in the ctest subset
    note: str = ""  # why exit 0 is fine for an "any" case
    fsize_blocks: int = 0  # ulimit -f (512-byte blocks): the disk is full after this much
    env: dict = dataclasses.field(default_factory=dict)
    needs: str = ""  # "full": a full file system was mounted
    max_lines: int = 0  # more lines than MAX_LINES allowed for this case (note says why)


@dataclasses.dataclass
class Outcome:
    case: Case
    klass: str
    reason: str
    rc: object
    seconds: float
    output: str


# ---- fixtures --------------------------------------------------------------------------------

SCENE = """{"version": 1, "output": {"width": 32, "height": 24},
  "camera": {"position": [0, 0, 3], "target": [0, 0, 0]},
  "environment": {"color": [0.2, 0.2, 0.2]},
  "meshes": {"ball": {"primitive": "sphere", "radius": 0.5, "segments": 8}},
  "materials": {"m": {"type": "standard"}},
  "objects": [{"name": "ball", "mesh": "ball", "material": "m"}]}
"""


def scene_with(meshes='{"m": {"primitive": "sphere", "radius": 0.5, "segments": 8}}',
               materials='{"a": {"type": "standard"}}', extra=""):
    return ('{"version": 1, "output": {"width": 32, "height": 24}, "camera": {"position": [0, 0, 3], "target": [0, 0, 0]},'
            + extra + ' "meshes": ' + meshes + ', "materials": ' + materials
            + ', "objects": [{"name": "o", "mesh": "m", "material": "a"}]}\n')


def fur_scene(src):
    photo = src / "examples/fur/synthetic_fur.png"
    return ('{"version": 1, "output": {"width": 32, "height": 24}, "camera": {"position": [0, 0.4, 2], "target": [0, 0, 0]},'
            ' "lights": [{"type": "directional", "direction": [-0.5, -1, -0.4], "intensity": 2}],'
            ' "meshes": {"ball": {"primitive": "sphere", "radius": 0.5, "segments": 8}},'
            ' "materials": {"fur": {"type": "fur", "photo": "' + str(photo) + '", "layers": 2}},'
            ' "objects": [{"name": "ball", "mesh": "ball", "material": "fur"}]}\n')


# Input paths a reader must refuse without waiting: (name, file name in fx made for each extension, what
# the error must name, quick). "{x}" is the extension.
IN_PATHS = [
    ("missing", "nope{x}", None, True),
    ("folder", "folder{x}", None, True),
    ("fifo", "fifo{x}", None, True),
    ("dev-zero-link", "zero{x}", None, True),
    ("dev-null-link", "null{x}", None, False),
    ("dangling-link", "dangling{x}", None, False),
    ("link-loop", "loop{x}", None, False),
    ("socket", "socket{x}", None, False),
    ("empty-file", "empty{x}", None, False),
    ("text", "text{x}", None, False),
    ("junk", "junk{x}", None, False),
    ("below-a-file", "afile/x{x}", None, False),
    ("long-name", "a" * 300 + "{x}", None, False),
    ("sparse-3g", "sparse{x}", None, False),
]
IN_ABSOLUTE = [  # the same, not in the fixture folder
    ("dev-zero", "/dev/zero", None, False),
    ("dev-stdin", "/dev/stdin", None, False),
    ("proc-self-mem", "/proc/self/mem", None, False),
    ("proc-kmsg", "/proc/kmsg", None, False),
    ("empty-arg", "", ("''", "empty", "required", "not found", "expected"), False),
]
EXTENSIONS = ["", ".bin", ".json", ".obj", ".stl", ".gltf", ".glb", ".png", ".hdr", ".exr", ".wbtf", ".btfraw", ".txt", ".so", ".wssdf"]


def make_fixture(fx: Path, src: Path):
    fx.mkdir(parents=True)
    (fx / "s.json").write_text(SCENE)
    (fx / "fur.json").write_text(fur_scene(src))
    (fx / "afile").write_text("a plain file, used as if it were a folder\n")
    (fx / "broken.json").write_text('{"version": 1, "objects": [')
    (fx / "deep.json").write_text("[" * 200000)
    (fx / "array.json").write_text("[1, 2, 3]\n")
    (fx / "nan.json").write_text('{"version": 1, "output": {"width": NaN, "height": 24}}\n')
    (fx / "wrong-types.json").write_text('{"version": "one", "output": {"width": -32, "height": 1e300}}\n')
    (fx / "bom.json").write_bytes(b"\xef\xbb\xbf" + SCENE.encode())
    (fx / "huge-size.json").write_text(SCENE.replace('"width": 32, "height": 24', '"width": 100000, "height": 100000'))
    (fx / "negative-size.json").write_text(SCENE.replace('"width": 32, "height": 24', '"width": -1, "height": -1'))
    (fx / "nan-camera.json").write_text(SCENE.replace('"position": [0, 0, 3]', '"position": [1e400, 0, 3]'))
    (fx / "same-eye.json").write_text(SCENE.replace('"position": [0, 0, 3]', '"position": [0, 0, 0]'))
    # Asset references out of the scene's folder: a symlink to /etc/passwd, a ../ path, a device.
    os.symlink("/etc/passwd", fx / "passwd.obj")
    for name, path in [("mesh-link-out", str(fx / "passwd.obj")), ("mesh-dotdot", "../../../../../../../../etc/passwd"),
                       ("mesh-dev-urandom", "/dev/urandom"), ("mesh-proc", "/proc/self/status")]:
        (fx / (name + ".json")).write_text(scene_with(meshes='{"m": {"path": "' + path + '"}}'))
    for x in EXTENSIONS:
        (fx / ("folder" + x)).mkdir()
        os.mkfifo(fx / ("fifo" + x))
        os.symlink("/dev/zero", fx / ("zero" + x))
        os.symlink("/dev/null", fx / ("null" + x))
        os.symlink(str(fx / "gone" / ("x" + x)), fx / ("dangling" + x))
        os.symlink("loop" + x, fx / ("loop" + x))
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.bind(str(fx / ("socket" + x)))
        s.close()
        (fx / ("empty" + x)).write_bytes(b"")
        (fx / ("text" + x)).write_text("hello, this is not the file you are looking for\n")
        (fx / ("junk" + x)).write_bytes(bytes((i * 131 + 7) % 256 for i in range(4096)))
        with open(fx / ("sparse" + x), "wb") as f:
            f.truncate(3 << 30)  # 3 GiB of zeros, no disk used
    # Scenes whose assets are each hostile path: mesh, texture, sky, fur photo, neural BTF model, pipeline.
    for name, file, _, _ in IN_PATHS + IN_ABSOLUTE:
        if name in ("long-name", "sparse-3g", "empty-arg"):
            continue
        for kind, x, text in asset_scenes():
            p = file.replace("{x}", x)
            p = p if p.startswith("/") else str(fx / p)
            (fx / ("asset-%s-%s.json" % (kind, name))).write_text(text.replace("PATH", p))
    (fx / "script-ok.txt").write_text("orbit 10 5\nwait 1\nquit\n")
    (fx / "farm-spec-empty.json").write_text('{"studies": []}\n')  # refused: a spec names at least one study
    (fx / "farm-spec.json").write_text('{"version": 1, "studies": [{"scene": "fur.json", "feature": "fur", "size": "16x8", '
                                       '"frames": 1, "values": {"layers": [1]}, "out": "study"}]}\n')
    (fx / "farm-spec-bad.json").write_text('{"studies": [{"scene": "nope.json", "feature": "nosuch"}]}\n')
    (fx / "farm-list-bad.json").write_text('{"tasks": [{"id": "a", "command": []}]}\n')
    (fx / "from.bin").write_bytes(b"cached bytes\n")
    (fx / "from-big.bin").write_bytes(b"cached bytes\n" * 5000)  # more than the 512-byte file-size limit


def asset_scenes():
    return [
        ("mesh", ".obj", scene_with(meshes='{"m": {"path": "PATH"}}')),
        ("texture", ".png", scene_with(materials='{"a": {"base_color_texture": "PATH"}}')),
        ("sky", ".hdr", scene_with(extra=' "environment": {"hdr": "PATH"},')),
        ("photo", ".png", scene_with(materials='{"a": {"type": "fur", "photo": "PATH"}}')),
        ("model", ".wbtf", scene_with(materials='{"a": {"type": "neural_btf", "model": "PATH"}}')),
        ("pipeline", ".json", scene_with(extra=' "pipeline": "PATH",')),
    ]


def mount_full_fs(root: Path):
    """A 64 KiB tmpfs filled to the last byte, when this process may mount one (root); else None."""
    if os.geteuid() != 0 or not shutil.which("mount"):
        return None
    full = root / "full"
    full.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(full)], capture_output=True).returncode != 0:
        return None
    try:
        with open(full / "filler", "wb") as f:
            while True:
                f.write(b"\0" * 4096)
                f.flush()
    except OSError:
        pass
    return full


# ---- the cases --------------------------------------------------------------------------------

BAD_UINT = ["", "-1", "abc", "1.5", "nan", "inf", "99999999999999999999", "4294967296", "0x10", "1,2", "--"]
BAD_FLOAT = ["", "abc", "nan", "-nan", "inf", "-inf", "1e999", "-1e999", "1,5", "0x", "--"]
BAD_SIZE = ["", "x", "32", "32x", "x24", "0x24", "32x0", "0x0", "-32x24", "32x-24", "-1x-1", "32x24x2", "abcxdef",
            "99999999999x24", "4294967297x1", "8193x24", "32.5x24", "nanxnan", " 32x24", "32 x 24", "+32x24", "--"]
BAD_WORD = ["", "bogus", "--", "low,high", "\u00e9t\u00e9"]


class Builder:
    def __init__(self, programs):
        self.cases = []
        self.ids = set()
        self.programs = programs

    def add(self, id, program, args, **kw):
        if program not in self.programs:
            return
        id = id.encode("ascii", "backslashreplace").decode("ascii")
        base = id
        n = 2
        while id in self.ids:
            id = "%s#%d" % (base, n)
            n += 1
        self.ids.add(id)
        self.cases.append(Case(id=id, program=program, args=list(args), **kw))

    # One option: each bad value in place of a good one (or appended), plus missing and repeated.
    def values(self, id, program, base, option, bad, good=None, names=None, quick=(), extra_ok=(), **kw):
        for v in bad:
            label = v if v else "empty"
            n = names or (option, option.lstrip("-"), option.lstrip("-").replace("-", "_"))
            opts = dict(kw)
            if v == "0x10" and program == "weft":
                opts.update(expect="any", note="CLI11 reads 0x10 as hexadecimal 16")
            self.add("%s %s=%s" % (id, option, label), program, base + [option, v], names=n + ((v,) if v.strip() else ()),
                     quick=v in quick, **opts)
        if good is not None:
            self.add("%s %s missing value" % (id, option), program, base + [option], names=names or (option,), **kw)
            self.add("%s %s repeated" % (id, option), program, base + [option, good, option, good], expect="any",
                     note="the same value twice; CLI11 refuses a second value or keeps the last", **kw)
        for v, note in extra_ok:
            self.add("%s %s=%s" % (id, option, v), program, base + [option, v], expect="any", note=note, **kw)

    def in_paths(self, id, program, make_args, x, quick=(), skip=(), names_of=None, **kw):
        """make_args(path) -> args; the path runs through every hostile input path with extension x."""
        for name, file, names, _ in IN_PATHS + IN_ABSOLUTE:
            if name in skip:
                continue
            p = file.replace("{x}", x)
            p = p if (p.startswith("/") or not p) else "{fx}/" + p
            n = names or ((Path(p).name if p else "''",) if names_of is None else names_of(p))
            self.add("%s %s" % (id, name), program, make_args(p), names=n, quick=name in quick, **kw)

    def out_paths(self, id, program, make_args, x, quick=(), skip=(), kinds=None, fsize=False, **kw):
        """make_args(path) -> args; the path runs through every hostile output path with extension x.

        fsize: also a file-size limit (ulimit -f) as the full disk. Only for commands that open no
        Vulkan device: lavapipe backs device memory with memfd files, which the limit also stops
        (SIGBUS in the driver's mapping, not weft's doing). The mounted full tmpfs covers the rest."""
        ro = "ro" + x

        def readonly(cwd):
            (cwd / ro).write_bytes(b"precious: must not change\n")
            os.chmod(cwd / ro, 0o444)

        def fifo(cwd):
            os.mkfifo(cwd / ("fifo" + x))

        def folder(cwd):
            (cwd / ("dir" + x)).mkdir()

        def link_full(cwd):
            os.symlink("/dev/full", cwd / ("full" + x))

        def link_null(cwd):
            os.symlink("/dev/null", cwd / ("null" + x))

        def rodir(cwd):
            (cwd / "rodir").mkdir()
            os.chmod(cwd / "rodir", 0o555)

        def afile(cwd):
            (cwd / "afile").write_text("a plain file\n")

        root_note = "running as root: the permission bits of a folder do not stop root"
        outs = [
            ("folder", "{cwd}/dir" + x, dict(setup=folder)),
            ("missing-parent", "{cwd}/no/such/dir/out" + x, dict(expect=kinds or "fail")),
            ("below-a-file", "{cwd}/afile/out" + x, dict(setup=afile, names=("out" + x, "afile"))),
            ("in-proc", "/proc/version/out" + x, dict(names=("out" + x, "/proc/version"))),
            ("in-sys", "/sys/out" + x, {}),
            ("read-only-file", "{cwd}/" + ro, dict(setup=readonly, names=(ro, "read-only"))),
            ("read-only-folder", "{cwd}/rodir/out" + x,
             dict(setup=rodir, expect="any" if os.geteuid() == 0 else "fail", note=root_note)),
            ("fifo", "{cwd}/fifo" + x, dict(setup=fifo)),
            ("dev-full-link", "{cwd}/full" + x, dict(setup=link_full)),
            ("dev-null-link", "{cwd}/null" + x, dict(setup=link_null)),
            ("full-disk", "{full}/out" + x, dict(needs="full")),
            ("file-size-limit", "{cwd}/out" + x, dict(fsize_blocks=1, names=("out" + x, "too large", "space"))),
            ("empty-arg", "", dict(names=("''", "empty", "required", "expected", "not a file"))),
            ("long-name", "{cwd}/" + "a" * 300 + x, dict(names=("name too long", "aaaaaaaa"))),
        ]
        for name, path, opts in outs:
            if name in skip or (name == "file-size-limit" and not fsize):
                continue
            opts = dict(opts)
            opts.setdefault("names", (Path(path).name,) if path else ("''",))
            merged = dict(kw)
            merged.update(opts)
            self.add("%s %s" % (id, name), program, make_args(path), quick=name in quick, **merged)


def build_cases(programs):
    b = Builder(programs)
    W = "weft"
    S = "{fx}/s.json"
    png = ["-o", "{cwd}/out.png"]

    # -- the weft command itself
    for args, expect, names, quick in [
        ([], "fail", ("subcommand", "required", "usage", "help"), True),
        (["--help"], "ok", (), True),
        (["rnder", S], "fail", ("rnder",), True),
        ([""], "fail", ("''", "unknown command", "empty"), False),
        (["-"], "fail", ("-",), False),
        (["--"], "fail", ("--", "subcommand"), False),
        (["--frobnicate"], "fail", ("frobnicate",), True),
        (["--plugin"], "fail", ("--plugin",), False),
        (["--plugin="], "fail", ("--plugin", "subcommand"), False),
        (["--plugin", "{fx}/text.so", "info"], "fail", ("text.so",), False),
        (["info", "extra"], "fail", ("extra",), False),
        (["info", "--frobnicate"], "fail", ("frobnicate",), False),
        (["render", "--help"], "ok", (), False),
        (["render", S, "-o", "{cwd}/" + "x" * 100000 + ".png"], "fail", ("too long", "xxxxxxxx"), False),
        (["render", "{fx}/\udcff\udcfe.json", "-o", "{cwd}/out.png"], "fail", ("not found",), False),
    ]:
        b.add("weft " + (" ".join(a[:40] for a in args) or "(no arguments)"), W, args, expect=expect, names=names, quick=quick)
    b.add("weft info", W, ["info"], expect="ok")
    b.in_paths("weft --plugin", W, lambda p: ["--plugin", p, "info"], ".so", quick=("fifo",))

    # -- weft render
    R = ["render", S] + png
    b.add("render valid", W, R, expect="ok", quick=True)
    b.add("render valid .exr", W, ["render", S, "-o", "{cwd}/out.exr", "--size", "16x8"], expect="ok")
    b.add("render no scene", W, ["render"], names=("scene",), quick=True)
    b.add("render two scenes", W, ["render", S, S] + png, names=("s.json", "argument", "extra"))
    b.values("render", W, R, "--size", BAD_SIZE, good="16x8", quick=("-1x-1", "nanxnan", "8193x24"),
             extra_ok=[("1x1", "the smallest image"), ("8192x1", "the largest side, one row")])
    b.values("render", W, R, "--frames", BAD_UINT + ["0", "10001"], good="2", quick=("abc",))
    b.values("render", W, R, "--accumulate", BAD_UINT + ["0", "4097"], good="2")
    b.values("render", W, R, "--budget-ms", BAD_FLOAT + ["0", "-1", "1e8"], good="50", quick=("nan",))
    b.values("render", W, R, "--exposure", BAD_FLOAT + ["0", "-1", "1e7"], good="1", quick=("inf",))
    b.values("render", W, R, "--quality", BAD_WORD, good="low", extra_ok=[("LOW", "a preset's name in capitals")])
    b.values("render", W, R, "--output", ["nosuch", "../../etc/passwd", "ssdf.irradiance_table"],
             names=("--output", "resource", "no pass slot", "nosuch"))
    for bad in ["{cwd}/out.bmp", "{cwd}/out", "{cwd}/out.", "{cwd}/.png", "-"]:
        b.add("render -o " + bad.replace("{cwd}/", ""), W, ["render", S, "-o", bad], names=("extension", "-o"))
    b.add("render -o out.PNG", W, ["render", S, "-o", "{cwd}/out.PNG"], expect="ok")
    b.in_paths("render scene", W, lambda p: ["render", p] + png, ".json", quick=("fifo", "dev-zero-link", "folder"))
    b.in_paths("render gltf", W, lambda p: ["render", p] + png, ".glb", quick=())
    b.in_paths("render --pipeline", W, lambda p: ["render", S, "--pipeline", p] + png, ".json", quick=("fifo",))
    b.out_paths("render -o", W, lambda p: ["render", S, "-o", p], ".png",
                quick=("read-only-file", "fifo", "below-a-file", "full-disk", "dev-full-link"))
    b.out_paths("render -o .exr", W, lambda p: ["render", S, "--size", "16x8", "-o", p], ".exr",
                skip=("in-sys", "long-name", "empty-arg", "dev-null-link"))
    for name in ["broken", "deep", "array", "nan", "wrong-types", "huge-size", "negative-size", "nan-camera", "same-eye",
                 "mesh-link-out", "mesh-dotdot", "mesh-dev-urandom", "mesh-proc"]:
        b.add("render scene " + name, W, ["render", "{fx}/%s.json" % name] + png,
              names=(name + ".json", "passwd", "urandom", "status"), quick=name in ("deep", "mesh-link-out"))
    b.add("render scene bom", W, ["render", "{fx}/bom.json"] + png, expect="any",
          note="a UTF-8 byte-order mark before a valid scene")
    for name, _, _, _ in IN_PATHS + IN_ABSOLUTE:
        if name in ("long-name", "sparse-3g", "empty-arg"):
            continue
        for kind, x, _ in asset_scenes():
            path_name = dict((n, f) for n, f, _, _ in IN_PATHS + IN_ABSOLUTE)[name].replace("{x}", x)
            # A colour map that is a folder or does not decode is a warning naming it, and the
            # object is drawn without it (weft's rule for maps; docs/scene-format.md); a path that
            # is not a file to read at all (a FIFO, a device) is an error.
            degrade = kind == "texture" and name in ("folder", "empty-file", "text", "junk")
            b.add("render %s asset %s" % (kind, name), W, ["render", "{fx}/asset-%s-%s.json" % (kind, name)] + png,
                  names=(Path(path_name).name,), quick=(kind, name) in (("mesh", "fifo"), ("sky", "dev-zero-link")),
                  expect="any" if degrade else "fail", note="a warning names the map; drawn without it" if degrade else "")

    # -- weft graph, graph check
    G = ["graph", S]
    b.add("graph valid", W, G, expect="ok")
    b.add("graph no scene", W, ["graph"], names=("scene",))
    b.add("graph --pass-types", W, ["graph", "--pass-types"], expect="ok")
    b.add("graph --dot -", W, G + ["--dot", "-"], expect="ok")
    b.in_paths("graph scene", W, lambda p: ["graph", p], ".json", quick=("socket",))
    b.in_paths("graph --pipeline", W, lambda p: G + ["--pipeline", p], ".json")
    b.values("graph", W, G, "--size", ["0x0", "-1x-1", "nanxnan", "99999999999x24"], good="16x8")
    b.values("graph", W, G, "--quality", ["", "bogus"], good="high")
    b.out_paths("graph --dot", W, lambda p: G + ["--dot", p], ".dot", quick=("fifo", "read-only-file", "file-size-limit"), fsize=True)
    b.out_paths("graph --export-pipeline", W, lambda p: G + ["--export-pipeline", p], ".json", quick=("dev-full-link",), fsize=True)
    GC = ["graph", "check", S]
    b.add("graph check valid", W, GC, expect="ok")
    b.add("graph check no scene", W, ["graph", "check"], names=("scene",))
    b.in_paths("graph check scene", W, lambda p: ["graph", "check", p], ".json")
    b.in_paths("graph check --pipeline", W, lambda p: GC + ["--pipeline", p], ".json")
    b.values("graph check", W, GC, "--size", ["0x0", "-1x-1", "x"], good="16x8")
    for name in ["broken", "deep", "nan", "huge-size"]:
        b.add("graph check scene " + name, W, ["graph", "check", "{fx}/%s.json" % name], names=(name + ".json",))

    # -- weft tradeoff (refusals only: a valid study renders for a while)
    T = ["tradeoff", "{fx}/fur.json", "--feature", "fur", "--frames", "1", "--values", "layers=1", "-o", "{cwd}/study"]
    b.add("tradeoff no scene", W, ["tradeoff", "--feature", "fur"], names=("scene",))
    b.add("tradeoff --list", W, ["tradeoff", "--list"], expect="ok")
    b.in_paths("tradeoff scene", W, lambda p: ["tradeoff", p, "--feature", "fur", "-o", "{cwd}/study"], ".json",
               quick=("fifo",))
    b.in_paths("tradeoff --pipeline", W,
               lambda p: ["tradeoff", "{fx}/fur.json", "--pass", "shadow_map", "--pipeline", p, "-o", "{cwd}/study"], ".json")
    b.values("tradeoff", W, T, "--frames", ["", "0", "-1", "abc", "nan", "1001", "99999999999999999999"], good="1")
    b.values("tradeoff", W, T, "--size", ["0x0", "-1x-1", "nanxnan", "99999999999x1", ""], good="16x8")
    b.values("tradeoff", W, T, "--exposure", ["nan", "inf", "-1", "0", "abc", ""], good="1")
    b.values("tradeoff", W, T, "--feature", ["", "bogus", "FUR"], names=("feature", "bogus", "fur"))
    for v in ["", "layers", "layers=", "layers=abc", "layers=nan", "layers=inf", "layers=-1", "layers=1,,2", "=1",
              "nosuch=1", "layers=99999999999", "layers=1e999", "layers=0x10"]:
        b.add("tradeoff --values " + (v or "empty"), W, T + ["--values", v], names=("--values", "layers", "knob", v or "''"),
              quick=v == "layers=nan")
    for v in ["", "layers", "layers=nan", "nosuch=1,2"]:
        b.add("tradeoff --cross " + (v or "empty"), W, T + ["--cross", v], names=("--cross", "layers", "knob", v or "''"))
    for v in ["", "layers", "layers=nan", "nosuch=1"]:
        b.add("tradeoff --extremes --base " + (v or "empty"), W, T + ["--extremes", "--base", v],
              names=("--base", "layers", "knob", v or "''"))
    b.values("tradeoff", W, T, "--batch", ["0", "-1", "abc", "100001"], good="2")
    b.values("tradeoff", W, T, "--pass", ["", "nosuch"], names=("--pass", "nosuch", "pass"))
    b.add("tradeoff --task bogus", W, T + ["--task", "bogus", "--cache", "{cwd}/cache"], names=("bogus",))
    b.in_paths("tradeoff --from-cache", W, lambda p: T + ["--from-cache", p], "",
               skip=("folder", "long-name", "sparse-3g", "socket", "dev-null-link"),
               names_of=lambda p: (Path(p).name, "cache", "task"))
    b.add("tradeoff -o an existing empty folder", W, T, expect="ok", setup=lambda cwd: (cwd / "study").mkdir())
    b.out_paths("tradeoff -o", W, lambda p: T[:-1] + [p], "", kinds="any",
                skip=("folder", "dev-full-link", "dev-null-link", "file-size-limit", "full-disk", "read-only-folder"),
                note="tradeoff makes its output folder")
    b.out_paths("tradeoff --tasks", W, lambda p: T + ["--tasks", p, "--cache", "{cwd}/cache"], ".json",
                skip=("full-disk",), fsize=True)

    # -- weft bake skin-lut | ssdf | btf
    L = ["bake", "skin-lut", "-o", "{cwd}/lut.exr", "--size", "8", "--samples", "8"]
    b.add("bake no asset", W, ["bake"], names=("subcommand", "required"))
    b.add("bake nosuch", W, ["bake", "nosuch"], names=("nosuch",))
    b.add("bake skin-lut valid", W, L, expect="ok", quick=True)
    b.add("bake skin-lut no -o", W, ["bake", "skin-lut"], names=("-o", "--output", "required"))
    b.values("bake skin-lut", W, L, "--size", BAD_UINT + ["0", "1", "4097"], good="8", quick=("-1",))
    zero_default = [("0", "0 is the default: the side is --size")]
    b.values("bake skin-lut", W, L, "--width", ["-1", "abc", "99999999999"], good="8", extra_ok=zero_default)
    b.values("bake skin-lut", W, L, "--height", ["-1", "nan", "4294967296"], good="8", extra_ok=zero_default)
    b.values("bake skin-lut", W, L, "--samples", ["0", "-1", "abc", "99999999999", "4294967295"], good="8")
    b.values("bake skin-lut", W, L, "--threads", ["-1", "abc", "99999999999", "4294967295", "100000"], good="1",
             quick=("100000",))
    b.values("bake skin-lut", W, L, "--max-curvature", BAD_FLOAT + ["0", "-1", "11"], good="2")
    b.values("bake skin-lut", W, L, "--variance-scale", ["nan", "inf", "-1", "abc", ""], good="1",
             extra_ok=[("0", "0 is the default: no override"), ("1e38", "a finite override: a LUT blurred flat")])
    for opt in ["--range", "--convention", "--normalization", "--quadrature"]:
        b.values("bake skin-lut", W, L, opt, ["", "bogus"])
    b.add("bake skin-lut -o .bmp", W, ["bake", "skin-lut", "-o", "{cwd}/lut.bmp", "--size", "8"], names=(".bmp", "extension"))
    b.out_paths("bake skin-lut -o", W, lambda p: ["bake", "skin-lut", "--size", "8", "--samples", "8", "-o", p], ".exr",
                quick=("read-only-file",), fsize=True)
    b.out_paths("bake skin-lut -o .png", W, lambda p: ["bake", "skin-lut", "--size", "64", "--samples", "8", "-o", p], ".png",
                skip=("in-sys", "empty-arg", "long-name", "full-disk"), fsize=True)
    SS = ["bake", "ssdf", S, "-o", "{cwd}/x.wssdf", "--resolution", "4", "--clusters", "2", "--components", "2"]
    b.add("bake ssdf no scene", W, ["bake", "ssdf", "-o", "{cwd}/x.wssdf"], names=("scene", "required"))
    b.values("bake ssdf", W, SS, "--resolution", BAD_UINT + ["0", "1025"], good="4", quick=("0",))
    b.values("bake ssdf", W, SS, "--clusters", ["0", "-1", "abc", "99999999999", "4294967295"], good="2")
    b.values("bake ssdf", W, SS, "--components", ["0", "-1", "nan", "4294967295"], good="2")
    b.values("bake ssdf", W, SS, "--energy", ["0", "-1", "1.5", "nan", "inf", "abc", ""], good="0.9")
    b.values("bake ssdf", W, SS, "--seeding", ["", "bogus"])
    b.values("bake ssdf", W, SS, "--coefficients", ["", "bogus", "fp64"])
    b.values("bake ssdf", W, SS, "--seed", ["-1", "abc", "99999999999999999999999"], good="3")
    b.values("bake ssdf", W, SS, "--threads", ["-1", "abc", "4294967295"], good="1")
    b.in_paths("bake ssdf scene", W, lambda p: ["bake", "ssdf", p, "-o", "{cwd}/x.wssdf", "--resolution", "4"], ".json")
    # (a 3 GiB mesh is read as asked: meshes may be that large, so the sparse file is not tried)
    b.in_paths("bake ssdf mesh", W, lambda p: ["bake", "ssdf", p, "-o", "{cwd}/x.wssdf", "--resolution", "4"], ".obj",
               skip=("empty-arg", "dev-zero", "dev-stdin", "proc-self-mem", "proc-kmsg", "sparse-3g"))
    b.out_paths("bake ssdf -o", W, lambda p: ["bake", "ssdf", S, "--resolution", "4", "--clusters", "2", "--components", "2",
                                              "-o", p], ".wssdf", skip=("in-sys", "long-name"))
    B = ["bake", "btf", "--synthetic", "4x4", "--epochs", "1", "--directions", "16", "-o", "{cwd}/x.wbtf"]
    b.add("bake btf valid", W, B, expect="ok")
    b.values("bake btf", W, B, "--synthetic", BAD_SIZE[:16] + ["99999x99999", "65536x65536"], good="4x4",
             names=("--synthetic", "texels"), quick=("65536x65536",))
    b.values("bake btf", W, B, "--clusters", ["-1", "abc", "99999999999", "4294967295", "17"], good="4")
    b.values("bake btf", W, B, "--epochs", ["0", "-1", "abc", "1000001", "nan"], good="1")
    b.values("bake btf", W, B, "--minutes", BAD_FLOAT + ["-1"], good="0")
    b.values("bake btf", W, B, "--recipe", ["", "bogus"])
    b.values("bake btf", W, B, "--directions", ["-1", "abc", "99999999999", "4294967295", "6562"], good="16")
    b.values("bake btf", W, B, "--batch", ["0", "-1", "abc"], good="4", extra_ok=[("4294967295", "more than the data has is all of it (the value is clamped)")])
    b.values("bake btf", W, B, "--optimizer", ["", "bogus"])
    b.values("bake btf", W, B, "--learning-rate", BAD_FLOAT + ["-1", "1e38"], good="0.01", quick=("nan",))
    b.values("bake btf", W, B, "--schedule", ["", "bogus"])
    b.values("bake btf", W, B, "--holdout", ["-1", "abc"], good="1", extra_ok=[("4294967295", "more than the data has is all of it (the value is clamped)"), ("16", "every 16th pair of 16 texels")])
    b.values("bake btf", W, B, "--patience", ["-1", "abc"], good="2", extra_ok=[("4294967295", "more than the data has is all of it (the value is clamped)")])
    b.values("bake btf", W, B, "--finetune", ["nan", "-0.1", "1.1", "inf", "abc", ""], good="0.5")
    b.values("bake btf", W, B, "--seed", ["-1", "abc", "99999999999999999999999"], good="3")
    b.values("bake btf", W, B, "--threads", ["-1", "abc", "4294967295", "100000"], good="1")
    b.values("bake btf", W, B, "--weave", ["", "bogus"])
    b.in_paths("bake btf input", W, lambda p: ["bake", "btf", p, "-o", "{cwd}/x.wbtf", "--epochs", "1"], ".btfraw",
               quick=("fifo",))
    b.out_paths("bake btf -o", W, lambda p: ["bake", "btf", "--synthetic", "4x4", "--epochs", "1", "--directions", "16",
                                             "-o", p], ".wbtf", quick=("read-only-file",), fsize=True)
    b.out_paths("bake btf --checkpoint", W, lambda p: B + ["--checkpoint", p], ".ckpt",
                skip=("empty-arg", "in-sys", "long-name", "dev-null-link"), fsize=True)

    # -- weft view: no display here, so every session fails; the script and options are read first
    V = ["view", S]
    b.add("view no scene", W, ["view"], names=("scene",))
    b.add("view valid, no display", W, V + ["--script", "{fx}/script-ok.txt"], names=("display",), env={"DISPLAY": None})
    b.values("view", W, V, "--size", ["0x0", "-1x-1", "16385x1", "nanxnan", "", "x"], good="64x48")
    b.values("view", W, V, "--quality", ["", "bogus"])
    b.values("view", W, V, "--motion-budget-ms", ["0", "-1", "nan", "inf", "abc", "100001"], good="50")
    b.values("view", W, V, "--accumulate", ["0", "-1", "abc", "4097"], good="2")
    b.values("view", W, V, "--scene-device", ["", "bogus"])
    b.in_paths("view scene", W, lambda p: ["view", p], ".json", env={"DISPLAY": None})
    b.in_paths("view --script", W, lambda p: V + ["--script", p], ".txt", quick=("fifo",), env={"DISPLAY": None},
               skip=("empty-file",))
    # The viewer names a --pipeline that is not a readable file before the window opens; what the
    # file says is the live reload's (shown in the UI), so text, junk and big files are not tried.
    b.in_paths("view --pipeline", W, lambda p: V + ["--pipeline", p], ".json", env={"DISPLAY": None},
               skip=("dev-null-link", "empty-file", "text", "junk", "sparse-3g"))
    for name, p in [("missing", "{fx}/nope"), ("a file", "{fx}/afile"), ("fifo", "{fx}/fifo.txt"), ("dev-zero", "/dev/zero")]:
        b.add("view --shader-dir " + name, W, V + ["--shader-dir", p], names=(Path(p).name, "shader"), env={"DISPLAY": None})
    for label, text in [("orbit nan", "orbit nan nan"), ("pan inf", "pan inf -inf"), ("zoom 0", "zoom 0"),
                        ("zoom -1", "zoom -1"), ("zoom nan", "zoom nan"), ("fly inf", "fly inf 0 0"),
                        ("resize -1", "resize -1 -1"), ("resize 0", "resize 0 0"), ("resize huge", "resize 99999999 99999999"),
                        ("resize nan", "resize nan nan"), ("wait -1", "wait -1"), ("wait huge", "wait 99999999999999"),
                        ("wait nan", "wait nan"), ("unknown", "frobnicate"), ("arity", "orbit 1"), ("knob", "knob"),
                        ("budget nan", "budget nan"), ("budget 0", "budget 0"), ("accumulate 0", "accumulate 0"),
                        ("accumulate huge", "accumulate 99999999999"), ("quality", "quality ultra"),
                        ("option json", "option tonemap exposure {"), ("knob json", "knob m roughness [[["),
                        ("long line", "orbit " + "9" * 100000 + " 1"), ("nul", "orbit 1\0 2"),
                        ("junk", "\x7fELF\x02\x01\x01"), ("ui", "ui maybe"), ("overlay", "overlay sideways")]:
        def write_script(cwd, text=text):
            (cwd / "session.txt").write_text(text + "\n")
        b.add("view script " + label, W, V + ["--script", "{cwd}/session.txt"], setup=write_script,
              names=("session.txt", "line"), env={"DISPLAY": None}, quick=label in ("orbit nan", "resize -1"))

    # -- weft farm
    b.add("farm no subcommand", W, ["farm"], names=("subcommand", "required"))
    b.add("farm plan empty spec", W, ["farm", "plan", "{fx}/farm-spec-empty.json", "--cache", "{cwd}/cache"],
          names=("studies",))
    b.add("farm plan valid", W, ["farm", "plan", "{fx}/farm-spec.json", "--cache", "{cwd}/cache"], expect="ok")
    b.add("farm plan bad spec", W, ["farm", "plan", "{fx}/farm-spec-bad.json", "--cache", "{cwd}/cache"],
          names=("farm-spec-bad.json", "nosuch", "nope.json"))
    b.in_paths("farm plan spec", W, lambda p: ["farm", "plan", p, "--cache", "{cwd}/cache"], ".json", quick=("fifo",))
    for name in ["broken", "deep", "array", "nan"]:
        b.add("farm plan spec " + name, W, ["farm", "plan", "{fx}/%s.json" % name, "--cache", "{cwd}/cache"],
              names=(name + ".json",))
    b.out_paths("farm plan -o", W, lambda p: ["farm", "plan", "{fx}/farm-spec.json", "--cache", "{cwd}/cache", "-o", p],
                ".json", skip=("missing-parent",), fsize=True)
    b.add("farm run no --farm", W, ["farm", "run", "{fx}/farm-spec-empty.json"], names=("--farm",))
    b.values("farm run", W, ["farm", "run", "{fx}/farm-spec-empty.json", "--cache", "{cwd}/cache"], "--farm", ["", "bogus",
                                                                                                              "LOCAL"])
    b.values("farm run", W, ["farm", "run", "{fx}/farm-spec-empty.json", "--cache", "{cwd}/cache", "--farm", "local"], "-j",
             ["0", "-1", "abc", "1025", "99999999999", "nan"], good="1")
    b.add("farm run --partition without slurm", W, ["farm", "run", "{fx}/farm-spec-empty.json", "--farm", "local",
                                                    "--partition", "x"], names=("--partition",))
    b.add("farm run --farm slurm (no sbatch)", W, ["farm", "run", "{fx}/farm-spec-empty.json", "--farm", "slurm",
                                                   "--cache", "{cwd}/cache"], names=("sbatch", "slurm"),
          env={"PATH": "/nonexistent"})
    b.in_paths("farm run input", W, lambda p: ["farm", "run", p, "--farm", "local", "--cache", "{cwd}/cache"], ".json")
    b.in_paths("farm task list", W, lambda p: ["farm", "task", p, "0"], ".json")
    b.add("farm task bad list", W, ["farm", "task", "{fx}/farm-list-bad.json", "0"], names=("farm-list-bad.json",))
    for v in ["-1", "abc", "99999999999999999999", "1e3", "", "nan"]:
        b.add("farm task index " + (v or "empty"), W, ["farm", "task", "{fx}/farm-list-bad.json", v],
              names=("index", v or "empty", "farm-list-bad.json"))
    b.in_paths("farm reduce list", W, lambda p: ["farm", "reduce", p], ".json")
    # Any regular file's bytes are placed as they are (a task's output is opaque): empty, text and
    # junk files are valid; a 3 GiB file is placed as asked (3 GiB written), so it is left out.
    b.in_paths("farm place from", W, lambda p: ["farm", "place", p, "{cwd}/to.bin"], ".bin",
               skip=("sparse-3g", "empty-file", "text", "junk"))
    for name in ("empty", "text", "junk"):
        b.add("farm place from " + name, W, ["farm", "place", "{fx}/%s.bin" % name, "{cwd}/to.bin"], expect="ok")
    b.out_paths("farm place to", W, lambda p: ["farm", "place", "{fx}/from-big.bin", p], ".bin", kinds="any",
                note="farm place makes the folders it needs", quick=("fifo",), fsize=True)
    for sub in ["status", "wait", "collect"]:
        for v in ["", "nosuch", "../../../../etc", "12345; rm -rf /", "-1"]:
            b.add("farm %s job %s" % (sub, v or "empty"), W, ["farm", sub, "--cache", "{cwd}/cache", "--", v] if v.startswith("-")
                  else ["farm", sub, v, "--cache", "{cwd}/cache"], names=("job", v or "empty", "cache", "sbatch", "slurm"),
                  env={"PATH": "/nonexistent"})
    b.values("farm wait", W, ["farm", "wait", "nosuch", "--cache", "{cwd}/cache"], "--timeout",
             ["nan", "inf", "-1", "abc", "1e8", ""], good="1")

    # -- the benchmarks and examples: --help answers at once, bad arguments are refused before any work
    def bench(program, options, positional=None):
        b.add(program + " --help", program, ["--help"], expect="ok")
        b.add(program + " --frobnicate", program, ["--frobnicate"], names=("frobnicate", "usage"))
        for option, bad, names in options:
            b.add("%s %s missing value" % (program, option), program, [option], names=(option, "usage"))
            for v in bad:
                # quick: the first option's non-number, which a stoul or atoi took for a crash or a zero
                b.add("%s %s=%s" % (program, option, v or "empty"), program, [option, v],
                      names=(option, "usage") + ((v,) if v.strip() else ()),
                      quick=option == options[0][0] and v in ("abc", "-1x-1"))
    num = ["abc", "-1", "0", "nan", "99999999999", ""]
    flt = ["abc", "nan", "inf", "-1", ""]
    sz = ["-1x-1", "0x0", "abc", "99999x99999", "16"]
    bench("weft-bench-aa", [("--size", sz, ()), ("--time-size", sz[:2], ()), ("--reference-scale", ["1", "9", "abc"], ()),
                            ("--runs", num, ()), ("--accumulate", ["1", "abc", "2,,3", "99999"], ()),
                            ("--edge-threshold", flt + ["0", "1"], ()), ("--move-frames", ["-1", "abc", "10001"], ()),
                            ("--move-step", flt + ["0", "10"], ())])
    b.in_paths("weft-bench-aa --scene", "weft-bench-aa", lambda p: ["--scene", p, "--no-timing"], ".json",
               skip=("empty-arg", "proc-kmsg", "proc-self-mem"))
    # --out is a folder made before any work (a missing scene then stops the run); an existing
    # folder and one below a missing folder are valid.
    b.out_paths("weft-bench-aa --out", "weft-bench-aa", lambda p: ["--scene", "{fx}/missing.json", "--out", p], "",
                skip=("folder", "read-only-file", "fifo", "dev-full-link", "dev-null-link", "file-size-limit", "full-disk",
                      "read-only-folder", "missing-parent"))
    bench("weft-bench-btf-data", [("--size", num, ()), ("--runs", num, ()), ("--pca-sample", num[:4], ()),
                                  ("--clusters", ["abc", "1,,2", "-1", "0", "99999999999"], ())])
    b.in_paths("weft-bench-btf-data --load", "weft-bench-btf-data", lambda p: ["--size", "4", "--load", p], ".btfraw",
               skip=("empty-arg",))
    bench("weft-bench-btf-decode", [("--runs", num, ()), ("--size", num, ()), ("--ghz", flt + ["0"], ())])
    b.add("weft-bench-btf-decode nosuch-section", "weft-bench-btf-decode", ["nosuch"], names=("nosuch",))
    bench("weft-bench-btf-interpolation", [("--directions", ["abc", "-1", "0", "257", "nan", ""], ()),
                                           ("--seed", ["abc", "-1", "99999999999999999999999"], ()),
                                           ("--weave", ["", "bogus"], ())])
    b.in_paths("weft-bench-btf-interpolation model", "weft-bench-btf-interpolation", lambda p: [p], ".wbtf", quick=("fifo",))
    bench("weft-bench-btf-train", [("--texels", num, ()), ("--clusters", ["abc", "1,,2", "-1", "99999999999"], ()),
                                   # 0 is a valid "none" or "all" for --minutes, --directions, --holdout,
                                   # --early-stop, --patience and --throughput: a full benchmark, not tried
                                   ("--minutes", flt, ()), ("--epochs", num, ()), ("--directions", num[:2] + num[3:], ()),
                                   ("--threads", ["abc", "-1", "99999999999", "100000"], ()), ("--holdout", num[:2], ()),
                                   ("--learning-rate", flt, ()), ("--optimizer", ["", "bogus"], ()),
                                   ("--schedule", ["", "bogus"], ()), ("--batch", num, ()), ("--finetune", flt + ["2"], ()),
                                   ("--early-stop", num[:2], ()), ("--patience", num[:2], ()), ("--throughput", num[:2], ()),
                                   ("--runs", num, ())])
    # A --cache that does not exist is written after the data are made (below a plain file it
    # cannot be: a warning, the benchmark goes on), so those are not tried.
    b.in_paths("weft-bench-btf-train --cache", "weft-bench-btf-train", lambda p: ["--texels", "4", "--epochs", "1",
                                                                                  "--cache", p], ".btfraw",
               skip=("missing", "dangling-link", "below-a-file", "link-loop", "long-name"))
    bench("weft-bench-fur", [("--frames", num, ()), ("--size", sz, ())])
    for v in ["", "nosuch"]:  # the object is looked up by --unfurred
        b.add("weft-bench-fur --unfurred --object=" + (v or "empty"), "weft-bench-fur", ["--unfurred", "--object", v],
              names=("--object", "object", v or "empty"))
    b.in_paths("weft-bench-fur --photo", "weft-bench-fur", lambda p: ["--accuracy", "--photo", p], ".png", quick=("fifo",))
    b.in_paths("weft-bench-fur --scene", "weft-bench-fur", lambda p: ["--unfurred", "--scene", p], ".json")
    bench("weft-bench-graph", [("--runs", num, ()), ("--sizes", ["abc", "0", "-1", "1,,2", "99999999999", ""], ()),
                               ("--builds", ["", "bogus"], ()), ("--shapes", ["", "bogus"], ())])
    bench("weft-bench-objects", [("--counts", ["0", "abc", "1,,2", "99999999999"], ()), ("--runs", num, ()),
                                 ("--size", sz, ()), ("--mesh", ["", "cone"], ())])
    bench("weft-bench-skin", [("--runs", num, ()), ("--size", sz, ())])
    b.in_paths("weft-bench-skin --head", "weft-bench-skin", lambda p: ["mesh", "--head", p], ".obj",
               skip=("sparse-3g",))  # a 3 GiB mesh is read as asked
    bench("weft-bench-ssdf", [("--resolution", num, ()), ("--threads", ["abc", "-1", "99999999999", "100000"], ()),
                              ("--only", [""], ())])
    b.in_paths("weft-bench-ssdf --teapot", "weft-bench-ssdf", lambda p: ["--quick", "--teapot", p], ".obj",
               skip=("sparse-3g",))  # a 3 GiB mesh is read as asked
    for option, bad in [("--size", num), ("--samples", num), ("--runs", num)]:
        b.add("weft-bench-ssdf --lighting %s missing value" % option, "weft-bench-ssdf", ["--lighting", option],
              names=(option, "usage"))
        for v in bad:
            b.add("weft-bench-ssdf --lighting %s=%s" % (option, v or "empty"), "weft-bench-ssdf", ["--lighting", option, v],
                  names=(option, "usage") + ((v,) if v else ()))

    # examples: programs a user runs first
    bench("weft-triangle", [("--size", sz, ())])
    b.out_paths("weft-triangle -o", "weft-triangle", lambda p: ["--size", "16x16", "-o", p], ".png",
                quick=("read-only-file",))
    bench("weft-custom-feature", [("--size", sz, ())])
    b.in_paths("weft-custom-feature scene", "weft-custom-feature", lambda p: [p, "-o", "{cwd}/out.png"], ".json")
    b.out_paths("weft-custom-feature --dot", "weft-custom-feature",
                lambda p: ["{src}/examples/custom_feature/scenes/toon.json", "--check", "--dot", p], ".dot",
                skip=("full-disk",))
    bench("weft-custom-pass", [("--size", sz, ())])
    b.out_paths("weft-custom-pass output", "weft-custom-pass", lambda p: [p, "--size", "16x16"], ".png",
                skip=("empty-arg",))
    bench("weft-fur-example", [("--size", sz, ()), ("--only", [""], ())])
    b.add("weft-fur-example --only=nosuch", "weft-fur-example", ["--only", "nosuch", "--out", "{cwd}/fur"],
          names=("nosuch",), max_lines=4,
          note="the images' meshes are made (three mesh warnings) before their names are known and none matches")
    b.in_paths("weft-fur-example --photo", "weft-fur-example", lambda p: ["--photo", p, "--out", "{cwd}/fur"], ".png")
    b.out_paths("weft-fur-example --write-synthetic", "weft-fur-example", lambda p: ["--write-synthetic", p], ".png",
                skip=("full-disk",), fsize=True)
    bench("weft-scene-in-code", [("--size", sz, ())])
    bench("weft-skin-example", [("--size", sz, ())])
    b.in_paths("weft-skin-example --head", "weft-skin-example", lambda p: ["{cwd}/skin", "--head", p], ".obj",
               skip=("sparse-3g",))  # a 3 GiB mesh is read as asked

    # Anything else in --bin: --help answers and an unknown option is refused.
    known = {c.program for c in b.cases}
    for program in sorted(programs - known):
        b.add(program + " --help", program, ["--help"], expect="any", note="not a program this script knows")
        b.add(program + " --frobnicate", program, ["--frobnicate"], names=("frobnicate", "usage", "unknown"))
    return b.cases


# ---- running and judging ----------------------------------------------------------------------

def snapshot(folder: Path):
    out = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for n in dirnames + filenames:
            p = Path(dirpath) / n
            try:
                st = p.lstat()
            except OSError:
                continue
            digest = ""
            if stat.S_ISREG(st.st_mode) and st.st_size > (1 << 20):
                digest = "%d bytes, mtime %d" % (st.st_size, st.st_mtime_ns)  # the sparse fixtures: not read
            elif stat.S_ISREG(st.st_mode):
                try:
                    digest = hashlib.sha1(p.read_bytes()).hexdigest()
                except OSError:
                    digest = "?"
            elif stat.S_ISLNK(st.st_mode):
                digest = "->" + os.readlink(p)
            out[str(p.relative_to(folder))] = (stat.S_IFMT(st.st_mode), stat.S_IMODE(st.st_mode), digest)
    return out


def expand(arg, ctx):
    for k, v in ctx.items():
        arg = arg.replace("{%s}" % k, v)
    return arg


def message_lines(text):
    lines = [l for l in text.splitlines() if l.strip()]
    kept = []
    for l in lines:
        if l.lower().lstrip().startswith("usage") or l.startswith("Run with --help"):
            if l.startswith("Run with --help"):
                continue
            break  # a usage block ends the message
        if LOG_LINE.match(l):
            continue
        kept.append(l)
        if PROBLEMS_LINE.search(l):
            break  # "3 problems:" and one line each: a reader's report of every problem is one error
    return kept


def judge(case, rc, out, err, seconds, timed_out, before, after, extra_dirty):
    text = out + err
    if timed_out:
        return "hang", "still running after %.0f s" % seconds
    if rc is not None and rc < 0:
        return "crash", "killed by signal %s" % signal.Signals(-rc).name
    for m in CRASH_MARKERS:
        if m in text:
            return "crash", "output says '%s'" % m
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    changed += extra_dirty
    if rc == 0:
        if case.expect in ("ok", "any"):
            return "accepted", case.note or "valid input"
        return "messy", "exit 0 on input that must be refused"
    for m in MESSY_MARKERS:
        if m in text and not any(m in a for a in case.args):
            return "messy", "output has '%s'" % m
    if case.expect == "ok":
        return "messy", "refused valid input (exit %d): %s" % (rc, (message_lines(err) or ["?"])[0][:200])
    lines = message_lines(err)
    if not lines:
        return "messy", "exit %d with no error on stderr" % rc
    if len(lines) > (case.max_lines or MAX_LINES):
        return "messy", "%d lines of error" % len(lines)
    names = [n for n in case.names if n]
    if names and not any(n.lower() in text.lower() for n in names):
        return "messy", "the error names none of %s" % ", ".join(repr(n[:40]) for n in names)
    if changed:
        return "messy", "left behind or changed: %s" % ", ".join(c[:60] for c in changed[:4])
    return "clean", ""


def run_case(case, bin_dir, root, fx, full, timeout, memory_mb, keep):
    cwd = root / "cases" / re.sub(r"[^A-Za-z0-9_.=-]+", "_", case.id)[:80]
    n = 2
    while cwd.exists():
        cwd = cwd.with_name(cwd.name.split("#")[0] + "#%d" % n)
        n += 1
    cwd.mkdir(parents=True)
    if case.setup:
        case.setup(cwd)
    ctx = {"fx": str(fx), "cwd": str(cwd), "src": str(SOURCE), "full": str(full) if full else "/nonexistent-full"}
    argv = [str(bin_dir / case.program)] + [expand(a, ctx) for a in case.args]
    before = snapshot(cwd)
    full_before = snapshot(full) if full else {}
    env = dict(os.environ)
    env.update({"HOME": str(root / "home"), "WEFT_CACHE_DIR": str(root / "home" / "cache"), "LC_ALL": "C"})
    for k in ("WEFT_PLUGIN_PATH", "WEFT_LOG", "DISPLAY", "WAYLAND_DISPLAY"):
        env.pop(k, None)
    for k, v in case.env.items():
        if v is None:
            env.pop(k, None)
        else:
            env[k] = v
    limits = "ulimit -c 0"
    if memory_mb:
        limits += "; ulimit -v %d" % (memory_mb * 1024)
    if case.fsize_blocks:
        limits += "; ulimit -f %d" % case.fsize_blocks
    wrapper = ["/bin/sh", "-c", limits + '; trap "" XFSZ; exec "$@"', "sh"] + argv
    t0 = time.monotonic()
    try:
        p = subprocess.Popen(wrapper, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             env=env, start_new_session=True)
    except (OSError, ValueError) as e:  # an argument with a NUL byte, say
        return Outcome(case, "clean" if case.expect != "ok" else "messy", "not startable: %s" % e, None, 0.0, "")
    timed_out = False
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        timed_out = True
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        out, err = p.communicate()
    seconds = time.monotonic() - t0
    try:  # a child left running in the group would be a hang too
        os.killpg(p.pid, 0)
        os.killpg(p.pid, signal.SIGKILL)
        left_running = True
    except (ProcessLookupError, PermissionError):
        left_running = False
    out = out.decode("utf-8", "replace")
    err = err.decode("utf-8", "replace")
    after = snapshot(cwd)
    dirty = []
    if full:
        fa = snapshot(full)
        dirty = ["{full}/" + k for k in set(full_before) | set(fa) if full_before.get(k) != fa.get(k)]
        for k in fa:
            if k not in full_before:
                try:
                    (full / k).unlink()
                except OSError:
                    pass
    if case.expect in ("ok", "any"):
        before, after = {}, {}  # an accepted case may write its output
    klass, reason = judge(case, p.returncode, out, err, seconds, timed_out, before, after, dirty)
    if left_running and klass not in ("hang", "crash"):
        klass, reason = "hang", "left a process running after it exited"
    if not keep:
        for dirpath, dirnames, _ in os.walk(cwd):
            for d in dirnames:
                try:
                    os.chmod(Path(dirpath) / d, 0o755)
                except OSError:
                    pass
        shutil.rmtree(cwd, ignore_errors=True)
    return Outcome(case, klass, reason, p.returncode, seconds, out + err)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="Classes: clean, accepted, crash, hang, messy (see the top of this file).")
    ap.add_argument("--bin", type=Path, default=SOURCE / "build" / "bin", help="the folder of weft and its programs")
    ap.add_argument("--jobs", "-j", type=int, default=2, help="cases at once (default 2)")
    ap.add_argument("--filter", default="", help="only cases whose id matches this regular expression")
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds before a case is a hang (default 60)")
    ap.add_argument("--quick", action="store_true", help="the ctest subset: a few dozen fast cases")
    ap.add_argument("--csv", type=Path, default=None, help="write every case here (default: hostile_cli.csv in the "
                    "current folder; --quick: none)")
    ap.add_argument("--list", action="store_true", help="print the cases and exit")
    ap.add_argument("--keep", action="store_true", help="keep the scratch folder (fixtures and each case's folder)")
    ap.add_argument("--memory-mb", type=int, default=8192, help="address-space limit of each case (0: none; a sanitizer "
                    "build needs 0)")
    a = ap.parse_args()
    a.bin = a.bin.resolve()  # each case runs in a folder of its own

    # Every program in --bin but the test suites (test_*) and fuzz harnesses (fuzz_*), which ctest runs.
    programs = {p.name for p in a.bin.iterdir() if p.is_file() and os.access(p, os.X_OK) and not p.name.startswith(("test_", "fuzz_"))
                } if a.bin.is_dir() else set()
    if "weft" not in programs and not a.list:
        print("hostile_cli: no weft in %s (build it, or give --bin DIR)" % a.bin, file=sys.stderr)
        return 2
    if a.list and not programs:
        programs = {"weft", "weft-triangle", "weft-custom-feature", "weft-custom-pass", "weft-fur-example",
                    "weft-scene-in-code", "weft-skin-example"} | {"weft-bench-" + n for n in (
                        "aa", "btf-data", "btf-decode", "btf-interpolation", "btf-train", "fur", "graph", "objects",
                        "skin", "ssdf")}
    cases = build_cases(programs)
    if a.quick:
        cases = [c for c in cases if c.quick]
    if a.filter:
        rx = re.compile(a.filter)
        cases = [c for c in cases if rx.search(c.id)]
    if a.list:
        for c in cases:
            print("%-60s %-6s %s %s" % (c.id[:60], c.expect, c.program, shlex.join(c.args)[:200]))
        print("%d cases" % len(cases))
        return 0

    root = Path(tempfile.mkdtemp(prefix="weft-hostile-"))
    full = None
    try:
        fx = root / "fx"
        make_fixture(fx, SOURCE)
        (root / "home").mkdir()
        # The full run mounts a full tmpfs when it may (root); --quick (ctest) never mounts: its
        # full disk is the file-size limit.
        if any(c.needs == "full" for c in cases) and not a.quick:
            full = mount_full_fs(root)
        if not full:
            cases = [c for c in cases if c.needs != "full"]
        fx_before = snapshot(fx)
        results = []
        lock = threading.Lock()
        t0 = time.monotonic()

        def one(c):
            r = run_case(c, a.bin, root, fx, full, a.timeout, a.memory_mb, a.keep)
            with lock:
                results.append(r)
                if r.klass in ("crash", "hang", "messy"):
                    print("%-6s %-55s %s" % (r.klass, r.case.id[:55], r.reason[:120]), flush=True)
            return r

        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, a.jobs)) as pool:
            list(pool.map(one, cases))
        wall = time.monotonic() - t0
        fx_after = snapshot(fx)
        fx_changed = sorted(k for k in set(fx_before) | set(fx_after) if fx_before.get(k) != fx_after.get(k))
    finally:
        if full:
            subprocess.run(["umount", "-l", str(full)], capture_output=True)
        if not a.keep:
            shutil.rmtree(root, ignore_errors=True)
        else:
            print("kept %s" % root)

    order = {c.id: i for i, c in enumerate(cases)}
    results.sort(key=lambda r: order[r.case.id])
    classes = ["clean", "accepted", "crash", "hang", "messy"]

    def group(c):
        if c.program != "weft":
            return c.program
        subcommands = ("info", "render", "graph", "bake", "tradeoff", "view", "farm")
        words = [w for w in c.args[:2] if not w.startswith("-") and not w.startswith("{")]
        if not words or words[0] not in subcommands:
            return "weft (no subcommand)"
        if words[:1] == ["graph"] and words[1:2] == ["check"]:
            return "weft graph check"
        if words[:1] in (["bake"], ["farm"]) and len(words) > 1:
            return "weft " + " ".join(words[:2])
        return "weft " + words[0] if words else "weft"

    table = {}
    for r in results:
        table.setdefault(group(r.case), {k: 0 for k in classes})[r.klass] += 1
    print("\n| program | cases | " + " | ".join(classes) + " |")
    print("|:--|--:|" + "--:|" * len(classes))
    for g in sorted(table):
        row = table[g]
        print("| %s | %d | %s |" % (g, sum(row.values()), " | ".join(str(row[k]) for k in classes)))
    totals = {k: sum(row[k] for row in table.values()) for k in classes}
    print("| **all** | **%d** | %s |" % (len(results), " | ".join("**%d**" % totals[k] for k in classes)))
    print("\n%d cases in %.0f s (--jobs %d, --timeout %.0f s)%s" % (len(results), wall, a.jobs, a.timeout,
                                                                   "" if full else "; no full file system mounted (--quick, or not root)"))
    if fx_changed:
        print("the fixtures changed (a case wrote where it must not): %s" % ", ".join(fx_changed[:8]))

    out_csv = a.csv if a.csv else (None if a.quick else Path("hostile_cli.csv"))
    if out_csv:
        with open(out_csv, "w", newline="", errors="backslashreplace") as f:
            w = csv.writer(f)
            w.writerow(["id", "program", "class", "exit", "seconds", "expect", "reason", "args", "first_line"])
            for r in results:
                first = next((l for l in (r.output or "").splitlines() if l.strip()), "")
                w.writerow([r.case.id, r.case.program, r.klass, r.rc, "%.2f" % r.seconds, r.case.expect, r.reason,
                            shlex.join(r.case.args)[:500], first[:300]])
        print("wrote %s" % out_csv)
    bad = totals["crash"] + totals["hang"] + totals["messy"]
    return 1 if bad or fx_changed else 0


if __name__ == "__main__":
    sys.exit(main())
