"""Feasibility experiment for issue 30 (BENCHMARKS.md, "A window about the contact"): does a
window about the contact point read the force better than the whole disc, at the same 112 px
input and with the same network? Force only, frames in contact only, with the geometry of each
dataset's own profile.toml (optical centre, crop radius, registration).

    python fovea_force.py TRAIN_DATASET TEST_DATASET [WINDOW_MM=24] [EPOCHS=20]

Both datasets come from `fringe sim dataset --sensor layered`. MULTI=1 trains the whole-disc
network with fringe's three heads and loss instead (MSE on Fz + cross-entropy on the shape + MSE
on the contact in mm, equal weights, as `fringe train`), FZ_WEIGHT scaling the force's term:
does sharing the network with the contact and shape cost the force? The window's centre is the
labelled contact point plus Gaussian jitter of 0.7 mm (about the keypoint CNN's contact error,
standing in for a first network that finds the contact). OFFSET=1 trains the window network to
read, beside Fz, where the press lies from the window's centre (the jitter undone, mm), its term
weighted by OFFSET_WEIGHT; KP=1 gives it the keypoint CNN's soft-argmax maps beside the pooled
features (BENCHMARKS.md, "The force network reads the contact too"). Needs torch, numpy and
Pillow.
"""
import csv, os, sys, math, time, tomllib, numpy as np, torch, torch.nn as nn, torch.nn.functional as F
from PIL import Image
torch.set_num_threads(2); torch.manual_seed(0); rng = np.random.default_rng(0)
WIN_MM = float(sys.argv[3]) if len(sys.argv) > 3 else 24.0
JIT_MM = 0.7
# FULL_PX=224: the whole disc at that input size instead (the control at the window's px per mm)
FULL_PX = int(os.environ.get('FULL_PX', '112'))
MULTI = os.environ.get('MULTI') == '1'
FZ_WEIGHT = float(os.environ.get('FZ_WEIGHT', '1'))

def geometry(d):
    """The crop circle and the map from contact mm to image px, from the dataset's profile.toml."""
    with open(d + '/profile.toml', 'rb') as f:
        p = tomllib.load(f)
    o, reg = p['optical'], p['registration']
    # Only the view the layered design has (mirrored, not turned), where a contact at (x, y) mm
    # lies at origin - (x, y) * px/mm: other views need the registration's turn, not done here.
    if not reg['mirror'] or abs(reg['rotation_deg']) > 1e-9:
        sys.exit(f"{d}/profile.toml: registration mirror={reg['mirror']} rotation_deg={reg['rotation_deg']}; "
                 "this experiment handles only the mirrored, unturned view (--sensor layered)")
    return o['centre_x_px'], o['centre_y_px'], o['crop_radius_px'], reg['px_per_mm'], reg['offset_px']

def load(d):
    CX, CY, R, PXMM, (OX, OY) = geometry(d)
    rows = list(csv.DictReader(open(d + '/0.labels.csv')))
    full, zoom, fz, aux, jit = [], [], [], [], []
    for r in rows:
        if r['Indentor_Shape'].lower() in ('none', 'no contact', ''):
            continue
        x, y = float(r['X_Position_mm']), float(r['Y_Position_mm'])
        im = Image.open(d + '/0.images/' + r['New_Image_Name']).convert('L')
        full.append(np.asarray(im.crop((round(CX-R), round(CY-R), round(CX+R), round(CY+R)))
            .resize((FULL_PX, FULL_PX), Image.BILINEAR), np.uint8))
        jx, jy = rng.normal(0, JIT_MM, 2)
        jit.append((jx, jy))
        px, py = OX - (x + jx) * PXMM, OY - (y + jy) * PXMM
        h = WIN_MM * PXMM / 2
        zoom.append(np.asarray(im.crop((round(px-h), round(py-h), round(px+h), round(py+h))).resize((112, 112), Image.BILINEAR), np.uint8))
        fz.append(abs(float(r['Fz'])))
        aux.append((0 if r['Indentor_Shape'].lower() == 'pentagon' else 1, x, y))
    global JITTER
    JITTER = JITTER + [np.array(jit, np.float32)]
    return np.stack(full), np.stack(zoom), np.array(fz, np.float32), np.array(aux, np.float32)
JITTER = []

