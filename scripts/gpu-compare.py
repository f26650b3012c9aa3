#!/usr/bin/env python3
"""The GPU backend against the CPU backend on scene folders (scene.glb,
template.glb): the same instances (distances within 1e-5: f32 harmonics)
and the same candidates and survivors at every layer. Selection scenes
(select-*) are skipped. Exits non-zero on any difference.

    gpu-compare.py CLI SCENES_DIR [EXTRA CLI ARGS...]

With --time, the whole search instead: `match --backend cpu`, `gpu` and
`auto`, each on 2 threads, alternating, GPU_CHECK_RUNS times (default 5)
per scene, the medians of the processes' wall times side by side. The
scale issue's goals are printed beside them: `auto` no slower than `cpu`
anywhere, `gpu` at least 5 times faster than `cpu` on a building.

    gpu-compare.py --time CLI SCENES_DIR
"""
import json
import os
import statistics
import subprocess
import sys
import time


def run(cli, folder, backend, extra):
    p = subprocess.run([cli, 'match', f'{folder}/scene.glb', '--template', f'{folder}/template.glb',
                        '--backend', backend, '--json', *extra], capture_output=True, text=True)
    if p.returncode:
        raise RuntimeError(f'{folder} {backend}: {p.stderr.strip()[-400:]}')
    return json.loads(p.stdout)


def timed(cli, root):
    runs = int(os.environ.get('GPU_CHECK_RUNS', '5'))
    backends = ('cpu', 'gpu', 'auto')
    print('| scene | cpu, 2 threads (s) | gpu (s) | auto (s) | cpu / gpu | auto / cpu | auto ran on |')
    print('|---|---:|---:|---:|---:|---:|---|')
    for name in sorted(os.listdir(root)):
        folder = os.path.join(root, name)
        if name.startswith('select') or not os.path.exists(f'{folder}/template.glb'):
            continue
        walls = {b: [] for b in backends}
        adapter = None
        for _ in range(runs):
            for backend in backends:
                start = time.perf_counter()
                report = run(cli, folder, backend, ['--threads', '2'])
                walls[backend].append(time.perf_counter() - start)
                if backend == 'auto':
                    adapter = (report.get('gpu') or {}).get('adapter') or 'cpu'
        m = {b: statistics.median(w) for b, w in walls.items()}
        print(f"| {name} | {m['cpu']:.3f} | {m['gpu']:.3f} | {m['auto']:.3f} | "
              f"{m['cpu'] / m['gpu']:.2f} | {m['auto'] / m['cpu']:.2f} | {adapter} |", flush=True)


def main():
    if sys.argv[1] == '--time':
        timed(sys.argv[2], sys.argv[3])
        return
    cli, root, extra = sys.argv[1], sys.argv[2], sys.argv[3:]
    differ = 0
    for name in sorted(os.listdir(root)):
        folder = os.path.join(root, name)
        if name.startswith('select') or not os.path.exists(f'{folder}/template.glb'):
            continue
        cpu, gpu = run(cli, folder, 'cpu', extra), run(cli, folder, 'gpu', extra)
        plain = lambda i: {k: v for k, v in i.items() if k != 'distance'}
        same = len(cpu['instances']) == len(gpu['instances']) and all(
            plain(a) == plain(b) and abs(a['distance'] - b['distance']) < 1e-5
            for a, b in zip(cpu['instances'], gpu['instances']))
        layers = lambda r: [(s['descriptor'], s['layer'], s['candidates'], s['survivors']) for s in r['stages']]
        kept = layers(cpu) == layers(gpu)
        info = gpu.get('gpu') or {}
        print(f"{name}: {len(cpu['instances'])} instances, same instances {same}, same survivors {kept}, "
              f"on {info.get('adapter')}, fallback {info.get('fallback')}")
        differ += (not same) + (not kept)
    print('differences:', differ)
    sys.exit(1 if differ else 0)


if __name__ == '__main__':
    main()
