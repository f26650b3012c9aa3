#!/usr/bin/env python3
"""The GPU backend against the CPU backend on scene folders (scene.glb,
template.glb): the same instances (distances within 1e-5: f32 harmonics)
and the same candidates and survivors at every layer. Selection scenes
(select-*) are skipped. Exits non-zero on any difference.

    gpu-compare.py CLI SCENES_DIR [EXTRA CLI ARGS...]
"""
import json
import os
import subprocess
import sys


def run(cli, folder, backend, extra):
    p = subprocess.run([cli, 'match', f'{folder}/scene.glb', '--template', f'{folder}/template.glb',
                        '--backend', backend, '--json', *extra], capture_output=True, text=True)
    if p.returncode:
        raise RuntimeError(f'{folder} {backend}: {p.stderr.strip()[-400:]}')
    return json.loads(p.stdout)


def main():
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
