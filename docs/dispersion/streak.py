import numpy as np
from PIL import Image, ImageDraw
cubes={b:np.load(f'out_{b}/tprf.npy') for b in ['450nm','550nm','650nm']}
H,W,T=cubes['550nm'].shape
row=H//2
# streak image: x across, time down; R=650, G=550, B=450
img=np.stack([cubes['650nm'][row],cubes['550nm'][row],cubes['450nm'][row]],-1) # W,T,3
img=img.transpose(1,0,2) # T,W,3
# time window where anything arrives
tsum=img.sum((1,2)); nz=np.nonzero(tsum)[0]; lo,hi=max(nz[0]-10,0),min(nz[-1]+10,T)
img=img[lo:hi]
img=img/np.percentile(img[img>0],99.5)
img=np.clip(img,0,1)**(1/2.2)
im=Image.fromarray((img*255).astype(np.uint8)).resize((W*6,(hi-lo)*3),Image.NEAREST)
d=ImageDraw.Draw(im)
d.text((5,5),f"row {row}: x across, time down (4 mm = 13.3 ps per bin, bins {lo}-{hi}); R 650 nm, G 550 nm, B 450 nm",fill=(255,255,255))
d.text((5,20),"left half: through 1 m of N-BK7; right half: air",fill=(255,255,255))
im.save('streak.png')
# per-band arrival at a pixel behind the glass (x=W//4) and in air (x=3W//4)
dt=0.004/299792458
for x in [W//4, 3*W//4]:
    s=[]
    for b in ['450nm','550nm','650nm']:
        t=cubes[b][row,x]; k=np.argmax(t)
        s.append(f"{b}: peak bin {k} ({(2.9+0.004*(k+0.5))/299792458*1e9:.4f} ns)")
    print(f"x={x}:", "; ".join(s))