def net(outputs=1):
    def blk(i, o): return nn.Sequential(nn.Conv2d(i, o, 3, padding=1), nn.BatchNorm2d(o), nn.ReLU(), nn.MaxPool2d(2))
    return nn.Sequential(blk(1, 16), blk(16, 32), blk(32, 64), blk(64, 128), nn.AdaptiveAvgPool2d(1), nn.Flatten(), nn.Linear(128, 64), nn.ReLU(), nn.Linear(64, outputs))

class KeypointNet(nn.Module):
    """The same four convolutions, without the last pool, with 16 soft-argmax keypoint maps read
    beside the pooled features (fringe's keypoint CNN)."""
    def __init__(self, outputs):
        super().__init__()
        def blk(i, o, pool=True): return nn.Sequential(nn.Conv2d(i, o, 3, padding=1), nn.BatchNorm2d(o), nn.ReLU(), *( [nn.MaxPool2d(2)] if pool else []))
        self.body = nn.Sequential(blk(1, 16), blk(16, 32), blk(32, 64), blk(64, 128, False))
        self.key = nn.Conv2d(128, 16, 1)
        self.head = nn.Sequential(nn.Linear(128 + 32, 64), nn.ReLU(), nn.Linear(64, outputs))
    def forward(self, x):
        f = self.body(x); n, _, h, w = f.shape
        k = self.key(f).flatten(2).softmax(2)
        ys = torch.linspace(-1, 1, h).repeat_interleave(w); xs = torch.linspace(-1, 1, w).repeat(h)
        kx, ky = (k * xs).sum(2), (k * ys).sum(2)
        return self.head(torch.cat([f.mean((2, 3)), kx, ky], 1))

def offset_run(xtr, ytr, jtr, xte, yte, jte, epochs):
    """Outputs: Fz and the contact's offset from the window's centre (mm, the label's axes):
    the window network refines the contact the first network found."""
    m = KeypointNet(3) if os.environ.get('KP') == '1' else net(3)
    opt = torch.optim.Adam(m.parameters(), 1e-3)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs)
    Xtr = torch.tensor(xtr, dtype=torch.float32).unsqueeze(1) / 255; Ytr = torch.tensor(ytr); Otr = -torch.tensor(jtr)
    Xte = torch.tensor(xte, dtype=torch.float32).unsqueeze(1) / 255; ote = -jte
    W = float(os.environ.get('OFFSET_WEIGHT', '1'))
    for e in range(epochs):
        m.train(); perm = torch.randperm(len(Xtr)); t = time.time()
        for i in range(0, len(perm), 32):
            b = perm[i:i+32]; xb = Xtr[b]; ob = Otr[b].clone()
            if torch.rand(1).item() < 0.5: xb = xb.flip(3); ob[:, 0] = -ob[:, 0]
            o = m(xb)
            loss = F.mse_loss(o[:, 0], Ytr[b]) + W * F.mse_loss(o[:, 1:3], ob)
            opt.zero_grad(); loss.backward(); opt.step()
        sched.step(); m.eval()
        with torch.no_grad(): o = torch.cat([m(Xte[i:i+64]) for i in range(0, len(Xte), 64)]).numpy()
        err = o[:, 0] - yte
        bins = [math.sqrt(np.mean(err[(yte >= a) & (yte < a + 2)] ** 2)) for a in (0, 2, 4, 6)]
        c = math.sqrt(np.mean(np.sum((o[:, 1:3] - ote) ** 2, 1)))
        c0 = math.sqrt(np.mean(np.sum(ote ** 2, 1)))
        cb = [math.sqrt(np.mean(np.sum((o[:, 1:3] - ote)[(yte >= a) & (yte < a + 2)] ** 2, 1))) for a in (0, 2, 4, 6)]
        print(f"offset ({'keypoint' if os.environ.get('KP') == '1' else 'pooled'}, weight {W}) epoch {e+1} {time.time()-t:.0f}s test Fz RMSE {math.sqrt(np.mean(err**2)):.3f} N  by 0-2/2-4/4-6/6-8 N: "
              + " ".join(f"{b:.3f}" for b in bins) + f"  contact {c:.3f} mm (window centre {c0:.3f} mm) by force: " + " ".join(f"{b:.3f}" for b in cb), flush=True)

