# Independent numpy reading of the attribute values checked in tests/test_io_attributes.cpp
# (headers and offsets parsed by hand with struct/zlib/base64, no trilevel code).
# Usage: /usr/bin/python3 tests/attribute_oracle.py [path/to/shared/data]
import gzip, struct, zlib, base64, re, sys
import numpy as np
D=sys.argv[1].rstrip('/') + '/' if len(sys.argv) > 1 else '../shared/data/'
# VTK bunny: FIELD velocity after POINT_DATA
d=open(D+'double_dam_break_frame_26_4732_particles.vtk','rb').read()
i=d.index(b'\nvelocity 3 4732 float\n')+len(b'\nvelocity 3 4732 float\n')
v=np.frombuffer(d,'>f4',4732*3,i).reshape(-1,3)
j=d.index(b'LOOKUP_TABLE id_table\n')+len(b'LOOKUP_TABLE id_table\n')
ids=np.frombuffer(d,'>u4',4732,j)
print('vtk ddb26 velocity', [repr(float(x)) for x in v[0]], [repr(float(x)) for x in v[4731]], [repr(float(x)) for x in v[1234]])
print('vtk ddb26 ids', ids[:5], ids[-3:], (ids==np.arange(4732)).all())
# VTU fluid_250 appended raw zlib, UInt64 header
d=open(D+'fluid_250_particles.vtu','rb').read()
u=d.index(b'_', d.index(b'<AppendedData'))+1
def arr(off):
    p=u+off
    nb,bs,last=struct.unpack_from('<3Q',d,p)
    cs=struct.unpack_from('<%dQ'%nb,d,p+24)
    q=p+24+8*nb; out=b''
    for c in cs: out+=zlib.decompress(d[q:q+c]); q+=c
    return out
vel=np.frombuffer(arr(6561),'<f8').reshape(-1,3); den=np.frombuffer(arr(12880),'<f8'); idx=np.frombuffer(arr(14759),'<i8')
print('vtu velocity', [repr(float(np.float32(x))) for x in vel[0]], [repr(float(np.float32(x))) for x in vel[249]])
print('vtu density', [repr(float(np.float32(x))) for x in den[[0,100,249]]], 'index', idx[:3], idx[-3:])
# VTU encoded base64 appended, UInt64 header, no compression
e=open(D+'fluid_encoded_250_particles.vtu','rb').read()
u2=e.index(b'_', e.index(b'<AppendedData'))+1
def arr2(off):
    t=e[u2+off:]
    hdr=base64.b64decode(t[:12]); n,=struct.unpack('<Q',hdr[:8])
    body=base64.b64decode(t[:4*((8+n+2)//3)])
    return body[8:8+n]
vel2=np.frombuffer(arr2(0),'<f8').reshape(-1,3); idx2=np.frombuffer(arr2(13372),'<i8'); den2=np.frombuffer(arr2(10692),'<f8')
print('vtu enc velocity', [repr(float(np.float32(x))) for x in vel2[0]], 'index', idx2[:3], 'density', [repr(float(np.float32(x))) for x in den2[[0,100,249]]])
# BGEO frame 9
d=gzip.decompress(open(D+'dam_break_frame_9_6859_particles.bgeo','rb').read()) if open(D+'dam_break_frame_9_6859_particles.bgeo','rb').read()[:2]==b'\x1f\x8b' else open(D+'dam_break_frame_9_6859_particles.bgeo','rb').read()
rec=np.frombuffer(d,'>f4',6859*9,102).reshape(6859,9)
ii=np.frombuffer(d,'>i4',6859*9,102).reshape(6859,9)[:,4]
print('bgeo density', [repr(float(x)) for x in rec[[0,1000,6858],5]])
print('bgeo velocity', [repr(float(x)) for x in rec[0,6:9]], [repr(float(x)) for x in rec[6858,6:9]])
print('bgeo id', ii[:5], ii[-3:])
