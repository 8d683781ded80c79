#!/usr/bin/python3
"""Soak test of `weft view` (issue 33, item 2): a long scripted session under Xvfb -- orbits,
knob changes, a scene save every cycle (valid and invalid in turn), a shader save every third
cycle, resizes, minimise/restore -- while the process's resident memory and open file
descriptors are sampled every --sample seconds. Prints the samples and the growth after the
first --settle seconds (the peak of the later half against the earlier half's, in MiB per 10
minutes, which is judged; a least-squares slope and the range for information), and the
viewer's own count of validation messages; exits 1 when the slope exceeds --max-growth or a
validation message was printed, 2 on bad arguments or a viewer that did not run.

    /usr/bin/python3 tools/soak_viewer.py --minutes 30                 # the benchmark
    /usr/bin/python3 tools/soak_viewer.py --minutes 1.5 --settle 30 --max-peak-mib 64   # ctest's short version

The session is written for the --minutes asked at the frame rate measured in a short first
run; the measured duration is printed (a slow machine makes the session longer, not shorter).
"""
import argparse
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent


def absolutize(value, base):
    """Relative asset paths of a scene, made absolute so the copy still finds them."""
    if isinstance(value, dict):
        return {k: absolutize(v, base) for k, v in value.items()}
    if isinstance(value, list):
        return [absolutize(v, base) for v in value]
    if isinstance(value, str) and value and not value.startswith("/") and (base / value).exists():
        return str((base / value).resolve())
    return value


def viewer_pid(parent):
    """The weft process under xvfb-run (a grandchild): found by its parent chain."""
    for entry in pathlib.Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmd = (entry / "cmdline").read_bytes().split(b"\0")
            if len(cmd) > 1 and cmd[0].endswith(b"/weft") and cmd[1] == b"view":
                pid = int(entry.name)
                p = pid
                for _ in range(4):  # weft <- sh <- xvfb-run <- us
                    stat = pathlib.Path(f"/proc/{p}/stat").read_text()
                    p = int(stat[stat.rindex(")") + 2:].split()[1])
                    if p == parent:
                        return pid
        except (OSError, ValueError, IndexError):
            continue
    return None


def sample(pid):
    try:
        rss = 0
        for line in pathlib.Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                rss = int(line.split()[1]) / 1024.0
        fds = len(os.listdir(f"/proc/{pid}/fd"))
        return rss, fds
    except OSError:
        return None


def slope_per_10_min(points):
    if len(points) < 2:
        return 0.0
    n = len(points)
    mt = sum(t for t, _ in points) / n
    mv = sum(v for _, v in points) / n
    den = sum((t - mt) ** 2 for t, _ in points)
    return 0.0 if den == 0 else sum((t - mt) * (v - mv) for t, v in points) / den * 600.0


