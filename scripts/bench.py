#!/usr/bin/env python3
"""The tables of docs/BENCHMARKS.md, measured afresh with the release CLI.

  python3 scripts/bench.py scores [--descriptor curvature] [--scenes DIR]
      every shared scene (or every scene in DIR) scored by
      ../shared/bench/evaluate.py
  python3 scripts/bench.py stages [--runs 3] [--descriptor curvature]
      every shared scene's stages, whole processes, median of --runs
  python3 scripts/bench.py scale [--runs 1] [--python PY]
      generated scenes of many parts (PY needs numpy and trimesh for the
      building generator; the tetrahedra need nothing)
  python3 scripts/bench.py plan [--runs 3] [--python PY]
      each shared scene and generated scene of `scale`, planned (`match
      --plan`) and searched, whole processes: what the plan costs and how
      its least time compares with the search's
  python3 scripts/bench.py hostile
      the hostile inputs of scripts/hostile-sweep.py, under 2 GiB and 20 s
  python3 scripts/bench.py wasm
      native against wasm in Node and headless Chromium (scripts/bench-wasm.sh)
  python3 scripts/bench.py frames
      the viewer's full and light frames on zoo-bunny and the generated
      buildings, headless Chromium on software GL (www/bench-frames.js;
      run `scale` first for the buildings)
  python3 scripts/bench.py update docs/BENCHMARKS.md [--only WORD]
      reruns every table between `<!-- bench: ARGS -->` and `<!-- /bench -->`
      (ARGS as above) and writes it back in place

Build first: `cargo build --release`. Each table starts with the command
that regenerates it, the date, the commit and the cores. Timings are wall
clock of whole processes; the machine's noise is a few percent from one
minute to the next, so compare builds side by side, not across tables of
different days.
"""

import argparse
import contextlib
import datetime
import importlib.util
import io
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("FAST_REJECT_SHARED", ROOT.parent / "shared"))
BIN = Path(os.environ.get("FAST_REJECT_BIN", ROOT / "target/release/fast-reject"))
TIMINGS = ["load", "voxelize", "surface", "template", "match", "group", "total"]


def measure(args, timeout, limit_mib=None):
    """Runs `args` as one process: (exit status or "timeout", seconds, peak
    MiB of that process alone, stdout bytes, stderr text)."""
    def limits():
        if limit_mib:
            size = limit_mib << 20
            resource.setrlimit(resource.RLIMIT_AS, (size, size))

    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        start = time.monotonic()
        proc = subprocess.Popen([str(a) for a in args], stdout=out, stderr=err, preexec_fn=limits)
        status = None
        while status is None:
            pid, code, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                status = os.waitstatus_to_exitcode(code)
                break
            if time.monotonic() - start > timeout:
                proc.kill()
                _, _, usage = os.wait4(proc.pid, 0)
                status = "timeout"
                break
            time.sleep(0.005)
        seconds = time.monotonic() - start
        proc.returncode = 0  # reaped above
        out.seek(0)
        err.seek(0)
        return status, seconds, usage.ru_maxrss / 1024, out.read(), err.read().decode("utf-8", "replace")


def scene_args(folder):
    """The CLI's arguments for a shared-style scene folder, and evaluate.py's."""
    truth = json.loads((folder / "truth.json").read_text())
    if "select" in truth:
        s = truth["select"]
        sphere = ",".join(repr(float(x)) for x in [*s["center"], s["radius"]])
        return ["match", folder / "scene.glb", f"--select={sphere}"], ["--select"]
    return ["match", folder / "scene.glb", "--template", folder / "template.glb"], []


def scene_folders(scenes=None):
    """Every folder with a truth.json in `scenes` (the shared scenes by default)."""
    root = ROOT / scenes if scenes else SHARED / "scenes"
    if not root.is_dir():
        sys.exit(f"{root} is missing: make the scenes first (scripts/make-more-scenes.sh)")
    return sorted(p for p in root.iterdir() if (p / "truth.json").exists())


def evaluate(folder, result_json, extra):
    with tempfile.NamedTemporaryFile(suffix=".json") as f:
        f.write(result_json)
        f.flush()
        done = subprocess.run([sys.executable, SHARED / "bench/evaluate.py", folder / "truth.json", f.name, *extra],
                              capture_output=True, text=True)
    return dict(kv.split("=", 1) for kv in done.stdout.split())


