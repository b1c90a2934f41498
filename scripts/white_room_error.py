"""Error against cost of bounced light: the white room of tests/mitsuba_caustics.rs (its spot a
point, radius = 0, as Mitsuba's) rendered at several bounce-photon budgets, each against Mitsuba
3's converged particle tracer (tests/data/mitsuba/white_room.exr) — the mean radiance, the 8×8
blocks' and the pixels' relative L1 — beside `refrakt bench`'s GPU times. The table in
docs/lights.md (Bounced light) comes from it.

On a GPU machine, for N in 125000 250000 … 8000000, with wr_N.lua that scene at bounce_photons = N:
    refrakt render wr_N.lua -o DIR/wr_N
    refrakt bench --scenes wr_125000.lua,… --frames 20 --out DIR/wr.json
then here (Python with numpy and OpenEXR, e.g. the bpy venv scripts/test_blender.sh makes):
    python scripts/white_room_error.py DIR
"""
import sys, json, glob, os
import numpy as np, OpenEXR
def read(path):
    with OpenEXR.File(path, separate_channels=True) as f:
        return {name: np.asarray(c.pixels, dtype=np.float64).reshape(-1) for name, c in f.parts[0].channels.items()}
ref = read('/work/main/tests/data/mitsuba/white_room.exr')
exact = (ref['R'] + ref['G'] + ref['B']) / 3; mask = ref['A'] > 0.5
N = 64
d = sys.argv[1]
bench = json.load(open(os.path.join(d, 'wr.json')))
times = {s['name']: s for s in bench['scenes']}
for n in [125000, 250000, 500000, 1000000, 2000000, 4000000, 8000000]:
    ch = read(glob.glob(os.path.join(d, f'wr_{n}', '*.exr'))[0])
    got = (ch['R'] + ch['G'] + ch['B']) / 3
    ind = (ch['indirect.R'] + ch['indirect.G'] + ch['indirect.B']) / 3
    g = got.reshape(N, N); e = exact.reshape(N, N); m = mask.reshape(N, N)
    l1 = tot = 0.0
    for by in range(8):
        for bx in range(8):
            mm = m[by*8:by*8+8, bx*8:bx*8+8]
            if mm.sum() < 32: continue
            a = g[by*8:by*8+8, bx*8:bx*8+8][mm].sum(); b = e[by*8:by*8+8, bx*8:bx*8+8][mm].sum()
            l1 += abs(a-b); tot += b
    px = np.abs(g[m]-e[m]).sum()/e[m].sum()
    s = times[f'.gl/wr_{n}.lua']; st = {k: v['median'] for k, v in s['stages_ms'].items()}
    bounce_ms = st.get('photons',0)+st.get('march',0)+st.get('indirect',0)
    print(f"| {n/1e6:g}M | {100*(g[m].mean()/e[m].mean()-1):+.2f} % | {l1/tot:.4f} | {px:.4f} | {s['gpu_ms']['median']:.2f} | {bounce_ms:.2f} | {100*ind.reshape(N,N)[m].mean()/g[m].mean():.0f} % |")
