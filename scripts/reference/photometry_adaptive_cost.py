#!/usr/bin/env python3
"""Cost against accuracy of cubature-adaptive beside the paper's cubature on the Lambertian check
(1 x 1 uniform emitter at h = 0.1 and 1.0 over a 4 x 4 m patch, 33 x 33 points, Lambert's closed
form as the truth). Needs numpy and the release binary: python3 scripts/reference/photometry_adaptive_cost.py
Prints rows: height | method | worst error | median error | triangles per point | microseconds per point."""
import numpy as np, subprocess, json, math
import tempfile, os, pathlib
B=str(pathlib.Path(__file__).resolve().parents[2] / "target" / "release" / "lumifit")
os.chdir(tempfile.mkdtemp())
v=[k*0.1 for k in range(901)]
open("l.ies","w").write("IES:LM-63-2019\nTILT=NONE\n1 -1 1 901 1 1 2 1 1 0\n1 1.00001 0\n"+" ".join(map(str,v))+"\n0\n"+" ".join(str(1000*math.cos(math.radians(g))) for g in v)+"\n")
n=33; xs=np.linspace(-2,2,n)
P=[(x+1e-3,y+2e-3) for x in xs for y in xs]
open("p.csv","w").write("x,y,z,nx,ny,nz\n"+"".join(f"{x},{y},0,0,0,1\n" for x,y in P))
def lam(px,py,h):
    # uniform emitter L=1000 over [-.5,.5]^2 at z=h, receiver at (px,py,0) normal +z; no clipping needed (light above)
    c=[(-.5,-.5),(.5,-.5),(.5,.5),(-.5,.5)]; s=0
    for i in range(4):
        a=np.array([c[i][0]-px,c[i][1]-py,h]); b=np.array([c[(i+1)%4][0]-px,c[(i+1)%4][1]-py,h])
        a/=np.linalg.norm(a); b/=np.linalg.norm(b); cr=np.cross(a,b); cn=np.linalg.norm(cr)
        s+=math.atan2(cn,a@b)*cr[2]/cn
    return 1000*abs(s)/2
for h in [0.1,1.0]:
    ex=np.array([lam(x,y,h) for x,y in P])
    for m,extra in [("cubature",[])]+[("cubature-adaptive",["--tolerance",t]) for t in ["0.3","0.1","0.03","0.01"]]:
        r=subprocess.run([B,"light","illuminance","l.ies","--rect","1,1","--center",f"0,0,{h}","--normal","0,0,-1","--up","1,0,0","--points","p.csv","--method",m,*extra,"--out","e.csv"],capture_output=True,check=True)
        info=json.loads(r.stdout); e=np.loadtxt("e.csv",delimiter=",",skiprows=1,usecols=6)
        mask=ex>1.0; err=np.abs(e[mask]/ex[mask]-1)
        print(f"| {h} | {m} {' '.join(extra)} | {100*err.max():.2f} % | {100*np.median(err):.2f} % | {info['mean_evaluations_per_point']:.0f} | {info['compute_seconds']*1e6/len(P):.1f} |")