def multi_run(xtr, ytr, atr, xte, yte, ate, epochs):
    """Outputs: Fz, two shape logits (pentagon, rectangle), contact x, y mm."""
    m = net(5); opt = torch.optim.Adam(m.parameters(), 1e-3)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs)
    Xtr = torch.tensor(xtr, dtype=torch.float32).unsqueeze(1) / 255; Ytr = torch.tensor(ytr); Atr = torch.tensor(atr)
    Xte = torch.tensor(xte, dtype=torch.float32).unsqueeze(1) / 255
    for e in range(epochs):
        m.train(); perm = torch.randperm(len(Xtr)); t = time.time()
        for i in range(0, len(perm), 32):
            b = perm[i:i+32]; o = m(Xtr[b]); a = Atr[b]
            loss = (FZ_WEIGHT * F.mse_loss(o[:, 0], Ytr[b]) + F.cross_entropy(o[:, 1:3], a[:, 0].long())
                    + F.mse_loss(o[:, 3:5], a[:, 1:3]))
            opt.zero_grad(); loss.backward(); opt.step()
        sched.step(); m.eval()
        with torch.no_grad(): o = torch.cat([m(Xte[i:i+64]) for i in range(0, len(Xte), 64)]).numpy()
        err = o[:, 0] - yte
        bins = [math.sqrt(np.mean(err[(yte >= a) & (yte < a + 2)] ** 2)) for a in (0, 2, 4, 6)]
        c = math.sqrt(np.mean(np.sum((o[:, 3:5] - ate[:, 1:3]) ** 2, 1)))
        acc = np.mean(o[:, 1:3].argmax(1) == ate[:, 0])
        print(f"multi (Fz weight {FZ_WEIGHT}) epoch {e+1} {time.time()-t:.0f}s test Fz RMSE {math.sqrt(np.mean(err**2)):.3f} N  by 0-2/2-4/4-6/6-8 N: "
              + " ".join(f"{b:.3f}" for b in bins) + f"  contact {c:.3f} mm  shape {acc:.3f}", flush=True)

def run(name, xtr, ytr, xte, yte, epochs):
    m = net(); opt = torch.optim.Adam(m.parameters(), 1e-3)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs)
    Xtr = torch.tensor(xtr, dtype=torch.float32).unsqueeze(1) / 255; Ytr = torch.tensor(ytr)
    Xte = torch.tensor(xte, dtype=torch.float32).unsqueeze(1) / 255
    for e in range(epochs):
        m.train(); perm = torch.randperm(len(Xtr)); t = time.time()
        for i in range(0, len(perm), 32):
            b = perm[i:i+32]; xb = Xtr[b]
            if torch.rand(1).item() < 0.5: xb = xb.flip(3)
            loss = F.mse_loss(m(xb).squeeze(1), Ytr[b]); opt.zero_grad(); loss.backward(); opt.step()
        sched.step(); m.eval()
        with torch.no_grad(): p = torch.cat([m(Xte[i:i+64]).squeeze(1) for i in range(0, len(Xte), 64)]).numpy()
        err = p - yte
        bins = [math.sqrt(np.mean(err[(yte >= a) & (yte < a + 2)] ** 2)) for a in (0, 2, 4, 6)]
        print(f"{name} epoch {e+1} {time.time()-t:.0f}s test Fz RMSE {math.sqrt(np.mean(err**2)):.3f} N  by 0-2/2-4/4-6/6-8 N: " + " ".join(f"{b:.3f}" for b in bins), flush=True)

tr, te = sys.argv[1], sys.argv[2]
t = time.time(); ftr, ztr, ytr, atr = load(tr); fte, zte, yte, ate = load(te)
print(f"loaded {len(ytr)} train / {len(yte)} test contact frames in {time.time()-t:.0f} s; window {WIN_MM} mm, jitter {JIT_MM} mm", flush=True)
E = int(sys.argv[4]) if len(sys.argv) > 4 else 20
if os.environ.get('OFFSET') == '1':
    offset_run(ztr, ytr, JITTER[0], zte, yte, JITTER[1], E)
    sys.exit(0)
if MULTI:
    multi_run(ftr, ytr, atr, fte, yte, ate, E)
    sys.exit(0)
if FULL_PX == 112:
    run('zoom', ztr, ytr, zte, yte, E)
run(f'full {FULL_PX} px', ftr, ytr, fte, yte, E)
