"""Is there normal information in the input photo? Correlation of the high-passed ground-truth shading n.l (the
flash above the centre, 66 deg field of view) with the high-passed log photo and with the log of photo / albedo.

    python docs/benchmarks/accuracy/scripts/photo_normal_information.py runs/flashfree/maps
"""
import sys, glob, numpy as np, torch, kornia
files = sorted(glob.glob(sys.argv[1] + "/*.npz"))
cs = []
for f in files:
    z = np.load(f)
    if "gt_normal" not in z: continue
    g = z["gt_normal"]; photo = z["photo"]; d = z["gt_diffuse"]
    h, w = g.shape[:2]
    # light from a flash above the centre at distance ~ W/(2 tan 33deg)
    dist = 0.5 / np.tan(np.radians(33)) * w
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    L = np.stack([(w/2 - xx), -(h/2 - yy), np.full((h, w), dist)], -1); L /= np.linalg.norm(L, axis=-1, keepdims=True)
    ndotl = (g * L).sum(-1)
    ratio = photo.mean(-1) / np.clip(d.mean(-1), 1e-3, None)   # shading = photo / albedo
    def hp(a):
        t = torch.from_numpy(a)[None, None].float()
        return (t - kornia.filters.gaussian_blur2d(t, (97, 97), (16., 16.), border_type="reflect"))[0, 0].numpy()
    def c(a, b): a = a - a.mean(); b = b - b.mean(); return float((a*b).mean() / (a.std()*b.std() + 1e-9))
    cs.append([c(hp(ndotl), hp(np.log(np.clip(ratio, 1e-3, None)))), c(hp(ndotl), hp(np.log(np.clip(photo.mean(-1), 1e-3, None)))),
               c(hp(np.log(np.clip(d.mean(-1), 1e-3, None))), hp(np.log(np.clip(photo.mean(-1), 1e-3, None))))])
cs = np.array(cs)
print("corr(n.l, shading=photo/albedo), corr(n.l, photo), corr(albedo, photo):", np.round(cs.mean(0), 3))
print(np.round(cs[:, 1], 2))
