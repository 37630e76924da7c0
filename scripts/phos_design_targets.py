#!/usr/bin/env python3
"""Writes h.csv (200 frames of 0.1 s of irradiance) and t.csv (4 keyframes of outgoing radiance
from known parameters k_e = 0.05,0.02,0.01, k_r = 0.3 /s, Lambda = 0.5,2,1, albedo 0.6,0.5,0.4)
into the current directory, for `lumifit phos design` timings (docs/performance.md).
Standard library only; exact solution of Eq. 1 per constant frame."""
import math

ts = [f * 0.1 for f in range(200)]
E = []
for t in ts:
    if t < 8:
        E.append([1 + 0.5 * math.sin(t), 0.8, 0.3 + 0.2 * math.cos(0.5 * t)])
    elif t < 15:
        E.append([0, 0, 0])
    else:
        E.append([0, 0, 0.2])
with open("h.csv", "w") as f:
    f.write("time_s,e_r,e_g,e_b\n")
    for t, e in zip(ts, E):
        f.write(f"{t},{e[0]},{e[1]},{e[2]}\n")
ke, kr, lam, alb = [0.05, 0.02, 0.01], 0.3, [0.5, 2.0, 1.0], [0.6, 0.5, 0.4]


def step(r, e, h):
    a = sum(k * x for k, x in zip(ke, e))
    l = a + kr
    req = a / l
    return req + (r - req) * math.exp(-l * h)


with open("t.csv", "w") as f:
    f.write("time_s,l_r,l_g,l_b\n")
    for K in [4.0, 9.0, 13.0, 19.5]:
        r = 0.0
        for i, t in enumerate(ts):
            if t >= K:
                break
            t1 = ts[i + 1] if i + 1 < len(ts) else 1e9
            r = step(r, E[i], min(t1, K) - t)
        i = max(j for j, t in enumerate(ts) if t <= K)
        L = [alb[c] * E[i][c] / math.pi + lam[c] * kr * r for c in range(3)]
        f.write(f"{K},{L[0]},{L[1]},{L[2]}\n")