def header(argv):
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    # What is built and measured: the docs and scripts being edited are not.
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "src", "js", "build.rs",
                            "Cargo.toml", "Cargo.lock", "www/src"], cwd=ROOT,
                           capture_output=True, text=True).stdout.strip()
    day = datetime.date.today().isoformat()
    print(f"`python3 scripts/bench.py {' '.join(argv)}` · {day} · {commit}{'+changes' if dirty else ''} · "
          f"{os.cpu_count()} cores")
    print()


def scores(a):
    extra = ["--descriptor", a.descriptor] if a.descriptor else []
    print("| scene | found | false hits | recall | precision |")
    print("|---|---:|---:|---:|---:|")
    for folder in scene_folders(a.scenes):
        args, flags = scene_args(folder)
        status, _, _, out, err = measure([BIN, *args, "--json", *extra], a.timeout)
        if status != 0:
            why = "over the time limit" if status == "timeout" else err.strip().splitlines()[-1][:80]
            print(f"| {folder.name} | {why} | | | |")
            continue
        s = evaluate(folder, out, flags)
        print(f"| {folder.name} | {s['tp']} | {s['fp']} | {s['recall']} | {s['precision']} |")


def print_stages(rows, first, skin):
    """A markdown table of `rows` (name, runs or why not): the median of
    each timing any run has over its runs (the result JSON plus "peak"),
    the skin voxels where `skin`, and the instances."""
    timed = [t for t in TIMINGS if any(isinstance(runs, list) and any(r["timings_ms"].get(t) for r in runs)
                                       for _, runs in rows)]
    heads = [first] + ["skin voxels"] * skin + timed + ["peak MiB", "instances"]
    print(f"| {' | '.join(heads)} |")
    print(f"|---|{'---:|' * (len(heads) - 1)}")
    for name, runs in rows:
        if not isinstance(runs, list):
            print(f"| {name} | {runs} |")
            continue
        med = lambda f: statistics.median(f(r) for r in runs)
        cells = [str((runs[0].get("grid") or {}).get("skin_voxels", ""))] * skin
        cells += [f"{med(lambda r: r['timings_ms'].get(t, 0.0)):.0f}" for t in timed]
        cells += [f"{med(lambda r: r['peak']):.0f}", str(len(runs[0]["instances"]))]
        print(f"| {name} | {' | '.join(cells)} |")


def run_many(args, count, timeout):
    """`count` runs of the CLI's JSON, each with its peak MiB; the first
    failure's stderr instead."""
    runs = []
    for _ in range(count):
        status, _, peak, out, err = measure([BIN, *args, "--json"], timeout)
        if status != 0:
            return "over the time limit" if status == "timeout" else err.strip().splitlines()[-1][:100]
        result = json.loads(out)
        result["peak"] = peak
        runs.append(result)
    return runs


def stages(a):
    extra = ["--descriptor", a.descriptor] if a.descriptor else []
    print(f"Milliseconds, the median of {a.runs} runs, each a whole process on all cores; peak is its "
          "resident MiB.")
    print()
    rows = [(folder.name, run_many([*scene_args(folder)[0], *extra], a.runs, a.timeout))
            for folder in scene_folders()]
    print_stages(rows, "scene", skin=not a.descriptor)


