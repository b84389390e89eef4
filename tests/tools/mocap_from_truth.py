# Usage: mocap_from_truth.py SIM_DIR OUT_DIR RATE_HZ SD_POS_M SD_THETA_RAD LATE_S SEED L1,L2,... [positions]
# Motion capture from a simulated log: truth.csv interpolated to RATE Hz,
# noise SD_POS m / SD_THETA rad, stamped LATE s late; mice.csv rows of
# sensor i stamped LAT_i later and re-sorted; no wheels.csv.
import sys, csv, math, random, shutil, os
src, dst, rate, sd_pos, sd_th, late, seed = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6]), int(sys.argv[7])
lat = [float(x) for x in sys.argv[8].split(',')]
positions_only = len(sys.argv) > 9 and sys.argv[9] == 'positions'
random.seed(seed)
os.makedirs(dst, exist_ok=True)
for f in ['robot.yaml', 'robot.true.yaml']: shutil.copy(os.path.join(src, f), dst)
rows = [r for r in csv.reader(open(os.path.join(src, 'truth.csv'))) if r and not r[0].startswith('#')][1:]
T = [(float(r[0]), float(r[1]), float(r[2]), float(r[3])) for r in rows]
out = open(os.path.join(dst, 'camera.csv'), 'w')
out.write('t,x,y,theta\n' if not positions_only else 't,x,y\n')
j = 0; k = 0
while True:
    t = k / rate; k += 1
    if t > T[-1][0]: break
    while T[j + 1][0] < t: j += 1
    a, b = T[j], T[j + 1]
    f = (t - a[0]) / (b[0] - a[0])
    x = a[1] + f * (b[1] - a[1]) + random.gauss(0, sd_pos)
    y = a[2] + f * (b[2] - a[2]) + random.gauss(0, sd_pos)
    th = a[3] + f * (b[3] - a[3]) + random.gauss(0, sd_th)
    th = math.atan2(math.sin(th), math.cos(th))
    if positions_only: out.write(f'{t + late:.6f},{x:.6f},{y:.6f}\n')
    else: out.write(f'{t + late:.6f},{x:.6f},{y:.6f},{th:.7f}\n')
lines = open(os.path.join(src, 'mice.csv')).read().splitlines()
head = [l for l in lines[:2]]
names = {}
data = []
for l in lines[2:]:
    p = l.split(',')
    if p[1] not in names: names[p[1]] = len(names)
    t = float(p[0]) + lat[names[p[1]]]
    data.append((t, names[p[1]], ','.join([f'{t:.6f}'] + p[1:])))
data.sort(key=lambda r: (r[0], r[1]))
open(os.path.join(dst, 'mice.csv'), 'w').write('\n'.join(head + [d[2] for d in data]) + '\n')