def script(cycles, work, frames_per_cycle):
    lines = []
    for c in range(cycles):
        lines += ["orbit 6 1", "orbit 6 -1", "zoom 0.97", "pan 0.01 0", "zoom 1.03", "pan -0.01 0"]
        lines.append(f"knob fur layers {[4, 8, 15, 24][c % 4]}")
        lines.append(f"copy {work / ('valid.json' if c % 2 == 0 else 'invalid.json')} {work / 'session.json'}")
        if c % 3 == 2:
            lines.append(f"copy {work / ('tonemap_b.frag' if c % 2 else 'tonemap_a.frag')} {work / 'shaders' / 'tonemap.frag'}")
        if c % 5 == 4:
            lines += ["resize 160 120", "wait 3", "resize 320 240"]
        if c % 7 == 6:
            lines += ["minimize", "wait 3", "restore"]
        lines.append(f"wait {frames_per_cycle}")
    lines.append(f"copy {work / 'valid.json'} {work / 'session.json'}")
    lines += ["wait 10", "quit"]
    return "\n".join(lines) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--minutes", type=float, default=30.0)
    p.add_argument("--sample", type=float, default=10.0, help="seconds between samples (default 10)")
    p.add_argument("--settle", type=float, default=60.0, help="seconds before growth is counted (default 60)")
    p.add_argument("--max-growth", type=float, default=1.0, help="MiB per 10 minutes of peak RSS growth allowed (default 1)")
    p.add_argument("--max-peak-mib", type=float, default=None,
                   help="instead of a rate: MiB the later half's peak may exceed the earlier half's (short runs)")
    p.add_argument("--bin", default=str(ROOT / "build" / "bin"))
    p.add_argument("--scene", default=str(ROOT / "examples" / "fur" / "scenes" / "fur_spot.json"))
    p.add_argument("--cycle-seconds", type=float, default=10.0, help="seconds per cycle: one scene save each (default 10)")
    p.add_argument("--csv", help="write the samples here")
    p.add_argument("--no-validation", action="store_true",
                   help="run without the Khronos validation layer (its own memory and threads stay out of the numbers)")
    a = p.parse_args()
    for name, v in (("--minutes", a.minutes), ("--sample", a.sample), ("--cycle-seconds", a.cycle_seconds)):
        if not (v > 0 and v < 1e6):
            p.error(f"{name} must be a positive number of reasonable size")
    if not (0 <= a.settle < a.minutes * 60):
        p.error("--settle must be at least 0 and shorter than the session")
    weft = pathlib.Path(a.bin) / "weft"
    if not weft.is_file():
        print(f"soak_viewer: no weft at {weft} (build first, or give --bin)", file=sys.stderr)
        return 2
    if shutil.which("xvfb-run") is None:
        print("soak_viewer: xvfb-run is not installed (./tools/bootstrap.sh installs it)", file=sys.stderr)
        return 2
    scene_path = pathlib.Path(a.scene).resolve()
    try:
        scene = absolutize(json.loads(scene_path.read_text()), scene_path.parent)
    except (OSError, ValueError) as e:
        print(f"soak_viewer: cannot read the scene {scene_path}: {e}", file=sys.stderr)
        return 2

    with tempfile.TemporaryDirectory(prefix="weft-soak-") as tmp:
        work = pathlib.Path(tmp)
        (work / "valid.json").write_text(json.dumps(scene, indent=1))
        (work / "invalid.json").write_text(json.dumps(scene)[: len(json.dumps(scene)) // 2])  # cut in half: a save in progress
        shutil.copy(work / "valid.json", work / "session.json")
        (work / "shaders").mkdir()
        tonemap = (ROOT / "passes" / "tonemap" / "tonemap.frag").read_text()
        (work / "tonemap_a.frag").write_text(tonemap)
        (work / "tonemap_b.frag").write_text(tonemap + "\n// saved again\n")
        shutil.copy(work / "tonemap_a.frag", work / "shaders" / "tonemap.frag")

        def run(script_text, measure):
            (work / "session.txt").write_text(script_text)
            env = dict(os.environ, WEFT_VALIDATION="0" if a.no_validation else "1")
            cmd = ["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", str(weft), "view", str(work / "session.json"),
                   "--size", "320x240", "--quality", "low", "--shader-dir", str(work / "shaders"),
                   "--script", str(work / "session.txt")]
            log = open(work / "viewer.log", "w")
            start = time.monotonic()
            proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
            samples = []
            pid = None
            next_sample = start
            try:
                while proc.poll() is None:
                    now = time.monotonic()
                    if pid is None:
                        pid = viewer_pid(proc.pid)
                    if measure and pid is not None and now >= next_sample:
                        s = sample(pid)
                        if s:
                            samples.append((now - start, s[0], s[1]))
                            print(f"  {now - start:7.1f} s  RSS {s[0]:8.1f} MiB  fds {s[1]}", flush=True)
                        next_sample += a.sample
                    time.sleep(0.2)
            except KeyboardInterrupt:
                os.killpg(proc.pid, signal.SIGTERM)
                raise
            log.close()
            return proc.returncode, time.monotonic() - start, samples, (work / "viewer.log").read_text()

        # Two short first runs of the same cycles measure what a cycle's waits take here (the
        # viewer's frames are faster when nothing changes than after a save): their difference
        # leaves the start-up out.
        timings = []
        for n in (2, 6):
            code, took, _, out = run(script(n, work, 200), False)
            if code != 0:
                print(f"soak_viewer: the viewer failed (exit {code}):\n{out[-3000:]}", file=sys.stderr)
                return 2
            timings.append(took)
        seconds_per_cycle = max(0.05, (timings[1] - timings[0]) / 4)
        fps = 200 / seconds_per_cycle
        cycles = max(2, int(a.minutes * 60 / a.cycle_seconds))
        per_cycle = max(5, int(fps * a.cycle_seconds))
        print(f"soak_viewer: a cycle of 200 frames took {seconds_per_cycle:.2f} s; {cycles} cycles of {per_cycle} frames "
              f"(~{a.cycle_seconds:g} s each) for {a.minutes:g} minutes", flush=True)
        code, took, samples, out = run(script(cycles, work, per_cycle), True)
        if a.csv:
            with open(a.csv, "w") as f:
                f.write("seconds,rss_mib,fds\n")
                for t, r, d in samples:
                    f.write(f"{t:.1f},{r:.2f},{d}\n")
        validation = [line for line in out.splitlines() if "validation message(s)" in line]
        settled = [(t, r, d) for t, r, d in samples if t >= a.settle]
        print(f"\nsession: {took / 60:.1f} minutes, exit {code}, {len(samples)} samples; {validation[-1].strip() if validation else 'no validation count printed'}")
        if len(settled) < 2:
            print("soak_viewer: fewer than two samples after --settle; nothing to judge", file=sys.stderr)
            return 2
        rss_slope = slope_per_10_min([(t, r) for t, r, _ in settled])
        # RSS swings with what the moment holds (a knob's buffers freed and made again), so
        # growth is judged on peaks: the highest sample of the second half of the settled
        # samples against the first half's, per 10 minutes between the halves' middles.
        half = len(settled) // 2
        first, second = settled[:half], settled[half:]
        span = (sum(t for t, _, _ in second) / len(second) - sum(t for t, _, _ in first) / len(first)) / 600.0
        peak_growth = (max(r for _, r, _ in second) - max(r for _, r, _ in first)) / max(span, 1e-9)
        fd_slope = slope_per_10_min([(t, d) for t, _, d in settled])
        rss = [r for _, r, _ in settled]
        fds = [d for _, _, d in settled]
        print(f"after {a.settle:g} s: RSS {rss[0]:.1f} -> {rss[-1]:.1f} MiB (min {min(rss):.1f}, max {max(rss):.1f}), "
              f"slope {rss_slope:+.2f} MiB / 10 min, peak growth {peak_growth:+.2f} MiB / 10 min (allowed {a.max_growth:g}); "
              f"fds {fds[0]} -> {fds[-1]} "
              f"(max {max(fds)}), slope {fd_slope:+.2f} / 10 min")
        failed = False
        if code != 0:
            print(f"soak_viewer: the viewer exited {code}:\n{out[-3000:]}", file=sys.stderr)
            failed = True
        peak_mib = peak_growth * max(span, 1e-9)
        if a.max_peak_mib is not None:
            if peak_mib > a.max_peak_mib:
                print(f"soak_viewer: the peak RSS grew {peak_mib:.1f} MiB between the halves (allowed {a.max_peak_mib:g})",
                      file=sys.stderr)
                failed = True
        elif peak_growth > a.max_growth:
            print(f"soak_viewer: peak RSS grows {peak_growth:.2f} MiB per 10 minutes (allowed {a.max_growth:g})",
                  file=sys.stderr)
            failed = True
        if fds[-1] > fds[0] + 2:
            print(f"soak_viewer: open file descriptors grew from {fds[0]} to {fds[-1]}", file=sys.stderr)
            failed = True
        if not a.no_validation and (not validation or "weft view: 0 validation message(s)" not in validation[-1]):
            print("soak_viewer: the viewer reported validation messages (or none were counted)", file=sys.stderr)
            failed = True
        return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