def load_sweep():
    spec = importlib.util.spec_from_file_location("hostile_sweep", ROOT / "scripts/hostile-sweep.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def scale_inputs(keep, python):
    """(name, CLI arguments, generator) of the generated scenes of many
    parts; each is written into `keep` once."""
    building = lambda out, *flags: [python, ROOT / "scripts/make-building-scenes.py", "families", out, *flags]
    folder = lambda name: keep / name
    scene = lambda name: ["match", folder(name) / "scene.glb", "--template", folder(name) / "template.glb"]
    return [
        ("2 000 jittered tetrahedra", ["match", keep / "tetrahedra-jittered-2000.ply", "--template",
                                       keep / "one-tetrahedron.ply"], None),
        ("3 000 distinct building parts", scene("distinct-3000"),
         building(folder("distinct-3000"), "--parts", "3000", "--families", "0", "--seed", "4")),
        ("10 000 building parts of 20 families", scene("families-10000"),
         building(folder("families-10000"), "--parts", "10000", "--families", "20", "--seed", "11")),
        ("10 000 distinct building parts", scene("distinct-10000"),
         building(folder("distinct-10000"), "--parts", "10000", "--families", "0", "--seed", "11")),
        # The whole-buildings issue's terrain: a vertex every 3 cm (the
        # recipe's default, 25 cm, makes 0.43 M triangles).
        ("the 30 m terrain, 2.4 M triangles", scene("terrain-2m4"),
         [python, ROOT / "scripts/make-building-scenes.py", "terrain", folder("terrain-2m4"),
          "--size", "30", "--cell", "0.03", "--seed", "5"]),
    ]


def scale(a):
    keep = Path(a.keep)
    keep.mkdir(parents=True, exist_ok=True)
    load_sweep().generated(keep)
    print(f"Milliseconds, the median of {a.runs} runs, each a whole process on all cores. Inputs: "
          "`scripts/hostile-sweep.py` "
          "(tetrahedra) and `scripts/make-building-scenes.py` (buildings and the terrain; the flags "
          "are in `scripts/bench.py`).")
    print()
    rows = []
    for name, args, make in scale_inputs(keep, a.python):
        if make and not (Path(make[3]) / "scene.glb").exists():
            subprocess.run([str(x) for x in make], check=True, stdout=subprocess.DEVNULL)
        rows.append((name, run_many(args, a.runs, a.timeout)))
    print_stages(rows, "input", skin=False)


def plan(a):
    keep = Path(a.keep)
    keep.mkdir(parents=True, exist_ok=True)
    load_sweep().generated(keep)
    inputs = [(folder.name, scene_args(folder)[0]) for folder in scene_folders()]
    for name, args, make in scale_inputs(keep, a.python):
        if make and not (Path(make[3]) / "scene.glb").exists():
            subprocess.run([str(x) for x in make], check=True, stdout=subprocess.DEVNULL)
        inputs.append((name, args))
    # A sphere too small dropped on the distinct building: a fifth of the
    # finest lattice's parts, all searched.
    distinct = keep / "distinct-10000"
    at = [row[3] for row in json.loads((distinct / "truth.json").read_text())["instances"][0]["transform"][:3]]
    inputs.append(("a 0.12 m sphere on the 10 000 distinct parts",
                   ["match", distinct / "scene.glb", f"--select={','.join(f'{x:.4f}' for x in at)},0.12"]))
    print(f"Seconds, the median of {a.runs} runs, each a whole process on all cores (loading the scene "
          "included): `match --plan` and the search; least is the plan's least time, searched the "
          "search's own stages (its total less the load).")
    print()
    print("| input | parts (distinct) | plan process | least | search process | searched | searched / least |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, args in inputs:
        planned, searched = [], []
        for _ in range(a.runs):
            status, seconds, _, out, err = measure([BIN, *args, "--plan", "--json"], a.timeout)
            if status != 0:
                break
            planned.append((seconds, json.loads(out)))
            status, seconds, _, out, err = measure([BIN, *args, "--json"], a.timeout)
            if status != 0:
                break
            searched.append((seconds, json.loads(out)))
        if status != 0 or not planned or planned[0][1] is None:
            why = "over the time limit" if status == "timeout" else (err.strip().splitlines() or ["no plan"])[-1]
            print(f"| {name} | {why[:90]} | | | | | |")
            continue
        med = statistics.median
        p = planned[0][1]
        work = med(r["timings_ms"]["total"] - r["timings_ms"].get("load", 0.0) for _, r in searched) / 1e3
        least = p["least_seconds"]
        print(f"| {name} | {p['parts']} ({p['distinct_parts']}) | {med(t for t, _ in planned):.2f} | {least:.2f} | "
              f"{med(t for t, _ in searched):.2f} | {work:.2f} | {work / least:.1f} |")


def hostile(a):
    sweep = load_sweep()
    keep = Path(a.keep)
    keep.mkdir(parents=True, exist_ok=True)
    subprocess.run(["cargo", "run", "--quiet", "--release", "--example", "hostile_files", "--", str(keep)],
                   cwd=ROOT, check=True)
    sweep.generated(keep)
    print("Each input under 2 GiB of address space and 20 s; exit 1 is a typed error, 2 a usage error.")
    print()
    print("| input | exit | s | peak MiB | raw control bytes | the error's first words |")
    print("|---|---:|---:|---:|---|---|")
    for name, args in sweep.cases(keep):
        status, seconds, peak, out, err = measure([BIN, *args], 20.0, 2048)
        control = sweep.raw_control(out + err.encode())
        line = err.strip().splitlines()[-1] if err.strip() else ""
        # Paths are this machine's: the message after them.
        line = re.sub(r"'[^']*/([^/']*)'", r"'\1'", line)[:70].replace("|", "\\|")
        print(f"| {name} | {status} | {seconds:.2f} | {peak:.0f} | {'YES' if control else 'none'} | {line} |")


def wasm(a):
    done = subprocess.run(["bash", ROOT / "scripts/bench-wasm.sh"], cwd=ROOT, stdout=subprocess.PIPE, text=True,
                          check=True)
    print(done.stdout.strip())


def frames(a):
    done = subprocess.run(["node", ROOT / "www/bench-frames.js"], cwd=ROOT, stdout=subprocess.PIPE, text=True,
                          check=True)
    print(done.stdout.strip())


def update(a):
    """Reruns each block in turn and writes the file after each, so that a
    block that fails (a missing browser, say) keeps its old table and costs
    none of the others."""
    path = Path(a.file)
    block = re.compile(r"(<!-- bench: (.*?) -->\n)(.*?)(<!-- /bench -->)", re.S)
    failed = []
    for args in [m.group(2) for m in block.finditer(path.read_text())]:
        if a.only and a.only not in args:
            continue
        print(f"running {args}", file=sys.stderr)
        table = io.StringIO()
        try:
            with contextlib.redirect_stdout(table):
                main(args.split())
        except (subprocess.CalledProcessError, SystemExit, OSError) as e:
            print(f"{args}: failed ({e}); its table is left as it was", file=sys.stderr)
            failed.append(args)
            continue
        text = path.read_text()
        m = next(m for m in block.finditer(text) if m.group(2) == args)
        path.write_text(text[:m.start(3)] + table.getvalue() + text[m.end(3):])
    if failed:
        sys.exit(f"failed: {', '.join(failed)}")


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    sub = p.add_subparsers(dest="what", required=True)
    s = sub.add_parser("scores")
    s.add_argument("--descriptor")
    s.add_argument("--scenes", help="a folder of scenes (scripts/make-more-scenes.sh) instead of the shared ones")
    s.add_argument("--timeout", type=float, default=600.0)
    s = sub.add_parser("stages")
    s.add_argument("--runs", type=int, default=3)
    s.add_argument("--descriptor")
    s.add_argument("--timeout", type=float, default=600.0)
    s = sub.add_parser("scale")
    s.add_argument("--runs", type=int, default=1)
    s.add_argument("--timeout", type=float, default=600.0)
    s.add_argument("--keep", default=str(ROOT / "target/bench-inputs"))
    s.add_argument("--python", default=os.environ.get("FAST_REJECT_PYTHON", sys.executable))
    s = sub.add_parser("plan")
    s.add_argument("--runs", type=int, default=3)
    s.add_argument("--timeout", type=float, default=600.0)
    s.add_argument("--keep", default=str(ROOT / "target/bench-inputs"))
    s.add_argument("--python", default=os.environ.get("FAST_REJECT_PYTHON", sys.executable))
    s = sub.add_parser("hostile")
    s.add_argument("--keep", default=str(ROOT / "target/bench-inputs"))
    sub.add_parser("wasm")
    sub.add_parser("frames")
    s = sub.add_parser("update")
    s.add_argument("file")
    s.add_argument("--only")
    a = p.parse_args(argv)
    if a.what != "update":
        header(argv)
    {"scores": scores, "stages": stages, "scale": scale, "plan": plan, "hostile": hostile, "wasm": wasm,
     "frames": frames, "update": update}[a.what](a)


if __name__ == "__main__":
    main(sys.argv[1:])
