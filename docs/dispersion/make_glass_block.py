import json, base64, struct
# Emitting floor z=0 (4 x 4 m), a 1 m BK7 block over its left half (x in [-2, 0], z in [1, 2]),
# camera at z = 3 looking down.
def quad(z, x0, x1, y0, y1, up):
    a,b,c,d=(x0,y0,z),(x1,y0,z),(x1,y1,z),(x0,y1,z)
    return [a,b,c,a,c,d] if up else [a,c,b,a,d,c]
def box(x0,x1,y0,y1,z0,z1):
    t=[]
    t+=quad(z1,x0,x1,y0,y1,True); t+=quad(z0,x0,x1,y0,y1,False)
    # sides, outward
    def q(p): return [p[0],p[1],p[2],p[0],p[2],p[3]]
    t+=q([(x0,y0,z0),(x0,y0,z1),(x0,y1,z1),(x0,y1,z0)])  # -x face: check winding below
    t+=q([(x1,y0,z0),(x1,y1,z0),(x1,y1,z1),(x1,y0,z1)])
    t+=q([(x0,y0,z0),(x1,y0,z0),(x1,y0,z1),(x0,y0,z1)])
    t+=q([(x0,y1,z0),(x0,y1,z1),(x1,y1,z1),(x1,y1,z0)])
    return t
def fix(tris, centre):
    out=[]
    for i in range(0,len(tris),3):
        a,b,c=tris[i:i+3]
        u=[b[k]-a[k] for k in range(3)]; v=[c[k]-a[k] for k in range(3)]
        n=[u[1]*v[2]-u[2]*v[1],u[2]*v[0]-u[0]*v[2],u[0]*v[1]-u[1]*v[0]]
        m=[(a[k]+b[k]+c[k])/3-centre[k] for k in range(3)]
        if sum(n[k]*m[k] for k in range(3))<0: b,c=c,b
        out+=[a,b,c]
    return out
floor=quad(0,-2,2,-2,2,True)
glass=fix(box(-2,0,-2,2,1,2),(-1,0,1.5))
meshes=[]; bufs=b''; views=[]; accs=[]
for tris in (floor, glass):
    data=b''.join(struct.pack('<3f',*p) for p in tris)
    views.append({"buffer":0,"byteOffset":len(bufs),"byteLength":len(data)})
    mn=[min(p[k] for p in tris) for k in range(3)]; mx=[max(p[k] for p in tris) for k in range(3)]
    accs.append({"bufferView":len(views)-1,"componentType":5126,"count":len(tris),"type":"VEC3","min":mn,"max":mx})
    bufs+=data
doc={"asset":{"version":"2.0"},
 "extensionsUsed":["KHR_materials_transmission"],
 "scene":0,"scenes":[{"nodes":[0,1,2]}],
 "nodes":[{"mesh":0},{"mesh":1},{"camera":0,"translation":[0,0,3]}],
 "cameras":[{"type":"perspective","perspective":{"yfov":1.2,"znear":0.01,"aspectRatio":1.0}}],
 "meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]},{"primitives":[{"attributes":{"POSITION":1},"material":1}]}],
 "materials":[{"name":"panel","pbrMetallicRoughness":{"baseColorFactor":[0,0,0,1]},"emissiveFactor":[1,1,1]},
   {"name":"bk7","pbrMetallicRoughness":{"baseColorFactor":[1,1,1,1],"metallicFactor":0,"roughnessFactor":0},
    "extensions":{"KHR_materials_transmission":{"transmissionFactor":1}},"extras":{"tprf":{"n":"bk7"}}}],
 "buffers":[{"byteLength":len(bufs),"uri":"data:application/octet-stream;base64,"+base64.b64encode(bufs).decode()}],
 "bufferViews":views,"accessors":accs}
json.dump(doc,open('glass_block.gltf','w'))
