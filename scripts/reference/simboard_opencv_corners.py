import cv2, glob, json, numpy as np, csv, time
truth = {}
for r in csv.DictReader(open('/tmp/simboard/corners.csv')):
    truth.setdefault((r['camera'], r['view']), []).append((float(r['x_px']), float(r['y_px'])))
ok = 0; errs = []; t = 0
files = sorted(glob.glob('/tmp/simboard/cam*/*.png'))
for f in files:
    img = cv2.imread(f, cv2.IMREAD_GRAYSCALE)
    t0 = time.perf_counter()
    found, c = cv2.findChessboardCorners(img, (9, 6))
    if found:
        c = cv2.cornerSubPix(img, c, (11, 11), (-1, -1), (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001))
    t += time.perf_counter() - t0
    cam = f.split('/')[-2]; view = f.split('/')[-1][:-4]
    if found:
        ok += 1
        tr = np.array(truth[(cam, view)]); c = c.reshape(-1, 2)
        d = np.linalg.norm(c - tr, axis=1); d2 = np.linalg.norm(c[::-1] - tr, axis=1)
        errs.append(min(d.max(), d2.max()))
        if d.max() > 1: print(f, 'order differs: max', d.max(), 'reversed', d2.max())
    else:
        print(f, 'not found')
print(ok, len(files), 'max err', max(errs), 'median', np.median(errs), 'time/img', t/len(files))
